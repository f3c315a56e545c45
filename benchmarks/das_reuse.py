"""DAS for repeated frames: the reuse variant (paper Section VI-B2) against
direct back-projection, on the human body's y = 1 m section at 3 mm.

Usage::

    python benchmarks/das_reuse.py [--budget-gb 2]

Prints the time to build the per-voxel tables, the per-frame time with them
(NumPy gather + multiply-add), the direct OpenCL kernel and the float64 NumPy
back-projection on the same frame, and the memory the tables would need for the
full 2 m x 2 m x 2 m volume (which the budget refuses).
"""

import argparse
import time

import numpy as np

from rpm_cl.baselines.das import DASPlan, DeviceDAS, das_numpy, parse_grid
from rpm_cl.cl import create_env
from rpm_cl.io.data import InputError
from rpm_cl.simulate import simulate_preset

SECTION = "-1:1:0.003,1.0:1.0:0.003,0:2:0.003"
VOLUME = "-1:1:0.003,0:2:0.003,0:2:0.003"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget-gb", type=float, default=2.0)
    args = ap.parse_args()
    budget = args.budget_gb * 1e9
    frames = [simulate_preset("human-body", 20.0, seed, noise="receiver")[0] for seed in range(3)]
    grid = parse_grid(SECTION)
    bp = grid.size * frames[0].array.n
    env = create_env()
    dev = DeviceDAS(env, "float32")
    dev.backproject(frames[0], grid)
    t0 = time.perf_counter()
    plan = DASPlan(frames[0], grid, budget)
    t_build = time.perf_counter() - t0
    per_frame, direct = [], []
    for f in frames:
        t0 = time.perf_counter()
        a = plan.apply(f)
        per_frame.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        b = dev.backproject(f, grid)
        direct.append(time.perf_counter() - t0)
    rel = float(np.abs(a - b).max() / np.abs(b).max())
    t0 = time.perf_counter()
    das_numpy(frames[0], grid, budget)
    t_np = time.perf_counter() - t0
    print(
        f"device: {env.name}; section {grid.shape}, {frames[0].array.n} antennas, "
        f"{bp:.3g} back-projections per frame"
    )
    print(f"reuse tables: {plan.nbytes / 1e9:.2f} GB, built in {t_build:.1f} s")
    print(
        f"per frame: reuse (NumPy) {np.median(per_frame):.3f} s "
        f"({bp / np.median(per_frame):.3g} bp/s) | direct OpenCL float32 "
        f"{np.median(direct):.3f} s ({bp / np.median(direct):.3g} bp/s) | direct NumPy float64 "
        f"{t_np:.1f} s ({bp / t_np:.3g} bp/s); reuse vs OpenCL max difference {rel:.1e} of the peak"
    )
    try:
        DASPlan(frames[0], parse_grid(VOLUME), budget)
    except InputError as exc:
        print(f"volume: {exc}")


if __name__ == "__main__":
    main()
