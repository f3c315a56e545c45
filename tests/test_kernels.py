"""OpenCL kernels against their float64 NumPy references (the specification)."""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from rpm_cl.rpm import reference as ref


def random_clusters(rng, sizes, x_span=0.1, r_lo=0.2, r_hi=0.8, dup_antennas=True):
    """Random RPs in contiguous clusters (some sharing antennas)."""
    n = int(sum(sizes))
    x = rng.uniform(-x_span / 2, x_span / 2, n)
    if dup_antennas:  # exact same-antenna pairs must be skipped
        x[rng.random(n) < 0.2] = x[0]
    r = rng.uniform(r_lo, r_hi, n)
    amp = rng.uniform(0.0, 2.0, n)
    starts = np.repeat(np.cumsum([0] + list(sizes[:-1])), sizes)
    counts = np.repeat(sizes, sizes)
    return x, r, amp, starts, counts, int(max(sizes))


def margin(x, r, starts, counts, maxc):
    """Smallest of the two validity margins (s-|d|, |d|-|e|) relative to R,
    per slot, from the float64 reference maths (inf for out-of-range slots)."""
    n = x.size
    js = np.arange(maxc)[None, :]
    j = np.minimum(starts[:, None] + js, n - 1)
    d = np.abs(x[j] - x[:, None])
    s = r[:, None] + r[j]
    e = np.abs(r[:, None] - r[j])
    m = np.minimum(np.abs(s - d), np.abs(d - e)) / s
    return np.where(js < counts[:, None], m, np.inf)


