"""Full-wave scenes nobody laid out: random gprMax B-scans, imaged per band.

The two committed gprMax fixtures (``tests/data/gprmax``, ``gprmax_b``) were
laid out by hand and the engine has been measured on them many times.  This
script draws scenes from a seed instead, simulates them with gprMax (the same
model as ``benchmarks/gprmax_fixture.py``: 2-D TM, 2 mm cells, a Ricker of
3 GHz, 41 antennas at 8 mm, x 0.29-0.61 m at y = 0.09 m, one free-space
background shared by every scene) and images each with phase-rpm, kspace-rpm
and DAS per band, scored as ``benchmarks/gprmax_image.py`` scores the
fixtures: the share of points within 50 mm of an object's boundary, the
median distance, and the objects hit (a point within 50 mm of the boundary).

A scene (:func:`draw`): three or four PEC cylinders of radius 5-20 mm whose
centres lie 0.28-0.62 m from the scan's centre within +-38 degrees of its
normal, and with even odds a PEC plate 0.08-0.14 m long, 4 mm thick, at
0.45-0.62 m, facing the scan's centre to within 12 degrees; every two
objects at least 60 mm apart (surface to surface) and every object at least
0.25 m from every antenna.

Usage::

    # with the Python that has gprMax (it is no dependency of rpm-cl)
    GPRMAX_PYTHON benchmarks/gprmax_random.py simulate --scenes 20 --first 0 \\
        --out DATA --jobs 2
    python benchmarks/gprmax_random.py image --data DATA \\
        [--bands 3.875:4.125,3:4,2:4,1.5:5] [--anatomy] [--centres-at-objects]
        [--out docs/gprmax_random.md]

``--anatomy`` lists phase-rpm's clusters with under half their points on an
object, each with the path through the scene's true objects that its range
walk follows best (:func:`anatomy`).  ``--centres-at-objects`` is a
diagnostic: the k-space decomposition of every
method also gets a centre at each object that no centre of its own search
lies near (:func:`centres_at`), so what it still misses is not the search's.

``simulate`` writes ``background_merged.h5`` and one folder per scene
(``sNNN/targets_merged.h5``, ``sNNN/scene.json``, the sidecar
:func:`rpm_cl.io.gprmax.read_sidecar` reads); it takes about 2 minutes of
one core per scan.  ``image`` prints one row per scene, band and method and
the pooled rows.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
import gprmax_fixture as F

#: Bands imaged, GHz (those of benchmarks/gprmax_image.py).
BANDS = "3.875:4.125,3:4,2:4,1.5:5"
#: Methods imaged besides DAS.
METHODS = ("phase-rpm", "kspace-rpm")
#: Least surface-to-surface gap between two objects, m.
MIN_GAP = 0.06
#: Least distance from an antenna to an object, m.
MIN_RANGE = 0.25


def _scan_x() -> np.ndarray:
    return F.SCAN_X0 + F.PITCH * np.arange(F.N_SCAN)


def _inside(x: float, y: float, r: float) -> bool:
    margin = 2 * F.PML_CELLS * F.DX
    return margin < x - r and x + r < F.DOMAIN[0] - margin and y + r < F.DOMAIN[1] - margin


def draw(seed: int) -> dict:
    """The objects of scene ``seed`` (module notes): ``cylinders`` (centre,
    radius) and ``plate`` (centre, length, thickness, the point it faces) or
    None, gprMax coordinates, m."""
    rng = np.random.default_rng(seed)
    xs = _scan_x()
    xc = 0.5 * (xs[0] + xs[-1])
    for _ in range(10_000):
        cyl = []
        for _ in range(int(rng.integers(3, 5))):
            d, a, r = rng.uniform(0.28, 0.62), np.radians(rng.uniform(-38, 38)), rng.uniform(5, 20)
            cyl.append(((xc + d * np.sin(a), F.SCAN_Y + d * np.cos(a)), r * 1e-3))
        plate = None
        if rng.random() < 0.5:
            d, a = rng.uniform(0.45, 0.62), np.radians(rng.uniform(-30, 30))
            c = (xc + d * np.sin(a), F.SCAN_Y + d * np.cos(a))
            tilt = np.radians(rng.uniform(-12, 12))
            to = np.array([xc, F.SCAN_Y]) - np.array(c)
            rot = np.array([[np.cos(tilt), -np.sin(tilt)], [np.sin(tilt), np.cos(tilt)]])
            face = np.array(c) + rot @ to
            plate = {
                "centre": [float(c[0]), float(c[1])],
                "length": float(rng.uniform(0.08, 0.14)),
                "thickness": 0.004,
                "face_to": face.tolist(),
            }
        if _valid(cyl, plate, xs):
            return {
                "cylinders": [
                    {
                        "centre": [round(float(x), 4), round(float(y), 4)],
                        "radius": round(float(r), 4),
                    }
                    for (x, y), r in cyl
                ],
                "plate": plate,
            }
    raise ValueError(f"scene {seed}: no layout found")


def _plate_points(plate) -> np.ndarray:
    p = _corners(plate)
    return np.concatenate([np.linspace(a, b, 40) for a, b in zip(p, np.roll(p, -1, axis=0))])


def _valid(cyl, plate, xs) -> bool:
    ant = np.stack([xs, np.full_like(xs, F.SCAN_Y)], axis=1)
    shapes = []
    for (x, y), r in cyl:
        if not _inside(x, y, r) or np.min(np.linalg.norm(ant - (x, y), axis=1)) - r < MIN_RANGE:
            return False
        t = np.linspace(0, 2 * np.pi, 90, endpoint=False)
        shapes.append(np.stack([x + r * np.cos(t), y + r * np.sin(t)], axis=1))
    if plate is not None:
        pts = _plate_points(plate)
        if not all(_inside(x, y, 0.0) for x, y in pts):
            return False
        if np.min(np.linalg.norm(ant[:, None] - pts[None], axis=2)) < MIN_RANGE:
            return False
        shapes.append(pts)
    for i in range(len(shapes)):
        for j in range(i):
            if np.min(np.linalg.norm(shapes[i][:, None] - shapes[j][None], axis=2)) < MIN_GAP:
                return False
    return True


def input_text(title: str, scene: dict | None) -> str:
    """gprMax input of the scan with ``scene``'s objects (None: free space),
    the settings of benchmarks/gprmax_fixture.py."""
    lines = F.header_lines(title, 1)
    if scene is not None:
        plates = [] if scene["plate"] is None else [_corners(scene["plate"])]
        lines += F.object_lines(scene["cylinders"], plates)
    return "\n".join(lines) + "\n"


def _corners(plate) -> np.ndarray:
    """A drawn plate's corners (4, 2), m, facing its ``face_to``."""
    return F.plate_corners(plate, plate["face_to"])


