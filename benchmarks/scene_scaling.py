"""Cost against what the scene holds and against the array's size.

    python benchmarks/scene_scaling.py [--sizes 15 45] [--repeats 5] [--method kspace-rpm]
    python benchmarks/scene_scaling.py --write 128 /tmp/spheres128.npz


The robustness benchmark's 3-D scene (three spheres, 20 GHz / 3 GHz, 96
frequencies, 7.5 mm pitch; ``rpm_cl.cli.robustness.GEOMETRY_3D``) on n x n
planar arrays, with all three spheres and with the first alone, noise-free.
Prints the median, least and largest engine time (``ImageResult.timings``,
after one warm-up run) and the decomposition's share, then the ratios the
speed targets name: one sphere against three on the same array, and the
largest array against the smallest.  ``--write N FILE`` saves the
three-sphere scene on an N x N array instead, for an end-to-end run of
``/usr/bin/time -v rpm-cl image FILE`` (wall time and peak memory).
"""

from __future__ import annotations

import argparse
import statistics
import sys
from dataclasses import replace

from rpm_cl.cl import create_env
from rpm_cl.cli import robustness as R
from rpm_cl.imaging import run_method
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.params import default_params


def _time(data, method, engine, repeats):
    params = default_params(data)
    run_method(method, data, params, engine)  # builds, caches
    tot, dec = [], []
    for _ in range(repeats):
        t = run_method(method, data, params, engine).timings
        tot.append(t["total"])
        dec.append(t.get("decompose", 0.0))
    return tot, dec


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[15, 45])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--method", default="kspace-rpm")
    ap.add_argument("--write", nargs=2, metavar=("N", "FILE"))
    ap.add_argument(
        "--default-malloc",
        action="store_true",
        help="leave glibc's malloc as it is (default: rpm_cl.heap.keep_freed_memory, "
        "as rpm-cl bench)",
    )
    args = ap.parse_args(argv)
    if not args.default_malloc:
        from rpm_cl.heap import keep_freed_memory

        keep_freed_memory()
    if args.write:
        from rpm_cl.io.formats import save_data

        n = int(args.write[0])
        g = replace(R.GEOMETRY_3D, x=(n, R.GEOMETRY_3D.x[1]), z=(n, R.GEOMETRY_3D.z[1]))
        spec, f, _ = R.synthesize(g, None, 0)
        save_data(args.write[1], R.radar_data(g, spec, f))
        print(f"wrote {args.write[1]}: three spheres, {n} x {n} array, noise-free")
        return 0
    engine = DeviceRPM(create_env(), "float32")
    med = {}
    for n in args.sizes:
        g3 = replace(R.GEOMETRY_3D, x=(n, R.GEOMETRY_3D.x[1]), z=(n, R.GEOMETRY_3D.z[1]))
        for k, g in ((1, replace(g3, targets=g3.targets[:1])), (3, g3)):
            spec, f, _ = R.synthesize(g, None, 0)
            tot, dec = _time(R.radar_data(g, spec, f), args.method, engine, args.repeats)
            med[n, k] = statistics.median(tot)
            print(
                f"{n:3d} x {n:<3d} {k} sphere{'s' if k > 1 else ' '}: total "
                f"{1e3 * med[n, k]:7.0f} ms (least {1e3 * min(tot):.0f}, largest "
                f"{1e3 * max(tot):.0f}), decompose {1e3 * statistics.median(dec):.0f} ms "
                f"(least {1e3 * min(dec):.0f}, largest {1e3 * max(dec):.0f})"
            )
    for n in args.sizes:
        print(f"{n} x {n}: one sphere / three = {med[n, 1] / med[n, 3]:.2f}")
    lo, hi = min(args.sizes), max(args.sizes)
    if hi > lo:
        print(f"three spheres, {hi} x {hi} / {lo} x {lo} = {med[hi, 3] / med[lo, 3]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
