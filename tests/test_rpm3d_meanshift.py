"""3-D RPM mean shift: kernel against its float64 reference, round trip to a
known scatterer, degenerate triplets, chunks, parameters."""

import numpy as np
import pytest
from test_spheres import lists, planar_cluster

from rpm_cl.io.data import InputError
from rpm_cl.rpm import reference as ref
from rpm_cl.rpm.params import RPMParams

SD, SR = 0.03, 0.02  # sigma_D, sigma_r, m


def start_points(x, z, r, amp, ant, st, ct):
    """The list argmax of every RP (the imaging path's start points)."""
    nbr, nn = lists(x, z, ant, st, ct)
    best, _, p0 = ref.rpm_spheres(x, z, r, amp, nbr, nn, SD, SR)
    return best, p0


@pytest.mark.parametrize("iters", [0, 1, 4])
def test_float64_kernel_matches_reference(dev64, rng, iters):
    x, z, r, amp, ant, st, ct = planar_cluster(rng, [21, 9, 33], noise=3e-3)
    _, p0 = start_points(x, z, r, amp, ant, st, ct)
    want = ref.meanshift_spheres(x, z, r, amp, st, ct, p0, SD, SR, iters)
    got = dev64.meanshift_spheres(x, z, r, amp, st, ct, p0, SD, SR, iters)
    if iters:
        assert np.mean(want[1] > 0) > 0.8 and np.any(np.abs(want[0] - p0) > 1e-4)
    else:  # no step: the points come back unchanged, density 0
        np.testing.assert_array_equal(want[0], p0)
    # the same sums in another order: float64 rounding only (|p| ~ 1 m)
    np.testing.assert_allclose(got[0], want[0], rtol=0, atol=1e-10)
    np.testing.assert_allclose(got[1], want[1], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(got[2], want[2], rtol=0, atol=1e-10)
    np.testing.assert_array_equal(got[3], want[3])


def test_float32_kernel_agrees_with_reference(dev32, rng):
    x, z, r, amp, ant, st, ct = planar_cluster(rng, [25, 40], noise=3e-3, dup=False)
    _, p0 = start_points(x, z, r, amp, ant, st, ct)
    want = ref.meanshift_spheres(x, z, r, amp, st, ct, p0, SD, SR, 2)
    got = dev32.meanshift_spheres(x, z, r, amp, st, ct, p0, SD, SR, 2)
    assert all(np.all(np.isfinite(g)) for g in got)
    # Error model: float32 candidates carry ~50 eps R^2 (|a_j|+|a_k|)/|det|
    # (test_spheres), ~1e-4 m for these 0.1 m arrays at R <= 1.6 m; a mean
    # of them carries no more, and two steps of a contraction do not amplify
    # it: 5e-4 m = sigma_r / 40.
    ok = want[1] > 0
    assert ok.sum() > 40
    assert np.abs(got[0][:, ok] - want[0][:, ok]).max() <= 5e-4
    np.testing.assert_allclose(got[1][ok], want[1][ok], rtol=1e-2)


def exact_scene(rng, m=12):
    """One scatterer seen from m antennas in general position, exact ranges."""
    target = np.array([0.05, 0.8, -0.03])
    x = rng.uniform(-0.06, 0.06, m)
    z = rng.uniform(-0.06, 0.06, m)
    r = np.sqrt((target[0] - x) ** 2 + target[1] ** 2 + (target[2] - z) ** 2)
    amp = rng.uniform(0.2, 1.0, m)
    return target, x, z, r, amp, np.zeros(m, int), np.full(m, m)


def pair_weight_sum(x, z, amp, i):
    """Sum over pairs j < k of the other antennas of g (eq. 11), written out
    independently of the code: every pair of distinct antennas in general
    position is a valid triplet with the exact intersection at the target;
    pairs of two antennas beyond MS_PAIR_CUTOFF sigma_D are left out (the
    stated truncation)."""
    total = 0.0
    for j in range(x.size):
        for k in range(j + 1, x.size):
            if i in (j, k):
                continue
            dj = (x[j] - x[i]) ** 2 + (z[j] - z[i]) ** 2
            dk = (x[k] - x[i]) ** 2 + (z[k] - z[i]) ** 2
            if min(dj, dk) > (ref.MS_PAIR_CUTOFF * SD) ** 2:
                continue
            total += amp[j] * np.exp(-dj / (2 * SD**2)) + amp[k] * np.exp(-dk / (2 * SD**2))
    return total


@pytest.mark.parametrize("engine", ["reference", "dev64", "dev32"])
def test_round_trip_to_the_scatterer(request, rng, engine):
    """Exact ranges: every candidate is the scatterer, so one step lands on it
    from 15 mm away, the second step is zero (stop), and the density there is
    the sum of all pair weights."""
    eng = ref if engine == "reference" else request.getfixturevalue(engine)
    target, x, z, r, amp, st, ct = exact_scene(rng)
    local = target[:, None] - np.stack([x, np.zeros_like(x), z])  # per main antenna
    p0 = local + np.array([0.009, -0.006, 0.01])[:, None]  # 15 mm off
    mode, dens, near, count = (
        np.asarray(v, np.float64)
        for v in eng.meanshift_spheres(x, z, r, amp, st, ct, p0, SD, SR, 5)
    )
    # float32: candidates of the narrowest triplets here err by up to ~1e-4 m
    # (~50 eps R^2 (|a_j|+|a_k|)/|det|, test_spheres' model), and so may
    # their weighted mean: 2.5e-4 m = sigma_r / 80
    tol = 1e-9 if engine != "dev32" else 2.5e-4
    np.testing.assert_allclose(mode, local, atol=tol)
    # every candidate is the scatterer: the nearest ones are all of it
    assert np.all(count == ref.MS_NEAR_K)
    np.testing.assert_allclose(near, np.repeat(local[:, None], ref.MS_NEAR_K, axis=1), atol=tol)
    want = np.array([pair_weight_sum(x, z, amp, i) for i in range(x.size)])
    # float32: G = exp(-d^2 / 2 sigma_r^2) of candidates d <= 2 x 2.5e-4 m off
    # the point falls short of 1 by <= 3e-4; the sums' rounding is far less
    np.testing.assert_allclose(dens, want, rtol=1e-9 if engine != "dev32" else 5e-4)


def test_degenerate_triplets_never_nan(dev32, dev64):
    # main RP 0 at the origin; 1, 2 collinear with it; 3 at its antenna; 4
    # too far to intersect; 5 and 6 a proper triangle.
    x = np.array([0.0, 0.01, 0.02, 0.0, 0.03, 0.0, 0.02])
    z = np.array([0.0, 0.0, 0.0, 0.0, 0.01, 0.015, 0.02])
    r = np.array([0.5, 0.5, 0.5, 0.5, 2.0, 0.5, 0.5])
    amp = np.ones(7)
    st, ct = np.zeros(7, int), np.full(7, 7)
    p0 = np.tile(np.array([[0.0], [0.5], [0.0]]), (1, 7))
    want = ref.meanshift_spheres(x, z, r, amp, st, ct, p0, SD, SR, 3)
    for dev in (dev32, dev64):
        got = dev.meanshift_spheres(x, z, r, amp, st, ct, p0, SD, SR, 3)
        assert all(np.all(np.isfinite(g)) for g in got)
        np.testing.assert_array_equal(got[1] > 0, want[1] > 0)
        np.testing.assert_allclose(got[0], want[0], atol=1e-5)
    # a cluster with no valid triplet: the points come back, density 0
    got = dev32.meanshift_spheres(
        x[:4], z[:4], r[:4], amp[:4], st[:4], np.full(4, 4), p0[:, :4], SD, SR, 3
    )
    np.testing.assert_array_equal(got[1], 0)
    np.testing.assert_allclose(got[0], p0[:, :4])


def test_chunk_equals_slice_and_bad_chunk_refused(dev64, rng):
    x, z, r, amp, ant, st, ct = planar_cluster(rng, [15, 20], noise=3e-3)
    _, p0 = start_points(x, z, r, amp, ant, st, ct)
    full = dev64.meanshift_spheres(x, z, r, amp, st, ct, p0, SD, SR, 2)
    part = dev64.meanshift_spheres(x, z, r, amp, st, ct, p0[:, 10:27], SD, SR, 2, 10, 17)
    np.testing.assert_array_equal(part[0], full[0][:, 10:27])
    np.testing.assert_array_equal(part[1], full[1][10:27])
    with pytest.raises(InputError):
        dev64.meanshift_spheres(x, z, r, amp, st, ct, p0, SD, SR, 2, 30, 10)
    with pytest.raises(InputError):
        dev64.meanshift_spheres(x, z, r, amp, st, ct, p0, SD, SR, -1)


def test_params_validate():
    assert RPMParams(meanshift_iters=0).meanshift_iters == 0
    assert RPMParams(meanshift_neighbours=None, near_neighbours=8).meanshift_neighbours is None
    # near beyond the short list: that list is all nearest (neighbour_lists caps it)
    assert RPMParams(max_neighbours=32, near_neighbours=16).near_neighbours == 16
    for bad in (
        {"meanshift_iters": -1},
        {"meanshift_point": "centre"},
        {"meanshift_neighbours": 1},
        {"meanshift_neighbours": 5000},
    ):
        with pytest.raises(InputError):
            RPMParams(**bad)


def test_meanshift_only_in_clusters_up_to_max_rps(dev64, rng):
    """Clusters larger than ``meanshift_max_rps`` keep the list's argmax
    exactly, with the ``max_neighbours`` list; the others get the mean-shift
    point, as with no cap, from the start of a ``meanshift_neighbours``
    list."""
    from dataclasses import replace

    from rpm_cl.extract.rangepoints import RangePoints
    from rpm_cl.rpm.pipeline import rpm_image

    sizes = [15, 40, 20]
    x, z, r, amp, ant, _, _ = planar_cluster(rng, sizes, noise=3e-3, dup=False)
    cl = np.repeat(np.arange(3), sizes)
    rps = RangePoints(ant, x, z, r, amp, cl)
    base = RPMParams(
        sigma_x=SD,
        sigma_r=SR,
        meanshift_iters=2,
        meanshift_point="sphere",
        max_neighbours=16,
        meanshift_neighbours=6,
    )
    off = rpm_image(rps, replace(base, meanshift_iters=0), dev64)
    on = rpm_image(rps, replace(base, meanshift_max_rps=10_000), dev64)
    capped = rpm_image(rps, replace(base, meanshift_max_rps=25), dev64)
    big = capped.cluster == 1
    assert big.sum() > 30 and (~big).sum() > 25
    # the cap changes something: mean shift moves most points
    assert np.mean(np.linalg.norm(on.points[~big] - off.points[~big], axis=1) > 1e-6) > 0.5
    np.testing.assert_array_equal(capped.rp_index, on.rp_index)
    np.testing.assert_array_equal(capped.points[big], off.points[big])
    np.testing.assert_array_equal(capped.points[~big], on.points[~big])
    # the refined clusters started from the short list: a 16 list moves them
    longer = rpm_image(rps, replace(base, meanshift_max_rps=25, meanshift_neighbours=16), dev64)
    np.testing.assert_array_equal(longer.points[big], off.points[big])
    assert np.any(np.linalg.norm(longer.points[~big] - capped.points[~big], axis=1) > 1e-9)
    # runs of two list lengths, each in several chunks: the same image
    chunked = rpm_image(rps, replace(base, meanshift_max_rps=25, chunk_slots=100), dev64)
    np.testing.assert_array_equal(chunked.rp_index, capped.rp_index)
    np.testing.assert_array_equal(chunked.points, capped.points)
    with pytest.raises(InputError):
        RPMParams(meanshift_max_rps=-1)


def test_density_kernels_match_reference(dev64, dev32, rng):
    """f at a few points near each main RP's mode: the float64 kernel within
    its series' stated error (5e-7 relative, points within sigma_r / 10 of
    the first), float32 within its rounding; a first point with no
    candidate within the cutoff gets 0."""
    x, z, r, amp, ant, st, ct = planar_cluster(rng, [21, 9, 33], noise=3e-3)
    _, p0 = start_points(x, z, r, amp, ant, st, ct)
    mode = ref.meanshift_spheres(x, z, r, amp, st, ct, p0, SD, SR, 3)[0]
    off = rng.uniform(-1, 1, (3, ref.MS_DENSITY_T, x.size)) * (SR / 10 / np.sqrt(3))
    off[:, 0] = 0
    pts = mode[:, None, :] + off
    pts[:, :, 5] += np.array([0.0, 5.0, 0.0])[:, None]  # 5 m off: nothing near
    want = ref.density_spheres(x, z, r, amp, st, ct, pts, SD, SR)
    assert want.shape == (ref.MS_DENSITY_T, x.size)
    assert np.all(want[:, 5] == 0) and np.mean(want > 0) > 0.8
    np.testing.assert_allclose(
        dev64.density_spheres(x, z, r, amp, st, ct, pts, SD, SR), want, rtol=5e-7, atol=1e-12
    )
    got32 = dev32.density_spheres(x, z, r, amp, st, ct, pts, SD, SR)
    # float32: candidates ~1e-4 m off (see above) move G by <= 2 d dd / sigma_r^2
    np.testing.assert_allclose(got32, want, rtol=2e-2, atol=1e-6)
    # a chunk is the slice; more points than MS_DENSITY_T are refused
    np.testing.assert_array_equal(
        dev64.density_spheres(x, z, r, amp, st, ct, pts[:, :, 10:20], SD, SR, 10, 10),
        dev64.density_spheres(x, z, r, amp, st, ct, pts, SD, SR)[:, 10:20],
    )
    with pytest.raises(InputError):
        dev64.density_spheres(
            x, z, r, amp, st, ct, np.zeros((3, ref.MS_DENSITY_T + 1, x.size)), SD, SR
        )


def test_default_point_is_the_exhaustive_argmax(dev64, rng):
    """The default 3-D RPM (list argmax, Newton / mean-shift steps, then the
    exhaustive density of the candidates nearest the mode) picks the same
    candidate as the exhaustive eq. 10 (every pair of the cluster scored
    against every other) for nearly every main RP, in clusters larger than
    the list; the mode put back on the sphere (the former default) never
    does, and the list's argmax alone seldom.  The body's sigmas (0.1 /
    0.05 m) and 1 mm range noise: random antennas make ill-conditioned
    triplets, whose density has several modes, and the rest start in
    another mode's basin (measured 96-97 % identical)."""
    from dataclasses import replace

    from rpm_cl.extract.rangepoints import RangePoints
    from rpm_cl.rpm.pipeline import rpm_image

    sizes = [60, 45, 80]
    x, z, r, amp, ant, _, _ = planar_cluster(rng, sizes, noise=1e-3, dup=False)
    rps = RangePoints(ant, x, z, r, amp, np.repeat(np.arange(3), sizes))
    base = RPMParams(sigma_x=0.1, sigma_r=0.05)
    exh = rpm_image(
        rps, replace(base, pair_cutoff=np.inf, max_neighbours=4096, meanshift_iters=0), dev64
    )
    rows = {
        "default": base,
        "sphere": replace(base, meanshift_point="sphere"),
        "list": replace(base, meanshift_iters=0),
    }
    same = {}
    for name, params in rows.items():
        got = rpm_image(rps, params, dev64)
        np.testing.assert_array_equal(got.rp_index, exh.rp_index)
        same[name] = np.mean(np.linalg.norm(got.points - exh.points, axis=1) < 1e-9)
    assert same["default"] >= 0.9
    assert same["sphere"] < 0.05 and same["list"] < 0.2


def test_newton_steps_converge_faster_than_mean_shift(rng, monkeypatch):
    """Three steps (Newton's on log f where it is concave enough) reach the
    mode that 40 steps converge to, to 1 um, for most main RPs, from list
    argmaxes a median 44 mm away (random antennas: a poor list); three plain
    mean-shift steps (the Newton test switched off) for none (measured 0.70
    and 0.00).  40 plain steps mostly reach the same modes (0.93: a Newton
    step, up to 10 mean-shift steps long, can cross into a neighbouring
    mode's basin)."""
    x, z, r, amp, ant, st, ct = planar_cluster(rng, [40, 30], noise=1e-3, dup=False)
    sd, sr = 0.1, 0.05
    _, p0 = start_points(x, z, r, amp, ant, st, ct)
    monkeypatch.setattr(ref, "MS_TOL", 1e-9)  # no early stop
    mode = ref.meanshift_spheres(x, z, r, amp, st, ct, p0, sd, sr, 40)[0]
    newton = ref.meanshift_spheres(x, z, r, amp, st, ct, p0, sd, sr, 3)[0]
    monkeypatch.setattr(ref, "MS_NEWTON_PIVOT", np.inf)
    shift = ref.meanshift_spheres(x, z, r, amp, st, ct, p0, sd, sr, 3)[0]
    slow = ref.meanshift_spheres(x, z, r, amp, st, ct, p0, sd, sr, 40)[0]
    near = {
        k: np.mean(np.linalg.norm(v - mode, axis=0) < 1e-6)
        for k, v in (("newton", newton), ("shift", shift), ("slow", slow))
    }
    assert near["newton"] >= 0.6 and near["shift"] < 0.05 and near["slow"] >= 0.85


def test_short_list_only_where_one_rp_per_antenna(dev64, rng):
    """``meanshift_neighbours`` applies to refined clusters with one RP per
    antenna; a cluster with two RPs at an antenna (the baselines' whole-scene
    clusters) keeps the ``max_neighbours`` list, so its points are those of
    ``meanshift_neighbours=None``."""
    from dataclasses import replace

    from rpm_cl.extract.rangepoints import RangePoints
    from rpm_cl.rpm.pipeline import _one_per_antenna, rpm_image

    sizes = [30, 40]
    x, z, r, amp, ant, st_, _ = planar_cluster(rng, sizes, noise=3e-3, dup=False)
    x[1], z[1], ant[1] = x[0], z[0], ant[0]  # cluster 0: a second RP at an antenna
    np.testing.assert_array_equal(_one_per_antenna(ant, st_), np.repeat([False, True], sizes))
    rps = RangePoints(ant, x, z, r, amp, np.repeat(np.arange(2), sizes))
    base = RPMParams(sigma_x=SD, sigma_r=SR, meanshift_point="sphere", max_neighbours=16)
    long_ = rpm_image(rps, replace(base, meanshift_neighbours=None), dev64)
    short = rpm_image(rps, replace(base, meanshift_neighbours=6), dev64)
    np.testing.assert_array_equal(short.rp_index, long_.rp_index)
    dup = short.cluster == 0
    np.testing.assert_array_equal(short.points[dup], long_.points[dup])
    # and the other cluster's are those of 6-long lists everywhere
    six = rpm_image(rps, replace(base, max_neighbours=6, meanshift_neighbours=None), dev64)
    np.testing.assert_array_equal(short.points[~dup], six.points[~dup])
    assert np.any(np.linalg.norm(short.points[~dup] - long_.points[~dup], axis=1) > 1e-9)


@pytest.mark.parametrize("store", [True, False])
def test_candidate_store_and_recomputation_agree_with_reference(dev64, rng, monkeypatch, store):
    """The kernel intersects each main RP's pairs once and reads them back
    in its later passes and in the density that reuses them (the store), or,
    where a chunk does not fit the store, intersects them in every pass:
    both equal the float64 reference, and a density reusing the store equals
    one that intersects again."""
    from rpm_cl.rpm import device_meanshift as dm

    if not store:
        monkeypatch.setattr(dm, "MS_STORE_SLOTS", 0)
    x, z, r, amp, ant, st, ct = planar_cluster(rng, [21, 9, 33], noise=3e-3)
    _, p0 = start_points(x, z, r, amp, ant, st, ct)
    want = ref.meanshift_spheres(x, z, r, amp, st, ct, p0, SD, SR, 3)
    got = dev64.meanshift_spheres(x, z, r, amp, st, ct, p0, SD, SR, 3)
    assert (dev64._ms_stored is not None) == store
    np.testing.assert_allclose(got[0], want[0], rtol=0, atol=1e-10)
    np.testing.assert_allclose(got[1], want[1], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(got[2], want[2], rtol=0, atol=1e-10)
    np.testing.assert_array_equal(got[3], want[3])
    # the density at each mode and 1 mm beside it (points sigma_r / 10 apart
    # or less, as the imaging path asks), reusing the store or not
    mode = np.asarray(got[0])
    pts = np.stack([mode, mode + np.array([[1e-3], [0.0], [0.0]])], axis=1)
    f_ref = ref.density_spheres(x, z, r, amp, st, ct, pts, SD, SR)
    f_reuse = dev64.density_spheres(x, z, r, amp, st, ct, pts, SD, SR, reuse=True)
    f_fresh = dev64.density_spheres(x, z, r, amp, st, ct, pts, SD, SR)
    np.testing.assert_allclose(f_reuse, f_ref, rtol=1e-6, atol=1e-12)  # the series' error
    np.testing.assert_allclose(f_reuse, f_fresh, rtol=1e-12, atol=1e-14)


def test_density_reuse_needs_the_same_chunk(dev64, rng):
    """A density call on another chunk than the last mean shift's does not
    read that mean shift's store (it intersects its own pairs)."""
    x, z, r, amp, ant, st, ct = planar_cluster(rng, [21, 9, 33], noise=3e-3)
    _, p0 = start_points(x, z, r, amp, ant, st, ct)
    dev64.meanshift_spheres(x, z, r, amp, st, ct, p0[:, :10], SD, SR, 2, 0, 10)
    pts = np.repeat(p0[:, None, 10:20], 1, axis=1)
    f = dev64.density_spheres(x, z, r, amp, st, ct, pts, SD, SR, 10, 10, reuse=True)
    want = ref.density_spheres(x, z, r, amp, st, ct, pts, SD, SR, 10, 10)
    np.testing.assert_allclose(f, want, rtol=1e-10, atol=1e-12)


def test_device_refuses_clusters_outside_the_rps(dev32):
    """The kernels read a cluster's RPs unchecked: a cluster reaching past
    the RPs, or a per-RP array of another length, is refused first."""
    x = np.linspace(-0.05, 0.05, 6)
    z, r, amp = np.zeros(6), np.full(6, 0.5), np.ones(6)
    st, ct = np.zeros(6, int), np.full(6, 6)
    p0 = np.zeros((3, 6))
    bad = ct.copy()
    bad[3] = 7
    with pytest.raises(InputError, match="every cluster must lie within the RPs"):
        dev32.meanshift_spheres(x, z, r, amp, st, bad, p0, SD, SR, 1)
    with pytest.raises(InputError, match="one entry per RP"):
        dev32.meanshift_spheres(x, z[:5], r, amp, st, ct, p0, SD, SR, 1)
    with pytest.raises(InputError, match="every cluster must lie within the RPs"):
        dev32.rpm_circles(x, r, amp, st, bad, 6, SD, SR)


def test_clusters_whose_sample_does_not_move_keep_the_list_argmax(dev64, rng):
    """``meanshift_sample``: a cluster of exact ranges to one point (every
    triplet meets at it, so the list's argmax is the mode and the steps move
    nothing) keeps the list's argmax and takes the steps only on its sample;
    a noisy cluster, whose points the steps move by a good fraction of
    sigma_r, gets exactly the points of a run without sampling."""
    from dataclasses import replace

    from rpm_cl.extract.rangepoints import RangePoints
    from rpm_cl.rpm import pipeline
    from rpm_cl.rpm.pipeline import MS_SAMPLE_MIN, rpm_image

    target, xe, ze, re, ampe, _, _ = exact_scene(rng, m=48)
    xn, zn, rn, ampn, _, _, _ = planar_cluster(rng, [48], noise=3e-3, dup=False)
    x, z, r, amp = (np.r_[a, b] for a, b in ((xe, xn), (ze, zn), (re, rn), (ampe, ampn)))
    rps = RangePoints(np.arange(96), x, z, r, amp, np.repeat([0, 1], 48))
    # one list length with steps and without (meanshift_neighbours None):
    # the skipped cluster keeps the argmax the steps would start from
    base = RPMParams(
        sigma_x=SD, sigma_r=SR, meanshift_iters=3, max_neighbours=10, meanshift_neighbours=None
    )
    ran = []
    steps = dev64.meanshift_spheres

    def counted(*a):
        ran.append(a[-1])  # main RPs of the call
        return steps(*a)

    dev64.meanshift_spheres = counted
    try:
        sampled = rpm_image(rps, base, dev64)
        n_sampled = sum(ran)
        ran.clear()
        every = rpm_image(rps, replace(base, meanshift_sample=0), dev64)
        n_every = sum(ran)
    finally:
        del dev64.meanshift_spheres
    off = rpm_image(rps, replace(base, meanshift_iters=0), dev64)
    exact = sampled.cluster == 0
    assert exact.sum() == 48 and (~exact).sum() == 48
    # the exact cluster: the list's argmax (at the target), not stepped
    np.testing.assert_array_equal(sampled.points[exact], off.points[exact])
    np.testing.assert_allclose(sampled.points[exact], np.tile(target, (48, 1)), atol=1e-9)
    # the noisy one moves (the test would pass vacuously otherwise) and is
    # stepped in full: the same points as without sampling
    moves = np.linalg.norm(every.points[~exact] - off.points[~exact], axis=1)
    assert np.median(moves) > pipeline.MS_SAMPLE_TOL * SR
    np.testing.assert_array_equal(sampled.points[~exact], every.points[~exact])
    # steps: both samples (48 / 16 -> at least MS_SAMPLE_MIN each) and the
    # noisy cluster, against both clusters without sampling
    assert n_every == 96
    assert n_sampled == 2 * MS_SAMPLE_MIN + 48
    with pytest.raises(InputError):
        RPMParams(meanshift_sample=-1)
