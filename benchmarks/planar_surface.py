"""A stand-in for a real near-field MMW scan of a flat sample: the default
run's time, memory and accuracy on a large planar array.

187 x 144 antennas at 3 mm (22.2-26.2 GHz's 24.2 GHz carrier, 4 GHz of
band), a gently curved surface 0.1 m away (a flat ellipsoid), 30 dB in-band
noise, 300 range gates of 2 mm.  The script simulates it into ``--out``
(skipped when the file is there), runs ``rpm-cl image -v`` on it in a child
process, and prints the engine's stage times, the child's peak memory
(VmHWM, polled) and the share of points within 15 mm of the surface.

    python benchmarks/planar_surface.py [--out plane.npz]
"""

import argparse
import os
import re
import subprocess
import sys
import time

import numpy as np


def _make(path):
    from rpm_cl.io.data import Array, Waveform
    from rpm_cl.io.formats import save_data
    from rpm_cl.simulate import simulate
    from rpm_cl.simulate.scene import Ellipsoid, Scene

    x = (np.arange(187) - 93) * 3e-3
    z = (np.arange(144) - 71.5) * 3e-3
    scene = Scene((Ellipsoid(np.array([0.0, 0.6, 0.0]), np.array([1.2, 0.5, 1.2]), 0.0),))
    data = simulate(
        scene, Array(x, z), Waveform(24.2e9, 4e9), np.arange(0, 0.6, 0.002), snr_db=30, seed=1
    )
    save_data(path, data)


def _peak_rss(pid):
    try:
        with open(f"/proc/{pid}/status") as f:
            line = next((s for s in f if s.startswith("VmHWM:")), None)
    except OSError:
        return 0
    return int(line.split()[1]) * 1024 if line else 0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="plane.npz")
    args = ap.parse_args(argv)
    if not os.path.exists(args.out):
        _make(args.out)
    result = os.path.splitext(args.out)[0] + "_points.npz"
    t0 = time.perf_counter()
    p = subprocess.Popen(
        [sys.executable, "-m", "rpm_cl", "image", args.out, "-o", result, "-v"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    peak = 0
    while p.poll() is None:
        peak = max(peak, _peak_rss(p.pid))
        time.sleep(0.05)
    out, err = p.communicate()
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        sys.exit(f"rpm-cl image failed: {err.strip().splitlines()[-1]}")
    stages = re.search(r"stage timings \(ms\): (.*)", err)
    from scipy.spatial import cKDTree

    pts = np.load(result)["points"]
    truth = np.load(args.out)["truth_boundary"]
    dist = cKDTree(truth).query(pts)[0]
    print(out.strip().splitlines()[0])
    print(f"stages (ms): {stages.group(1) if stages else '?'}")
    print(
        f"wall {wall:.1f} s, peak memory {peak / 1e9:.2f} GB, {len(pts)} points, "
        f"{100 * np.mean(dist <= 0.015):.1f} % within 15 mm, median {1e3 * np.median(dist):.1f} mm"
    )


if __name__ == "__main__":
    main()
