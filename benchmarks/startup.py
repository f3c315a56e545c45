"""Start-up cost of the command line, against importing NumPy alone.

    python benchmarks/startup.py [--runs 9]

Each run is a fresh process, interleaved so that the machine's load hits
all alike: ``python -c "import numpy"``; ``rpm-cl image`` of the paper's
2-D scene (a small file, range domain) and of a wide-band GPR line
(:data:`LINE`); loading the paper's file and the same
scene as a frequency-domain spectrum (``load_data``).  Prints the medians
and the ratios.  Run it where the package's ``.pyc`` files exist (a pip
install writes them; with ``PYTHONDONTWRITEBYTECODE`` set in an editable
checkout every run compiles the sources, about 0.17 s more).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

#: A wide-band GPR line: 300 traces at 1 cm, 1-2 GHz, three points
#: 1.2-1.35 m down, 20 dB (phase-rpm runs its FFTs across the array, the
#: range-walk alignment, the coherent centres and the coherence test).
LINE = """
import numpy as np
from rpm_cl.io.data import Array, Waveform
from rpm_cl.io.formats import save_data
from rpm_cl.simulate import simulate
from rpm_cl.simulate.scene import PointTarget, Scene
scene = Scene(tuple(PointTarget(p) for p in [(0.8, 1.2), (1.5, 1.35), (2.2, 1.25)]))
x = np.arange(300) * 0.01
save_data({!r}, simulate(scene, Array(x), Waveform(1.5e9, 1e9), np.arange(0, 2, 5e-3), 20.0, 0))
"""


def _time(cmd) -> float:
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True)
    return time.perf_counter() - t0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=9)
    args = ap.parse_args(argv)
    py = sys.executable
    exe = os.path.join(os.path.dirname(py), "rpm-cl")
    with tempfile.TemporaryDirectory() as tmp:
        scene = os.path.join(tmp, "p2.npz")
        subprocess.run([exe, "simulate", "paper-2d", "-o", scene, "-q"], check=True)
        f = np.linspace(20e9, 20.2e9, 64)
        x = np.arange(21) * 5e-3
        r = np.hypot(x - 0.01, 0.4)
        spec = os.path.join(tmp, "spec.npz")
        np.savez(spec, spectrum=np.exp(-4j * np.pi * f[None] * r[:, None] / 3e8), frequency=f, x=x)
        line = os.path.join(tmp, "line.npz")
        subprocess.run([py, "-c", LINE.format(line)], check=True)
        out = os.path.join(tmp, "out.npz")
        runs = {
            "import numpy": [],
            "rpm-cl image": [],
            "rpm-cl image line": [],
            "load range-domain": [],
            "load spectrum": [],
        }
        for f in (scene, line):  # the programs built and cached
            subprocess.run([exe, "image", f, "-o", out, "-q"], check=True)
        for _ in range(args.runs):
            runs["import numpy"].append(_time([py, "-c", "import numpy"]))
            os.remove(out)
            runs["rpm-cl image"].append(_time([exe, "image", scene, "-o", out, "-q"]))
            os.remove(out)
            runs["rpm-cl image line"].append(_time([exe, "image", line, "-o", out, "-q"]))
            load = "from rpm_cl.io.formats import load_data; load_data({!r})"
            runs["load range-domain"].append(_time([py, "-c", load.format(scene)]))
            runs["load spectrum"].append(_time([py, "-c", load.format(spec)]))
    med = {k: statistics.median(v) for k, v in runs.items()}
    base = med["import numpy"]
    for k, v in med.items():
        print(f"{k:18s} {v:.3f} s  {v / base:4.1f}x import numpy")
    print(f"spectrum / range-domain load: {med['load spectrum'] / med['load range-domain']:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
