"""Sub-RP lists of 3-D RPM: the grid ranking against the float ranking.

Usage::

    python benchmarks/neighbour_lists.py [--sizes 11 32 64] [--repeats 3]

For the human body seen by square arrays at 7.5 mm (11 x 17 for 11; S/N
20 dB, seed 0, the default settings, the decomposition's zero-padding 2
above 1024 antennas as in ``pareto.py``) it builds the RPs once, then times
:func:`rpm_cl.rpm.neighbours.neighbour_lists` with the integer grid ranking
(the default for antennas on a grid) and with the stable float sort it
replaced (forced by hiding the grid), interleaved, medians of ``--repeats``.
It also counts the rows whose lists differ: both rank by distance, then by
index, but the float sort saw equal distances as unequal after rounding.
"""

import argparse
import time

import numpy as np
from pareto import body_on_array  # benchmarks/pareto.py, beside this script

from rpm_cl.extract.kspace import decompose
from rpm_cl.extract.rangepoints import rps_from_decomposition
from rpm_cl.rpm import neighbours
from rpm_cl.rpm.pipeline import _prepare


def list_args(n):
    """neighbour_lists' arguments for the body on an n x n (11: 11 x 17) array."""
    nz = 17 if n == 11 else n
    d, params = body_on_array(n, nz)
    rps = rps_from_decomposition(d, decompose(d, params.kspace), params.rp_threshold_db)
    p = params.rpm
    idx, _, _, start, count = _prepare(rps, p)
    return (
        np.asarray(rps.x, float)[idx],
        np.asarray(rps.z, float)[idx],
        np.asarray(rps.antenna)[idx],
        start,
        count,
        p.pair_cutoff * p.sigma_x,
        p.max_neighbours,
        p.near_neighbours,
    ), nz


def timed(args, grid: bool):
    real = neighbours._grid_offsets
    if not grid:
        neighbours._grid_offsets = lambda x, z: None
    try:
        t = time.perf_counter()
        out = neighbours.neighbour_lists(*args)
        return time.perf_counter() - t, out
    finally:
        neighbours._grid_offsets = real


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[11, 32, 64])
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    print(
        f"{'array':>9} {'RPs':>7} {'clusters':>8} {'grid s':>8} {'float s':>8} {'ratio':>6} "
        f"{'rows differing':>15}"
    )
    for n in a.sizes:
        args, nz = list_args(n)
        tg, tf = [], []
        for _ in range(a.repeats):
            t, g = timed(args, True)
            tg.append(t)
            t, f = timed(args, False)
            tf.append(t)
        differ = int(np.sum(np.any(g[0] != f[0], axis=1))) if g[0].shape == f[0].shape else -1
        mg, mf = np.median(tg), np.median(tf)
        print(
            f"{n:3d} x {nz:3d} {args[0].size:7d} {np.unique(args[3]).size:8d} {mg:8.3f} {mf:8.3f} "
            f"{mf / mg:6.2f} {differ:15d}",
            flush=True,
        )


if __name__ == "__main__":
    main()
