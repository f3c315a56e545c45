"""Double-bounce echoes (rpm_cl.rpm.multipath): predicted ranges and ghost points
against their formulas, and phase-rpm on data with a double bounce
synthesised here (rpm_cl.simulate makes none)."""

import numpy as np
import pytest

from rpm_cl import imaging
from rpm_cl.io.data import C0, Array, RadarData, Waveform
from rpm_cl.io.formats import range_compress
from rpm_cl.rpm.multipath import double_bounce, ghost_points
from rpm_cl.rpm.params import default_params


def test_double_bounce_is_the_shortest_path():
    rng = np.random.default_rng(11)
    ant = np.column_stack([rng.uniform(-0.1, 0.1, 7), np.zeros(7), rng.uniform(-0.1, 0.1, 7)])
    a = rng.normal([0.1, 0.5, 0.0], 0.02, (5, 3))
    b = rng.normal([-0.1, 0.6, 0.05], 0.02, (4, 3))
    want = np.array(
        [
            min(
                np.linalg.norm(x - p) + np.linalg.norm(p - q) + np.linalg.norm(q - x)
                for p in a
                for q in b
            )
            / 2
            for x in ant
        ]
    )
    np.testing.assert_allclose(double_bounce(ant, a, b), want, rtol=0, atol=1e-12)


def test_ghost_points_of_two_points_are_their_envelope():
    """For point legs A, B the ghost range is R(X) = (|X-A| + |AB| + |X-B|)/2
    with dR/dX the mean of the two direction cosines; the ghost point is
    X + R (-dR/dX, sqrt(1 - (dR/dX)^2))."""
    x = np.linspace(-0.06, 0.06, 13)
    ant = np.column_stack([x, 0 * x, 0 * x])
    a, b = np.array([[-0.1, 0.4, 0.0]]), np.array([[0.12, 0.38, 0.0]])
    ra, rb = np.hypot(x - a[0, 0], a[0, 1]), np.hypot(x - b[0, 0], b[0, 1])
    r = 0.5 * (ra + rb + np.linalg.norm(a - b))
    slope = 0.5 * ((x - a[0, 0]) / ra + (x - b[0, 0]) / rb)
    want = np.column_stack([x - r * slope, r * np.sqrt(1 - slope**2), 0 * x])
    np.testing.assert_allclose(ghost_points(ant, a, b), want, atol=1e-7)


def test_ghost_points_of_extended_legs_in_3d_follow_the_range_walk():
    """Legs of several points off the plane z = 0, seen by a planar array:
    the ghost point is X - R grad R (x, z) at y = R sqrt(1 - |grad R|^2), with
    grad R the central differences of double_bounce (an independent route
    to the gradient the function forms in closed form)."""
    rng = np.random.default_rng(11)
    xg, zg = np.meshgrid(np.linspace(-0.05, 0.05, 6), np.linspace(-0.04, 0.04, 5))
    ant = np.column_stack([xg.ravel(), 0 * xg.ravel(), zg.ravel()])
    a = np.array([-0.1, 0.4, 0.03]) + 0.01 * rng.standard_normal((5, 3))
    b = np.array([0.12, 0.38, -0.02]) + 0.01 * rng.standard_normal((4, 3))
    r = double_bounce(ant, a, b)
    h = 1e-6
    grad = np.zeros_like(ant)
    for axis in (0, 2):
        e = np.zeros(3)
        e[axis] = h
        grad[:, axis] = (double_bounce(ant + e, a, b) - double_bounce(ant - e, a, b)) / (2 * h)
    across = 1 - grad[:, 0] ** 2 - grad[:, 2] ** 2
    want = ant - r[:, None] * grad
    want[:, 1] = r * np.sqrt(across)
    np.testing.assert_allclose(ghost_points(ant, a, b), want[across > 0], atol=1e-8)