def _run(python: str, name: str, text: str, dest: str) -> float:
    """One gprMax scan (1 thread) into ``dest`` (merged HDF5); seconds."""
    work = tempfile.mkdtemp(prefix=f"gprmax-{name}-")
    try:
        with open(os.path.join(work, f"{name}.in"), "w") as fh:
            fh.write(text)
        merged, sec, _ = F.run_gprmax(python, name, F.N_SCAN, work, 1)
        shutil.copyfile(merged, dest)
        return sec
    finally:
        shutil.rmtree(work, ignore_errors=True)


def simulate(args) -> int:
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    jobs = []
    if not (out / "background_merged.h5").exists():
        jobs.append(("background", input_text("background", None), out / "background_merged.h5"))
    scenes = {}
    for seed in range(args.first, args.first + args.scenes):
        folder = out / f"s{seed:03d}"
        folder.mkdir(exist_ok=True)
        scenes[seed] = draw(seed)
        if not (folder / "targets_merged.h5").exists():
            jobs.append(
                (f"s{seed:03d}", input_text(f"s{seed}", scenes[seed]), folder / "targets_merged.h5")
            )
    t0 = time.perf_counter()
    with ThreadPoolExecutor(args.jobs) as pool:
        secs = dict(
            zip(
                [j[0] for j in jobs],
                pool.map(lambda j: _run(args.python, j[0], j[1], str(j[2])), jobs),
            )
        )
    for name, sec in secs.items():
        print(f"{name}: {F.N_SCAN} traces in {sec:.0f} s")
    xs = _scan_x()
    for seed, scene in scenes.items():
        plates = []
        if scene["plate"] is not None:
            pl = scene["plate"]
            plates.append(
                {
                    "corners": _corners(pl).round(6).tolist(),
                    "length": pl["length"],
                    "thickness": pl["thickness"],
                    "material": "pec",
                }
            )
        sidecar = {
            "description": f"random gprMax scene {seed} of benchmarks/gprmax_random.py",
            "waveform": F.WAVEFORM,
            "scan": {
                "x": [round(float(v), 6) for v in xs],
                "y": F.SCAN_Y,
                "pitch": F.PITCH,
                "tx_rx": "same cell",
                "component": "Ez",
            },
            "cylinders": scene["cylinders"],
            "plates": plates,
        }
        with open(out / f"s{seed:03d}" / "scene.json", "w") as fh:
            json.dump(sidecar, fh, indent=1)
    print(f"{len(jobs)} scans in {time.perf_counter() - t0:.0f} s with {args.jobs} job(s)")
    return 0


