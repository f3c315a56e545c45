"""RPM, DAS and RMA above a dielectric half-space: the error of each approximation
against the exact (Fermat) geometry, and the gprMax half-space fixture.

Part 1, geometry (``rpm_cl.rpm.halfspace``): range points with the exact
refracted ranges of point targets (optionally with Gaussian range noise),
imaged by the half-space RPM with its steps switched on one by one:

- ``paraxial``: circles (spheres) about the paraxial virtual antennas only;
- ``+crossing``: each point then moved onto the exact crossing of its RPs'
  refracted curves;
- ``tangent xN``: N tangent-matching passes (each followed by the crossing
  where the row says so); ``*`` marks the default.

The scenes: 2-D, 51 antennas at 10 mm 0.08 m above eps_r = 6, four points
0.06-0.25 m deep (one 0.22 m aside at 0.06 m depth, seen at up to 80
degrees); 3-D, 15 x 15 antennas at 20 mm, three points 0.10-0.20 m deep.
Rows ``air`` image the same antennas and points in free space with the same
noise (RPM's own noise amplification, for comparison).  Columns: points,
median / 90th percentile / largest distance to the nearest target (mm),
points farther than 10 mm.

Part 2, the fixture (``tests/data/gprmax_halfspace``, 1-3 GHz): DAS peaks
(the four strongest local maxima, 50 mm apart, 2 mm grid) against the rods'
tops with the refracted ranges, with straight rays (the line of sight's air
and material parts, no bending), with the antennas taken into the material
(no air gap, no refraction) and in air; then every RPM method with and
without the half-space: points, the share within 20 mm of a rod's boundary,
the median distance, points within 20 mm per rod.

Usage::

    python benchmarks/halfspace_rpm.py [--device SPEC] [--noise 1e-3] [--seed 0]
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from rpm_cl.baselines.peaks import image_peaks
from rpm_cl.extract.rangepoints import RangePoints
from rpm_cl.io.medium import Medium, one_way
from rpm_cl.rpm.params import RPMParams
from rpm_cl.rpm.pipeline import rpm_image

DATA = Path(__file__).resolve().parent.parent / "tests" / "data" / "gprmax_halfspace"
EPS, H = 6.0, 0.08
MEDIUM = Medium(EPS, H)


def scene_2d():
    x = np.arange(51) * 0.01 - 0.25
    ant = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    tg = np.array(
        [[0.0, H + 0.10, 0], [0.10, H + 0.20, 0], [-0.12, H + 0.25, 0], [0.22, H + 0.06, 0]]
    )
    return ant, tg, RPMParams(sigma_x=0.5, sigma_r=0.006)


def scene_3d():
    xs = np.arange(15) * 0.02 - 0.14
    gx, gz = np.meshgrid(xs, xs, indexing="ij")
    ant = np.column_stack([gx.ravel(), np.zeros(gx.size), gz.ravel()])
    tg = np.array([[0.0, H + 0.10, 0.0], [0.08, H + 0.20, -0.05], [-0.10, H + 0.15, 0.06]])
    return ant, tg, RPMParams(sigma_x=0.05, sigma_r=0.005)


def exact_rps(ant, tg, medium, planar):
    """One cluster per target, one RP per antenna, the exact optical paths."""
    r = (
        one_way(medium, ant[:, None], tg[None])
        if medium is not None
        else np.linalg.norm(ant[:, None] - tg[None], axis=2)
    )
    k, t = r.shape
    return RangePoints(
        np.tile(np.arange(k), t),
        np.tile(ant[:, 0], t),
        np.tile(ant[:, 2], t) if planar else None,
        r.T.ravel(),
        np.ones(k * t),
        np.repeat(np.arange(t), k),
    )


def row(label, points, tg):
    dim = points.shape[1]
    d = np.min(np.linalg.norm(points[:, None] - tg[None, :, :dim], axis=2), axis=1)
    print(
        f"  {label:24s} {len(d):5d} {1e3 * np.median(d):9.3f} {1e3 * np.percentile(d, 90):9.3f}"
        f" {1e3 * d.max():9.2f} {int(np.sum(d > 0.01)):6d}"
    )


def part_geometry(engine, noise, seed):
    from rpm_cl.rpm.halfspace import halfspace_rpm

    rng = np.random.default_rng(seed)
    print(
        "Part 1: exact refracted RPs (eps_r 6, antennas 0.08 m above the surface); "
        "distances to the nearest target, mm"
    )
    for name, make in (("2-D", scene_2d), ("3-D", scene_3d)):
        ant, tg, params = make()
        planar = name == "3-D"
        for sigma in (0.0, noise):
            exact = exact_rps(ant, tg, MEDIUM, planar)
            jitter = sigma * rng.standard_normal(len(exact))
            rps = replace(exact, range=exact.range + jitter)
            print(
                f"{name}, range noise {1e3 * sigma:g} mm: {'label':>16s} {'pts':>5s} "
                f"{'median':>9s} {'p90':>9s} {'max':>9s} {'>10mm':>6s}"
            )
            for label, it, pol in (
                ("paraxial", 0, False),
                ("paraxial +crossing", 0, True),
                ("tangent x1", 1, False),
                ("tangent x1 +crossing", 1, True),
                ("tangent x2", 2, False),
                ("tangent x2 +crossing *", 2, True),
                ("tangent x3 +crossing", 3, True),
            ):
                row(label, halfspace_rpm(rps, params, engine, MEDIUM, it, pol).points, tg)
            air = exact_rps(ant, tg, None, planar)
            air = replace(air, range=air.range + jitter)
            row("air (same points)", rpm_image(air, params, engine).points, tg)


def part_fixture(engine, das_grid="0.2:0.75:0.002,0.08:0.42:0.002"):
    import tempfile

    import rpm_cl.io.medium as M
    from rpm_cl.baselines.das import das_numpy, parse_grid
    from rpm_cl.imaging import RPM_METHODS, run_method
    from rpm_cl.io import gprmax as G
    from rpm_cl.io.formats import load_data
    from rpm_cl.rpm.params import default_params

    scene = json.loads((DATA / "scene.json").read_text())
    ys = scene["scan"]["y"]
    rods = np.array(
        [(c["centre"][0], ys - c["centre"][1], c["radius"]) for c in scene["cylinders"]]
    )
    tops = np.column_stack([rods[:, 0], rods[:, 1] - rods[:, 2]])
    medium = G.read_sidecar(DATA / "scene.json").medium()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "scan.npz"
        G.save_spectrum(
            path,
            G.convert(
                DATA / "targets_merged.h5",
                DATA / "background_merged.h5",
                (1e9, 3e9),
                sidecar=DATA / "scene.json",
            ),
        )
        data = load_data(path)
    print(
        f"\nPart 2: the gprMax fixture, 1-3 GHz ({len(rods)} rods, eps_r "
        f"{medium.eps_r:g}, antennas {medium.antenna_height:.3f} m above the surface)"
    )
    print(
        f"DAS on {das_grid}: each rod's nearest of the 4 strongest peaks, |dx| / |d depth| "
        f"from its top, mm"
    )
    grid = parse_grid(das_grid)
    n = medium.n

    def straight(_, antennas, points):
        a, p = np.asarray(antennas, float), np.asarray(points, float)
        length = np.linalg.norm(p - a, axis=-1)
        air = np.clip(medium.antenna_height / np.maximum(p[..., 1] - a[..., 1], 1e-9), 0, 1)
        return length * (air + n * (1 - air))

    for label, med, patch in (
        ("refracted", medium, None),
        ("straight rays", medium, straight),
        ("antennas in the material", Medium(medium.eps_r), None),
        ("air", Medium(), None),
    ):
        saved = M.one_way
        if patch is not None:
            M.one_way = patch
        try:
            img = das_numpy(data, grid, medium=med)
        finally:
            M.one_way = saved
        peaks, _ = image_peaks(
            img, (grid.x, grid.y), n_peaks=len(rods), min_separation=0.05, threshold_db=-20
        )
        off = np.abs(peaks[:, None, :] - tops[None])
        best = np.argmin(np.linalg.norm(off, axis=2), axis=0)
        cells = " ".join(
            f"{1e3 * off[b, k, 0]:5.1f}/{1e3 * off[b, k, 1]:5.1f}" for k, b in enumerate(best)
        )
        print(f"  {label:26s} {cells}")
    print(
        "RPM: points, share within 20 mm of a rod's boundary, median distance, "
        "points within 20 mm per rod"
    )
    for name in RPM_METHODS:
        for label, kw in (
            ("half-space", {"eps_r": medium.eps_r, "antenna_height": medium.antenna_height}),
            ("no medium", {}),
        ):
            pts = run_method(name, data, default_params(data, **kw), engine).image.points
            d = np.abs(
                np.hypot(pts[:, None, 0] - rods[None, :, 0], pts[:, None, 1] - rods[None, :, 1])
                - rods[None, :, 2]
            )
            near = d <= 0.02
            print(
                f"  {name:11s} {label:11s} {len(pts):4d} {100 * near.any(axis=1).mean():5.0f} % "
                f"{1e3 * np.median(d.min(axis=1)):7.1f} mm  {near.sum(axis=0).tolist()}"
            )


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--device", help="OpenCL device (as rpm-cl --device)")
    ap.add_argument("--noise", type=float, default=1e-3, help="range noise of part 1, m")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    from rpm_cl.cl import create_env
    from rpm_cl.rpm import DeviceRPM

    env = create_env(args.device)
    engine = DeviceRPM(env)
    print(f"device {env.name} (float32 kernels)")
    part_geometry(engine, args.noise, args.seed)
    part_fixture(engine)


if __name__ == "__main__":
    main()