def _two_targets_and_ghost(seed, snr_db, ghost=0.3):
    """Two point targets and their double bounce (both paths, each ``ghost``
    of a target's amplitude), 0.25 GHz at 22 GHz, 31 antennas at 4 mm, noise in
    the frequency samples (S/N as the peak compressed power over the mean
    compressed noise power)."""
    r = np.random.default_rng(seed)
    x = (np.arange(31) - 15) * 4e-3
    a = np.array([r.uniform(-0.15, -0.05), r.uniform(0.35, 0.45)])
    b = np.array([r.uniform(0.05, 0.15), r.uniform(0.35, 0.45)])
    fc, band, nf = 22e9, 0.25e9, 64
    f = fc - band / 2 + np.arange(nf) * band / (nf - 1)
    ra, rb = np.hypot(x - a[0], a[1]), np.hypot(x - b[0], b[1])
    rab = 0.5 * (ra + rb + np.linalg.norm(a - b))
    y = sum(
        g * np.exp(-4j * np.pi * f * rr[:, None] / C0) / rr[:, None]
        for g, rr in ((1.0, ra), (1.0, rb), (2 * ghost, rab))
    )
    if snr_db is not None:
        peak = np.max(np.abs(np.fft.ifft(y, 4096, axis=1) * 4096 / nf)) ** 2
        s2 = peak / 10 ** (snr_db / 10) * nf
        g = np.random.default_rng(seed + 99)
        y = y + np.sqrt(s2 / 2) * (g.standard_normal(y.shape) + 1j * g.standard_normal(y.shape))
    s, rng_axis = range_compress(y, f, fc, "hann")
    keep = rng_axis < 2.0
    ghost_at = ghost_points(
        np.column_stack([x, 0 * x, 0 * x]), np.array([[*a, 0.0]]), np.array([[*b, 0.0]])
    )[:, :2]
    return RadarData(s[:, keep], Array(x), rng_axis[keep], Waveform(fc, band / 2)), a, b, ghost_at


@pytest.mark.parametrize("seed,snr", [(2, None), (3, None), (4, 30.0), (2, 20.0), (3, 20.0)])
def test_double_bounce_is_dropped_by_default_and_flagged_on_request(dev32, seed, snr):
    data, a, b, ghost_at = _two_targets_and_ghost(seed, snr)
    flagged = imaging.run_method(
        "phase-rpm", data, default_params(data, multipath="flag"), dev32
    ).image
    near_t = (
        np.minimum(
            np.linalg.norm(flagged.points - a, axis=1), np.linalg.norm(flagged.points - b, axis=1)
        )
        < 0.05
    )
    near_g = np.min(np.linalg.norm(flagged.points[:, None] - ghost_at[None], axis=2), axis=1) < 0.1
    # the ghost is imaged (that is what the test is about) and every point of
    # it is flagged; no cluster of a target's (most of its points on it) is
    # (the ghost's cluster may put a few points on a target, from the ends of
    # the targets' echoes its window holds: flagged with it, harmlessly)
    assert np.count_nonzero(near_g & ~near_t) >= 10
    assert np.all(flagged.multipath[near_g & ~near_t])
    for c in np.unique(flagged.cluster):
        mine = flagged.cluster == c
        if np.mean(near_t[mine]) > 0.5:
            assert not np.any(flagged.multipath[mine])
    dropped = imaging.run_method("phase-rpm", data, default_params(data), dev32).image
    assert dropped.multipath is None
    assert len(dropped.points) == np.count_nonzero(~flagged.multipath)
    d = np.minimum(
        np.linalg.norm(dropped.points - a, axis=1), np.linalg.norm(dropped.points - b, axis=1)
    )
    assert np.all(d < 0.05)


def test_real_targets_are_not_flagged(dev32):
    """Three or four point targets spread over +-35 degrees (the narrow-band
    scenes of tests/test_phase.py): no echo is a double bounce, none is
    flagged."""
    from test_phase import _independent_scene

    for seed in range(4):
        data, _ = _independent_scene(seed, 30.0)
        img = imaging.run_method(
            "phase-rpm", data, default_params(data, multipath="flag"), dev32
        ).image
        assert not img.multipath.any()


def test_cli_writes_the_flag_column(tmp_path):
    from rpm_cl.cli import main
    from rpm_cl.io.formats import save_data

    data, *_ = _two_targets_and_ghost(3, None)
    src = tmp_path / "in.npz"
    save_data(src, data)
    out = tmp_path / "out.npz"
    assert main(["image", str(src), "-o", str(out), "-q", "--multipath", "flag"]) == 0
    with np.load(out) as f:
        assert f["multipath"].shape == f["cluster"].shape and f["multipath"].any()
        n_flag = len(f["points"])
        n_ghost = int(f["multipath"].sum())
    assert main(["image", str(src), "-o", str(out), "-q"]) == 0
    with np.load(out) as f:
        assert "multipath" not in f.files and len(f["points"]) == n_flag - n_ghost


