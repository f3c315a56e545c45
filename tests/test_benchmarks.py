"""The helpers the benchmark scripts draw their conclusions with."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from pareto import pareto


def test_pareto_front_with_a_time_tolerance():
    """(time, error) pairs: a pair is beaten by one as accurate and faster
    by more than the tolerance, or by one more accurate and no slower than
    the tolerance allows; the same error within the tolerance beats
    nothing, so run-to-run noise alone does not decide the front."""
    pts = [
        (100.0, 0.02),
        (110.0, 0.02),  # same error, 10 % apart
        (50.0, 0.10),  # faster, worse: on the front
        (130.0, 0.02),  # same error, 30 % slower than the first
        (200.0, 0.05),
    ]  # slower and worse than the first
    assert pareto(pts) == [0, 2]  # exact: 110 ms loses to 100 ms
    assert pareto(pts, 0.15) == [0, 1, 2]  # within 15 %: neither beats the other
    # more accurate and within the tolerance beats a faster one; beyond it, not
    assert pareto([(100.0, 0.02), (112.0, 0.01)], 0.15) == [1]
    assert pareto([(100.0, 0.02), (120.0, 0.01)], 0.15) == [0, 1]


def test_eq10_density_is_the_untruncated_reference_density(rng):
    """``exhaustive_3d.eq10_density`` (global points, every triplet of the
    cluster) equals the reference mean-shift density (local frames) where
    the reference's truncations leave nothing out: sigma_D and sigma_r wide
    against the clusters (antennas within 0.3 m, points within a few m of
    the candidates, cutoffs 4 sigma >= 4 m), with sigma_D != sigma_r so that
    swapping them shows.  Where a cutoff bites (sigma_r = 0.05 m, points 0.3 m
    off: candidates; sigma_D = 0.05 m: pairs of two sub RPs beyond 0.2 m),
    it adds what the reference leaves out."""
    import numpy as np
    from exhaustive_3d import eq10_density
    from test_spheres import planar_cluster

    from rpm_cl.extract.rangepoints import RangePoints
    from rpm_cl.rpm import reference as ref

    sizes = [12, 9]
    x, z, r, amp, ant, st, ct = planar_cluster(rng, sizes, span=0.3, dup=False)
    rps = RangePoints(ant, x, z, r, amp, np.repeat([0, 1], sizes))
    main = rng.permutation(x.size)[:8]
    pts = np.column_stack([x[main], np.zeros(main.size), z[main]]) + rng.normal(0, 0.3, (8, 3))
    pts[:, 1] += r[main]
    local = (pts - np.column_stack([x[main], np.zeros(main.size), z[main]])).T[:, None, :]

    def reference(sd, sr):
        return np.array(
            [
                ref.density_spheres(x, z, r, amp, st, ct, local[:, :, [q]], sd, sr, int(i), 1)[0, 0]
                for q, i in enumerate(main)
            ]
        )

    np.testing.assert_allclose(
        eq10_density(rps, main, pts, 1.0, 1.5), reference(1.0, 1.5), rtol=1e-12
    )
    assert not np.allclose(eq10_density(rps, main, pts, 1.5, 1.0), reference(1.0, 1.5), rtol=1e-6)
    for sd, sr in ((1.0, 0.05), (0.05, 1.5)):
        got, want = eq10_density(rps, main, pts, sd, sr), reference(sd, sr)
        # the same sums in another order: equal to rounding where nothing is cut
        assert np.all(got >= want * (1 - 1e-12)) and np.any(got > want * (1 + 1e-9)), (sd, sr)


def test_exhaustive_ties_tells_a_tie_from_another_point(rng):
    """``exhaustive_3d.exhaustive_ties``: the exhaustive image against itself
    is the same point everywhere; its point moved along y by 1.1 um is no
    longer the same point but a float32 tie (eq. 10 changes by about
    1.1e-6 |p - mode| / sigma_r^2: measured at most 3.9e-6 at 1.5 um over
    seeds 0-199, under TIE_REL = 1e-5), not a float64 one; moved by 20 mm
    it is neither (a drop of about (0.02 / 0.05)^2 / 2 = 8 %; measured at
    least 2.2 %).  The row holds a shuffled subset of the main RPs, so the
    two images are matched by index."""
    from dataclasses import replace
    from types import SimpleNamespace

    import numpy as np
    from exhaustive_3d import TIE_REL, exhaustive_ties, same_or_tied
    from test_spheres import planar_cluster

    from rpm_cl.extract.rangepoints import RangePoints
    from rpm_cl.rpm import reference as ref
    from rpm_cl.rpm.params import RPMParams
    from rpm_cl.rpm.pipeline import rpm_image

    sizes = [15, 12]
    x, z, r, amp, ant, _, _ = planar_cluster(rng, sizes, noise=1e-3, dup=False)
    rps = RangePoints(ant, x, z, r, amp, np.repeat([0, 1], sizes))
    rpm = replace(
        RPMParams(sigma_x=0.1, sigma_r=0.05),
        pair_cutoff=np.inf,
        max_neighbours=4096,
        meanshift_iters=0,
    )
    exh = rpm_image(rps, rpm, ref)
    params = SimpleNamespace(rpm=rpm)
    keep = rng.permutation(exh.rp_index.size)[:20]  # a shuffled subset of the main RPs

    def moved(dy):
        pts = exh.points[keep] + np.array([0.0, dy, 0.0])
        return SimpleNamespace(
            rps=rps, image=SimpleNamespace(rp_index=exh.rp_index[keep], points=pts)
        )

    tie = TIE_REL["float32"]
    same, rel = exhaustive_ties(moved(0.0), exh, params)
    assert same.all() and rel.size == 0 and same.size == 20
    same, rel = exhaustive_ties(moved(1.1e-6), exh, params)
    assert not same.any() and np.all(np.abs(rel) < tie) and same_or_tied(same, rel, "float32") == 1
    assert same_or_tied(same, rel, "float64") < 1
    same, rel = exhaustive_ties(moved(0.02), exh, params)
    assert not same.any() and np.all(rel > 100 * tie) and same_or_tied(same, rel, "float32") == 0


def test_random_gprmax_scenes_keep_their_drawing_rules():
    """``gprmax_random.draw``: the same seed gives the same scene; every
    object lies inside the domain's PML margin, at least MIN_RANGE from every
    antenna and MIN_GAP from every other object (surface to surface); and
    the gprMax input holds each cylinder and each plate's two prisms."""
    import gprmax_fixture as F
    import gprmax_random as R
    import numpy as np

    xs = F.SCAN_X0 + F.PITCH * np.arange(F.N_SCAN)
    ant = np.stack([xs, np.full_like(xs, F.SCAN_Y)], axis=1)
    plates = 0
    for seed in range(6):
        scene = R.draw(seed)
        assert scene == R.draw(seed)
        assert 3 <= len(scene["cylinders"]) <= 4
        shapes = []
        for c in scene["cylinders"]:
            (x, y), r = c["centre"], c["radius"]
            assert 0.005 - 1e-9 <= r <= 0.02 + 1e-9
            t = np.linspace(0, 2 * np.pi, 90, endpoint=False)
            shapes.append(np.stack([x + r * np.cos(t), y + r * np.sin(t)], axis=1))
        if scene["plate"] is not None:
            plates += 1
            shapes.append(R._plate_points(scene["plate"]))
        margin = 2 * F.PML_CELLS * F.DX
        for s in shapes:
            assert np.all(s[:, 0] > margin) and np.all(s[:, 0] < F.DOMAIN[0] - margin)
            assert np.all(s[:, 1] < F.DOMAIN[1] - margin)
            # rounding the centres to 0.1 mm may move a surface by 0.1 mm
            assert np.min(np.linalg.norm(ant[:, None] - s[None], axis=2)) >= R.MIN_RANGE - 2e-4
        for i in range(len(shapes)):
            for j in range(i):
                gap = np.min(np.linalg.norm(shapes[i][:, None] - shapes[j][None], axis=2))
                assert gap >= R.MIN_GAP - 2e-4
        text = R.input_text("t", scene)
        assert text.count("#cylinder:") == len(scene["cylinders"])
        assert text.count("#triangle:") == (0 if scene["plate"] is None else 2)
        assert "#cylinder:" not in R.input_text("t", None)
    assert 0 < plates < 6  # both kinds of scene among the first six


