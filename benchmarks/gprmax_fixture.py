"""Full-wave validation data: a gprMax 2-D TM B-scan of PEC cylinders and a plate.

Writes the fixture of ``tests/data/gprmax/`` (the data the engine did not make):

- ``targets_merged.h5``: the monostatic B-scan of the scene (41 traces);
- ``background_merged.h5``: the same scan with no targets (free space);
- ``scene.json``: the geometry (cylinder centres and radii, the plate's
  corners), the scan positions, the waveform and the FDTD settings.

Both B-scans are gprMax's own output, one file per trace merged by gprMax's
``outputfiles_merge`` (``rxs/rx1/Ez`` of shape (Iterations, traces) and the
per-trace positions under ``trace_metadata``).

The model
---------
2-D TM (``#domain_mode: TM``, Ez, Hx, Hy), free space, 2 mm cells.  A z-directed
Hertzian dipole (a line current in 2-D) and a receiver of Ez in the same cell
move together 8 mm a step along x (``#src_steps`` / ``#rx_steps``), 41
positions, x 0.29-0.61 m at y = 0.09 m.  The targets lie 0.30-0.60 m from the
scan line (their nearest surfaces 0.29-0.67 m from the antennas), in
directions from -34 to +38 degrees seen from the array centre: four PEC
cylinders (radii 8-15 mm) and a PEC plate (0.10 m x 4 mm, tilted by 15
degrees to face the array centre, made of two triangular prisms and
staircased by the grid).  The objects are 0.24-0.54 m apart, so that the
double echoes between them mostly arrive well behind the single ones; the
plate and its nearest cylinders still add a double echo close behind the
plate's own for some antennas (tests/test_gprmax.py measures that).

Choices, checked below before anything runs:

- **Excitation**: a Ricker wavelet of centre 3 GHz.  Its spectrum
  ``f^2 exp(-f^2/f0^2)`` peaks at f0 and is within -7 dB of the peak from 1.5
  to 5 GHz (-5.5 dB at 1.5 GHz, -6.6 dB at 5 GHz), so one run serves every band
  of the benchmarks; it falls to -40 dB at 8.3 GHz.  A gaussiandot of the same
  centre keeps more of its energy below 1 GHz, which the bands do not use.
- **Cell**: 2 mm is 18 cells per wavelength at 8.3 GHz (the -40 dB frequency;
  gprMax's own check reports 17.7 at its limit, 8.5 GHz) and 30 at 5 GHz,
  above the rule of 10.  The time step is gprMax's 2-D Courant limit,
  dx / (c sqrt 2) = 4.717 ps.
- **Pitch**: 8 mm, below a quarter wavelength at 5 GHz (15 mm) and at 8.3 GHz
  (9.0 mm), so the monostatic k_x axis (up to 2k) is not aliased.
- **Time window**: 6 ns (1273 iterations), longer than the round trip to 0.7 m
  (4.67 ns) plus the Ricker pulse (2 sqrt(2)/f0 = 0.94 ns); the farthest
  object surface (0.67 m) needs 5.40 ns.
- **PML**: 20 cells on each side of x and y (gprMax's default formulation,
  HORIPML of order 1); a scattered wave the PML reflects is not removed by
  the background subtraction, so it is thicker than the default 10.
- **Precision**: double (``-cpu_precision double``): the receiver sits in the
  source cell, so the direct field is far larger than the echoes, and the
  background subtraction should leave the scattered field, not float32
  rounding.

Usage (with the gprMax environment, never rpm-cl's: gprMax is no dependency of
rpm-cl)::

    /work/gprmax-venv/bin/python benchmarks/gprmax_fixture.py [--objects first|second]
        [--out tests/data/gprmax] [--threads 1]

It prints the settings, gprMax's run time of each scan and the sizes written
(2 x 41 models of 450 x 420 cells: about 100-120 s per scan on one core).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

C0 = 299_792_458.0

# ---------------------------------------------------------------- settings
DX = 0.002  # cell, m (square cells; one cell in z)
DOMAIN = (0.90, 0.84)  # x, y extent, m
PML_CELLS = 20
TIME_WINDOW = 6e-9  # s
WAVEFORM = {"type": "ricker", "amplitude": 1.0, "frequency": 3e9}
N_SCAN = 41
PITCH = 0.008  # m
SCAN_X0 = 0.290  # first position, m (the array centre is at x = 0.45)
SCAN_Y = 0.090  # the scan line, m
CYLINDERS = [  # centre x, y (m), radius (m)
    {"centre": [0.190, 0.470], "radius": 0.012},
    {"centre": [0.450, 0.390], "radius": 0.010},
    {"centre": [0.730, 0.450], "radius": 0.015},
    {"centre": [0.330, 0.670], "radius": 0.008},
]
PLATE = {"centre": [0.610, 0.690], "length": 0.100, "thickness": 0.004}
#: ``--objects second`` (``tests/data/gprmax_b``): the same scan and
#: settings, other objects laid out without looking at any image of them: a
#: 20 mm cylinder 0.33 m away, a 6 mm one 0.41 m away 13 degrees aside, a
#: 12 mm one at 0.54 m, a 10 mm one 0.26 m from the scan's end, and a 0.12 m
#: plate straight ahead at 0.59 m.
SECOND = (
    [
        {"centre": [0.360, 0.420], "radius": 0.020},
        {"centre": [0.550, 0.500], "radius": 0.006},
        {"centre": [0.250, 0.600], "radius": 0.012},
        {"centre": [0.640, 0.360], "radius": 0.010},
    ],
    {"centre": [0.470, 0.680], "length": 0.120, "thickness": 0.004},
)
BAND_CHECK = (1.5e9, 5e9)  # the band the fixture is meant for, Hz


def plate_corners(plate, face_to):
    """Corners (4, 2) of a thin rectangle centred at ``plate['centre']`` whose
    normal points at ``face_to`` (m): front edge first."""
    c = np.asarray(plate["centre"], float)
    n = np.asarray(face_to, float) - c
    n /= np.linalg.norm(n)
    a = np.array([n[1], -n[0]])  # along the plate
    h, t = plate["length"] / 2, plate["thickness"] / 2
    return np.array([c + t * n - h * a, c + t * n + h * a, c - t * n + h * a, c - t * n - h * a])


def ricker_db(f, f0):
    """Level of the Ricker spectrum f^2 exp(-f^2/f0^2) at f, dB below its peak (f0)."""
    x = f / f0
    return 20 * math.log10(x * x * math.exp(1 - x * x))


def frequency_at_db(level_db, f0):
    """Frequency above f0 where the Ricker spectrum falls to ``level_db``."""
    lo, hi = f0, 20 * f0
    for _ in range(100):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if ricker_db(mid, f0) > level_db else (lo, mid)
    return lo


def surface_distances(xs, ys):
    """Distance (n_antennas, n_objects) from each antenna at (xs, ys) to each
    object's nearest surface point, m (the plate as its polygon)."""
    ant = np.stack([xs, np.full_like(xs, ys)], axis=1)
    out = [np.linalg.norm(ant - c["centre"], axis=1) - c["radius"] for c in CYLINDERS]
    poly = plate_corners(PLATE, (SCAN_X0 + (N_SCAN - 1) * PITCH / 2, SCAN_Y))
    d = np.full(len(ant), np.inf)
    for p, q in zip(poly, np.roll(poly, -1, axis=0)):
        u = np.clip(((ant - p) @ (q - p)) / ((q - p) @ (q - p)), 0, 1)
        d = np.minimum(d, np.linalg.norm(ant - (p + u[:, None] * (q - p)), axis=1))
    out.append(d)
    return np.stack(out, axis=1)