def centres_at(objects):
    """A stand-in for the decomposition's coherent centres
    (``rpm_cl.extract.kspace.coherent_centres``) that proposes a centre at
    each of ``objects`` ((u, R) seen from the array's middle: sin of the
    direction, range to the nearest surface, m) where no centre of the
    search lies within a quarter window in k and ``gate`` in range: the
    ``--centres-at-objects`` diagnostic (what the rest of the method makes
    of a search that misses no object)."""

    def propose(data, idx, runs, k_axis, rel, window, gate):
        period = 2 * np.pi / data.array.dx
        held = [(k_axis[a], b) for a, b in np.asarray(idx, np.intp).reshape(-1, 2)]
        out = []
        for u, r in objects:
            k = 2 * data.waveform.kc * u
            a = int(np.argmin(np.abs((k_axis - k + 0.5 * period) % period - 0.5 * period)))
            b = int(np.clip(np.rint((r - data.range[0]) / data.dr), 0, data.range.size - 1))
            if any(
                abs((k_axis[a] - hk + 0.5 * period) % period - 0.5 * period) < 0.25 * window
                and abs(b - hg) * data.dr <= gate
                for hk, hg in held
            ):
                continue
            held.append((k_axis[a], b))
            out.append((a, b))
        return np.array(out, np.intp).reshape(-1, 2)

    return propose


def _objects_seen(side, xs) -> list:
    """(u, R) of each cylinder and plate of a sidecar from the array's middle."""
    xc = 0.5 * (xs[0] + xs[-1])
    out = []
    for cx, cy, r in side.cylinders:
        d = np.hypot(cx - xc, cy - side.scan_y)
        out.append(((cx - xc) / d, d - r))
    for poly in side.polygons:
        c = poly.mean(axis=0)
        d = np.hypot(c[0] - xc, c[1] - side.scan_y)
        out.append(((c[0] - xc) / d, d))
    return out


def _surfaces(side) -> dict:
    """Points on each object's boundary in the scan's frame (y from the scan
    line), m: ``c1..`` the cylinders, ``p1..`` the plates."""
    out = {}
    t = np.linspace(0, 2 * np.pi, 180, endpoint=False)
    for i, (cx, cy, r) in enumerate(side.cylinders):
        out[f"c{i + 1}"] = np.stack([cx + r * np.cos(t), cy - side.scan_y + r * np.sin(t)], 1)
    for j, poly in enumerate(side.polygons):
        edge = [np.linspace(a, b, 40) for a, b in zip(poly, np.roll(poly, -1, axis=0))]
        out[f"p{j + 1}"] = np.concatenate(edge) - [0.0, side.scan_y]
    return out