def test_anatomy_names_the_double_bounce_a_cluster_follows():
    """``gprmax_random.anatomy``: a cluster whose RPs lie on the double
    bounce between two cylinders (ranges ``min (|X - a| + |a - b| + |b -
    X|) / 2`` over their boundaries), with its points far from both, is
    listed with that pair at 0.0 mm RMS and 0.0 mm off; a cluster whose
    points lie on an object is not listed."""
    from types import SimpleNamespace

    import gprmax_random as R
    import numpy as np
    from scipy.spatial import cKDTree

    side = SimpleNamespace(
        cylinders=((0.40, 0.50, 0.015), (0.55, 0.60, 0.010)), polygons=(), scan_y=0.09
    )
    obj = R._surfaces(side)
    x = np.linspace(0.29, 0.61, 21)
    ant = np.stack([x, np.zeros_like(x)], axis=1)
    da = np.linalg.norm(ant[:, None] - obj["c1"][None], axis=2)
    db = np.linalg.norm(ant[:, None] - obj["c2"][None], axis=2)
    ab = np.linalg.norm(obj["c1"][:, None] - obj["c2"][None], axis=2)
    ghost = 0.5 * np.min(da[:, :, None] + ab[None] + db[:, None, :], axis=(1, 2))
    single = da.min(axis=1)
    rps = SimpleNamespace(
        x=np.concatenate([x, x]),
        range=np.concatenate([single, ghost]),
        amp=np.concatenate([np.ones(21), np.full(21, 0.3)]),
        cluster=np.repeat([0, 1], 21),
    )
    on_c1 = np.array([[0.40, 0.41 - 0.015]] * 5)  # on c1's near side (scan frame)
    behind = np.array([[0.47, 0.80]] * 5)  # 0.2 m behind both
    image = SimpleNamespace(points=np.concatenate([on_c1, behind]), cluster=np.repeat([0, 1], 5))
    trees = [(k, cKDTree(v)) for k, v in obj.items()]
    lines = R.anatomy(SimpleNamespace(image=image, rps=rps), side, trees)
    assert len(lines) == 1
    assert (
        "cluster 1: 5 points" in lines[0] and "follows c1-c2 to 0.0 mm RMS, +0.0 mm off" in lines[0]
    )
    assert "amplitude 0.30 of the strongest" in lines[0]


def test_medium_check_of_a_dense_gssi_row():
    """``medium_apex.py``'s dense row, written as a GSSI file from Ricker
    pulses and converted as ``rpm-cl convert`` does: no track fits, the
    apexes read its eps_r 5 to within the bias their neighbours give (at
    most a quarter up, docs/decisions.md), the line imaged as air draws the
    warning and in its own medium none."""
    from medium_apex import line_rows

    row = line_rows(["d"], None)[2].strip("| ").split(" | ")
    assert row[0] == "d" and row[2] == "nan (0)"
    reading = float(row[3].split()[0])
    assert 5.0 <= reading <= 1.25 * 5.0
    assert row[4] == row[3].split()[0] and row[5] == "-"
