"""Run time against error over imaging settings and array sizes (issue 5).

Usage::

    python benchmarks/pareto.py [--out benchmarks/pareto.png] [--quick]

1. Settings grid on the human body (11 x 17 array, S/N 20 dB, seed 0):
   max_neighbours x pair_cutoff x window period x kernel precision.  For
   each: the median time from s(X, Z, R) to points (3 runs after a warm-up) and
   the accuracy figures (RP <= 10 mm, RPM <= 50 mm, RPM <= 10 mm).  The table
   marks the settings on the Pareto front of (time, fraction of points
   beyond 10 mm) and the default.
2. The default setting on larger arrays at the same 7.5 mm pitch: 11 x 17,
   32 x 32, 64 x 64 (the decomposition's zero-padding lowered to 2 above
   1024 antennas to bound its memory).

Writes the plot of (1) to ``--out`` (matplotlib, Agg).
"""

import argparse
import itertools

import numpy as np

from rpm_cl.cl import create_env
from rpm_cl.data import Array
from rpm_cl.imaging import default_params, timed_run
from rpm_cl.metrics import summary
from rpm_cl.rpm import DeviceRPM
from rpm_cl.scene import HUMAN_BODY_ARRAY_Z, get_preset
from rpm_cl.simulate import simulate, simulate_preset


def figures(res, truth):
    s = summary(res.rps, res.image, truth)
    n, m = max(1, s["rp_total"]), max(1, s["rpm_total"])
    return s["rp_within_10mm"] / n, s["rpm_within_50mm"] / m, s["rpm_within_10mm"] / m, s


def pareto(points):
    """Indices of the (time, error) pairs no other pair beats in both."""
    idx = []
    for i, (t, e) in enumerate(points):
        if not any((t2 <= t and e2 <= e) and (t2 < t or e2 < e) for t2, e2 in points):
            idx.append(i)
    return idx


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="benchmarks/pareto.png")
    ap.add_argument("--quick", action="store_true", help="a smaller grid")
    ap.add_argument("--arrays-only", action="store_true", help="only part 2 (larger arrays)")
    args = ap.parse_args()
    env = create_env()
    engines = {p: DeviceRPM(env, p) for p in ("float32", "float64")}
    data, pre = simulate_preset("human-body", 20.0, 0)
    grid = [] if args.arrays_only else list(itertools.product(
        [8, 16, 24, 32] if not args.quick else [16, 24],
        [1.5, 2.0, 3.0] if not args.quick else [2.0],
        [75.0, 100.0, 150.0] if not args.quick else [100.0],
        ["float32", "float64"] if not args.quick else ["float32"]))
    rows = []
    for k, cut, w, prec in grid:
        params = default_params(data, **{**pre.defaults, "max_neighbours": k, "pair_cutoff": cut,
                                         "window_x": w, "window_z": w})
        res, sec, _ = timed_run("kspace-rpm", data, params, engines[prec], repeats=3)
        rp10, rpm50, rpm10, _ = figures(res, data.truth)
        rows.append((k, cut, w, prec, sec, rp10, rpm50, rpm10))
        print(f"{k:3d} {cut:4.1f} {w:6.0f} {prec:8s} {1e3 * sec:8.1f} ms  RP<=10 {rp10:6.1%}  "
              f"RPM<=50 {rpm50:6.1%}  RPM<=10 {rpm10:6.1%}", flush=True)
    if not rows:
        return larger_arrays(engines["float32"])
    front = set(pareto([(r[4], 1 - r[7]) for r in rows]))
    print("\nPareto front (time, share of points beyond 10 mm); * = on the front, "
          "D = the default (24, 2.0, 100, float32)")
    for i, r in enumerate(rows):
        mark = ("*" if i in front else " ") + ("D" if r[:4] == (24, 2.0, 100.0, "float32") else " ")
        print(f"{mark} nbrs {r[0]:3d} cutoff {r[1]:3.1f} window {r[2]:5.0f} {r[3]:8s} "
              f"{1e3 * r[4]:8.1f} ms  RPM<=10 {r[7]:6.1%}  RPM<=50 {r[6]:6.1%}")

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 4.5), dpi=100)
        t = np.array([1e3 * r[4] for r in rows])
        e = np.array([100 * (1 - r[7]) for r in rows])
        ax.scatter(t, e, c=["C0" if r[3] == "float32" else "C1" for r in rows], s=18)
        f = sorted(front, key=lambda i: t[i])
        ax.plot(t[f], e[f], "k--", lw=1, label="Pareto front")
        d = [i for i, r in enumerate(rows) if r[:4] == (24, 2.0, 100.0, "float32")]
        if d:
            ax.plot(t[d], e[d], "r*", ms=14, label="default")
        ax.set_xlabel("time s(X,Z,R) to points (ms)")
        ax.set_ylabel("points beyond 10 mm (%)")
        ax.set_title("human body, S/N 20 dB: settings grid (blue float32, orange float64)")
        ax.legend()
        ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(args.out)
        print(f"wrote {args.out}")
    except ImportError:
        print("matplotlib not installed: no plot")

    larger_arrays(engines["float32"])


def body_on_array(nx, nz, snr=20.0, seed=0):
    """The human body seen by an nx x nz array at 7.5 mm (centred where the
    preset's is) and its default parameters (the decomposition's
    zero-padding lowered to 2 above 1024 antennas to bound its memory)."""
    preset = get_preset("human-body")
    arr = Array((np.arange(nx) - (nx - 1) / 2) * 7.5e-3,
                HUMAN_BODY_ARRAY_Z + (np.arange(nz) - (nz - 1) / 2) * 7.5e-3)
    d = simulate(preset.scene, arr, preset.waveform, preset.range_axis, snr, seed,
                 boundary_spacing=preset.boundary_spacing)
    extra = {"pad": 2} if nx * nz > 1024 else {}
    return d, default_params(d, **{**preset.defaults, **extra})


def larger_arrays(engine):
    print("\nLarger arrays at 7.5 mm, default settings, S/N 20 dB:")
    for nx, nz in ((11, 17), (32, 32), (64, 64)):
        d, params = body_on_array(nx, nz)
        res, sec, st = timed_run("kspace-rpm", d, params, engine, repeats=1)
        rp10, rpm50, rpm10, _ = figures(res, d.truth)
        print(f"{nx:3d} x {nz:3d}: {len(res.rps):6d} RPs ({d.truth.rp_range.size} true), "
              f"{len(res.image.points):6d} points in "
              f"{sec:7.2f} s (decompose {st['decompose']:.2f}, rpm {st['rpm']:.2f})  "
              f"RP<=10 {rp10:6.1%}  RPM<=50 {rpm50:6.1%}  RPM<=10 {rpm10:6.1%}", flush=True)


if __name__ == "__main__":
    main()
