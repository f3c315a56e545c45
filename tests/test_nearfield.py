"""Near-field decomposition of sparse linear arrays (paper Section V-A4)."""

import numpy as np
import pytest

from rpm_cl.extract import nearfield
from rpm_cl.extract.kspace import KSpaceParams, decompose
from rpm_cl.extract.rangepoints import rps_from_decomposition
from rpm_cl.imaging import run_method
from rpm_cl.io.data import C0, Array, InputError, RadarData, Waveform
from rpm_cl.metrics import err_range, summary
from rpm_cl.rpm import reference
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import simulate, simulate_preset
from rpm_cl.simulate.scene import PointTarget, Scene, get_preset


def test_sparse_paper_2d_reaches_the_paper(dev32):
    """Acceptance: the sparse 20 mm case (Section V-A4, Fig. 12(c)).

    Measured: RP <= 10 mm 63/63, RPM <= 50 mm 63/63, <= 100 mm 63/63.  The
    floors are the paper's 87 % (55/63) and 94 %: the centres come from a
    discrete search (grid scans, a choice among map peaks) that can settle a
    grid step differently on another BLAS or device and move a few edge RPs
    (with a 3-term envelope instead of 4 the same search gives 61/63 and
    62/63), so 8 RPs and 6 % of points of margin; the RP count (one per
    antenna per target) catches a lost or split cluster outright.
    """
    data, pre = simulate_preset("paper-2d-sparse")
    res = run_method("kspace-rpm", data, default_params(data, **pre.defaults), dev32)
    s = summary(res.rps, res.image, data.truth)
    assert s["rp_total"] == 63
    assert s["rp_within_10mm"] >= 55  # 87 %
    assert s["rpm_within_50mm"] / s["rpm_total"] >= 0.94
    assert s["rpm_within_100mm"] / s["rpm_total"] >= 0.98


def test_sparse_paper_2d_at_20_db():
    """One noisy realisation (measured over seeds 0-4: RP <= 10 mm 56-63 of
    63, RPM <= 50 mm 62-63 of 63; seed 0: 62 and 63); floors of 85 % leave
    room for the noise draw."""
    data, pre = simulate_preset("paper-2d-sparse", 20.0, seed=0, noise="receiver")
    res = run_method("kspace-rpm", data, default_params(data, **pre.defaults), reference)
    s = summary(res.rps, res.image, data.truth)
    assert s["rp_total"] == 63
    assert s["rp_within_10mm"] / s["rp_total"] >= 0.85
    assert s["rpm_within_50mm"] / s["rpm_total"] >= 0.85


def test_aliased_pair_is_separated():
    """+3 and +25 degrees are aliases at 20 mm (k 43.9 and 40.1 rad/m on a
    314 rad/m axis): each gets its own cluster holding its own ranges."""
    data, _ = simulate_preset("paper-2d-sparse")
    dec = decompose(data, KSpaceParams())
    assert len(dec.clusters) == 3
    theta = sorted(np.degrees(np.arcsin(c.k[0] / (2 * data.waveform.kc))) for c in dec.clusters)
    np.testing.assert_allclose(theta, [-28, 3, 25], atol=0.5)
    rps = rps_from_decomposition(data, dec, -10.0)
    true_r = data.truth.rp_range.reshape(3, -1)  # (target, antenna)
    matched = set()
    for c in range(3):
        sel = rps.cluster == c
        within = [
            np.mean(np.abs(rps.range[sel] - true_r[t, rps.antenna[sel]]) <= 0.010) for t in range(3)
        ]
        matched.add(int(np.argmax(within)))
        assert max(within) >= 0.95
    assert matched == {0, 1, 2}


def test_single_sparse_target_is_exact():
    pre = get_preset("paper-2d-sparse")
    data = simulate(Scene((PointTarget([0.15, 0.4]),)), pre.array, pre.waveform, pre.range_axis)
    dec = decompose(data, KSpaceParams())
    assert len(dec.clusters) == 1
    rps = rps_from_decomposition(data, dec, -10.0)
    assert len(rps) == 21
    assert np.max(err_range(rps.antenna, rps.range, data.truth)) < 1e-3


def test_switch_follows_the_pitch():
    dense, _ = simulate_preset("paper-2d")
    sparse, _ = simulate_preset("paper-2d-sparse")
    assert not nearfield.near_field_wanted(dense)  # 5 mm < lambda/2: plane-wave FFT
    assert nearfield.near_field_wanted(sparse)  # 20 mm > lambda/2
    # the plane-wave decomposition stays available on request
    assert len(decompose(sparse, KSpaceParams(near_field=False)).clusters) == 1