def test_parts_of_one_object_are_not_each_others_double_bounce(dev32, monkeypatch):
    """The three spheres on 64 x 64 antennas at 7.5 mm, decomposed whole
    (``segments`` off: the whole aperture's decomposition splits each sphere
    into several clusters, which meet on its surface) and in tiles (one
    cluster per sphere and tile); there is no double bounce in the data.  No
    point is flagged; decomposed whole, with every
    accepted cluster its own object (a cube of touching too small to join
    any two) the sphere's parts predict "double bounces" onto its other
    parts, and hundreds of points on the spheres are flagged."""
    from dataclasses import replace

    from rpm_cl.cli import robustness as R
    from rpm_cl.rpm import multipath

    g = replace(R.GEOMETRY_3D, x=(64, 7.5e-3), z=(64, 7.5e-3))
    spec, f, _ = R.synthesize(g, None, 0)
    data = R.radar_data(g, spec, f)
    tiled = imaging.run_method("phase-rpm", data, default_params(data, multipath="flag"), dev32)
    # 3 x 3 tiles, one cluster per sphere and tile
    assert len(np.unique(tiled.rps.cluster)) == 27 and not tiled.image.multipath.any()
    params = default_params(data, multipath="flag", segments=False)
    res = imaging.run_method("phase-rpm", data, params, dev32)
    assert len(res.image.points) > 20000 and not res.image.multipath.any()
    monkeypatch.setattr(multipath, "TOUCH", 1e-9)
    apart = multipath.flag_multipath(
        data.array.positions(), res.rps, res.image, data.waveform.range_resolution
    )
    assert apart.sum() > 500


def _synthetic(clusters, x):
    """RangePoints and an Image of clusters given as (points (M, 2), ranges
    at every antenna, amplitude): one RP and one point per antenna."""
    from rpm_cl.extract.rangepoints import RangePoints
    from rpm_cl.result import Image

    n = x.size
    pts, rng_, amp, cl = [], [], [], []
    for c, (p, r, a) in enumerate(clusters):
        pts.append(p), rng_.append(r), amp.append(np.full(n, a)), cl.append(np.full(n, c))
    cl = np.concatenate(cl)
    rps = RangePoints(
        np.tile(np.arange(n), len(clusters)),
        np.tile(x, len(clusters)),
        None,
        np.concatenate(rng_),
        np.concatenate(amp),
        cl,
    )
    image = Image(np.concatenate(pts), cl, np.ones(cl.size), np.arange(cl.size))
    return rps, image


def test_a_cluster_on_surfaces_found_is_no_double_bounce(monkeypatch):
    """Two points and their double bounce, imaged where the bounce predicts
    (on the envelope of its ranges): flagged.  With an object accepted
    first whose surface runs through those places, the same cluster lies on
    a surface already found and is not flagged; without the rule it is."""
    from rpm_cl.rpm import multipath

    x = (np.arange(31) - 15) * 4e-3
    ant = np.column_stack([x, 0 * x, 0 * x])
    a, b = np.array([[-0.1, 0.4, 0.0]]), np.array([[0.12, 0.38, 0.0]])
    ra, rb = (np.linalg.norm(ant - t, axis=1) for t in (a, b))
    ghost = ghost_points(ant, a, b)[:, :2]
    legs = [(np.repeat(t[:, :2], x.size, 0), r, 1.0) for t, r in ((a, ra), (b, rb))]
    bounce = (ghost, double_bounce(ant, a, b), 0.3)
    res = 0.6
    rps, image = _synthetic([*legs, bounce], x)
    flags = multipath.flag_multipath(np.column_stack([x, 0 * x]), rps, image, res)
    assert flags[image.cluster == 2].all() and not flags[image.cluster < 2].any()
    # a surface through the same places, as strong as the legs (no ghost
    # itself) and ranked before the bounce
    surface = (ghost + [0.0, 1e-3], np.linalg.norm(ant[:, :2] - ghost, axis=1), 1.0)
    rps, image = _synthetic([*legs, surface, bounce], x)
    flags = multipath.flag_multipath(np.column_stack([x, 0 * x]), rps, image, res)
    assert not flags.any()
    monkeypatch.setattr(multipath._Objects, "covered", lambda self, p: 0.0)
    flags = multipath.flag_multipath(np.column_stack([x, 0 * x]), rps, image, res)
    assert flags[image.cluster == 3].all()


