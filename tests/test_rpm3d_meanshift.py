"""3-D RPM mean shift: kernel against its float64 reference, round trip to a
known scatterer, degenerate triplets, chunks, parameters."""

import numpy as np
import pytest
from test_spheres import lists, planar_cluster

from rpm_cl.data import InputError
from rpm_cl.imaging import RPMParams
from rpm_cl.rpm import reference as ref

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
    p0 = local + np.array([0.009, -0.006, 0.01])[:, None]         # 15 mm off
    mode, dens, near = (np.asarray(v, np.float64)
                        for v in eng.meanshift_spheres(x, z, r, amp, st, ct, p0, SD, SR, 5))
    # float32: candidates of the narrowest triplets here err by up to ~1e-4 m
    # (~50 eps R^2 (|a_j|+|a_k|)/|det|, test_spheres' model), and so may
    # their weighted mean: 2.5e-4 m = sigma_r / 80
    tol = 1e-9 if engine != "dev32" else 2.5e-4
    np.testing.assert_allclose(mode, local, atol=tol)
    np.testing.assert_allclose(near, local, atol=tol)
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
    got = dev32.meanshift_spheres(x[:4], z[:4], r[:4], amp[:4], st[:4], np.full(4, 4),
                                  p0[:, :4], SD, SR, 3)
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
    for bad in ({"meanshift_iters": -1}, {"meanshift_point": "centre"}):
        with pytest.raises(InputError):
            RPMParams(**bad)


def test_meanshift_only_in_clusters_up_to_max_rps(dev64, rng):
    """Clusters larger than ``meanshift_max_rps`` keep the list's argmax
    exactly; the others get the mean-shift point, as with no cap."""
    from dataclasses import replace

    from rpm_cl.imaging import rpm_image
    from rpm_cl.rangepoints import RangePoints

    sizes = [15, 40, 20]
    x, z, r, amp, ant, _, _ = planar_cluster(rng, sizes, noise=3e-3, dup=False)
    cl = np.repeat(np.arange(3), sizes)
    rps = RangePoints(ant, x, z, r, amp, cl)
    base = RPMParams(sigma_x=SD, sigma_r=SR, meanshift_iters=2)
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
    with pytest.raises(InputError):
        RPMParams(meanshift_max_rps=-1)
