"""3-D RPM: sphere-triplet kernel against its float64 reference, neighbour lists."""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from rpm_cl.rpm import reference as ref
from rpm_cl.rpm.neighbours import neighbour_lists

EPS32 = float(np.finfo(np.float32).eps)


def planar_cluster(rng, sizes, span=0.1, noise=1e-3, dup=True):
    """RPs of random scatterers seen from random antennas on the y = 0 plane.

    Ranges are the exact distances plus Gaussian noise (so most triplets
    intersect, some do not); with ``dup`` some RPs share an antenna.
    Returns x, z, r, amp, antenna, cstart, ccount.
    """
    xs, zs, rs, ants = [], [], [], []
    a0 = 0
    for m in sizes:
        p = np.array([rng.uniform(-0.3, 0.3), rng.uniform(0.3, 1.5), rng.uniform(-0.3, 0.3)])
        x = rng.uniform(-span / 2, span / 2, m)
        z = rng.uniform(-span / 2, span / 2, m)
        ant = a0 + np.arange(m)
        if dup:
            same = rng.random(m) < 0.15
            x[same], z[same], ant[same] = x[0], z[0], ant[0]
        r = np.sqrt((p[0] - x) ** 2 + p[1] ** 2 + (p[2] - z) ** 2) + rng.normal(0, noise, m)
        xs.append(x), zs.append(z), rs.append(r), ants.append(ant)
        a0 += m
    sizes = np.asarray(sizes)
    starts = np.repeat(np.cumsum(np.r_[0, sizes[:-1]]), sizes)
    counts = np.repeat(sizes, sizes)
    x, z, r, ant = (np.concatenate(v) for v in (xs, zs, rs, ants))
    amp = rng.uniform(0.1, 2.0, x.size)
    return x, z, r, amp, ant, starts, counts


def lists(x, z, ant, starts, counts, kmax=9):
    return neighbour_lists(x, z, ant, starts, counts, np.inf, kmax)


def test_pair_table_colex_prefix_property():
    for kmax in (2, 3, 7, 32):
        pa, pb = ref.pair_table(kmax)
        assert pa.size == kmax * (kmax - 1) // 2
        assert np.all(pa < pb) and np.all(pb < kmax)
        assert len(set(zip(pa.tolist(), pb.tolist()))) == pa.size  # every pair once
        for m in range(2, kmax + 1):  # the first m(m-1)/2 slots are the pairs below m
            k = m * (m - 1) // 2
            assert pb[:k].max() == m - 1 and (k == pa.size or pb[k] == m)


def test_neighbour_lists_respect_cluster_antenna_radius_and_order(rng):
    x, z, _r, _amp, ant, starts, counts = planar_cluster(rng, [30, 25])
    radius, kmax = 0.04, 12
    nbr, nn = neighbour_lists(x, z, ant, starts, counts, radius, kmax)
    for i in range(x.size):
        lst = nbr[i, : nn[i]]
        d = np.hypot(x[lst] - x[i], z[lst] - z[i])
        assert np.all((lst >= starts[i]) & (lst < starts[i] + counts[i]))
        assert np.all(ant[lst] != ant[i]) and np.all(d <= radius)
        assert np.all(np.diff(d) >= 0)  # nearest first
        lo, hi = starts[i], starts[i] + counts[i]
        dall = np.hypot(x[lo:hi] - x[i], z[lo:hi] - z[i])
        eligible = np.sum((ant[lo:hi] != ant[i]) & (dall <= radius))
        assert nn[i] == min(kmax, eligible)
        assert np.all(nbr[i, nn[i] :] == -1)


def test_intersect_float64_matches_reference(dev64, rng):
    x, z, r, amp, ant, st_, ct = planar_cluster(rng, [12, 9, 15])
    nbr, nn = lists(x, z, ant, st_, ct)
    want = ref.intersect_spheres(x, z, r, amp, nbr, nn, 0.03)
    got = dev64.intersect_spheres(x, z, r, amp, nbr, nn, 0.03)
    assert want[2].any() and not want[2].all()  # both kinds of slot occur
    np.testing.assert_array_equal(got[2], want[2])
    np.testing.assert_allclose(got[0], want[0], rtol=1e-9, atol=1e-11)
    np.testing.assert_allclose(got[1], want[1], rtol=1e-12, atol=1e-14)


