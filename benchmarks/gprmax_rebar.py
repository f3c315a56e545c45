"""Make the gprMax rebar fixture: a row of bars in concrete under a ground-coupled line.

Writes ``tests/data/gprmax_rebar/``:

- ``targets_merged.h5``: a monostatic B-scan (61 traces) inside a lossless
  dielectric of relative permittivity 6 that fills the whole model (the
  antennas lie in it, as a ground-coupled GPR's see the concrete below the
  surface), with five PEC bars 0.15 m apart under 0.1-0.13 m of cover and
  a thicker, deeper bar between two of them;
- ``background_merged.h5``: the same scan without the bars (the direct
  coupling), so that subtracting it leaves the bars' echoes, their double
  bounces between neighbouring bars and the waves creeping round them,
  which rpm-cl's own simulator does not make;
- ``scene.json``: the geometry (bar centres and radii, the permittivity),
  the scan positions, the waveform and the FDTD settings and run times;
  ``rpm_cl.io.gprmax.read_sidecar`` reads it (a ``medium`` without a
  surface: a homogeneous medium).

The model
---------
2-D TM (Ez, Hx, Hy), 2 mm cells.  gprMax's y is up; the antennas (a
z-directed Hertzian dipole and an Ez receiver in the same cell) move 12 mm a
step along x at ``SCAN_Y``; the bars lie below them.  At half the antennas
the two nearest bars' echoes are less than 48 mm apart in range (true
metres), about the 41 mm range resolution of the imaged band in the
dielectric: the echoes of neighbouring bars overlap.

Choices, checked below before anything runs:

- **Excitation**: a Ricker wavelet of centre 1.5 GHz, within -6 dB of its
  peak from 0.75 to 2.25 GHz (the band the tests image), -40 dB at
  4.1 GHz.
- **Cell**: 2 mm is at least 10 cells per wavelength in the dielectric at
  the -40 dB frequency; the time step is gprMax's 2-D Courant limit of free
  space, dx / (c sqrt 2).
- **Pitch**: 12 mm, below a quarter wavelength in the dielectric at
  2.25 GHz (13.6 mm), so the monostatic k_x axis is not aliased over the
  imaged band.
- **Time window**: the longest two-way travel time to a bar (from the
  farthest antenna, at the dielectric's speed) plus the Ricker pulse
  (2 sqrt(2)/f0).
- **PML**: 20 cells on each side (the dielectric runs into it).
- **Precision**: double (``-cpu_precision double``): the direct coupling is
  far stronger than the bars' echoes.

Usage (with the gprMax environment, never rpm-cl's: gprMax is no dependency of
rpm-cl)::

    /work/gprmax-venv/bin/python benchmarks/gprmax_rebar.py
        [--out tests/data/gprmax_rebar] [--threads 1]

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
DOMAIN = (1.00, 0.42)  # x, y extent, m
PML_CELLS = 20
WAVEFORM = {"type": "ricker", "amplitude": 1.0, "frequency": 1.5e9}
EPS_R = 6.0  # the dielectric, lossless, everywhere
N_SCAN = 61
PITCH = 0.012  # m
SCAN_X0 = 0.140  # first position, m (the array centre is at x = 0.50)
SCAN_Y = 0.340  # the antennas, gprMax y, m
BARS = [  # centre x (m), depth of the centre below the antennas (m), radius (m)
    {"x": 0.200, "depth": 0.110, "radius": 0.006},
    {"x": 0.350, "depth": 0.125, "radius": 0.008},
    {"x": 0.500, "depth": 0.105, "radius": 0.006},
    {"x": 0.650, "depth": 0.130, "radius": 0.008},
    {"x": 0.800, "depth": 0.115, "radius": 0.006},
    {"x": 0.430, "depth": 0.220, "radius": 0.010},
]
BAND = (0.75e9, 2.25e9)  # the band the fixture is meant for, Hz


def bar_ranges(xs):
    """Air-equivalent range (n_antennas, n_bars) from each antenna to each
    bar's nearest point: sqrt(eps_r) times the distance to its surface, m."""
    n = math.sqrt(EPS_R)
    out = np.zeros((len(xs), len(BARS)))
    for j, bar in enumerate(BARS):
        out[:, j] = n * (np.hypot(xs - bar["x"], bar["depth"]) - bar["radius"])
    return out