def test_switch_takes_half_a_wavelength_as_coarse_whatever_the_rounding():
    """A pitch computed as lambda / 2 from the carrier of a frequency grid
    takes the near-field path whichever way its last bit rounds (the path
    must not flip on 1e-17 m); a pitch 1 % finer takes the plane-wave one."""
    f = 24e9 - 0.125e9 + (np.arange(64) + 0.5) * 0.25e9 / 64
    fc = 0.5 * (f[0] + f[-1])
    half = 0.5 * C0 / fc

    def wanted(pitch):
        arr = Array((np.arange(32) - 15.5) * pitch)
        rng = 0.5 + np.arange(8) * 0.01
        return nearfield.near_field_wanted(
            RadarData(np.ones((32, 8), complex), arr, rng, Waveform(fc, 0.25e9))
        )

    for pitch in (half, np.nextafter(half, 0.0), np.nextafter(half, 1.0), half * (1 - 1e-12)):
        assert wanted(pitch)
    assert not wanted(0.99 * half)


@pytest.mark.parametrize(
    "bandwidth, pitch, n, near",
    [
        (0.2e9, 20e-3, 21, True),  # the paper's sparse case: 0.4 m aperture, 0.75 m resolution
        (0.4e9, 20e-3, 21, True),  # 1.07 range resolutions
        (0.5e9, 20e-3, 21, False),  # 1.33
        (3e9, 7.5e-3, 32, False),  # a wideband array just over lambda/2: 4.7 resolutions
    ],
)
def test_switch_follows_the_aperture_in_range_resolutions(bandwidth, pitch, n, near):
    """The near-field model's envelope follows a range walk of about one
    resolution; a longer aperture goes to the plane-wave path."""
    arr = Array((np.arange(n) - (n - 1) / 2) * pitch)
    data = RadarData(
        np.ones((n, 8), complex), arr, 0.5 + np.arange(8) * 0.01, Waveform(20e9, bandwidth)
    )
    assert nearfield.near_field_wanted(data) is near


@pytest.mark.parametrize("deg", [35, 55])
def test_wideband_half_wavelength_array_images_a_steep_target(dev32, deg):
    """32 antennas at 7.5 mm (just over lambda/2 at 20 GHz), 3 GHz: a point
    35 or 55 degrees off broadside at 0.8 m.  The k axis aliases it (|u| >
    0.5), the alignment picks the alias by the range walk, and every antenna
    gives an RP within 10 mm and an image point within 50 mm of it.  Through
    the near-field path, which a pitch over lambda/2 alone does not choose
    (this aperture is 4.7 range resolutions long), the same scene gives 6
    and 19 RPs and no point within 50 mm (benchmarks/path_choice.py)."""
    arr = Array((np.arange(32) - 15.5) * 7.5e-3)
    th = np.radians(deg)
    data = simulate(
        Scene((PointTarget((0.8 * np.sin(th), 0.8 * np.cos(th))),)),
        arr,
        Waveform(20e9, 3e9),
        np.arange(0.5, 1.1, 2.5e-3),
        20.0,
        0,
        noise="receiver",
    )
    res = run_method("kspace-rpm", data, default_params(data), dev32)
    s = summary(res.rps, res.image, data.truth)
    assert s["rp_total"] == 32 and s["rp_within_10mm"] == 32
    assert s["rpm_within_50mm"] == s["rpm_total"] == 32


def test_planar_array_refuses_near_field():
    arr = Array(np.arange(4) * 0.02, np.arange(3) * 0.02)
    data = RadarData(np.ones((4, 3, 8), complex), arr, np.arange(8) * 0.01, Waveform(20e9, 0.2e9))
    with pytest.raises(InputError, match="linear"):
        decompose(data, KSpaceParams(near_field=True))
    assert not nearfield.near_field_wanted(data)


def test_scans_equal_direct_fits(rng):
    """The batched one- and two-centre scans equal least-squares fits done one by one."""
    x = (np.arange(21) - 10) * 0.02
    sc = rng.standard_normal((21, 21)) + 1j * rng.standard_normal((21, 21))
    model = nearfield._Model(x, 419.0, sc, nearfield.SEARCH_TERMS)
    others = [[0.1, 0.45]]
    um, rm = np.array([0.3, 0.31, 0.32]), np.array([0.45, 0.46, 0.47])
    un, rn = np.array([-0.4, -0.41]), np.array([0.42, 0.43])
    one = [model.cost(others + [[um[i], rm[i]]]) for i in range(3)]
    np.testing.assert_allclose(model.scan(others, um, rm), one, rtol=1e-9)
    two = [
        [model.cost(others + [[um[i], rm[i]], [un[j], rn[j]]]) for j in range(2)] for i in range(3)
    ]
    np.testing.assert_allclose(model.scan_pair(others, um, rm, un, rn), two, rtol=1e-9)


def test_polish_jacobian_gives_the_exact_gradient(rng):
    """The polish's analytic (Kaufman) Jacobian: its residual is _real_fit's,
    and J^T r equals the central-difference gradient of |r|^2 / 2 (the term
    it drops is orthogonal to the residual)."""
    x = (np.arange(21) - 10) * 0.02
    s = rng.standard_normal((21, 42)) + 1j * rng.standard_normal((21, 42))
    fit = nearfield._Polish(x, 419.0, nearfield.SEARCH_TERMS, s)
    v = np.array([0.1, 0.45, 0.3, -0.3, 0.42, -1.0])
    r = fit.fun(v)
    np.testing.assert_allclose(
        r,
        nearfield._real_fit(x, 419.0, v.reshape(-1, 3), nearfield.SEARCH_TERMS, s)[2].ravel(),
        atol=1e-9,
    )
    h = np.tile([1e-7, 1e-7, 1e-6], 2)
    e = np.eye(v.size)
    fd = [
        (np.sum(fit.fun(v + h[i] * e[i]) ** 2) - np.sum(fit.fun(v - h[i] * e[i]) ** 2)) / (4 * h[i])
        for i in range(v.size)
    ]
    np.testing.assert_allclose(fit.jac(v).T @ r, fd, rtol=1e-5, atol=1e-6 * np.max(np.abs(fd)))