def test_intersect_float32_agrees_with_reference(dev32, rng):
    x, z, r, amp, ant, st_, ct = planar_cluster(rng, [12, 9, 15])
    nbr, nn = lists(x, z, ant, st_, ct)
    want = ref.intersect_spheres(x, z, r, amp, nbr, nn, 0.03)
    got = dev32.intersect_spheres(x, z, r, amp, nbr, nn, 0.03)
    assert np.all(np.isfinite(got[0])) and np.all(np.isfinite(got[1]))
    # Error model: float32 ranges carry ~eps*R, so b = ((Ri-Rj)(Ri+Rj)+|a|^2)/2
    # carries ~2 eps R^2 and Cramer's rule divides it by det / |a|: the
    # in-plane error is ~ eps R^2 (|a_j| + |a_k|) / |det|; p_y inherits it
    # times rho / p_y.  Slots whose validity sits within that error of a
    # threshold may flip; compare the others.
    pa, pb = ref.pair_table(nbr.shape[1])
    i = np.arange(x.size)[:, None]
    inr = pb[None, :] < nn[:, None]
    j = np.where(inr, nbr[i, pa], i)
    k = np.where(inr, nbr[i, pb], i)
    ajx, ajz, akx, akz = x[j] - x[i], z[j] - z[i], x[k] - x[i], z[k] - z[i]
    nj, nk = np.hypot(ajx, ajz), np.hypot(akx, akz)
    det = np.abs(ajx * akz - ajz * akx)
    R = r[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        err_p = 50 * EPS32 * R**2 * (nj + nk) / det + 50 * EPS32 * R
        rho = np.hypot(want[0][0], want[0][2])
        clear = inr & (det > 2 * ref.EPS_DET * nj * nk) & (np.abs(R - rho) > 4 * err_p)
    both = clear & (want[2] == 1)
    assert both.sum() > 50
    np.testing.assert_array_equal(got[2][clear], want[2][clear])
    for plane in (0, 2):
        assert np.all(np.abs(got[0][plane][both] - want[0][plane][both]) <= err_p[both])
    tol_y = err_p * (1 + rho / np.maximum(want[0][1], 1e-30))
    assert np.all(np.abs(got[0][1][both] - want[0][1][both]) <= tol_y[both])
    np.testing.assert_allclose(got[1][both], want[1][both], rtol=1e-5)


def test_rpm_spheres_chain_matches_reference(dev32, dev64, rng):
    x, z, r, amp, ant, st_, ct = planar_cluster(rng, [14, 14], dup=False)
    nbr, nn = lists(x, z, ant, st_, ct)
    want = ref.rpm_spheres(x, z, r, amp, nbr, nn, 0.03, 0.02)
    got64 = dev64.rpm_spheres(x, z, r, amp, nbr, nn, 0.03, 0.02)
    np.testing.assert_array_equal(got64[0], want[0])
    np.testing.assert_allclose(got64[2], want[2], atol=1e-9)
    got32 = dev32.rpm_spheres(x, z, r, amp, nbr, nn, 0.03, 0.02)
    # float32 may pick another candidate on a near-tie: its float64 score must
    # then equal the best within float32 accumulation error.
    scores = ref.score_candidates(*ref.intersect_spheres(x, z, r, amp, nbr, nn, 0.03), 0.02)
    ok = want[0] >= 0
    assert ok.sum() > 20
    np.testing.assert_array_equal(got32[0] >= 0, ok)
    picked = scores[np.arange(x.size), np.maximum(got32[0], 0)]
    np.testing.assert_allclose(picked[ok], want[1][ok], rtol=1e-4)


def test_degenerate_triplets_are_skipped_never_nan(dev32, dev64):
    # main RP 0 at the origin, R = 1; sub RPs: 1, 2 collinear with it (along
    # x), 3 at the main antenna itself, 4 too far to intersect, 5 and 6 a
    # proper triangle.
    x = np.array([0.0, 0.01, 0.02, 0.0, 3.0, 0.0, 0.01])
    z = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.01, 0.01])
    p = np.array([0.05, 0.9, 0.02])
    r = np.sqrt((p[0] - x) ** 2 + p[1] ** 2 + (p[2] - z) ** 2)
    r[4] = 1.0
    nbr = np.array([[1, 2, 3, 4, 5, 6]] + [[-1] * 6] * 6)
    nn = np.array([6, 0, 0, 0, 0, 0, 0])
    amp = np.ones_like(x)
    pa, pb = ref.pair_table(6)
    pairs = {(int(a) + 1, int(b) + 1): s for s, (a, b) in enumerate(zip(pa, pb))}
    for engine in (ref, dev32, dev64):
        cand, w, valid = engine.intersect_spheres(x, z, r, amp, nbr, nn, 0.03)
        assert np.all(np.isfinite(cand)) and np.all(np.isfinite(w))
        assert valid[0, pairs[(1, 2)]] == 0  # collinear
        assert all(valid[0, pairs[tuple(sorted((3, o)))]] == 0 for o in (1, 2, 4, 5, 6))
        assert valid[0, pairs[(4, 5)]] == 0  # no real intersection
        assert valid[0, pairs[(5, 6)]] == 1
        np.testing.assert_allclose(cand[:, 0, pairs[(5, 6)]], p, atol=1e-5)
        assert np.all(cand[:, valid == 0] == 0) and np.all(w[valid == 0] == 0)
        assert not valid[1:].any()


