"""Make the gprMax half-space fixture: PEC rods buried in a dielectric below an air gap.

Writes ``tests/data/gprmax_halfspace/``:

- ``targets_merged.h5``: a monostatic B-scan (51 traces) over a lossless
  dielectric half-space (relative permittivity 6) with four PEC rods buried
  in it;
- ``background_merged.h5``: the same scan over the same half-space without
  the rods (so that subtracting it removes the direct coupling *and* the
  surface's own reflection, leaving the rods' echoes);
- ``scene.json``: the geometry (rod centres and radii, the surface, the
  permittivity, the antenna height), the scan positions, the waveform and the
  FDTD settings and run times; ``rpm_cl.io.gprmax.read_sidecar`` reads it.

The model
---------
2-D TM (``#domain_mode: TM``: Ez, Hx, Hy), 2 mm cells.  gprMax's y is up: the
half-space fills ``y < SURFACE_Y`` (through the PML on the three sides it
touches); the antennas (a z-directed Hertzian dipole and an Ez receiver in
the same cell) move 10 mm a step along x, 51 positions, x 0.20-0.70 m, at
``ANTENNA_HEIGHT`` = 0.08 m above the surface.  The rods (radii 6-10 mm) lie
0.10-0.29 m below the surface (centres), spread over the aperture, seen from
every antenna through the surface at up to 70 degrees off the normal.

Choices, checked below before anything runs:

- **Excitation**: a Ricker wavelet of centre 2 GHz, within -6 dB of its peak
  from 1 to 3 GHz (the band the tests image), -40 dB at 5.5 GHz.
- **Cell**: 2 mm is 11 cells per wavelength *in the dielectric* at the -40 dB
  frequency (the rule is 10) and 20 at 3 GHz; the time step is gprMax's 2-D
  Courant limit of free space, dx / (c sqrt 2) = 4.717 ps.  FDTD's numerical
  dispersion slows a wave of 20 cells per wavelength by about (k dx)^2 / 24
  = 0.4 % (at most, along the axes), a few mm over the 0.3 m paths in the
  dielectric: well under the tests' 20 mm.
- **Pitch**: 10 mm, below a quarter wavelength in air at 3 GHz (25 mm), so the
  monostatic k_x axis (up to 2 k in air, where the antennas are) is not
  aliased over the imaged band.
- **Time window**: the longest two-way refracted travel time to a rod
  (Fermat, from the farthest antenna) plus the Ricker pulse (2 sqrt(2)/f0).
- **PML**: 20 cells on each side (the half-space runs into it: gprMax's PML
  takes the material of the cells it covers).
- **Precision**: double (``-cpu_precision double``): the surface reflection
  and the direct coupling are far stronger than the rods' echoes, and the
  background subtraction should leave the rods' echoes, not rounding.

Usage (with the gprMax environment, never rpm-cl's: gprMax is no dependency of
rpm-cl)::

    /work/gprmax-venv/bin/python benchmarks/gprmax_halfspace.py
        [--out tests/data/gprmax_halfspace] [--threads 1]

It prints the settings, gprMax's run time of each scan and the sizes written.
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile

import numpy as np
from gprmax_fixture import (  # this folder: the same runs and Ricker
    fdtd_record,
    fixture_args,
    frequency_at_db,
    read_pair,
    ricker_db,
    run_pair,
    write_scene,
)

C0 = 299_792_458.0

# ---------------------------------------------------------------- settings
DX = 0.002  # cell, m (square cells; one cell in z)
DOMAIN = (0.90, 0.57)  # x, y extent, m
PML_CELLS = 20
WAVEFORM = {"type": "ricker", "amplitude": 1.0, "frequency": 2e9}
EPS_R = 6.0  # the half-space, lossless
SURFACE_Y = 0.40  # the surface, gprMax y, m; the half-space is y < SURFACE_Y
ANTENNA_HEIGHT = 0.08  # the antennas above the surface, m
N_SCAN = 51
PITCH = 0.010  # m
SCAN_X0 = 0.200  # first position, m (the array centre is at x = 0.45)
RODS = [  # centre x (m), depth of the centre below the surface (m), radius (m)
    {"x": 0.300, "depth": 0.100, "radius": 0.008},
    {"x": 0.450, "depth": 0.220, "radius": 0.010},
    {"x": 0.580, "depth": 0.140, "radius": 0.006},
    {"x": 0.660, "depth": 0.290, "radius": 0.008},
]
BAND = (1e9, 3e9)  # the band the fixture is meant for, Hz


def refracted_range(rho, h, d, n, step=1e-4):
    """One-way optical path (air-equivalent range, m) from an antenna at
    height ``h`` above the surface to points ``d`` below it and ``rho``
    aside (arrays of one shape): Fermat's minimum over the crossing point, by
    a search over crossings every ``step`` (the path is stationary there, so
    the error is of order step^2 / h: below 1 um), independent of rpm-cl's
    solver."""
    rho, d = np.broadcast_arrays(np.asarray(rho, float), np.asarray(d, float))
    u = np.arange(0.0, rho.max() + step, step)[:, None] * np.ones(rho.size)
    u = np.minimum(u, rho.ravel()[None])
    path = np.hypot(u, h) + n * np.hypot(rho.ravel()[None] - u, d.ravel()[None])
    return path.min(axis=0).reshape(rho.shape)


def rod_ranges(xs):
    """Air-equivalent range (n_antennas, n_rods) from each antenna to each
    rod's nearest point in optical path (its surface, sampled every degree), m."""
    n = math.sqrt(EPS_R)
    a = np.radians(np.arange(0, 360, 1.0))
    out = np.zeros((len(xs), len(RODS)))
    for j, rod in enumerate(RODS):
        px = rod["x"] + rod["radius"] * np.cos(a)
        pd = rod["depth"] + rod["radius"] * np.sin(a)
        for i, x in enumerate(xs):
            out[i, j] = refracted_range(np.abs(px - x), ANTENNA_HEIGHT, pd, n).min()
    return out