def test_focus_map_equals_the_direct_sum():
    """The complex64 focused map against its definition in float64,
    |sum_X w(X) s(X, R) exp(j 2 k0 (|X - p| - R))|, at every tenth direction."""
    data, _ = simulate_preset("paper-2d-sparse")
    search = nearfield._Search(data, 10 ** (-10 / 20), 4)
    fmap = search.focus_map(search.s_det)
    x = search.x[:, None]
    for i in range(0, search.u_det.size, 10):
        r = search.r_det[None]
        d = np.sqrt(x * x - 2 * x * r * search.u_det[i] + r * r)
        ref = np.abs(np.sum(search.w[:, None] * search.s_det * np.exp(2j * search.k0 * (d - r)), 0))
        np.testing.assert_allclose(fmap[i], ref, rtol=1e-4, atol=1e-5 * ref.max())


def test_one_centre_placement_lands_on_a_lone_target():
    """Coarse-to-fine placement from 0.6 cell and one depth of focus away
    ends within its final step (du / 12, 0.1 depth of focus) of the target."""
    pre = get_preset("paper-2d-sparse")
    p = np.array([0.15, 0.4])
    data = simulate(Scene((PointTarget(p),)), pre.array, pre.waveform, pre.range_axis)
    search = nearfield._Search(data, 10 ** (-10 / 20), 4)
    u_t, r_t = p[0] / np.hypot(*p), np.hypot(*p)
    f = search.dof(r_t)
    u, r = search.place_one([], (u_t + 0.6 * search.du, r_t + f))
    assert abs(u - u_t) <= search.du / 12
    assert abs(r - r_t) <= 0.1 * f


def test_repeated_question_costs_no_fits():
    """best_with remembers its answers: the re-seat cycles ask again."""
    data, _ = simulate_preset("paper-2d-sparse")
    search = nearfield._Search(data, 10 ** (-10 / 20), 4)
    first = search.best_with([])
    fits = search.model.fits
    assert search.best_with([]) == first
    assert search.model.fits == fits


def test_pair_scan_equals_direct_fits_for_correlated_pairs(rng):
    """The pair scan's written-out 2 x 2 algebra holds where the two waves
    correlate strongly (neighbours and a grating-lobe alias, 0.375 apart in
    sin(theta) at 20 mm and 15 mm wavelength): the pairs it exists for."""
    x = (np.arange(21) - 10) * 0.02
    sc = rng.standard_normal((21, 21)) + 1j * rng.standard_normal((21, 21))
    model = nearfield._Model(x, 419.0, sc, nearfield.SEARCH_TERMS)
    um, rm = np.array([0.05, 0.052]), np.array([0.46, 0.462])
    un, rn = np.array([0.06, 0.425, 0.055]), np.array([0.465, 0.46, 0.47])
    for i in range(2):
        for j in range(3):
            a = nearfield._steer(x, [um[i], un[j]], [rm[i], rn[j]], 419.0)
            assert abs(np.vdot(a[:, 0], a[:, 1])) / 21 > nearfield.PAIR_CORRELATION
    two = [[model.cost([[um[i], rm[i]], [un[j], rn[j]]]) for j in range(3)] for i in range(2)]
    np.testing.assert_allclose(model.scan_pair([], um, rm, un, rn), two, rtol=1e-9)


@pytest.mark.parametrize("near_field", [None, True])
def test_moving_the_array_moves_the_image(dev32, near_field):
    """Positions as recorded (a line starting 12 m along) image the same as
    the same positions centred, moved by the same offset: the near-field
    search's spherical waves are placed from the array's centre, not from
    the origin (from the origin, 82 points became 36)."""
    import dataclasses

    from rpm_cl.simulate import simulate
    from rpm_cl.simulate.scene import PointTarget, Scene

    x = (np.arange(41) - 20) * 0.02
    scene = Scene((PointTarget((-0.05, 0.4)), PointTarget((0.1, 0.5))))
    data = simulate(scene, Array(x), Waveform(20e9, 0.2e9), np.arange(0, 1.5, 2.5e-3), 30.0, 1)
    off = 12.345
    moved = dataclasses.replace(data, array=Array(x + off))
    for method in ("phase-rpm", "kspace-rpm"):
        a = run_method(method, data, default_params(data, near_field=near_field), dev32)
        b = run_method(method, moved, default_params(moved, near_field=near_field), dev32)
        assert a.image.points.shape == b.image.points.shape and len(a.image.points) > 40
        np.testing.assert_allclose(b.image.points - [off, 0.0], a.image.points, atol=1e-9)
