"""What a long GPR line costs phase-rpm, stage by stage.

    python benchmarks/long_line_cost.py [--positions 2000] [--range-max 1.5] [--host-sums]
    python benchmarks/long_line_cost.py --data LINE.npz [--host-sums]

N positions at 2 cm (default 2000: a 40 m line), 1.5 GHz with 1 GHz of
band, 20 dB in-band noise, point targets every 0.6 m along it 0.30-0.34 m
deep, range axis to 1.5 m (``--range-max``: a longer record, as a deep
survey's, whose every antenna reaches every point).  Printed: targets, points, the share within
30 mm of a target, targets hit, each stage's time (``multipath`` covers the
point filters: reach, coherence, double bounces) and the points each
filter drops.  ``--host-sums`` runs the line again with the coherence
test's sums in NumPy instead of on the device (float64 both ways) and says
whether the points are the same.
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
    from rpm_cl.rpm import DeviceRPM, methods
    from rpm_cl.rpm.params import default_params
    from rpm_cl.simulate import simulate
    from rpm_cl.simulate.scene import PointTarget, Scene

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--positions", type=int, default=2000)
    ap.add_argument(
        "--range-max", type=float, default=1.5, help="end of the range axis, m (default 1.5)"
    )
    ap.add_argument(
        "--host-sums",
        action="store_true",
        help="run again with the coherence test's sums on the host (NumPy)",
    )
    ap.add_argument(
        "--data",
        help="instead: this input file (as rpm-cl image reads it), imaged with time zero "
        "'auto'; no targets to score",
    )
    args = ap.parse_args(argv)
    over = {}
    if args.data:
        from rpm_cl.io.load import load_data

        data = load_data(args.data)
        n, targets, over = data.array.n, np.zeros((0, 2)), {"time_zero": "auto"}
    else:
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
        rng = np.arange(0, args.range_max, 0.005)
        data = simulate(scene, Array(x), Waveform(1.5e9, 1.0e9), rng, 20.0, 0)
    engine = DeviceRPM(create_env())
    on_device = methods.device_sums
    results = []
    for where in ("device", "host") if args.host_sums else ("device",):
        methods.device_sums = on_device if where == "device" else (lambda engine: None)
        try:
            t0 = time.perf_counter()
            res = run_method("phase-rpm", data, default_params(data, **over), engine)
            wall = time.perf_counter() - t0
        finally:
            methods.device_sums = on_device
        p = res.image.points
        line = f"{n} positions, coherence sums on the {where}: {len(p)} points"
        if len(targets):
            d = np.linalg.norm(p[:, None] - targets[None], axis=2)
            line = (
                f"{n} positions, {len(targets)} targets, coherence sums on the {where}: "
                f"{len(p)} points, {100 * np.mean(d.min(axis=1) <= 0.03):.1f} % within 30 mm, "
                f"{int(np.sum(d.min(axis=0) <= 0.03))} hit"
            )
        print(f"{line}; {wall:.1f} s")
        print("stages (s): " + ", ".join(f"{k} {v:.2f}" for k, v in res.timings.items()))
        print("dropped: " + ", ".join(f"{k} {v}" for k, v in res.dropped.items()))
        results.append(res.image.points)
    if len(results) == 2:
        print(f"the same points both ways: {np.array_equal(results[0], results[1])}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
