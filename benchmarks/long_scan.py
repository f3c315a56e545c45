"""A GPR-like long line over several targets: targets hit and points on them.

    python benchmarks/long_scan.py [--seeds 0 1] [--rebar]

200 positions at 2 cm (a 4 m line), 1.5 GHz carrier with 1 GHz of band
(range resolution 0.15 m), six point targets 0.30-0.34 m deep spread over
the line (``tests/test_config.py``'s scene), noise-free and 20 dB in-band.
For phase-rpm and kspace-rpm with the default settings, without the
near-field focus (``focus=False``) and without the range-walk alignment
(``align=False``), and DAS peaks: the targets with a point within 30 mm,
each target's nearest point (mm) and the share of points within 30 mm of
a target.  The line is 13 times as long as the targets are deep: a
cluster's k and range then hold every target seen at that angle, each at
its own place along the line, while the focus (kspace module notes, step
5) is the wavefront of one point at the line's centre.  phase-rpm cuts
such a line into segments (``rpm_cl.extract.segments``); kspace-rpm, the
paper's method, decomposes it whole.

``--rebar``: eighteen points 0.2 m apart, 0.27-0.33 m down, under 200
positions at 2.13 cm with 0.98-2 GHz (a rebar mat's B-scan in electrical
range: a 0.11-0.13 m cover at eps_r 6), the defaults only.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from rpm_cl.cl import create_env
from rpm_cl.imaging import run_method
from rpm_cl.io.data import Array, Waveform
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import simulate
from rpm_cl.simulate.scene import PointTarget, Scene

TARGETS = np.array(
    [(t, 0.30 + 0.02 * (i % 3)) for i, t in enumerate((-1.5, -0.9, -0.3, 0.4, 1.0, 1.6))]
)
REBAR = np.array([(-1.8 + 0.2 * i, 0.27 + 0.03 * ((i * 7) % 3)) for i in range(18)])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0])
    ap.add_argument("--rebar", action="store_true", help="the eighteen-point scene")
    args = ap.parse_args(argv)
    engine = DeviceRPM(create_env())
    targets = REBAR if args.rebar else TARGETS
    scene = Scene(tuple(PointTarget(tuple(p)) for p in targets))
    if args.rebar:
        xs, waveform = np.arange(200) * 0.0213 - 2.13, Waveform(1.49e9, 1.02e9)
        runs = [("phase-rpm", "default"), ("kspace-rpm", "default"), ("das", "default")]
    else:
        xs, waveform = np.arange(200) * 0.02 - 2.0, Waveform(1.5e9, 1.0e9)
        runs = [(m, o) for m in ("phase-rpm", "kspace-rpm") for o in ("default", "focus", "align")]
        runs.append(("das", "default"))
    print(
        "S/N    seed  method       off      points  hit  nearest per target (mm)          <= 30 mm"
    )
    for snr in (None, 20.0):
        for seed in args.seeds:
            data = simulate(scene, Array(xs), waveform, np.arange(0, 1.5, 0.005), snr, seed)
            for method, off in runs:
                params = default_params(data, **({} if off == "default" else {off: False}))
                pts = run_method(method, data, params, engine).image.points
                d = np.linalg.norm(pts[:, None] - targets[None], axis=2)
                near = d.min(axis=0) if len(pts) else np.full(len(targets), np.inf)
                on = float(np.mean(d.min(axis=1) <= 0.03)) if len(pts) else 0.0
                label = "-" if off == "default" else off
                mm = " ".join(f"{v * 1e3:5.0f}" for v in near) if not args.rebar else ""
                print(
                    f"{'inf' if snr is None else f'{snr:g}':5s}  {seed:4d}  {method:11s}  "
                    f"{label:7s}  {len(pts):6d}  {int(np.sum(near <= 0.03))}/{len(targets)}  "
                    f"{mm}  {100 * on:6.1f} %"
                )
    return 0


if __name__ == "__main__":
    sys.exit(main())
