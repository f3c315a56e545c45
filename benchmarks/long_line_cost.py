"""What a long GPR line costs phase-rpm, stage by stage.

    python benchmarks/long_line_cost.py [--positions 2000]

N positions at 2 cm (default 2000: a 40 m line), 1.5 GHz with 1 GHz of
band, 20 dB in-band noise, point targets every 0.6 m along it 0.30-0.34 m
deep, range axis to 1.5 m.  Printed: targets, points, the share within
30 mm of a target, targets hit, each stage's time (``multipath`` covers the
point filters: reach, coherence, double bounces) and the points each
filter drops.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np


def main(argv=None) -> int:
    from rpm_cl.cl import create_env
    from rpm_cl.imaging import run_method
    from rpm_cl.io.data import Array, Waveform
    from rpm_cl.rpm import DeviceRPM
    from rpm_cl.rpm.params import default_params
    from rpm_cl.simulate import simulate
    from rpm_cl.simulate.scene import PointTarget, Scene

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--positions", type=int, default=2000)
    args = ap.parse_args(argv)
    n = args.positions
    length = n * 0.02
    targets = np.array(
        [
            (-length / 2 + 0.5 + 0.6 * i, 0.30 + 0.02 * (i % 3))
            for i in range(int((length - 1) / 0.6))
        ]
    )
    scene = Scene(tuple(PointTarget(tuple(p)) for p in targets))
    x = np.arange(n) * 0.02 - length / 2
    data = simulate(scene, Array(x), Waveform(1.5e9, 1.0e9), np.arange(0, 1.5, 0.005), 20.0, 0)
    engine = DeviceRPM(create_env())
    t0 = time.perf_counter()
    res = run_method("phase-rpm", data, default_params(data), engine)
    wall = time.perf_counter() - t0
    p = res.image.points
    d = np.linalg.norm(p[:, None] - targets[None], axis=2)
    print(
        f"{n} positions, {len(targets)} targets: {len(p)} points, "
        f"{100 * np.mean(d.min(axis=1) <= 0.03):.1f} % within 30 mm, "
        f"{int(np.sum(d.min(axis=0) <= 0.03))} hit; {wall:.1f} s"
    )
    print("stages (s): " + ", ".join(f"{k} {v:.2f}" for k, v in res.timings.items()))
    print("dropped: " + ", ".join(f"{k} {v}" for k, v in res.dropped.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