def test_covered_counts_points_in_or_beside_accepted_cells():
    from rpm_cl.rpm.multipath import TOUCH, _Objects

    objects = _Objects()
    assert objects.covered(np.zeros((3, 3))) == 0.0
    objects.add(np.array([[0.0, 1.0, 0.0], [0.5 * TOUCH, 1.0, 0.0]]))
    pts = np.array([[1.5 * TOUCH, 1.0, 0.0], [3.5 * TOUCH, 1.0, 0.0], [0.0, 1.0, -0.5 * TOUCH]])
    assert objects.covered(pts) == pytest.approx(2 / 3)


def test_touching_does_not_depend_on_where_cells_end():
    """Parts of one object: points closer than TOUCH always join, across a
    cell's edge or the origin; points 5 TOUCH apart never do, unless a third
    cluster bridges them."""
    from rpm_cl.rpm.multipath import TOUCH, _Objects

    def joined(*clusters):
        objects = _Objects()
        for c in clusters:
            objects.add(np.asarray(c, float))
        return objects.same(0, 1)

    t = TOUCH
    assert joined([[t - 1e-6, 1, 0]], [[t + 1e-6, 1, 0]])  # either side of an edge
    assert joined([[-1e-6, 1, 0]], [[1e-6, 1, 0]])  # either side of the origin
    assert joined([[0, 1, 0.3 * t]], [[0.6 * t, 1, -0.5 * t]])
    assert not joined([[0, 1, 0]], [[5 * t, 1, 0]])
    bridge = [[1.5 * t, 1, 0], [2.5 * t, 1, 0], [3.5 * t, 1, 0]]
    assert joined([[0, 1, 0]], [[4.2 * t, 1, 0]], bridge)
    assert not joined([[0, 1, 0]], [[7 * t, 1, 0]], bridge)


@pytest.mark.parametrize("far", [0.0, 20e3])
def test_objects_answer_alike_beyond_the_packed_cells_reach(far):
    """The cells are packed into int64 codes counted from the first point's
    cell; a point 20 km off (beyond 2^20 cells) moves them to tuples, with
    the same answers: the touching pair joins across a cell's edge, the
    distant cluster stays its own object, and covered counts the same."""
    from rpm_cl.rpm import multipath
    from rpm_cl.rpm.multipath import TOUCH, _Objects

    t = TOUCH
    objects = _Objects()
    objects.add(np.array([[t - 1e-6, 1.0, 0.0], [0.5 * t, 1.0, 0.0]]))
    objects.add(np.array([[far, 1.0, 0.0]]) if far else np.zeros((0, 3)))
    objects.add(np.array([[t + 1e-6, 1.0, 0.0]]))
    assert (objects.cells is not None) == (far > multipath._CELL_REACH * t)
    assert objects.same(0, 2) and not objects.same(0, 1)
    pts = np.array([[2.5 * t, 1.0, 0.0], [4.5 * t, 1.0, 0.0], [0.0, 1.0, -0.5 * t], [far, 1.0, t]])
    assert objects.covered(pts) == pytest.approx(3 / 4)


