"""Image the gprMax full-wave fixture with every method and with DAS, per band.

The fixture (``tests/data/gprmax``, made by ``benchmarks/gprmax_fixture.py``)
is a 2-D TM FDTD B-scan of four PEC cylinders and a PEC plate, 41 antennas at
8 mm.  For each band it is converted (``rpm_cl.gprmax.convert``: background
subtracted, Ricker and line-source factor deconvolved), range-compressed with
the default Hann window, and imaged by every method of
``rpm_cl.imaging.METHODS`` with its default parameters
(``rpm_cl.imaging.default_params``) and by DAS (the local maxima of |I| over
5 x 5 pixels within 10 dB of the maximum, ``rpm_cl.reproduce.das_points``, on
a 4 mm grid over the scene).

Columns: image points; the share within 50 mm of the objects' boundaries; the
median distance to the nearest boundary; the objects hit (an object is hit
when some point lies within 50 mm of its boundary), of 5.

Usage::

    python benchmarks/gprmax_image.py [--bands 3.875:4.125,3:4,2:4,1.5:5] [--device SPEC]
"""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from rpm_cl import gprmax as G
from rpm_cl.formats import load_data

DATA = Path(__file__).resolve().parent.parent / "tests" / "data" / "gprmax"
GRID = "0.05:0.85:0.004,0.15:0.75:0.004"


def object_trees(sidecar: G.Sidecar, x, y_scan):
    """One KD-tree of boundary samples per object, in the engine's frame."""
    trees = []
    for c in sidecar.cylinders:
        b = G.truth_arrays(G.Sidecar(cylinders=(c,)), x, y_scan)["truth_boundary"]
        trees.append(("cylinder r=%.0f mm" % (1e3 * c[2]), cKDTree(b)))
    for p in sidecar.polygons:
        b = G.truth_arrays(G.Sidecar(polygons=(p,)), x, y_scan)["truth_boundary"]
        trees.append(("plate", cKDTree(b)))
    return trees


def score(points, trees):
    """(points, share within 50 mm, median distance m, objects hit)."""
    if len(points) == 0:
        return 0, 0.0, float("nan"), 0
    d = np.stack([t.query(points)[0] for _, t in trees], axis=1)
    best = d.min(axis=1)
    hit = int(np.sum(d.min(axis=0) <= 0.05))
    return len(points), float(np.mean(best <= 0.05)), float(np.median(best)), hit


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bands", default="3.875:4.125,3:4,2:4,1.5:5",
                    help="comma-separated GHz bands F0:F1")
    ap.add_argument("--device", help="OpenCL device (as rpm-cl --device)")
    args = ap.parse_args()
    from rpm_cl.cl import create_env
    from rpm_cl.das import DeviceDAS, parse_grid
    from rpm_cl.imaging import METHODS, default_params, run_method
    from rpm_cl.reproduce import das_points
    from rpm_cl.rpm import DeviceRPM

    env = create_env(args.device)
    engine, das = DeviceRPM(env), DeviceDAS(env)
    grid = parse_grid(GRID)
    side = G.read_sidecar(DATA / "scene.json")
    print(f"gprMax fixture {DATA}: 41 antennas at 8 mm, 4 PEC cylinders + 1 PEC plate; "
          f"device {env.name}; DAS grid {GRID}")
    print(f"{'method':11s} {'band GHz':>12s} {'points':>6s} {'<=50 mm':>8s} {'median':>9s} "
          f"{'objects hit':>11s}")
    with tempfile.TemporaryDirectory() as tmp:
        for text in args.bands.split(","):
            lo, hi = (float(v) * 1e9 for v in text.split(":"))
            path = os.path.join(tmp, "scan.npz")
            G.save_spectrum(path, G.convert(DATA / "targets_merged.h5",
                                            DATA / "background_merged.h5", (lo, hi),
                                            sidecar=DATA / "scene.json"))
            data = load_data(path)
            trees = object_trees(side, data.array.x, side.scan_y)
            rows = []
            for name in METHODS:
                res = run_method(name, data, default_params(data), engine)
                rows.append((name, score(res.image.points, trees)))
            pts, _ = das_points(das, data, grid, "image")
            rows.append(("das", score(pts, trees)))
            for name, (n, share, med, hit) in rows:
                med_text = "-" if n == 0 else f"{1e3 * med:.1f} mm"
                print(f"{name:11s} {text:>12s} {n:6d} {100 * share:7.0f}% {med_text:>9s} "
                      f"{hit:>9d}/{len(trees)}")


if __name__ == "__main__":
    main()