def check_settings():
    """The rules of the module docstring, asserted; returns the numbers printed."""
    f0 = WAVEFORM["frequency"]
    dt = DX / (C0 * math.sqrt(2))
    f40 = frequency_at_db(-40, f0)
    chi = math.sqrt(2) / f0  # gprMax's Ricker delay
    xs = SCAN_X0 + PITCH * np.arange(N_SCAN)
    dist = surface_distances(xs, SCAN_Y)
    checks = {
        "cells per wavelength at the -40 dB frequency": C0 / f40 / DX,
        "cells per wavelength at 5 GHz": C0 / BAND_CHECK[1] / DX,
        "pitch / (wavelength/4) at 5 GHz": PITCH / (C0 / BAND_CHECK[1] / 4),
        "pitch / (wavelength/4) at the -40 dB frequency": PITCH / (C0 / f40 / 4),
        "round trip to 0.7 m + pulse, ns": (2 * 0.7 / C0 + 2 * chi) * 1e9,
        "round trip to the farthest object + pulse, ns": (2 * dist.max() / C0 + 2 * chi) * 1e9,
    }
    assert checks["cells per wavelength at the -40 dB frequency"] >= 10
    assert checks["pitch / (wavelength/4) at the -40 dB frequency"] < 1
    assert checks["round trip to 0.7 m + pulse, ns"] < TIME_WINDOW * 1e9
    assert dist.min() > 0.25 and dist.max() < 0.7
    assert all(ricker_db(f, f0) > -10 for f in BAND_CHECK)
    margin = 2 * PML_CELLS * DX
    for c in CYLINDERS:
        x, y = c["centre"]
        assert margin < x - c["radius"] and x + c["radius"] < DOMAIN[0] - margin
        assert SCAN_Y < y - c["radius"] and y + c["radius"] < DOMAIN[1] - margin
    return dt, f40, chi, xs, dist, checks