@pytest.mark.parametrize("half_space", [False, True])
def test_leg_pairs_are_those_the_exact_level_test_keeps(half_space):
    """The stacked level test (multipath._Legs) returns exactly the pairs,
    in the loop's order, whose double bounce (double_bounce) lies within
    the tolerance, on random clusters of random sizes; and nothing the
    ``keep`` table rules out."""
    from rpm_cl.io.medium import Medium
    from rpm_cl.rpm import multipath

    rng = np.random.default_rng(21)
    medium = Medium(4.0, 0.05) if half_space else None
    legs = multipath._Legs(medium)
    clusters = []
    for _ in range(14):
        m = int(rng.integers(1, multipath.MAX_OBJECT_POINTS + 1))
        centre = np.array([rng.uniform(-0.3, 0.3), rng.uniform(0.2, 0.6), 0.0])
        c = centre + rng.normal(0, 0.02, (m, 3)) * [1, 1, 0]
        clusters.append(c)
        legs.add(c)
    one = np.array([[rng.uniform(-0.2, 0.2), 0.0, 0.0]])
    all_pairs = [(i, j) for i in range(14) for j in range(i + 1, 14)]
    ranges = {
        p: multipath.double_bounce(one, clusters[p[0]], clusters[p[1]], medium)[0]
        for p in all_pairs
    }
    keep = np.ones((14, 14), bool)
    for r in np.quantile(list(ranges.values()), [0.2, 0.5, 0.8]):
        tol = 0.03
        want = [p for p in all_pairs if abs(r - ranges[p]) <= tol]
        assert want and legs.candidates(one, r, tol, keep) == want
    keep[0, :] = keep[:, 0] = False
    got = legs.candidates(one, float(np.median(list(ranges.values()))), 10.0, keep)
    assert got == [p for p in all_pairs if 0 not in p]


def test_legs_from_another_tile_are_compared_as_the_clusters_antennas_see_them():
    """Planar tiles: two point objects found by one tile's antennas (1.0
    each) and a cluster imaged exactly where their double bounce would image
    from another tile 0.4 m aside.  In one decomposition a cluster at 0.45
    of the legs is their double bounce (below GHOST_AMP = 0.7).  Found in
    another tile, the legs were seen from 0.505 and 0.467 m (median ranges)
    where the cluster's median antenna sees them from 0.680 and 0.547 m, so
    there they give (0.505 / 0.680)^2 = 0.55 and 0.73 of their amplitude, and
    0.45 is above 0.7 x 0.55: no double bounce (with 1 / R instead of two-way
    spherical spreading, 0.7 x 0.74 = 0.52, it would be); a cluster at 0.2
    still is."""
    from rpm_cl.extract.rangepoints import RangePoints
    from rpm_cl.result import Image
    from rpm_cl.rpm import multipath

    g = (np.arange(8) - 3.5) * 0.02
    gx, gz = (v.ravel() for v in np.meshgrid(g, g, indexing="ij"))
    near = np.column_stack([gx, 0 * gx, gz])
    far = near + [0.4, 0.0, 0.0]
    ant = np.concatenate([near, far])
    a, b = np.array([[-0.05, 0.5, 0.0]]), np.array([[0.1, 0.45, 0.05]])
    ghost = ghost_points(far, a, b)
    assert len(ghost) == len(far)
    n = len(near)

    def scene(ghost_amp):
        pts = [np.repeat(a, n, 0), np.repeat(b, n, 0), ghost]
        rng_ = [np.linalg.norm(near - a, axis=1), np.linalg.norm(near - b, axis=1)]
        rng_.append(double_bounce(far, a, b))
        amp = [np.ones(n), np.ones(n), np.full(n, ghost_amp)]
        antenna = np.concatenate([np.arange(n), np.arange(n), n + np.arange(n)])
        cl = np.repeat([0, 1, 2], n)
        p = ant[antenna]
        rps = RangePoints(antenna, p[:, 0], p[:, 2], np.concatenate(rng_), np.concatenate(amp), cl)
        image = Image(np.concatenate(pts), cl, np.ones(cl.size), np.arange(cl.size))
        return rps, image

    res = 0.05
    positions = ant  # (x, y = 0, z), as Array.positions() gives a planar array
    tiles = np.repeat([0, 0, 1], n)
    for ghost_amp, whole, tiled in ((0.45, True, False), (0.2, True, True)):
        rps, image = scene(ghost_amp)
        one = multipath.flag_multipath(positions, rps, image, res)
        apart = multipath.flag_multipath(positions, rps, image, res, parts=tiles)
        same = multipath.flag_multipath(positions, rps, image, res, parts=np.zeros(3 * n, int))
        assert not one[image.cluster < 2].any() and not apart[image.cluster < 2].any()
        assert one[image.cluster == 2].all() == whole
        assert same[image.cluster == 2].all() == whole
        assert apart[image.cluster == 2].all() == tiled and apart[image.cluster == 2].any() == tiled
