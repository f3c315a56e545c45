"""The coherent sum at points (rpm_cl.extract.backprojection) and phase-rpm's
coherence test of its points (rpm_cl.rpm.coherence)."""

import numpy as np
import pytest

from rpm_cl.baselines.das import Grid, das_numpy
from rpm_cl.extract.backprojection import at_points
from rpm_cl.io.data import C0, Array, InputError, RadarData, Waveform
from rpm_cl.rpm.coherence import coherent_keep, crossrange_resolution
from rpm_cl.rpm.params import ImagingParams, default_params
from rpm_cl.simulate import simulate
from rpm_cl.simulate.scene import PointTarget, Scene


def _random_data(rng, planar):
    x = (np.arange(9) - 4) * 6e-3
    z = (np.arange(4) - 1.5) * 6e-3 if planar else None
    arr = Array(x, z)
    r = 0.25 + 2e-3 * np.arange(150)
    sig = rng.normal(size=arr.shape + (r.size,)) + 1j * rng.normal(size=arr.shape + (r.size,))
    return RadarData(sig, arr, r, Waveform(18e9, 2e9))


def _loop_sum(data, p):
    """I(p) written out antenna by antenna: np.interp of the real and
    imaginary profiles at |p - a|, times exp(+j 2 k_c |p - a|)."""
    pos = data.array.positions()
    sig = data.signal.reshape(-1, data.range.size)
    k2 = 4 * np.pi * data.waveform.fc / C0
    pz = p[2] if data.array.planar else 0.0
    total = 0j
    for a, s in zip(pos, sig):
        az = a[2] if data.array.planar else 0.0
        d = np.sqrt((p[0] - a[0]) ** 2 + p[1] ** 2 + (pz - az) ** 2)
        v = np.interp(d, data.range, s.real, 0, 0) + 1j * np.interp(d, data.range, s.imag, 0, 0)
        total += v * np.exp(1j * k2 * d)
    return total


@pytest.mark.parametrize("planar", [False, True])
def test_sum_at_points_matches_the_written_out_sum_and_das(planar):
    rng = np.random.default_rng(11)
    data = _random_data(rng, planar)
    n = 40
    pts = np.column_stack(
        [rng.uniform(-0.05, 0.05, n), rng.uniform(0.27, 0.5, n)]
        + ([rng.uniform(-0.03, 0.03, n)] if planar else [])
    )
    got = at_points(data, pts, memory_budget=1e4)  # several chunks
    want = np.array([_loop_sum(data, p) for p in pts])
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-10 * np.abs(want).max())
    g = Grid(pts[:3, 0], pts[:3, 1], pts[:3, 2] if planar else None)
    img = das_numpy(data, g)
    i = np.arange(3)
    diag = img[i, i, i] if planar else img[i, i]
    np.testing.assert_allclose(at_points(data, pts[:3]), diag, rtol=1e-12)


def test_sum_at_points_wants_the_array_s_dimension():
    data = _random_data(np.random.default_rng(1), False)
    with pytest.raises(InputError, match="shape"):
        at_points(data, np.zeros((4, 3)))


def test_crossrange_resolution_by_hand():
    x = np.linspace(-0.5, 0.5, 101)
    lam = C0 / 10e9
    # seen from (0, 0.5) the ends are at 45 deg: sin spans 2 sin 45
    got = crossrange_resolution(x, np.array([[0.0, 0.5]]), 10e9, 90.0)
    assert got[0] == pytest.approx(lam / (2 * 2 * np.sin(np.pi / 4)), rel=1e-9)
    # a 30 deg reach keeps the antennas with |sin| <= 0.5: the spread is that
    # of the outermost such antennas
    p = np.array([[0.0, 0.5]])
    s = x / np.hypot(x, 0.5)
    s = s[np.abs(s) <= 0.5]
    got = crossrange_resolution(x, p, 10e9, 30.0)
    assert got[0] == pytest.approx(lam / (2 * (s.max() - s.min())), rel=1e-9)
    # off to one side: only one side's antennas, a coarser resolution
    side = crossrange_resolution(x, np.array([[0.9, 0.5]]), 10e9, 90.0)
    assert side[0] > 2 * got[0]
    # only the antennas that saw the point count: x in [-0.1, 0.2]
    few = crossrange_resolution(x, p, 10e9, 90.0, seen=np.array([[-0.1, 0.2]]))
    s = x[(x >= -0.1) & (x <= 0.2)] / np.hypot(x[(x >= -0.1) & (x <= 0.2)], 0.5)
    assert few[0] == pytest.approx(lam / (2 * (s.max() - s.min())), rel=1e-9)