def anatomy(result, side, trees) -> list:
    """For each cluster of ``result`` with under half its points within
    50 mm of an object (``--anatomy``): the path through the scene's true
    objects whose range walk its RPs follow best, a single echo or a double
    bounce ``(|X - a| + |a - b| + |b - X|) / 2``, with the RMS of the RPs'
    ranges about it and their mean offset (m), and the cluster's median RP
    amplitude relative to the strongest cluster's.  Lines of text."""
    from itertools import combinations

    pts, rps = result.image.points, result.rps
    if not len(pts):
        return []
    near = np.stack([t.query(pts)[0] for _, t in trees], axis=1).min(axis=1) <= 0.05
    objects = _surfaces(side)
    top = max(float(np.median(rps.amp[rps.cluster == c])) for c in np.unique(rps.cluster))
    lines = []
    for c in np.unique(result.image.cluster):
        if np.mean(near[result.image.cluster == c]) >= 0.5:
            continue
        m = rps.cluster == c
        ant = np.stack([rps.x[m], np.zeros(int(m.sum()))], axis=1)
        r = np.asarray(rps.range[m], np.float64)
        leg = {k: np.linalg.norm(ant[:, None] - v[None], axis=2) for k, v in objects.items()}
        walks = {k: d.min(axis=1) for k, d in leg.items()}
        for a, b in combinations(objects, 2):
            ab = np.linalg.norm(objects[a][:, None] - objects[b][None], axis=2)
            walks[f"{a}-{b}"] = 0.5 * np.min(
                leg[a][:, :, None] + ab[None] + leg[b][:, None, :], axis=(1, 2)
            )
        name, walk = min(walks.items(), key=lambda kv: np.std(r - kv[1]))
        e = r - walk
        lines.append(
            f"  cluster {int(c)}: {int(np.sum(result.image.cluster == c))} points, "
            f"amplitude {float(np.median(rps.amp[m])) / top:.2f} of the strongest; follows "
            f"{name} to {1e3 * np.std(e):.1f} mm RMS, {1e3 * np.mean(e):+.1f} mm off"
        )
    return lines