def header_lines(title, threads: int) -> list:
    """The gprMax commands of the scan without its objects: domain, cells,
    time window, PML, waveform, and the source and receiver stepped along x."""
    w = WAVEFORM
    return [
        f"#title: {title}",
        "#domain_mode: TM",
        f"#domain: {DOMAIN[0]:.3f} {DOMAIN[1]:.3f} inf",
        f"#dx_dy_dz: {DX} {DX} {DX}",
        f"#time_window: {TIME_WINDOW:g}",
        f"#pml_cells: {PML_CELLS} {PML_CELLS} 0 {PML_CELLS} {PML_CELLS} 0",
        f"#num_threads: {threads}",
        f"#waveform: {w['type']} {w['amplitude']:g} {w['frequency']:g} pulse",
        f"#hertzian_dipole: z {SCAN_X0:.3f} {SCAN_Y:.3f} inf pulse",
        f"#rx: {SCAN_X0:.3f} {SCAN_Y:.3f} inf rx1 Ez",
        f"#src_steps: {PITCH} 0 0",
        f"#rx_steps: {PITCH} 0 0",
    ]


def object_lines(cylinders, plates) -> list:
    """The gprMax commands of PEC ``cylinders`` (dicts of ``centre`` and
    ``radius``, m) and thin ``plates`` (corners (4, 2) each, m; a rectangle as
    two triangular prisms one cell thick)."""
    lines = []
    for c in cylinders:
        (x, y), r = c["centre"], c["radius"]
        lines.append(f"#cylinder: {x:.4f} {y:.4f} 0 {x:.4f} {y:.4f} inf {r:.4f} pec")
    for p in plates:
        for tri in (p[[0, 1, 2]], p[[0, 2, 3]]):
            pts = " ".join(f"{x:.5f} {y:.5f} 0" for x, y in tri)
            lines.append(f"#triangle: {pts} {DX} pec")
    return lines


def input_file(title, targets: bool, threads: int) -> str:
    """A gprMax input file of the scan (``targets`` False: free space only)."""
    lines = header_lines(title, threads)
    if targets:
        plate = plate_corners(PLATE, (SCAN_X0 + (N_SCAN - 1) * PITCH / 2, SCAN_Y))
        lines += object_lines(CYLINDERS, [plate])
    return "\n".join(lines) + "\n"


