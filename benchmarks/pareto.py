"""Run time against error over imaging settings and array sizes .

Usage::

    python benchmarks/pareto.py [--out benchmarks/pareto.png] [--quick] [--arrays-only]
        [--time-tol 0.15] [--exhaustive FILE.npz]

1. Settings grid on the human body (11 x 17 array, S/N 20 dB, seed 0):
   list length x mean-shift steps x pair_cutoff x window period x kernel
   precision.  Every body cluster is refined (at most ``meanshift_max_rps``
   RPs, one per antenna), so with steps the list length is
   ``meanshift_neighbours`` (``max_neighbours`` keeps its default and does
   not enter), and with 0 steps (the list's argmax is the point) it is
   ``max_neighbours``.  The default is the row with list 12, 3 steps.  For each:
   the median time from s(X, Z, R) to points (3 runs after a warm-up) and the
   accuracy figures (RP <= 10 mm, RPM <= 50 mm, RPM <= 10 mm).  The table
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
from exhaustive_3d import TIE_REL, exhaustive_image, exhaustive_ties, same_or_tied

from rpm_cl.cl import create_env
from rpm_cl.imaging import timed_run
from rpm_cl.io.data import Array
from rpm_cl.metrics import summary
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import simulate, simulate_preset
from rpm_cl.simulate.scene import HUMAN_BODY_ARRAY_Z, get_preset

#: The default's row: list (meanshift_neighbours on the body), mean-shift
#: steps, pair_cutoff, window (rad/m), precision; checked against the defaults.
DEFAULT = (12, 3, 2.0, 60.0, "float32")


def figures(res, truth):
    s = summary(res.rps, res.image, truth)
    n, m = max(1, s["rp_total"]), max(1, s["rpm_total"])
    return s["rp_within_10mm"] / n, s["rpm_within_50mm"] / m, s["rpm_within_10mm"] / m, s


def pareto(points, time_tol=0.0):
    """Indices of the (time, error) pairs no other pair beats.

    One pair beats another when its error is no larger and it is faster by
    more than ``time_tol`` (relative), or when its error is smaller and it is
    no slower than that: times within ``time_tol`` of each other count as
    equal (the machine's run-to-run noise), so that of two settings with the
    same error neither beats the other by noise alone.
    """
    idx = []
    for i, (t, e) in enumerate(points):
        if not any(
            (e2 <= e and t2 * (1 + time_tol) < t) or (e2 < e and t2 <= t * (1 + time_tol))
            for t2, e2 in points
        ):
            idx.append(i)
    return idx


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="benchmarks/pareto.png")
    ap.add_argument("--quick", action="store_true", help="a smaller grid")
    ap.add_argument("--arrays-only", action="store_true", help="only part 2 (larger arrays)")
    ap.add_argument(
        "--time-tol",
        type=float,
        default=0.15,
        help="times within this fraction of each other count as equal on the "
        "front (default 0.15: identical settings measured 10 %% apart)",
    )
    ap.add_argument(
        "--exhaustive",
        metavar="FILE.npz",
        help="exhaustive_3d.py's cache for S/N 20 (made if missing, minutes): "
        "adds each float32 default-window row's share of points equal to "
        "the float32 exhaustive eq. 10 image's (within 1 um; float64 "
        "candidates differ from float32 ones by more than that), and the "
        "share equal or tied (eq. 10 in float64 within "
        f"{TIE_REL['float32']:g} of the exhaustive point's, "
        "exhaustive_3d.TIE_REL)",
    )
    args = ap.parse_args()
    env = create_env()
    engines = {p: DeviceRPM(env, p) for p in ("float32", "float64")}
    data, pre = simulate_preset("human-body", 20.0, 0, noise="receiver")
    d = default_params(data, **pre.defaults)
    assert (
        d.rpm.meanshift_neighbours,
        d.rpm.meanshift_iters,
        d.rpm.pair_cutoff,
        d.kspace.window_x,
    ) == DEFAULT[:4], "DEFAULT no longer names the defaults"
    exh = None
    if args.exhaustive and not args.arrays_only:
        exh, sec, line = exhaustive_image(data, pre, engines["float32"], 20.0, args.exhaustive)
        print(f"exhaustive eq. 10 (float32): {sec:.1f} s, {line}", flush=True)
    grid = (
        []
        if args.arrays_only
        else list(
            itertools.product(
                [8, 12, 24, 32] if not args.quick else [8, 12, 24],
                [0, 2, 3],
                [1.5, 2.0, 3.0] if not args.quick else [2.0],
                [50.0, 60.0, 75.0, 100.0] if not args.quick else [DEFAULT[3]],
                ["float32", "float64"] if not args.quick else ["float32"],
            )
        )
    )
    rows = []
    for k, steps, cut, w, prec in grid:
        lists = {"meanshift_neighbours": k} if steps else {"max_neighbours": k}
        params = default_params(
            data,
            **{
                **pre.defaults,
                **lists,
                "meanshift_iters": steps,
                "pair_cutoff": cut,
                "window_x": w,
                "window_z": w,
            },
        )
        res, sec, _ = timed_run("kspace-rpm", data, params, engines[prec], repeats=3)
        rp10, rpm50, rpm10, _ = figures(res, data.truth)
        same = "     -                "
        if exh is not None and w == DEFAULT[3] and prec == "float32":
            eq, rel = exhaustive_ties(res, exh, params)
            if eq.size:
                same = f"{eq.mean():6.1%} (or tied {same_or_tied(eq, rel, 'float32'):6.1%})"
        rows.append((k, steps, cut, w, prec, sec, rp10, rpm50, rpm10, same))
        print(
            f"{k:3d} {steps:2d} {cut:4.1f} {w:6.0f} {prec:8s} {1e3 * sec:8.1f} ms  "
            f"RP<=10 {rp10:6.1%}  RPM<=50 {rpm50:6.1%}  RPM<=10 {rpm10:6.1%}  "
            f"exhaustive {same}",
            flush=True,
        )
    if not rows:
        return larger_arrays(engines["float32"])
    front = set(pareto([(r[5], 1 - r[8]) for r in rows], args.time_tol))
    print(
        f"\nPareto front (time, share of points beyond 10 mm; times within "
        f"{args.time_tol:.0%} count as equal); * = on the front, "
        f"D = the default (list {DEFAULT[0]}, {DEFAULT[1]} steps, cutoff {DEFAULT[2]}, "
        f"window {DEFAULT[3]:g}, {DEFAULT[4]}); exhaustive = the points equal to the "
        "exhaustive image's"
    )
    for i, r in enumerate(rows):
        mark = ("*" if i in front else " ") + ("D" if r[:5] == DEFAULT else " ")
        print(
            f"{mark} list {r[0]:3d} steps {r[1]} cutoff {r[2]:3.1f} window {r[3]:5.0f} "
            f"{r[4]:8s} {1e3 * r[5]:8.1f} ms  RPM<=10 {r[8]:6.1%}  RPM<=50 {r[7]:6.1%}  "
            f"exhaustive {r[9]}"
        )

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 4.5), dpi=100)
        t = np.array([1e3 * r[5] for r in rows])
        e = np.array([100 * (1 - r[8]) for r in rows])
        ax.scatter(t, e, c=["C0" if r[4] == "float32" else "C1" for r in rows], s=18)
        f = sorted(front, key=lambda i: t[i])
        ax.plot(t[f], e[f], "k--", lw=1, label="Pareto front")
        d = [i for i, r in enumerate(rows) if r[:5] == DEFAULT]
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
    arr = Array(
        (np.arange(nx) - (nx - 1) / 2) * 7.5e-3,
        HUMAN_BODY_ARRAY_Z + (np.arange(nz) - (nz - 1) / 2) * 7.5e-3,
    )
    d = simulate(
        preset.scene,
        arr,
        preset.waveform,
        preset.range_axis,
        snr,
        seed,
        boundary_spacing=preset.boundary_spacing,
        noise="receiver",
    )
    extra = {"pad": 2} if nx * nz > 1024 else {}
    return d, default_params(d, **{**preset.defaults, **extra})


def larger_arrays(engine):
    print("\nLarger arrays at 7.5 mm, default settings, S/N 20 dB:")
    for nx, nz in ((11, 17), (32, 32), (64, 64)):
        d, params = body_on_array(nx, nz)
        res, sec, st = timed_run("kspace-rpm", d, params, engine, repeats=1)
        rp10, rpm50, rpm10, _ = figures(res, d.truth)
        print(
            f"{nx:3d} x {nz:3d}: {len(res.rps):6d} RPs ({d.truth.rp_range.size} true), "
            f"{len(res.image.points):6d} points in "
            f"{sec:7.2f} s (decompose {st['decompose']:.2f}, rpm {st['rpm']:.2f})  "
            f"RP<=10 {rp10:6.1%}  RPM<=50 {rpm50:6.1%}  RPM<=10 {rpm10:6.1%}",
            flush=True,
        )


if __name__ == "__main__":
    main()