def check_settings():
    """The rules of the module docstring, asserted; returns the numbers printed."""
    f0 = WAVEFORM["frequency"]
    dt = DX / (C0 * math.sqrt(2))
    f40 = frequency_at_db(-40, f0)
    chi = math.sqrt(2) / f0  # gprMax's Ricker delay
    n = math.sqrt(EPS_R)
    xs = SCAN_X0 + PITCH * np.arange(N_SCAN)
    ranges = bar_ranges(xs)
    window = 2 * ranges.max() / C0 + 2 * chi
    window = math.ceil(window * 1e10 + 1) / 1e10  # up to the next 0.1 ns, with 0.1 ns spare
    checks = {
        "cells per wavelength in the dielectric at the -40 dB frequency": C0 / (n * f40) / DX,
        "pitch / (wavelength in the dielectric / 4) at the top of the band": PITCH
        / (C0 / (n * BAND[1]) / 4),
        "longest round trip + pulse, ns": 1e9 * (2 * ranges.max() / C0 + 2 * chi),
        "time window, ns": 1e9 * window,
    }
    assert checks["cells per wavelength in the dielectric at the -40 dB frequency"] >= 10
    assert checks["pitch / (wavelength in the dielectric / 4) at the top of the band"] < 1
    assert all(ricker_db(f, f0) > -6 for f in BAND)
    margin = PML_CELLS * DX
    assert margin + 0.02 < SCAN_Y < DOMAIN[1] - margin - 0.02
    assert 2 * margin < xs[0] and xs[-1] < DOMAIN[0] - 2 * margin
    for bar in BARS:
        y, r = SCAN_Y - bar["depth"], bar["radius"]
        assert 2 * margin < bar["x"] - r and bar["x"] + r < DOMAIN[0] - 2 * margin
        assert margin + 0.03 < y - r
    return dt, f40, xs, ranges, window, checks


def input_file(title, bars: bool, threads: int, window: float) -> str:
    """A gprMax input file of the scan (``bars`` False: the dielectric only)."""
    w = WAVEFORM
    lines = [
        f"#title: {title}",
        "#domain_mode: TM",
        f"#domain: {DOMAIN[0]:.3f} {DOMAIN[1]:.3f} inf",
        f"#dx_dy_dz: {DX} {DX} {DX}",
        f"#time_window: {window:.4g}",
        f"#pml_cells: {PML_CELLS} {PML_CELLS} 0 {PML_CELLS} {PML_CELLS} 0",
        f"#num_threads: {threads}",
        f"#material: {EPS_R:g} 0 1 0 concrete",
        f"#waveform: {w['type']} {w['amplitude']:g} {w['frequency']:g} pulse",
        f"#hertzian_dipole: z {SCAN_X0:.3f} {SCAN_Y:.3f} inf pulse",
        f"#rx: {SCAN_X0:.3f} {SCAN_Y:.3f} inf rx1 Ez",
        f"#src_steps: {PITCH} 0 0",
        f"#rx_steps: {PITCH} 0 0",
        f"#box: 0 0 0 {DOMAIN[0]:.3f} {DOMAIN[1]:.3f} inf concrete",
    ]
    if bars:
        for bar in BARS:
            x, y, r = bar["x"], SCAN_Y - bar["depth"], bar["radius"]
            lines.append(f"#cylinder: {x:.4f} {y:.4f} 0 {x:.4f} {y:.4f} inf {r:.4f} pec")
    return "\n".join(lines) + "\n"


def main():
    args = fixture_args(__doc__, "gprmax_rebar")
    import gprMax

    dt, f40, xs, ranges, window, checks = check_settings()
    iterations = math.ceil(window / dt) + 1
    nx, ny = round(DOMAIN[0] / DX), round(DOMAIN[1] / DX)
    print(
        f"gprMax {gprMax.__version__}: 2-D TM (Ez), {nx} x {ny} cells of {1e3 * DX:g} mm, "
        f"PML {PML_CELLS} cells, double precision, {args.threads} thread(s)"
    )
    print(f"dielectric eps_r {EPS_R:g} (lossless) everywhere, the antennas in it")
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
        f"  ranges to the bars (air-equivalent, c t / 2): {ranges.min():.3f} .. "
        f"{ranges.max():.3f} m"
    )

    os.makedirs(args.out, exist_ok=True)
    work = args.keep or tempfile.mkdtemp(prefix="gprmax-rebar-")
    os.makedirs(work, exist_ok=True)
    try:
        runs = run_pair(
            args.out,
            work,
            N_SCAN,
            args.threads,
            args.python,
            lambda name, bars: input_file(
                f"rpm-cl rebar fixture: {name}", bars, args.threads, window
            ),
        )
        its, dt_file, pos = read_pair(args.out, "bars' echoes")
        assert np.allclose(pos[:, 0], xs) and np.allclose(pos[:, 1], SCAN_Y)
        scene = {
            "description": "gprMax 2-D TM B-scan inside a dielectric with PEC bars "
            "(benchmarks/gprmax_rebar.py); gprMax coordinates, m; the bars lie at y < "
            "the scan line, the dielectric fills the model",
            "gprmax_version": gprMax.__version__,
            "waveform": WAVEFORM,
            "scan": {
                "x": [round(float(v), 6) for v in xs],
                "y": SCAN_Y,
                "pitch": PITCH,
                "tx_rx": "same cell",
                "component": "Ez",
            },
            "medium": {"eps_r": EPS_R, "conductivity": 0.0},
            "cylinders": [
                {
                    "centre": [b_["x"], round(SCAN_Y - b_["depth"], 6)],
                    "radius": b_["radius"],
                    "depth": b_["depth"],
                    "material": "pec",
                }
                for b_ in BARS
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
