"""Image the gprMax full-wave fixture with every method and with DAS, per band.

The fixture (``tests/data/gprmax``, made by ``benchmarks/gprmax_fixture.py``)
is a 2-D TM FDTD B-scan of four PEC cylinders and a PEC plate, 41 antennas at
8 mm.  For each band it is converted (``rpm_cl.io.gprmax.convert``: background
subtracted, Ricker and line-source factor deconvolved), range-compressed with
the default Hann window, and imaged by every method of
``rpm_cl.imaging.RPM_METHODS`` with its default parameters
(``rpm_cl.rpm.params.default_params``) and by DAS (the local maxima of |I| over
5 x 5 pixels within 10 dB of the maximum, ``rpm_cl.cli.reproduce.das_points``, on
a 4 mm grid over the scene).

Columns: image points; the share within 50 mm of the objects' boundaries; the
median distance to the nearest boundary; the objects hit (an object is hit
when some point lies within 50 mm of its boundary), of 5.

With ``--twin``, each method also images the geometric-optics twin of the
scene (``rpm_cl.simulate``: the cylinders as circles, the plate as a thin
ellipse, the same antennas, the band's centre and Hann bandwidth, no noise):
rows ``METHOD/go``.  What the twin gets and the fixture does not is what the
full-wave data add (resonant cylinders, edge diffraction, double echoes); what
neither gets is the method's limit on this scene and band.

Usage::

    python benchmarks/gprmax_image.py [--bands 3.875:4.125,3:4,2:4,1.5:5] [--twin]
        [--data tests/data/gprmax_b] [--device SPEC] [--out docs/gprmax.md]
"""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from rpm_cl.io import gprmax as G
from rpm_cl.io.formats import load_data

DATA = Path(__file__).resolve().parent.parent / "tests" / "data" / "gprmax"
GRID = "0.05:0.85:0.004,0.15:0.75:0.004"


def object_trees(sidecar: G.Sidecar, x, y_scan):
    """One KD-tree of boundary samples per object, in the engine's frame."""
    trees = []
    for i, c in enumerate(sidecar.cylinders):
        b = G.truth_arrays(G.Sidecar(cylinders=(c,)), x, y_scan)["truth_boundary"]
        trees.append((f"c{i + 1}", cKDTree(b)))
    for i, p in enumerate(sidecar.polygons):
        b = G.truth_arrays(G.Sidecar(polygons=(p,)), x, y_scan)["truth_boundary"]
        trees.append((f"p{i + 1}", cKDTree(b)))
    return trees


def go_twin(sidecar: G.Sidecar, data):
    """The scene through the geometric-optics simulator, on ``data``'s
    antennas, band centre and bandwidth (RadarData, noise-free)."""
    from rpm_cl.simulate import simulate
    from rpm_cl.simulate.scene import Ellipsoid, Scene

    ys = sidecar.scan_y
    targets = [Ellipsoid([cx, cy - ys], [r, r]) for cx, cy, r in sidecar.cylinders]
    for poly in sidecar.polygons:  # a thin rectangle -> an ellipse of its length and width
        c = poly.mean(axis=0)
        sides = np.roll(poly, -1, axis=0) - poly
        lengths = np.linalg.norm(sides, axis=1)
        long = sides[np.argmax(lengths)]
        targets.append(
            Ellipsoid(
                [c[0], c[1] - ys],
                [lengths.max() / 2, lengths.min() / 2],
                [np.arctan2(long[1], long[0])],
            )
        )
    w = data.waveform
    rng = np.arange(0.0, 1.5, w.range_resolution / 16)
    return simulate(Scene(tuple(targets)), data.array, w, rng)


def score(points, trees):
    """(points, share within 50 mm, median distance m, names of the objects hit)."""
    if len(points) == 0:
        return 0, 0.0, float("nan"), []
    d = np.stack([t.query(points)[0] for _, t in trees], axis=1)
    best = d.min(axis=1)
    hit = [name for (name, _), near in zip(trees, d.min(axis=0) <= 0.05) if near]
    return len(points), float(np.mean(best <= 0.05)), float(np.median(best)), hit


def ghz_band(text: str) -> tuple[float, float]:
    """A band written "lo:hi" in GHz, as (lo, hi) in Hz."""
    return tuple(float(v) * 1e9 for v in text.split(":"))


def band_data(targets, background, sidecar, band, tmp):
    """The B-scan ``targets`` less ``background`` over ``band`` (Hz, a pair),
    written as a spectrum file in the folder ``tmp`` and loaded as
    ``rpm-cl image`` loads it."""
    path = os.path.join(tmp, "scan.npz")
    G.save_spectrum(path, G.convert(targets, background, band, sidecar=sidecar))
    return load_data(path)