def test_tangent_triplet_is_skipped():
    # spheres of antennas (0,0), (d,0), (0,d) all tangent to the plane y = 0
    # at the same point on the array: R_i = rho exactly -> p_y = 0: skipped.
    d = 0.01
    x = np.array([0.0, d, 0.0])
    z = np.array([0.0, 0.0, d])
    p = np.array([0.5, 0.0, 0.5])  # in the array plane: y = 0, tangent case
    r = np.sqrt((p[0] - x) ** 2 + (p[2] - z) ** 2)
    cand, _w, valid = ref.intersect_spheres(
        x, z, r, np.ones(3), np.array([[1, 2]] * 3), np.array([2, 2, 2]), 0.03
    )
    assert valid[0, 0] == 0 and np.all(np.isfinite(cand))


coord = st.floats(-0.5, 0.5, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(
    px=coord,
    py=st.floats(0.05, 20.0),
    pz=coord,
    dx=st.floats(5e-4, 0.05),
    dz=st.floats(5e-4, 0.05),
    ang=st.floats(0.2, 2.9),
)
@example(px=0.0, py=20.0, pz=0.0, dx=5e-4, dz=5e-4, ang=1.5)  # far and tiny: worst case
def test_round_trip_recovers_scatterer(px, py, pz, dx, dz, ang):
    """Exact ranges from three non-collinear antennas intersect at the scatterer."""
    x = np.array([0.0, dx, dz * np.cos(ang)])
    z = np.array([0.0, 0.0, dz * np.sin(ang)])
    r = np.sqrt((px - x) ** 2 + py**2 + (pz - z) ** 2)
    cand, _w, valid = ref.intersect_spheres(
        x, z, r, np.ones(3), np.array([[1, 2]] * 3), np.array([2, 2, 2]), 0.1
    )
    assert valid[0, 0] == 1
    # float64 rounding of R (~1e-16 R) amplified by R^2 / (baseline area).
    tol = 1e-14 * py**2 * (dx + dz) / (dx * dz * np.sin(ang)) + 1e-12
    np.testing.assert_allclose(cand[:, 0, 0], [px, py, pz], atol=tol * max(1.0, py))


def test_device_refuses_chunks_outside_the_arrays(dev32, rng):
    """The kernels have no bounds checks; the host must refuse what the
    reference would index out of range (a device read past the end can
    crash the process)."""
    from rpm_cl.io.data import InputError

    x, z, r, amp, ant, st_, ct = planar_cluster(rng, [10])
    nbr, nn = lists(x, z, ant, st_, ct)
    for kw in ({"i0": 8, "n": 50}, {"i0": -1, "n": 2}):
        with pytest.raises(InputError):
            dev32.rpm_spheres(x, z, r, amp, nbr, nn, 0.03, 0.02, **kw)
    with pytest.raises(InputError):
        dev32.rpm_spheres(x, z, r, amp, nbr + 100, nn, 0.03, 0.02)
    with pytest.raises(InputError):
        dev32.rpm_circles(x, r, amp, np.zeros(10, int), np.full(10, 15), 10, 0.1, 0.05)


def test_neighbour_lists_near_plus_spread(rng):
    """near + spread lists: the first entries are the nearest within the
    radius, the rest distinct RPs of the same cluster at other antennas,
    spread over the distance ranks up to the farthest."""
    x, z, _r, _amp, ant, st_, ct = planar_cluster(rng, [60, 40], dup=False)
    nbr, nn = neighbour_lists(x, z, ant, st_, ct, 0.03, 12, near=4)
    for i in range(x.size):
        lst = nbr[i, : nn[i]]
        lo, hi = st_[i], st_[i] + ct[i]
        assert len(set(lst.tolist())) == len(lst) and np.all((lst >= lo) & (lst < hi))
        assert np.all(ant[lst] != ant[i]) and nn[i] == min(12, ct[i] - 1)
        d = np.hypot(x[lst] - x[i], z[lst] - z[i])
        dall = np.sort(np.hypot(x[lo:hi] - x[i], z[lo:hi] - z[i]))[1:]  # without itself
        k = int(min(4, np.sum(dall <= 0.03)))
        np.testing.assert_allclose(d[:k], dall[:k])  # the nearest part
        assert d[-1] == pytest.approx(dall[-1])  # the spread part reaches the farthest


def test_neighbour_lists_per_cluster_length(rng):
    """A list length per cluster (the refined clusters' shorter lists): each
    cluster's lists are those of a call with its own length alone, padded
    with -1 to the longest."""
    x, z, _, _, ant, st_, ct = planar_cluster(rng, [30, 50, 20], dup=False)
    kmax = np.repeat([8, 16, 5], [30, 50, 20])
    nbr, nn = neighbour_lists(x, z, ant, st_, ct, 0.03, kmax, near=4)
    assert nbr.shape == (x.size, 16)
    for k in (8, 16, 5):
        rows = kmax == k
        want, wn = neighbour_lists(x, z, ant, st_, ct, 0.03, k, near=4)
        np.testing.assert_array_equal(nn[rows], wn[rows])
        np.testing.assert_array_equal(nbr[rows, : want.shape[1]], want[rows])
        assert np.all(nbr[rows, want.shape[1] :] == -1) and nn[rows].max() == k


def grid_cluster(rng, steps=(7.5e-3, 5e-3), shape=(9, 7), keep=0.7, origin=(0.0, 0.0)):
    """RPs at a random subset of a uniform grid's antennas, one antenna twice.

    Returns x, z (m), antenna, the integer grid offsets (ix, iz) and the
    steps in units of 0.5 mm (so that squared distances are exact integers).
    """
    gx, gz = np.meshgrid(np.arange(shape[0]), np.arange(shape[1]), indexing="ij")
    gx, gz = gx.ravel(), gz.ravel()
    sel = np.flatnonzero(rng.random(gx.size) < keep)
    sel = np.sort(np.r_[sel, sel[rng.integers(sel.size)]])  # a second RP at one antenna
    ix, iz = gx[sel], gz[sel]
    x = origin[0] + ix * steps[0]
    z = origin[1] + iz * steps[1]
    units = [round(s / 0.5e-3) for s in steps]
    return x, z, sel, ix, iz, units


@pytest.mark.parametrize("steps", [(7.5e-3, 7.5e-3), (7.5e-3, 5e-3)])
def test_grid_ranking_is_exact_distance_then_index(rng, steps):
    """On a uniform grid the RPs are ranked by their exact distance (integer
    squared offsets, so that equal distances such as offsets (3, 4) and
    (5, 0), or (2, 0) and (0, 3) at 7.5 / 5 mm, tie exactly) and then by
    index; RPs at the row's own antenna come last and are not eligible."""
    from rpm_cl.rpm.neighbours import _grid_offsets, _ranked_grid

    x, z, ant, ix, iz, (ux, uz) = grid_cluster(rng, steps)
    c = x.size
    grid = _grid_offsets(x, z)
    assert grid is not None
    radius = 3.2 * steps[0]
    same = ant[:, None] == ant[None, :]
    order, eligible, within = _ranked_grid(grid, same, 0, c, radius, np.arange(c))
    ties = 0
    for i in range(c):
        d2 = [(ux * (ix[j] - ix[i])) ** 2 + (uz * (iz[j] - iz[i])) ** 2 for j in range(c)]
        others = [j for j in range(c) if ant[j] != ant[i]]
        want = sorted(others, key=lambda j: (d2[j], j))
        ties += len(others) - len({d2[j] for j in others})
        assert order[i, : len(want)].tolist() == want
        assert eligible[i] == len(others)
        assert within[i] == sum(d2[j] * 0.25e-6 <= radius**2 for j in others)
    assert ties > 0  # the layout has ties to break


def test_grid_neighbour_lists_are_translation_invariant(rng):
    """The same grid layout anywhere in the plane gets the same lists (ties
    are broken by index, not by how the coordinates happen to round)."""
    x, z, ant, *_ = grid_cluster(rng, shape=(12, 10))
    n = x.size
    st_, ct = np.zeros(n, int), np.full(n, n)
    want = neighbour_lists(x, z, ant, st_, ct, 0.03, 12, near=4)
    for shift in ((0.3137, -1.2719), (-0.0371, 0.0123), (17.3, 4.1)):
        got = neighbour_lists(x + shift[0], z + shift[1], ant, st_, ct, 0.03, 12, near=4)
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])


