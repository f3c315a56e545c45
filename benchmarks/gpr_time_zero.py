"""Impulse GPR rebar lines recorded from before the antennas' pulse: bars
found with time zero at the record's start, at the transmit instant, and
picked from the data (``--time-zero auto``,
``rpm_cl.extract.preprocess.pick_time_zero``).

The lines are those of ``benchmarks/gpr_jitter.py`` (written sample by
sample as GSSI files, not by the engine's simulator), without jitter, and
a third, ``c``: a 2.6 GHz ringing pulse (its envelope peaks 0.45 periods
after the transmit instant), eps_r 8.5, sixteen bars 0.15 m apart under 45
mm and eight 0.3 m apart under 160 mm, 300 traces at 1 cm, recorded with
a range gain of 4 dB/ns from the transmit instant.  Each is
converted with time zero at sample 0 (``rpm_cl.io.dzt.convert``) and
imaged in its medium with the default background by phase-rpm and the DAS
peaks (``das`` method).  Columns: the time zero used (range, m), the bars
found (a point within 30 mm of a bar's top in x and depth), the share of
points within 30 mm of a bar's boundary, and the median over the bars of
the depth error of the nearest point within 30 mm in x.

Usage::

    python benchmarks/gpr_time_zero.py [--lines a b c]
"""

from __future__ import annotations

import argparse

import numpy as np
from gpr_jitter import LINES, N0, SAMPLES, as_loaded, image_points, score, traces

from rpm_cl.io.model import C0

RINGING = {
    "pulse": "ringing",
    "fc": 2.6e9,
    "eps": 8.5,
    "nx": 300,
    "dx": 0.01,
    "window": 10e-9,
    "bars": [(0.37 + 0.15 * k, 0.045) for k in range(16)]
    + [(0.45 + 0.30 * k, 0.160) for k in range(8)],
    "seed": 1,
    "noise": 0.01,
    "gain_db_per_ns": 4.0,
}
ALL = {**LINES, "c": RINGING}


def depth_error(points: np.ndarray, line: dict) -> float:
    """Median over the bars of the depth error (m) of the nearest point in
    depth among those within 30 mm in x (bars without one left out)."""
    errs = []
    for xb, cover in line["bars"]:
        m = np.abs(points[:, 0] - xb) <= 0.03
        if m.any():
            errs.append(np.min(np.abs(points[m, 1] - cover)))
    return float(np.median(errs)) if errs else float("nan")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", nargs="+", choices=sorted(ALL), default=sorted(ALL))
    args = ap.parse_args(argv)

    from rpm_cl.cl import create_env
    from rpm_cl.rpm import DeviceRPM

    engine = DeviceRPM(create_env())
    print(
        f"{'line':4s} {'time zero':18s} {'method':9s} {'bars':>6s} {'<=30 mm':>8s} "
        f"{'depth err':>10s}"
    )
    for name in args.lines:
        line = ALL[name]
        data = as_loaded(traces(line, 0.0)[0], line)
        transmit = N0 * line["window"] / SAMPLES * C0 / 2
        for label, zero in (("record start", 0.0), ("transmit", transmit), ("auto", None)):
            for method in ("phase-rpm", "das"):
                pts, params = image_points(method, data, engine, eps_r=line["eps"], time_zero=zero)
                found, near, _ = score(pts, line)
                err = depth_error(pts, line)
                print(
                    f"{name:4s} {label:12s} {params.time_zero:5.3f} {method:9s} "
                    f"{found:3d}/{len(line['bars']):<2d} {100 * near:7.1f}% "
                    f"{1e3 * err:7.1f} mm"
                )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