def method_rows(data, trees, methods, engine, das, grid, results=None):
    """``(name, score)`` of each method of ``methods`` with its default
    parameters, then of DAS's peaks on ``grid`` (:func:`score`); each
    method's ImageResult also goes into the dict ``results`` by name where
    one is given."""
    from rpm_cl.cli.reproduce import das_points
    from rpm_cl.imaging import run_method
    from rpm_cl.rpm.params import default_params

    rows = []
    for name in methods:
        res = run_method(name, data, default_params(data), engine)
        rows.append((name, score(res.image.points, trees)))
        if results is not None:
            results[name] = res
    pts, _ = das_points(das, data, grid, "image")
    rows.append(("das", score(pts, trees)))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--bands", default="3.875:4.125,3:4,2:4,1.5:5", help="comma-separated GHz bands F0:F1"
    )
    ap.add_argument(
        "--twin",
        action="store_true",
        help="also image the scene's geometric-optics twin (rows METHOD/go)",
    )
    ap.add_argument(
        "--data",
        default=str(DATA),
        help="the fixture's folder (default tests/data/gprmax; tests/data/gprmax_b: the "
        "second scene of benchmarks/gprmax_fixture.py --objects second)",
    )
    ap.add_argument("--device", help="OpenCL device (as rpm-cl --device)")
    ap.add_argument("--out", help="also write the table as Markdown here (e.g. docs/gprmax.md)")
    args = ap.parse_args()
    lines = []

    def say(text=""):
        print(text)
        lines.append(text)

    from rpm_cl.baselines.das import DeviceDAS, parse_grid
    from rpm_cl.cl import create_env
    from rpm_cl.imaging import RPM_METHODS, run_method
    from rpm_cl.rpm import DeviceRPM
    from rpm_cl.rpm.params import default_params

    env = create_env(args.device)
    engine, das = DeviceRPM(env), DeviceDAS(env)
    grid = parse_grid(GRID)
    data_dir = Path(args.data)
    side = G.read_sidecar(data_dir / "scene.json")
    say(
        f"gprMax fixture tests/data/{data_dir.name}: 41 antennas at 8 mm, {len(side.cylinders)} PEC "
        f"cylinders + {len(side.polygons)} PEC plate; device {env.name}; DAS grid {GRID}"
    )
    say(
        f"{'method':13s} {'band GHz':>12s} {'points':>6s} {'<=50 mm':>8s} {'median':>9s} "
        f"{'objects hit':>11s}"
    )
    say("(objects: c1-c4 the cylinders of scene.json in order, p1 the plate)")
    with tempfile.TemporaryDirectory() as tmp:
        for text in args.bands.split(","):
            band = ghz_band(text)
            data = band_data(
                data_dir / "targets_merged.h5",
                data_dir / "background_merged.h5",
                data_dir / "scene.json",
                band,
                tmp,
            )
            trees = object_trees(side, data.array.x, side.scan_y)
            rows = method_rows(data, trees, RPM_METHODS, engine, das, grid)
            if args.twin:
                twin = go_twin(side, data)
                for name in RPM_METHODS:
                    res = run_method(name, twin, default_params(twin), engine)
                    rows.append((f"{name}/go", score(res.image.points, trees)))
            for name, (n, share, med, hit) in rows:
                med_text = "-" if n == 0 else f"{1e3 * med:.1f} mm"
                say(
                    f"{name:13s} {text:>12s} {n:6d} {100 * share:7.0f}% {med_text:>9s} "
                    f"{len(hit):>5d}/{len(trees)} {' '.join(hit)}"
                )
    if args.out:
        cmd = "python benchmarks/gprmax_image.py" + (" --twin" if args.twin else "")
        title = "gprMax full-wave fixture"
        if data_dir.resolve() != DATA.resolve():
            cmd += f" --data tests/data/{data_dir.name}"
            title = f"gprMax full-wave scene {data_dir.name}"
        with open(args.out, "w") as f:
            f.write(
                f"# {title}\n\nGenerated by `{cmd} --out {args.out}`.  "
                "Every method with its default parameters, and DAS peaks, per band "
                "(`rpm_cl.io.gprmax.convert`, Hann range window); rows `METHOD/go` image "
                "the geometric-optics twin of the scene (`rpm_cl.simulate`, noise-free).\n\n"
                "```\n" + "\n".join(lines) + "\n```\n"
            )


if __name__ == "__main__":
    main()