def run_gprmax(python, name, n_traces, work, threads):
    """Run gprMax on ``work/name.in`` (``n_traces`` traces, double precision,
    ``threads`` OpenMP threads; its output to ``work/name.log``) and merge
    the traces; returns (merged path, seconds, log path)."""
    from gprMax.toolboxes.Utilities.outputfiles_merge import merge_files

    path = os.path.join(work, f"{name}.in")
    log = os.path.join(work, f"{name}.log")
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    t0 = time.perf_counter()
    with open(log, "w") as fh:
        subprocess.run(
            [
                python,
                "-m",
                "gprMax",
                path,
                "-n",
                str(n_traces),
                "-cpu_precision",
                "double",
                "--hide-progress-bars",
            ],
            check=True,
            stdout=fh,
            stderr=subprocess.STDOUT,
            env=env,
            cwd=work,
        )
    sec = time.perf_counter() - t0
    traces = [os.path.join(work, f"{name}{i}.h5") for i in range(1, n_traces + 1)]
    merged = os.path.join(work, f"{name}_merged.h5")
    merge_files(traces, merged)
    return merged, sec, log


def fixture_args(doc: str, folder: str, objects: bool = False):
    """The command line of a fixture script (``doc`` its docstring, ``folder``
    its default under tests/data): --out, --threads, --python, --keep, and
    with ``objects`` --objects (first: ``folder``; second: ``folder``_b)."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    if objects:
        ap.add_argument(
            "--objects",
            choices=("first", "second"),
            default="first",
            help="the fixture's objects (default) or the second scene's (SECOND)",
        )
    ap.add_argument("--out", help=f"output folder (default tests/data/{folder}[_b])")
    ap.add_argument("--threads", type=int, default=1, help="OpenMP threads of gprMax (default 1)")
    ap.add_argument(
        "--python",
        default=sys.executable,
        help="the Python that has gprMax installed (default: this one)",
    )
    ap.add_argument(
        "--keep", help="a folder where gprMax's input files, logs and per-trace outputs are kept"
    )
    args = ap.parse_args()
    if args.out is None:
        second = getattr(args, "objects", "first") == "second"
        name = folder + ("_b" if second else "")
        args.out = os.path.join(os.path.dirname(__file__), "..", "tests", "data", name)
    return args


def run_pair(out, work, n_traces, threads, python, write_input):
    """Run the targets' and the background's scans (``write_input(name,
    with_targets)`` gives each one's input file text), copy the merged
    outputs to ``out``; returns each scan's gprMax seconds."""
    runs = {}
    for name, targets in (("targets", True), ("background", False)):
        with open(os.path.join(work, f"{name}.in"), "w") as fh:
            fh.write(write_input(name, targets))
        merged, sec, _ = run_gprmax(python, name, n_traces, work, threads)
        runs[name] = sec
        print(f"{name}: {n_traces} traces in {sec:.1f} s (gprMax, {threads} thread(s))")
        shutil.copyfile(merged, os.path.join(out, f"{name}_merged.h5"))
    return runs


def read_pair(out, what="scattered"):
    """The merged B-scans in ``out``: prints their peaks and that of the
    difference (``what`` names it); returns (iterations, dt, positions)."""
    import h5py

    with (
        h5py.File(os.path.join(out, "targets_merged.h5"), "r") as f,
        h5py.File(os.path.join(out, "background_merged.h5"), "r") as g,
    ):
        a, b = f["rxs/rx1/Ez"][()], g["rxs/rx1/Ez"][()]
        its, dt_file = int(f.attrs["Iterations"]), float(f.attrs["dt"])
        pos = f["trace_metadata/rxs/rx1/Position"][()]
    scat = a - b
    print(
        f"Ez {a.shape} ({a.dtype}); background peak {np.abs(b).max():.3g} V/m, "
        f"{what} peak {np.abs(scat).max():.3g} V/m "
        f"({20 * np.log10(np.abs(scat).max() / np.abs(b).max()):.1f} dB)"
    )
    return its, dt_file, pos


def fdtd_record(cell, pml_cells, domain, window, dt_file, its, threads, runs):
    """The ``fdtd`` entry of a fixture's scene.json."""
    return {
        "mode": "2-D TM",
        "cell": cell,
        "domain": list(domain),
        "pml_cells": pml_cells,
        "time_window": window,
        "dt": dt_file,
        "iterations": its,
        "precision": "double",
        "threads": threads,
        "seconds": {k: round(v, 1) for k, v in runs.items()},
    }


def write_scene(out, scene):
    """Write ``out/scene.json`` and print the fixture's files and size."""
    with open(os.path.join(out, "scene.json"), "w") as fh:
        json.dump(scene, fh, indent=1)
        fh.write("\n")
    total = 0
    for name in ("targets_merged.h5", "background_merged.h5", "scene.json"):
        size = os.path.getsize(os.path.join(out, name))
        total += size
        print(f"wrote {os.path.join(out, name)} ({size / 1e3:.0f} kB)")
    print(f"fixture: {total / 1e6:.2f} MB")


def main():
    global CYLINDERS, PLATE
    args = fixture_args(__doc__, "gprmax", objects=True)
    if args.objects == "second":
        CYLINDERS, PLATE = SECOND
    import gprMax

    dt, f40, _, xs, dist, checks = check_settings()
    iterations = math.ceil(TIME_WINDOW / dt) + 1
    nx, ny = round(DOMAIN[0] / DX), round(DOMAIN[1] / DX)
    print(
        f"gprMax {gprMax.__version__}: 2-D TM (Ez), free space, {nx} x {ny} cells of "
        f"{1e3 * DX:g} mm, PML {PML_CELLS} cells, double precision, {args.threads} thread(s)"
    )
    print(
        f"time window {1e9 * TIME_WINDOW:g} ns, dt {1e12 * dt:.3f} ps (2-D Courant limit), "
        f"about {iterations} iterations"
    )
    print(
        f"waveform {WAVEFORM['type']} {WAVEFORM['frequency'] / 1e9:g} GHz: "
        f"{ricker_db(1.5e9, WAVEFORM['frequency']):.1f} dB at 1.5 GHz, "
        f"{ricker_db(5e9, WAVEFORM['frequency']):.1f} dB at 5 GHz, -40 dB at {f40 / 1e9:.2f} GHz"
    )
    print(
        f"scan: {N_SCAN} positions at {1e3 * PITCH:g} mm, x {xs[0]:.3f} .. {xs[-1]:.3f} m, "
        f"y {SCAN_Y} m; tx and rx in the same cell"
    )
    for k, v in checks.items():
        print(f"  {k}: {v:.2f}")
    print(
        f"  nearest object surface from the antennas: {dist.min():.3f} .. "
        f"{dist.min(axis=1).max():.3f} m; farthest object {dist.max():.3f} m"
    )

    os.makedirs(args.out, exist_ok=True)
    work = args.keep or tempfile.mkdtemp(prefix="gprmax-fixture-")
    os.makedirs(work, exist_ok=True)
    try:
        runs = run_pair(
            args.out,
            work,
            N_SCAN,
            args.threads,
            args.python,
            lambda name, targets: input_file(f"rpm-cl fixture: {name}", targets, args.threads),
        )
        its, dt_file, pos = read_pair(args.out)
        assert np.allclose(pos[:, 0], xs) and np.allclose(pos[:, 1], SCAN_Y)
        scene = {
            "description": "gprMax 2-D TM B-scan fixture of rpm-cl (benchmarks/gprmax_fixture.py);"
            " gprMax coordinates, m; the targets lie at y > the scan line",
            "gprmax_version": gprMax.__version__,
            "waveform": WAVEFORM,
            "scan": {
                "x": [round(float(v), 6) for v in xs],
                "y": SCAN_Y,
                "pitch": PITCH,
                "tx_rx": "same cell",
                "component": "Ez",
            },
            "cylinders": CYLINDERS,
            "plates": [
                {
                    "corners": plate_corners(PLATE, (SCAN_X0 + (N_SCAN - 1) * PITCH / 2, SCAN_Y))
                    .round(6)
                    .tolist(),
                    "length": PLATE["length"],
                    "thickness": PLATE["thickness"],
                    "material": "pec",
                }
            ],
            "fdtd": fdtd_record(
                DX, PML_CELLS, DOMAIN, TIME_WINDOW, dt_file, its, args.threads, runs
            ),
            "files": {"targets": "targets_merged.h5", "background": "background_merged.h5"},
        }
        write_scene(args.out, scene)
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