def check_settings():
    """The rules of the module docstring, asserted; returns the numbers printed."""
    f0 = WAVEFORM["frequency"]
    dt = DX / (C0 * math.sqrt(2))
    f40 = frequency_at_db(-40, f0)
    chi = math.sqrt(2) / f0  # gprMax's Ricker delay
    n = math.sqrt(EPS_R)
    xs = SCAN_X0 + PITCH * np.arange(N_SCAN)
    ranges = rod_ranges(xs)
    window = 2 * ranges.max() / C0 + 2 * chi
    window = math.ceil(window * 1e10 + 1) / 1e10  # up to the next 0.1 ns, with 0.1 ns spare
    checks = {
        "cells per wavelength in the half-space at the -40 dB frequency": C0 / (n * f40) / DX,
        "cells per wavelength in the half-space at 3 GHz": C0 / (n * BAND[1]) / DX,
        "pitch / (wavelength in air / 4) at 3 GHz": PITCH / (C0 / BAND[1] / 4),
        "longest refracted round trip + pulse, ns": 1e9 * (2 * ranges.max() / C0 + 2 * chi),
        "time window, ns": 1e9 * window,
    }
    assert checks["cells per wavelength in the half-space at the -40 dB frequency"] >= 10
    assert checks["pitch / (wavelength in air / 4) at 3 GHz"] < 1
    assert all(ricker_db(f, f0) > -7 for f in BAND)
    margin = PML_CELLS * DX
    y_ant = SURFACE_Y + ANTENNA_HEIGHT
    assert margin < y_ant - 0.02 and y_ant + 0.02 < DOMAIN[1] - margin
    for rod in RODS:
        y = SURFACE_Y - rod["depth"]
        r = rod["radius"]
        assert 2 * margin < rod["x"] - r and rod["x"] + r < DOMAIN[0] - 2 * margin
        assert margin + 0.03 < y - r and y + r < SURFACE_Y - 0.05
    return dt, f40, chi, xs, ranges, window, checks


def input_file(title, rods: bool, threads: int, window: float) -> str:
    """A gprMax input file of the scan (``rods`` False: the half-space only)."""
    w = WAVEFORM
    y_ant = SURFACE_Y + ANTENNA_HEIGHT
    lines = [
        f"#title: {title}",
        "#domain_mode: TM",
        f"#domain: {DOMAIN[0]:.3f} {DOMAIN[1]:.3f} inf",
        f"#dx_dy_dz: {DX} {DX} {DX}",
        f"#time_window: {window:.4g}",
        f"#pml_cells: {PML_CELLS} {PML_CELLS} 0 {PML_CELLS} {PML_CELLS} 0",
        f"#num_threads: {threads}",
        f"#material: {EPS_R:g} 0 1 0 half_space",
        f"#waveform: {w['type']} {w['amplitude']:g} {w['frequency']:g} pulse",
        f"#hertzian_dipole: z {SCAN_X0:.3f} {y_ant:.3f} inf pulse",
        f"#rx: {SCAN_X0:.3f} {y_ant:.3f} inf rx1 Ez",
        f"#src_steps: {PITCH} 0 0",
        f"#rx_steps: {PITCH} 0 0",
        f"#box: 0 0 0 {DOMAIN[0]:.3f} {SURFACE_Y:.3f} inf half_space",
    ]
    if rods:
        for rod in RODS:
            x, y, r = rod["x"], SURFACE_Y - rod["depth"], rod["radius"]
            lines.append(f"#cylinder: {x:.4f} {y:.4f} 0 {x:.4f} {y:.4f} inf {r:.4f} pec")
    return "\n".join(lines) + "\n"