def _two_targets(snr=None):
    """A strong and a 12 dB weaker point 0.3 m down under a 1.3 m line at
    2 cm, 1.5 GHz with 1 GHz of band (cross-range resolution ~45 mm)."""
    targets = np.array([[-0.2, 0.3], [0.15, 0.32]])
    scene = Scene((PointTarget(targets[0]), PointTarget(targets[1], amplitude=0.25)))
    xs = (np.arange(66) - 32.5) * 0.02
    data = simulate(scene, Array(xs), Waveform(1.5e9, 1e9), np.arange(0, 1.2, 5e-3), snr, 3)
    return data, targets


@pytest.mark.parametrize("snr", [None, 20.0])
def test_points_on_targets_are_kept_and_beside_them_dropped(snr):
    data, targets = _two_targets(snr)
    dx = crossrange_resolution(data.array.x, targets, data.waveform.fc, 70.0)
    # on each target, 0.2 resolutions off it, and one resolution beside it
    # at its depth (where a point that slid along its range circle lands)
    on = np.vstack([targets, targets + np.column_stack([0.2 * dx, 0 * dx])])
    beside = np.vstack(
        [targets + np.column_stack([dx, 0 * dx]), targets - np.column_stack([dx, 0 * dx])]
    )
    keep = coherent_keep(data, np.vstack([on, beside]), -6.0, 70.0)
    assert keep[: len(on)].all()
    assert not keep[len(on) :].any()


def test_a_laxer_threshold_keeps_more():
    data, targets = _two_targets()
    dx = crossrange_resolution(data.array.x, targets, data.waveform.fc, 70.0)
    pts = targets[:1] + np.outer(np.linspace(0, 1.2, 13), [dx[0], 0.0])
    n = [int(coherent_keep(data, pts, t, 70.0).sum()) for t in (-1.0, -6.0, -20.0)]
    assert 1 <= n[0] < n[1] < n[2]


def test_threshold_is_checked():
    for bad in (0.0, 1.0, -61.0, float("nan")):
        with pytest.raises(InputError, match="coherence_db"):
            ImagingParams(coherence_db=bad)


# ------------------------------------------------------------- phase-rpm
BARS = np.array([(-0.7 + 0.2 * i, 0.27 + 0.03 * ((i * 7) % 3)) for i in range(8)])


@pytest.fixture(scope="module")
def bars_data():
    """Eight points 0.2 m apart, 0.27-0.33 m down, under 100 positions at
    2.13 cm with 0.98-2 GHz: a rebar mat's B-scan in electrical range,
    whose neighbouring bars share the 0.15 m range resolution."""
    scene = Scene(tuple(PointTarget(p) for p in BARS))
    xs = (np.arange(100) - 49.5) * 0.0213
    return simulate(scene, Array(xs), Waveform(1.49e9, 1.02e9), np.arange(0, 1.5, 5e-3), 20.0, 0)


def _scored(data, dev32, **over):
    from rpm_cl.imaging import run_method

    res = run_method("phase-rpm", data, default_params(data, **over), dev32)
    d = np.linalg.norm(res.image.points[:, None] - BARS[None], axis=2)
    return float(np.mean(d.min(axis=1) <= 0.03)), int(np.sum(d.min(axis=0) <= 0.03)), res


def test_phase_rpm_keeps_the_points_on_the_bars(bars_data, dev32):
    """Without the test about a third of phase-rpm's points sit beside the
    bars; with it at least 85 % lie within 30 mm of one, and every bar
    keeps a point."""
    share, hit, res = _scored(bars_data, dev32)
    off_share, off_hit, off = _scored(bars_data, dev32, coherence=False)
    assert share >= 0.85 and hit == len(BARS)
    assert off_share < 0.75 and off_hit == len(BARS)
    assert res.dropped["coherence"] > 0 and off.dropped["coherence"] == 0
    # the same RPs make the same RPM points, which the filters share out
    assert len(res.image.points) + sum(res.dropped.values()) == len(off.image.points) + sum(
        off.dropped.values()
    )


def test_a_peak_no_point_marks_keeps_the_points_beside_it():
    """Points beside the weak target only: with no point on its peak they
    stay (they are all the image says about it); with one on it they go."""
    data, targets = _two_targets()
    dx = crossrange_resolution(data.array.x, targets, data.waveform.fc, 70.0)
    beside = targets[1] + np.array([[dx[1], 0.0], [-dx[1], 0.0]])
    strong = targets[:1]
    assert coherent_keep(data, np.vstack([strong, beside]), -6.0, 70.0).all()
    keep = coherent_keep(data, np.vstack([strong, targets[1:], beside]), -6.0, 70.0)
    np.testing.assert_array_equal(keep, [True, True, False, False])


