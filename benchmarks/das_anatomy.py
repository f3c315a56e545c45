"""Where the DAS kernel's time goes: the back-projection with parts of it taken out.

    python benchmarks/das_anatomy.py [--repeats 5] [--grid X0:X1:DX,Y,Z0:Z1:DZ]

The human body's DAS section (the grid of ``rpm-cl bench``), float32,
through ``kernels/das.cl`` as shipped and through three altered copies of
its source (patched in memory here, never in the package):

- ``no gather``: every lane reads the same range row instead of its own
  (the eight scattered row loads and their transpose become one cached
  load);
- ``no sin/cos``: the phase factor's polynomial replaced by one add;
- ``neither``: both.

The altered kernels compute wrong images; they only time what is left.
Each figure is the best of ``--repeats`` calls after a warm-up (a limit,
not a typical time), back-projections (voxels x antennas) per second.  What
the kernel as shipped loses against ``neither`` is the cost of the per-voxel
range lookup and of the phase, which any back-projection with exact phases
pays.
"""

from __future__ import annotations

import argparse
import sys
import time

from rpm_cl import cl as rcl
from rpm_cl.baselines.das import DeviceDAS, parse_grid
from rpm_cl.simulate.synth import simulate_preset

GATHER = (
    "const INTV iv = CAT(CAT(convert_, IDX), VW)(t);",
    "const INTV iv = (INTV)((IDX)(nr / 2));",
)
SINCOS = ("const REALV sn = poly_sincos(x, &c);", "const REALV sn = x; c = x + (REAL)1;")
VARIANTS = {
    "as shipped": (),
    "no gather": (GATHER,),
    "no sin/cos": (SINCOS,),
    "neither": (GATHER, SINCOS),
}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--grid", default="-1:1:0.003,1.0:1.0:0.003,0:2:0.003")
    args = ap.parse_args(argv)
    data, _ = simulate_preset("human-body", None, 0, noise="receiver")
    grid = parse_grid(args.grid)
    bp = grid.size * data.array.n
    env = rcl.create_env()
    original = rcl.kernel_source
    print(f"device {env.name}; {grid.shape} voxels x {data.array.n} antennas = {bp:.3g} bp")
    for index, (name, patches) in enumerate(VARIANTS.items()):

        def source(filename, patches=patches):
            text = original(filename)
            if filename == "das.cl":
                for old, new in patches:
                    if old not in text:
                        raise SystemExit(f"das.cl no longer holds {old!r}: update this script")
                    text = text.replace(old, new)
            return text

        rcl.kernel_source = source
        try:
            das = DeviceDAS(env, "float32")
            # a define no other build uses, so that this source gets its own program
            das._defines = dict(das._defines, DAS_ANATOMY=index)
            das.backproject(data, grid)
            best = float("inf")
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                das.backproject(data, grid)
                best = min(best, time.perf_counter() - t0)
        finally:
            rcl.kernel_source = original
        print(f"{name:12s} {1e3 * best:7.1f} ms  {bp / best:.3g} bp/s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
