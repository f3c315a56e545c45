"""A stand-in for a real near-field MMW scan of a flat sample: the default
run's time, memory and accuracy on a large planar array.

187 x 144 antennas at 3 mm (22.2-26.2 GHz's 24.2 GHz carrier, 4 GHz of
band), a gently curved surface 0.1 m away (a flat ellipsoid), 30 dB in-band
noise, 300 range gates of 2 mm.  The script simulates it into ``--out``
(skipped when the file is there), runs ``rpm-cl image -v`` on it in a child
process, and prints the engine's stage times, the child's peak memory
(VmHWM, polled) and the share of points within 15 mm of the surface.

``--frequencies N`` hands the engine the same surface as a real stepped-
frequency scan records it instead: a spectrum file of N frequencies over
22.2-26.2 GHz (11 for the public 24 GHz scan), one unit echo per antenna
at the simulated specular range, ``exp(-j 4 pi f R / c)``, with 30 dB of
white noise on the samples (S/N as the engine's in-band model: a rect
compression's peak power over its mean noise power).

    python benchmarks/planar_surface.py [--out plane.npz] [--frequencies 11]
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


def _spectrum(path, out, nf):
    """The range-domain stand-in's specular ranges as an ``nf``-frequency
    spectrum file (module notes)."""
    t = np.load(path)
    x, z = t["x"], t["z"]
    r = np.full(x.size * z.size, np.nan)
    r[t["truth_rp_antenna"]] = t["truth_rp_range"]
    f = np.linspace(22.2e9, 26.2e9, nf)
    spec = np.exp(-4j * np.pi * f * r.reshape(x.size, z.size, 1) / 299792458.0)
    # rect compression: a unit echo's peak nf, noise power nf s2 per gate
    s2 = nf / 10.0 ** (30 / 10)
    rng = np.random.default_rng(2)
    spec += np.sqrt(s2 / 2) * (
        rng.standard_normal(spec.shape) + 1j * rng.standard_normal(spec.shape)
    )
    np.savez(
        out,
        spectrum=spec.astype(np.complex64),
        frequency=f,
        x=x,
        z=z,
        truth_boundary=t["truth_boundary"],
    )


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
    ap.add_argument("--frequencies", type=int, default=0, help="image a spectrum of N frequencies")
    args = ap.parse_args(argv)
    if not os.path.exists(args.out):
        _make(args.out)
    source = args.out
    if args.frequencies:
        source = os.path.splitext(args.out)[0] + f"_f{args.frequencies}.npz"
        if not os.path.exists(source):
            _spectrum(args.out, source, args.frequencies)
    result = os.path.splitext(source)[0] + "_points.npz"
    t0 = time.perf_counter()
    p = subprocess.Popen(
        [sys.executable, "-m", "rpm_cl", "image", source, "-o", result, "-v"],
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