def test_narrow_band_data_are_left_alone(dev32):
    """0.2 GHz at 20 GHz (1 % of the carrier): the DAS image's side lobes are
    peaks of their own, and phase-rpm drops nothing by this test."""
    from rpm_cl.imaging import run_method

    scene = Scene((PointTarget((-0.05, 0.4)), PointTarget((0.1, 0.5))))
    x = (np.arange(41) - 20) * 0.02
    data = simulate(scene, Array(x), Waveform(20e9, 0.2e9), np.arange(0, 1.5, 2.5e-3), 30.0, 1)
    res = run_method("phase-rpm", data, default_params(data), dev32)
    assert res.dropped["coherence"] == 0 and len(res.image.points) > 40


def test_recorded_data_undoes_the_paraxial_scene():
    from rpm_cl.io.medium import Medium, paraxial_data, recorded_data

    data = _random_data(np.random.default_rng(5), False)
    m = Medium(6.0, 0.08)
    back = recorded_data(paraxial_data(data, m), m)
    np.testing.assert_allclose(back.signal, data.signal, rtol=1e-6)
    np.testing.assert_allclose(back.range, data.range, rtol=1e-12)
    assert back.waveform.fc == pytest.approx(data.waveform.fc, rel=1e-12)
    assert back.waveform.bandwidth == pytest.approx(data.waveform.bandwidth, rel=1e-12)
    assert recorded_data(data, Medium(6.0)) is data


def test_sum_at_points_follows_the_refracted_paths():
    """Above a half-space the sum at a point equals DAS's refracted image
    there, and differs from the straight-line sum."""
    from rpm_cl.io.medium import Medium

    rng = np.random.default_rng(8)
    data = _random_data(rng, False)
    m = Medium(4.0, 0.05)
    g = Grid(np.array([-0.02, 0.01, 0.03]), np.array([0.12, 0.15, 0.2]))
    img = das_numpy(data, g, medium=m)
    i = np.arange(3)
    pts = np.column_stack([g.x, g.y])
    got = at_points(data, pts, medium=m)
    np.testing.assert_allclose(got, img[i, i], rtol=1e-12)
    assert np.abs(got - at_points(data, pts)).max() > 0.1 * np.abs(got).max()


def test_sum_at_points_on_a_long_line_leaves_out_only_silent_antennas():
    """A 3 m line whose range axis ends at 0.6 m: each point is summed over
    the antennas within 0.6 m of it only (the others' ranges lie beyond the
    axis), which must give the written-out sum over every antenna."""
    rng = np.random.default_rng(17)
    x = np.linspace(-1.5, 1.5, 60)
    r = 0.05 + 5e-3 * np.arange(110)  # to 0.595 m
    sig = rng.normal(size=(60, r.size)) + 1j * rng.normal(size=(60, r.size))
    data = RadarData(sig, Array(x), r, Waveform(2e9, 1e9))
    pts = np.column_stack([rng.uniform(-1.6, 1.6, 50), rng.uniform(0.1, 0.5, 50)])
    got = at_points(data, pts, memory_budget=2e4)  # several chunks
    want = np.array([_loop_sum(data, p) for p in pts])
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-10 * np.abs(want).max())


# ------------------------------------------------------ on the device
@pytest.mark.parametrize("planar", [False, True])
@pytest.mark.parametrize("kc_dr", [0.1, 1.09, 1.4])
def test_device_sum_at_points_matches_numpy(cl_env, rng, planar, kc_dr):
    """The ``das_points`` kernel (float64) against its NumPy reference,
    ``at_points``, to 1e-12 of the largest sum, on fresh random profiles and
    points at k_c dr either side of 1.1: 23 antennas (not a
    whole number of vector lanes), points beside and beyond the line, some
    off the range axis at both ends; on the line the range axis ends short
    of the far antennas, so each point sums only those within reach."""
    from rpm_cl.extract.backprojection_cl import device_for

    dev = device_for(cl_env)
    if dev is None:
        pytest.skip("device has no float64")
    x = (np.arange(23) - 11) * 0.02 + rng.uniform(-0.01, 0.01)
    z = (np.arange(5) - 2) * 0.02 if planar else None
    arr = Array(x, z)
    r = 0.1 + 2e-3 * np.arange(120)  # to 0.34 m: the line is 0.44 m long
    sig = rng.normal(size=arr.shape + (r.size,)) + 1j * rng.normal(size=arr.shape + (r.size,))
    # k_c dr either side of the DAS kernel's polynomial limit, 1.1
    fc = kc_dr * C0 / (2 * np.pi * 2e-3)
    data = RadarData(sig, arr, r, Waveform(fc, 0.1 * fc))
    n = 3000
    pts = np.column_stack(
        [rng.uniform(-0.5, 0.5, n), rng.uniform(0.01, 0.4, n)]
        + ([rng.uniform(-0.1, 0.1, n)] if planar else [])
    )
    want = at_points(data, pts)
    got = dev.at_points(data, pts)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())
    assert np.abs(want).min() == 0  # some points lie off the axis: nothing is read there
    np.testing.assert_array_equal(got[want == 0], 0)
    with pytest.raises(InputError, match="shape"):
        dev.at_points(data, np.zeros((4, 4)))