def test_intersect_float64_matches_reference_exactly_in_mask(dev64, rng):
    x, r, amp, st_, ct, maxc = random_clusters(rng, [30, 7, 1, 45])
    got = dev64.intersect_circles(x, r, amp, st_, ct, maxc, 0.1)
    want = ref.intersect_circles(x, r, amp, st_, ct, maxc, 0.1)
    np.testing.assert_array_equal(got[2], want[2])
    assert 0 < want[2].sum() < want[2].size  # both valid and invalid slots exercised
    # same float64 formulas; only operation order/FMA contraction differ:
    # a few ulps of R (~1 m) -> 1e-12 m is ample.
    np.testing.assert_allclose(got[0], want[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(got[1], want[1], rtol=1e-12, atol=1e-15)


def test_intersect_float32_agrees_with_reference(dev32, rng):
    x, r, amp, st_, ct, maxc = random_clusters(rng, [40, 12, 25])
    got = dev32.intersect_circles(x, r, amp, st_, ct, maxc, 0.05)
    want = ref.intersect_circles(x, r, amp, st_, ct, maxc, 0.05)
    # masks may differ only where the float64 validity margin is within float32
    # rounding of the inputs (a few 1e-7 relative); elsewhere exactly equal.
    clear = margin(x, r, st_, ct, maxc) > 1e-5
    np.testing.assert_array_equal(got[2][clear], want[2][clear])
    both = (got[2] == 1) & (want[2] == 1) & clear
    # Error analysis: the inputs are rounded to float32 (eps = 6e-8 relative),
    # so x = (e*s + d^2) / (2d) carries an absolute error ~ eps * R * (R/|d|),
    # and y = sqrt(R^2 - x^2) amplifies an x error by |x|/y.  A factor 20 covers
    # the handful of roundings in each formula.
    eps = np.finfo(np.float32).eps
    j = np.minimum(st_[:, None] + np.arange(maxc), x.size - 1)
    with np.errstate(divide="ignore"):
        cond = r[:, None] / np.abs(x[j] - x[:, None])
    cx, cy = want[0][0][both], want[0][1][both]
    tol_x = 20 * eps * r.max() * (1 + cond[both])
    tol_y = tol_x * (1 + np.abs(cx) / cy)
    assert np.all(np.abs(got[0][0][both] - cx) <= tol_x)
    assert np.all(np.abs(got[0][1][both] - cy) <= tol_y)
    assert np.all(np.isfinite(got[0])) and np.all(np.isfinite(got[1]))


@pytest.mark.parametrize("dim", [2, 3])
def test_score_matches_reference(dev32, dev64, rng, dim):
    n, maxc = 17, 23
    cand = rng.normal(0, 0.05, (dim, n, maxc))
    w = rng.uniform(0, 1, (n, maxc))
    valid = (rng.random((n, maxc)) < 0.7).astype(np.int8)
    w[valid == 0] = 0.0
    want = ref.score_candidates(cand, w, valid, 0.03)
    np.testing.assert_allclose(
        dev64.score_candidates(cand, w, valid, 0.03), want, rtol=1e-12, atol=1e-12
    )
    # float32: each term has relative error ~1e-6 (exp of an argument <= ~30
    # with 6e-8 relative rounding), sums of <= 23 positive terms.
    np.testing.assert_allclose(
        dev32.score_candidates(cand, w, valid, 0.03), want, rtol=1e-4, atol=1e-6
    )
    assert np.all(want[valid == 0] == -1)


def test_score_gaussian_over_its_whole_range(dev32, dev64):
    # One weighted neighbour at distance d from a zero-weight candidate: the
    # score is exactly exp(-d^2 / 2 sigma^2).  d runs from 0 to 60 sigma, so
    # the kernel's inline 2^x meets every reduced argument, the normal range
    # down to 2^-126 (float32) and the underflow to 0 beyond it.
    sigma, n = 0.03, 4001
    d = np.linspace(0.0, 60 * sigma, n)
    cand = np.zeros((3, n, 2))
    cand[0, :, 1] = d / np.sqrt(2)
    cand[2, :, 1] = d / np.sqrt(2)
    w = np.zeros((n, 2))
    w[:, 1] = 1.0
    valid = np.ones((n, 2), np.int8)
    want = np.exp(-(d**2) / (2 * sigma**2))
    got64 = dev64.score_candidates(cand, w, valid, sigma)[:, 0]
    np.testing.assert_allclose(got64, want, rtol=1e-12, atol=1e-300)
    got32 = dev32.score_candidates(cand, w, valid, sigma)[:, 0]
    tiny = np.finfo(np.float32).tiny
    normal = want >= tiny
    # the argument -d^2/2sigma^2 carries float32 rounding of |arg| * 6e-8
    arg = d**2 / (2 * sigma**2)
    rel = np.abs(got32[normal] - want[normal]) / want[normal]
    assert np.all(rel <= 4e-7 + 2 * arg[normal] * np.finfo(np.float32).eps)
    assert np.all(got32[~normal] <= 2 * tiny) and np.all(got32 >= 0)
    assert np.all(np.isfinite(got32)) and np.all(np.isfinite(got64))


def test_argmax_matches_reference(dev32, dev64, rng):
    n, maxc = 40, 31
    score = rng.uniform(0, 1, (n, maxc))
    score[rng.random((n, maxc)) < 0.3] = -1.0
    score[5] = -1.0  # a row with no valid candidate
    score[6, :] = 0.5  # ties -> lowest index
    cand = rng.normal(size=(2, n, maxc))
    want = ref.argmax_candidates(score, cand)
    for dev in (dev32, dev64):
        got = dev.argmax_candidates(score.astype(dev.dtype), cand)
        # float32 rounding of distinct uniform scores cannot reorder them
        # unless two are within 6e-8; with 31 values that has probability ~1e-5.
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_allclose(got[1], want[1], rtol=1e-6)
        np.testing.assert_allclose(got[2], want[2], rtol=1e-6)
    assert want[0][5] == -1 and want[0][6] == 0


def test_rpm_chain_matches_reference(dev32, dev64, rng):
    x, r, amp, st_, ct, maxc = random_clusters(rng, [21, 21, 21], dup_antennas=False)
    want = ref.rpm_circles(x, r, amp, st_, ct, maxc, 0.1, 0.05)
    got64 = dev64.rpm_circles(x, r, amp, st_, ct, maxc, 0.1, 0.05)
    np.testing.assert_array_equal(got64[0], want[0])
    np.testing.assert_allclose(got64[2], want[2], atol=1e-10)
    got32 = dev32.rpm_circles(x, r, amp, st_, ct, maxc, 0.1, 0.05)
    # float32 may pick another candidate on a near-tie; then the score it
    # found must equal the best within float32 tolerance.
    scores = ref.score_candidates(*ref.intersect_circles(x, r, amp, st_, ct, maxc, 0.1), 0.05)
    picked = scores[np.arange(x.size), np.maximum(got32[0], 0)]
    ok = want[0] >= 0
    np.testing.assert_array_equal(got32[0] >= 0, ok)
    np.testing.assert_allclose(picked[ok], want[1][ok], rtol=1e-4)


def test_degenerate_pairs_are_skipped_never_nan(dev32, dev64):
    # main RP 0 at x=0, R=1; partners: same antenna, external tangent,
    # internal tangent, disjoint, nested, and one proper intersection.
    x = np.array([0.0, 0.0, 0.5, 0.5, 3.0, 0.1, 0.3])
    r = np.array([1.0, 0.7, 0.5, 1.5, 1.0, 0.2, 1.0])
    amp = np.ones_like(x)
    st_ = np.zeros(7, int)
    ct = np.full(7, 7)
    for engine in (ref, dev32, dev64):
        cand, w, valid = engine.intersect_circles(x, r, amp, st_, ct, 7, 0.1)
        assert np.all(np.isfinite(cand)) and np.all(np.isfinite(w))
        np.testing.assert_array_equal(valid[0], [0, 0, 0, 0, 0, 0, 1])
        assert np.all(cand[:, valid == 0] == 0) and np.all(w[valid == 0] == 0)


def test_single_rp_cluster_and_empty_input(dev32):
    got = dev32.rpm_circles(
        np.array([0.0]),
        np.array([1.0]),
        np.array([1.0]),
        np.array([0]),
        np.array([1]),
        1,
        0.1,
        0.05,
    )
    assert got[0].tolist() == [-1]
    got = dev32.rpm_circles(
        np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0, int), np.zeros(0, int), 1, 0.1, 0.05
    )
    assert got[0].shape == (0,)


coord = st.floats(-0.5, 0.5, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(
    px=coord,
    py=st.floats(0.05, 20.0),
    xi=coord,
    dx=st.floats(5e-4, 0.05),
    sign=st.sampled_from([-1.0, 1.0]),
)
@example(px=0.0, py=20.0, xi=0.0, dx=5e-4, sign=1.0)  # far and narrow: worst conditioning
def test_round_trip_recovers_scatterer(px, py, xi, dx, sign):
    """Exact ranges from two antennas to a scatterer intersect at it."""
    xj = xi + sign * dx
    ri, rj = np.hypot(px - xi, py), np.hypot(px - xj, py)
    cand, _w, valid = ref.intersect_circles(
        np.array([xi, xj]), np.array([ri, rj]), np.ones(2), np.zeros(2, int), np.full(2, 2), 2, 0.1
    )
    assert valid[0, 1] == 1
    # backward error: float64 rounding of the ranges (~1e-16 R) amplified by
    # the geometry's conditioning (R/|d|)^2 at worst.
    tol = 1e-13 * (py / dx) ** 2 + 1e-12
    assert abs(xi + cand[0, 0, 1] - px) <= tol * max(1.0, py)
    assert abs(cand[1, 0, 1] - py) <= tol * max(1.0, py)