def main():
    args = fixture_args(__doc__, "gprmax_halfspace")
    import gprMax

    dt, f40, _, xs, ranges, window, checks = check_settings()
    iterations = math.ceil(window / dt) + 1
    nx, ny = round(DOMAIN[0] / DX), round(DOMAIN[1] / DX)
    print(
        f"gprMax {gprMax.__version__}: 2-D TM (Ez), {nx} x {ny} cells of {1e3 * DX:g} mm, "
        f"PML {PML_CELLS} cells, double precision, {args.threads} thread(s)"
    )
    print(
        f"half-space eps_r {EPS_R:g} (lossless) below y = {SURFACE_Y} m; antennas "
        f"{ANTENNA_HEIGHT} m above it"
    )
    print(
        f"time window {1e9 * window:g} ns, dt {1e12 * dt:.3f} ps (2-D Courant limit), "
        f"about {iterations} iterations"
    )
    print(
        f"waveform {WAVEFORM['type']} {WAVEFORM['frequency'] / 1e9:g} GHz: "
        f"{ricker_db(BAND[0], WAVEFORM['frequency']):.1f} dB at {BAND[0] / 1e9:g} GHz, "
        f"{ricker_db(BAND[1], WAVEFORM['frequency']):.1f} dB at {BAND[1] / 1e9:g} GHz, "
        f"-40 dB at {f40 / 1e9:.2f} GHz"
    )
    print(
        f"scan: {N_SCAN} positions at {1e3 * PITCH:g} mm, x {xs[0]:.3f} .. {xs[-1]:.3f} m; "
        f"tx and rx in the same cell"
    )
    for k, v in checks.items():
        print(f"  {k}: {v:.2f}")
    print(
        f"  refracted ranges to the rods (air-equivalent, c t / 2): {ranges.min():.3f} .. "
        f"{ranges.max():.3f} m"
    )

    os.makedirs(args.out, exist_ok=True)
    work = args.keep or tempfile.mkdtemp(prefix="gprmax-halfspace-")
    os.makedirs(work, exist_ok=True)
    try:
        runs = run_pair(
            args.out,
            work,
            N_SCAN,
            args.threads,
            args.python,
            lambda name, rods: input_file(
                f"rpm-cl half-space fixture: {name}", rods, args.threads, window
            ),
        )
        its, dt_file, pos = read_pair(args.out, "rods' echoes")
        y_ant = SURFACE_Y + ANTENNA_HEIGHT
        assert np.allclose(pos[:, 0], xs) and np.allclose(pos[:, 1], y_ant)
        scene = {
            "description": "gprMax 2-D TM B-scan over a dielectric half-space with buried PEC "
            "rods (benchmarks/gprmax_halfspace.py); gprMax coordinates, m; the "
            "half-space fills y < medium.surface_y, the antennas lie above it",
            "gprmax_version": gprMax.__version__,
            "waveform": WAVEFORM,
            "scan": {
                "x": [round(float(v), 6) for v in xs],
                "y": round(y_ant, 6),
                "pitch": PITCH,
                "tx_rx": "same cell",
                "component": "Ez",
            },
            "medium": {
                "eps_r": EPS_R,
                "surface_y": SURFACE_Y,
                "antenna_height": ANTENNA_HEIGHT,
                "conductivity": 0.0,
            },
            "cylinders": [
                {
                    "centre": [r["x"], round(SURFACE_Y - r["depth"], 6)],
                    "radius": r["radius"],
                    "depth": r["depth"],
                    "material": "pec",
                }
                for r in RODS
            ],
            "band": list(BAND),
            "fdtd": fdtd_record(DX, PML_CELLS, DOMAIN, window, dt_file, its, args.threads, runs),
            "files": {"targets": "targets_merged.h5", "background": "background_merged.h5"},
        }
        write_scene(args.out, scene)
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