def test_the_device_sums_keep_the_same_points(bars_data, dev32):
    """phase-rpm's coherence test with the sums on the device (float64) and
    on the host drops the same points of the bars' image."""
    from rpm_cl.imaging import run_method
    from rpm_cl.rpm.methods import device_sums

    if not dev32.env.has_double:
        pytest.skip("device has no float64")
    params = default_params(bars_data, coherence=False, multipath="flag")
    res = run_method("phase-rpm", bars_data, params, dev32)
    pts = res.image.points
    host = coherent_keep(bars_data, pts, -6.0, 70.0)
    dev = coherent_keep(bars_data, pts, -6.0, 70.0, sums=device_sums(dev32))
    np.testing.assert_array_equal(dev, host)
    assert 0 < host.sum() < host.size


def test_the_sorted_crossrange_search_matches_every_antenna_tried(rng):
    """On an increasing line with points in front, the span of sin t comes
    from bisection (O(M log A)); it equals, bit for bit, the span over every
    antenna, on random lines, reaches (beyond 90 degrees too) and seen
    ranges, with points whose reach lands on an antenna and seen ranges of
    a single antenna."""
    from rpm_cl.rpm.coherence import _sine_span, _sine_span_sorted

    for trial in range(60):
        n = int(rng.integers(2, 300))
        x = np.sort(rng.choice(np.arange(4000) * 0.01, n, replace=False)) - 20
        m = 150
        pts = np.column_stack([rng.uniform(-30, 30, m), rng.uniform(0.01, 10, m)])
        reach = float(rng.choice([30.0, 60.0, 70.0, 89.9, 90.0, 120.0]))
        on = rng.integers(0, n, 40)  # the reach's right end, then its left, on an antenna
        edge = np.tan(np.radians(min(reach, 89.0))) * pts[:40, 1]
        pts[:40, 0] = x[on] + np.where(np.arange(40) < 20, -edge, edge)
        seen = None
        if trial % 2:
            lo = rng.uniform(-25, 25, m)
            seen = np.column_stack([lo, lo + rng.uniform(0, 10, m)])
            seen[:10] = np.column_stack([x[on[:10]], x[on[:10]]])
        c = np.sin(np.radians(min(reach, 90.0)))
        want = _sine_span(x, pts, c, seen)
        got = _sine_span_sorted(x, pts, c, reach, seen)
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])


def test_marked_decides_as_the_k_d_tree(monkeypatch, rng):
    """``marked`` (bisection on x, pairs tested in passes) says what a k-d
    tree's nearest distance says, on random places, marks and radii, with
    marks at exactly a place's radius, in one pass or many, and through its
    own k-d tree where the pairs are too many."""
    from scipy.spatial import cKDTree

    from rpm_cl.rpm import coherence

    for trial in range(40):
        q = int(rng.integers(1, 400))
        marks = rng.uniform(-2, 2, (q, 2)) * [1.0, 0.2]
        if trial % 4 == 0:
            marks[:, 0] = np.round(marks[:, 0], 1)  # many equal x
        places = rng.uniform(-2.5, 2.5, (300, 2)) * [1.0, 0.2]
        radius = rng.uniform(0, 0.5, 300) ** 2
        # some places with a mark at exactly their radius
        pick = rng.integers(0, q, 30)
        places[20:30, 1] = marks[pick[20:30], 1]  # ten of them straight beside it in x
        d = marks[pick] - places[:30]
        radius[:30] = np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1])
        want = ~(cKDTree(marks).query(places)[0] > radius)
        assert want[:30].all()
        np.testing.assert_array_equal(coherence.marked(places, marks, radius), want)
        monkeypatch.setattr(coherence, "MARK_PAIRS", int(rng.integers(1, 50)))
        np.testing.assert_array_equal(coherence.marked(places, marks, radius), want)
        monkeypatch.setattr(coherence, "MARK_PAIRS_TREE", 0)
        np.testing.assert_array_equal(coherence.marked(places, marks, radius), want)
        monkeypatch.undo()
