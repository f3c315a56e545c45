"""Which functions each compiled kernel calls on PoCL's CPU device.

PoCL 3.0 (the pip build) links its built-in functions into a kernel without
inlining them on this machine, and a call inside a hot loop spills every
vector register.  The hot loops of das.cl and score.cl therefore avoid
built-ins (kernels/simd.h).  This script compiles every kernel into a fresh
PoCL cache, runs each once on a small scene, disassembles the binaries PoCL
left there (objdump, from binutils) and prints the symbols each one calls, so
that a built-in creeping back into a hot loop shows.  The calls outside the
loops (vload of the lane coordinates, the final horizontal sum, the
intersection kernels' scalar sqrt/exp per work-item) are expected.
``das_points`` (the coherence test's sums) is built in float64, the
precision the test runs it in, where the device takes doubles.

Usage::

    python benchmarks/kernel_calls.py
"""

import glob
import os
import subprocess
import sys
import tempfile


def main():
    cache = tempfile.mkdtemp(prefix="pocl-calls-")
    env = dict(os.environ, POCL_CACHE_DIR=cache, PYOPENCL_NO_CACHE="1")
    code = r"""
import numpy as np
from rpm_cl.cl import create_env
from rpm_cl.baselines.das import DeviceDAS, Grid
from rpm_cl.extract.backprojection_cl import PointSums
from rpm_cl.imaging import run_method
from rpm_cl.rpm.params import default_params
from rpm_cl.rpm import DeviceRPM
from rpm_cl.simulate.scene import get_preset
from rpm_cl.simulate import simulate
env = create_env()
for name in ("paper-2d", "human-body"):
    pre = get_preset(name)
    data = simulate(pre.scene, pre.array, pre.waveform, pre.range_axis, None, 0)
    run_method("kspace-rpm", data, default_params(data, **pre.defaults), DeviceRPM(env))
    g = Grid(np.linspace(-0.1, 0.1, 16), np.array([1.0]), np.linspace(0.9, 1.1, 16)) \
        if data.array.planar else Grid(np.linspace(-0.1, 0.1, 16), np.linspace(0.4, 0.5, 16))
    DeviceDAS(env).backproject(data, g)
    pts = np.column_stack([np.linspace(-0.1, 0.1, 16), np.linspace(0.4, 0.5, 16)]
                          + ([np.zeros(16)] if data.array.planar else []))
    if env.has_double:
        PointSums(env).at_points(data, pts)
"""
    subprocess.run([sys.executable, "-c", code], env=env, check=True)
    rows = []
    for so in sorted(glob.glob(os.path.join(cache, "**", "*.so"), recursive=True)):
        kernel = os.path.basename(os.path.dirname(os.path.dirname(so)))
        dis = subprocess.run(
            ["objdump", "-d", "--no-show-raw-insn", so], capture_output=True, text=True, check=True
        ).stdout
        calls = sorted(
            {
                ln.rsplit("<", 1)[-1].rstrip(">")
                for ln in dis.splitlines()
                if "\tcall " in ln and "<" in ln
            }
        )
        rows.append((kernel, calls))
    for kernel, calls in sorted({(k, tuple(c)) for k, c in rows}):
        print(f"{kernel:20s} {', '.join(calls) if calls else '(no calls)'}")


if __name__ == "__main__":
    main()