def test_off_grid_antennas_take_the_float_ranking(rng):
    """Antennas off any uniform grid: no grid offsets, and the lists still
    hold the nearest RPs by distance."""
    from rpm_cl.rpm.neighbours import _grid_offsets

    x, z, *_ = planar_cluster(rng, [40], dup=False)
    assert _grid_offsets(x, z) is None
    xg, zg, antg, *_ = grid_cluster(rng)
    xg[3] += 1e-4 * np.sqrt(2)  # one antenna moved off the grid (by 1e-4 it is on a 0.1 mm one)
    assert _grid_offsets(xg, zg) is None
    nbr, nn = neighbour_lists(
        xg, zg, antg, np.zeros(xg.size, int), np.full(xg.size, xg.size), np.inf, 6
    )
    for i in range(xg.size):
        d = np.hypot(xg[nbr[i, : nn[i]]] - xg[i], zg[nbr[i, : nn[i]]] - zg[i])
        dall = np.sort(np.hypot(xg - xg[i], zg - zg[i])[antg != antg[i]])
        np.testing.assert_allclose(d, dall[:6])


@pytest.mark.parametrize("off_grid", [False, True])
@pytest.mark.parametrize("near", [None, 0, 2, 6])
def test_clusters_smaller_than_the_list(off_grid, near):
    """A cluster of fewer RPs than the list is long (a weak part seen by a
    few antennas) gives each RP the other RPs of its cluster, and only those.
    With ``near`` > 0 the ranking has one column per RP of the cluster and
    the list ``kmax`` (the two must not be broadcast together), and off the
    grid with an unbounded radius the float ranking must not count the RP
    itself as within (inf <= inf), which would make it its own sub-RP."""
    x = np.array([0.0, 7.5e-3, 15e-3, 0.0, 7.5e-3, 30e-3])
    z = np.array([0.0, 0.0, 0.0, 7.5e-3, 7.5e-3, 0.0])
    if off_grid:
        x[1] += 1e-4 * np.sqrt(2)
    start = np.array([0, 0, 0, 3, 3, 5])
    count = np.array([3, 3, 3, 2, 2, 1])
    nbr, nn = neighbour_lists(x, z, np.arange(6), start, count, np.inf, 8, near=near)
    for i in range(6):
        others = set(range(start[i], start[i] + count[i])) - {i}
        assert nn[i] == len(others)
        assert set(nbr[i, : nn[i]].tolist()) == others
        assert np.all(nbr[i, nn[i] :] == -1)