def image(args) -> int:
    from gprmax_image import GRID, band_data, ghz_band, method_rows, object_trees

    import rpm_cl.io.gprmax as G
    from rpm_cl.baselines.das import DeviceDAS, parse_grid
    from rpm_cl.cl import create_env
    from rpm_cl.rpm import DeviceRPM

    env = create_env(args.device)
    engine, das = DeviceRPM(env), DeviceDAS(env)
    grid = parse_grid(GRID)
    root = Path(args.data)
    folders = sorted(p for p in root.glob("s[0-9][0-9][0-9]") if (p / "scene.json").exists())
    lines = []

    def say(text=""):
        print(text, flush=True)
        lines.append(text)

    say(
        f"{'scene':6s} {'method':11s} {'band GHz':>12s} {'points':>6s} {'<=50 mm':>8s} "
        f"{'median':>9s} {'objects hit':>11s}"
    )
    pooled = {}
    with tempfile.TemporaryDirectory() as tmp:
        for folder in folders:
            side = G.read_sidecar(folder / "scene.json")
            for text in args.bands.split(","):
                band = ghz_band(text)
                data = band_data(
                    folder / "targets_merged.h5",
                    root / "background_merged.h5",
                    folder / "scene.json",
                    band,
                    tmp,
                )
                trees = object_trees(side, data.array.x, side.scan_y)
                if args.centres_at_objects:
                    from rpm_cl.extract import kspace

                    kspace.wants_coherent_centres = lambda data, params: True
                    kspace.coherent_centres = centres_at(_objects_seen(side, data.array.x))
                results = {}
                rows = method_rows(data, trees, METHODS, engine, das, grid, results)
                if args.anatomy:
                    for line in anatomy(results["phase-rpm"], side, trees):
                        say(f"{folder.name:6s} {text:>12s}{line}")
                for name, (n, share, med, hit) in rows:
                    acc = pooled.setdefault((text, name), [0, 0, [], 0, 0, 0])
                    acc[0] += n
                    acc[1] += share * n
                    acc[2].append(med)
                    acc[3] += len(hit)
                    acc[4] += len(trees)
                    acc[5] += len(hit) == len(trees)
                    med_text = "-" if n == 0 else f"{1e3 * med:.1f} mm"
                    say(
                        f"{folder.name:6s} {name:11s} {text:>12s} {n:6d} {100 * share:7.0f}% "
                        f"{med_text:>9s} {len(hit):>5d}/{len(trees)} {' '.join(hit)}"
                    )
    say()
    say(f"pooled over {len(folders)} scenes")
    say(
        f"{'method':11s} {'band GHz':>12s} {'points':>6s} {'<=50 mm':>8s} {'median':>9s} "
        f"{'objects hit':>11s} {'scenes all hit':>14s}"
    )
    for (text, name), (n, good, meds, hit, tot, allhit) in pooled.items():
        med = np.nanmedian(meds) if meds else float("nan")
        say(
            f"{name:11s} {text:>12s} {n:6d} {100 * good / max(n, 1):7.0f}% "
            f"{1e3 * med:6.1f} mm {hit:>5d}/{tot:<5d} {allhit:>8d}/{len(folders)}"
        )
    if args.out:
        seeds = [int(p.name[1:]) for p in folders]
        span = f"s{min(seeds):03d}-s{max(seeds):03d}" if seeds else "none"
        with open(args.out, "w") as fh:
            fh.write(
                "# Random gprMax scenes\n\nGenerated by `python benchmarks/gprmax_random.py image "
                f"--data DATA{' --centres-at-objects' if args.centres_at_objects else ''} "
                f"--out {args.out}`, DATA holding the {len(folders)} scenes {span} "
                f"of `python benchmarks/gprmax_random.py simulate --scenes {len(folders)} "
                f"--first {min(seeds, default=0)} --out DATA` (gprMax, module notes).  Every "
                "method with its default parameters and DAS peaks, per band, scored as "
                "`benchmarks/gprmax_image.py` scores the fixtures: points within 50 mm of an "
                "object's boundary, the median distance, the objects hit (c1-c4 the cylinders "
                "of each scene.json in order, p1 its plate); pooled: points and share summed, "
                "the median of the scenes' medians.\n\n```\n" + "\n".join(lines) + "\n```\n"
            )
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="what", required=True)
    s = sub.add_parser("simulate", help="draw the scenes and run gprMax")
    s.add_argument("--scenes", type=int, default=8)
    s.add_argument("--first", type=int, default=0, help="seed of the first scene")
    s.add_argument("--out", required=True, help="folder of the scans")
    s.add_argument("--python", default=sys.executable, help="the Python that has gprMax")
    s.add_argument("--jobs", type=int, default=2, help="scans run at once (one thread each)")
    i = sub.add_parser("image", help="image every scene per band")
    i.add_argument("--data", required=True, help="the folder simulate wrote")
    i.add_argument("--bands", default=BANDS, help=f"comma-separated GHz bands (default {BANDS})")
    i.add_argument("--device", help="OpenCL device (as rpm-cl --device)")
    i.add_argument("--out", help="also write the table as Markdown here")
    i.add_argument(
        "--anatomy",
        action="store_true",
        help="also list phase-rpm's clusters with under half their points on an object, "
        "each with the single or double-bounce path it follows best (anatomy)",
    )
    i.add_argument(
        "--centres-at-objects",
        action="store_true",
        help="diagnostic: the decomposition also gets a centre at each object (centres_at)",
    )
    args = ap.parse_args(argv)
    return simulate(args) if args.what == "simulate" else image(args)


if __name__ == "__main__":
    sys.exit(main())