@pytest.mark.parametrize("off_grid", [False, True])
def test_large_clusters_thin_only_the_far_part(rng, monkeypatch, off_grid):
    """A cluster larger than THIN_ABOVE: the nearest part of every list is
    the exact one (from the RPs within the radius alone), and the far part
    holds distinct RPs of the cluster at other antennas, spread from near the
    nearest part out to the farthest ranks."""
    from rpm_cl.rpm import neighbours as NB

    gx, gz = np.meshgrid(np.arange(24), np.arange(20), indexing="ij")
    x, z = gx.ravel() * 7.5e-3, gz.ravel() * 7.5e-3
    if off_grid:
        x = x + rng.uniform(-1e-3, 1e-3, x.size)
    ant = np.arange(x.size)
    ant[5] = ant[4]  # two RPs at one antenna
    x[5], z[5] = x[4], z[4]
    c = x.size
    st_, ct = np.zeros(c, int), np.full(c, c)
    radius, kmax, near = 0.03, 16, 4
    exact, _ = NB.neighbour_lists(x, z, ant, st_, ct, radius, kmax, near)
    monkeypatch.setattr(NB, "THIN_ABOVE", 100)
    monkeypatch.setattr(NB, "FAR_SAMPLE", 100)
    thin, tn = NB.neighbour_lists(x, z, ant, st_, ct, radius, kmax, near)
    dall = np.hypot(x[:, None] - x[None, :], z[:, None] - z[None, :])
    reach = []
    for i in range(c):
        lst = thin[i, : tn[i]]
        np.testing.assert_array_equal(lst[:near], exact[i, :near])  # the nearest part
        assert len(set(lst.tolist())) == len(lst) and np.all(ant[lst] != ant[i])
        assert tn[i] >= kmax - 4  # a thinned RP may repeat a nearest one
        others = np.sort(dall[i, ant != ant[i]])
        rank = np.searchsorted(others, dall[i, lst[near:]], side="left") / (others.size - 1)
        reach.append((rank.min(), rank.max()))
    reach = np.array(reach)
    assert np.median(reach[:, 0]) < 0.1 and np.median(reach[:, 1]) > 0.9
