"""Forward model: geometry, phase convention, noise level, GO specular points."""

import numpy as np
import pytest

from rpm_cl.io.data import C0, Array, InputError, Waveform
from rpm_cl.simulate import echoes, simulate, synthesize
from rpm_cl.simulate.scene import Ellipsoid, PointTarget, Scene, boundary_samples, specular_point


def test_point_target_peak_and_phase():
    """A lone echo peaks at its range with |s| = amplitude and phase exp(-2j kc R)."""
    wf = Waveform(20e9, 0.2e9)
    ax = np.arange(0.0, 2.0, 1e-3)
    s = synthesize(np.array([0]), np.array([0.8123]), np.array([0.7]), 1, wf, ax)[0]
    k = np.argmax(np.abs(s))
    assert abs(ax[k] - 0.8123) <= 1e-3
    # |s| at the echo's range equals its amplitude (matched filter normalised)
    s_at = synthesize(
        np.array([0]), np.array([0.8123]), np.array([0.7]), 1, wf, np.array([0.0, 0.8123])
    )[0, 1]
    assert abs(abs(s_at) - 0.7) < 1e-9
    assert abs(np.angle(s_at * np.exp(2j * wf.kc * 0.8123))) < 1e-9


def test_measured_snr_matches_definition():
    """Noise variance per receiver sample = peak signal power / 10^(SNR/10).

    The matched filter keeps in-band noise only: for white noise of variance
    sigma^2 per sample at rate fs, the MF output noise variance is
    sigma^2 / n_rx * sum|P|^2 / (sum|P|^2)^2 * ... ; rather than re-derive it we
    check the definition directly: simulate noise alone with the same sigma^2
    and compare its MF output power to the predicted value from Parseval.
    """
    from rpm_cl.simulate.synth import _receiver_grid

    wf = Waveform(20e9, 0.2e9)
    ax = np.arange(0.0, 1.5, 2.5e-3)
    n_ant = 400
    rng = np.random.default_rng(3)
    amp = 2.0
    clean = synthesize(np.arange(n_ant), np.full(n_ant, 0.5), np.full(n_ant, amp), n_ant, wf, ax)
    noisy = synthesize(
        np.arange(n_ant),
        np.full(n_ant, 0.5),
        np.full(n_ant, amp),
        n_ant,
        wf,
        ax,
        snr_db=10.0,
        rng=rng,
        noise="receiver",
    )
    noise = noisy - clean
    _f, p, window = _receiver_grid(wf, ax[-1])
    fs = C0 / (2 * 2.5e-3)
    n_rx = fs * window
    # peak received power of a lone echo of amplitude a: |a * sum P / sqrt(n_rx)|^2
    peak = (amp * p.sum()) ** 2 / n_rx
    sigma2 = peak / 10.0
    # MF output noise variance: sigma2 * sum|P|^2 / (sum|P|^2)^2
    want = sigma2 / np.sum(p**2)
    got = np.mean(np.abs(noise) ** 2)
    assert got == pytest.approx(want, rel=0.05)  # 400 x 600 correlated samples


def test_ellipse_specular_point_is_nearest_boundary_point(rng):
    for _ in range(5):
        ell = Ellipsoid(
            rng.uniform(-0.3, 0.3, 2) + [0, 1.0], rng.uniform(0.01, 0.3, 2), rng.uniform(0, np.pi)
        )
        p = np.stack([rng.uniform(-1, 1, 20), np.zeros(20)], axis=1)
        _spec, d, radii = specular_point(ell, p)
        dense = boundary_samples(ell, 1e-5)
        brute = np.min(np.linalg.norm(dense[None] - p[:, None], axis=2), axis=1)
        np.testing.assert_allclose(d, brute, atol=2e-6)
        assert np.all(radii > 0)


def test_ellipsoid_specular_point_elongated_and_curvature():
    # very elongated body (1000:1): bisection still converges
    ell = Ellipsoid([0.0, 1.0, 0.0], [0.5, 5e-4, 0.2], [0.3, 0.1, 0.2])
    p = np.array([[0.01, 0.0, 0.02], [-0.3, 0.0, 0.1]])
    spec, d, _radii = specular_point(ell, p)
    rot = ell.rotation
    u = (spec - ell.center) @ rot
    np.testing.assert_allclose(np.sum((u / ell.semi_axes) ** 2, axis=1), 1.0, atol=1e-9)
    # the specular direction is normal to the surface
    g = (u / ell.semi_axes**2) @ rot.T
    n = g / np.linalg.norm(g, axis=1, keepdims=True)
    v = (p - spec) / d[:, None]
    np.testing.assert_allclose(np.abs(np.sum(n * v, axis=1)), 1.0, atol=1e-9)
    # sphere: both principal radii equal the radius
    _, _, rr = specular_point(Ellipsoid([0, 1.0, 0], [0.1, 0.1, 0.1]), np.zeros((1, 3)))
    np.testing.assert_allclose(rr, 0.1, rtol=1e-9)


def test_blocked_path_is_dropped():
    # a big ellipse in front of a point target shadows it for central antennas
    arr = Array(np.linspace(-0.05, 0.05, 11))
    pt = PointTarget([0.0, 1.0])
    wall = Ellipsoid([0.0, 0.5], [0.2, 0.02])
    *_, tgt = echoes(Scene((pt, wall)), arr)
    assert np.sum(tgt == 0) == 0  # the point is hidden from all antennas
    assert np.sum(tgt == 1) == 11
    *_, tgt = echoes(Scene((pt, Ellipsoid([0.6, 0.5], [0.05, 0.02]))), arr)
    assert np.sum(tgt == 0) == 11


def test_truth_matches_geometry():
    arr = Array(np.linspace(-0.05, 0.05, 5))
    data = simulate(
        Scene((PointTarget([0.1, 0.4]),)), arr, Waveform(20e9, 0.2e9), np.arange(0, 1, 5e-3)
    )
    want = np.hypot(0.1 - arr.x, 0.4)
    np.testing.assert_allclose(data.truth.rp_range, want)
    assert data.signal.shape == (5, 200)


def test_mixed_dimensions_rejected():
    with pytest.raises(InputError):
        Scene((PointTarget([0, 1.0]), PointTarget([0, 1.0, 0])))
    with pytest.raises(InputError):
        echoes(Scene((PointTarget([0, 1.0, 0]),)), Array(np.linspace(0, 1, 3)))


# --------------------------------------------------------------------------
# the in-band noise model (rpm_cl.simulate, module notes, *Noise*)
WF_WIDE = Waveform(20e9, 3e9)  # resolution c/2B = 50 mm


def _lone_echoes(n_ant, axis, snr_db=None, seed=None, noise="in-band", r_e=0.7125, amp=0.5):
    """One echo of amplitude ``amp`` at ``r_e`` per antenna: its
    matched-filter output peaks at |s| = amp exactly (the filter's
    normalisation, test_point_target_peak_and_phase), so the clean peak
    power is amp^2 whatever grid the output is sampled on."""
    rng = None if seed is None else np.random.default_rng(seed)
    return synthesize(
        np.arange(n_ant),
        np.full(n_ant, r_e),
        np.full(n_ant, amp),
        n_ant,
        WF_WIDE,
        axis,
        snr_db,
        rng,
        noise=noise,
    )


@pytest.mark.parametrize("snr_db", [20.0, 0.0, -10.0])
@pytest.mark.parametrize(
    "axis",
    [
        np.arange(0.3, 1.3, 0.025),  # 40 gates of 25 mm
        np.arange(0.0, 3.0, 0.010),
    ],
)  # 300 gates of 10 mm
def test_in_band_snr_is_the_requested_one(snr_db, axis):
    """Measured S/N = clean peak power / mean compressed noise power equals
    the requested one, on two range axes (different gate spacing and length,
    so different numbers of frequency bins: 67 and 135).

    The echo lies half-way between two 25 mm gates of the first axis, where
    the sampled output is 0.86 dB below its peak: a peak taken on the
    requested gates instead of the continuous output fails.  sigma^2 without
    sum|P|^2 is off by 10 log10(sum|P|^2), 14 and 17 dB here.  Tolerance 0.1 dB:
    the mean is over 1500 antennas (independent draws) x at least 20
    resolution cells (nearly independent along range), so its relative
    standard deviation is at most 1/sqrt(30000) = 0.6 %, 0.025 dB; 0.1 dB
    is four of them."""
    n_ant = 1500
    clean = _lone_echoes(n_ant, axis)
    noisy = _lone_echoes(n_ant, axis, snr_db, seed=7)
    measured = 10 * np.log10(0.5**2 / np.mean(np.abs(noisy - clean) ** 2))
    assert measured == pytest.approx(snr_db, abs=0.1)


@pytest.mark.parametrize("noise", ["in-band", "receiver"])
def test_compressed_noise_has_the_bands_autocorrelation(noise):
    """The noise is white over the in-band samples |f| < B (the same
    variance in every bin) and goes through the matched filter P*: its range
    profile's autocorrelation at lag D is then the band's,

        rho(D) = int |P(f)|^2 exp(-j 4 pi f D / c) df / int |P(f)|^2 df,

    evaluated here by an independent quadrature of the cos^4 band.  Noise
    added to the profiles after the filter (rho = 0 at every lag > 0) or
    shaped by P before it (the cos^8 band: rho(25 mm) = 0.80 against 0.67)
    fails.  Tolerance 0.02: each lag is averaged over 1500 antennas x about
    100 independent gates, a standard deviation near 1/sqrt(150000) =
    0.003 (measured largest deviation 0.002)."""
    axis = np.arange(0.0, 3.0, 0.005)
    n_ant = 1500
    clean = _lone_echoes(n_ant, axis)
    nz = _lone_echoes(n_ant, axis, 10.0, seed=11, noise=noise) - clean
    lags = np.arange(0, 31)  # 0 .. 150 mm in 5 mm steps
    zero = np.mean(np.abs(nz) ** 2)
    got = np.array([np.mean(nz[:, : nz.shape[1] - m] * np.conj(nz[:, m:])) for m in lags]) / zero
    f = np.linspace(-WF_WIDE.bandwidth, WF_WIDE.bandwidth, 20001)
    w = np.cos(np.pi * f / (2 * WF_WIDE.bandwidth)) ** 4
    want = (
        np.array([np.sum(w * np.exp(-4j * np.pi * f * (m * 0.005) / C0)) for m in lags]) / w.sum()
    )
    np.testing.assert_allclose(got, want, rtol=0, atol=0.02)
    # the tolerance tells the band from the cos^8 band of noise shaped by P
    w8 = w * w
    shaped = (
        np.array([np.sum(w8 * np.exp(-4j * np.pi * f * (m * 0.005) / C0)) for m in lags]) / w8.sum()
    )
    assert np.max(np.abs(shaped - want)) > 0.1


def test_noise_model_choice_is_checked_and_in_band_is_the_default():
    arr = Array(np.linspace(-0.05, 0.05, 5))
    scene = Scene((PointTarget([0.0, 0.5]),))
    axis = np.arange(0.0, 1.0, 5e-3)
    default = simulate(scene, arr, WF_WIDE, axis, 10.0, 3)
    inband = simulate(scene, arr, WF_WIDE, axis, 10.0, 3, noise="in-band")
    receiver = simulate(scene, arr, WF_WIDE, axis, 10.0, 3, noise="receiver")
    np.testing.assert_array_equal(default.signal, inband.signal)
    assert not np.allclose(inband.signal, receiver.signal)
    with pytest.raises(InputError, match="noise must be one of"):
        simulate(scene, arr, WF_WIDE, axis, 10.0, 3, noise="thermal")
    with pytest.raises(InputError, match="receiver_fs applies to noise='receiver' only"):
        simulate(scene, arr, WF_WIDE, axis, 10.0, 3, receiver_fs=12e9)


def test_receiver_model_sits_above_the_in_band_one_by_the_noise_bandwidth():
    """The receiver model's S/N is taken before the matched filter on noise
    white over fs = c / (2 dr): its range profiles show 10 log10(1.5 fs / 2B)
    dB more, the filter's noise-bandwidth ratio fs / 2B times its gain on
    the cos^2 pulse, sum|P|^2 N / (sum P)^2 -> (3/8) / (1/2)^2 = 1.5 (11.76
    dB at 3 GHz and 2.5 mm gates).  The same draws at S and at S + 11.76 dB
    of the in-band model are the same data, up to the sampling of the two
    peaks on their time grids (the noise parts differ by one factor, 1.4e-4
    from 1 here).  Tolerance 0.1 dB as in
    test_in_band_snr_is_the_requested_one (1500 antennas x 60 cells)."""
    axis = np.arange(0.0, 3.0, 2.5e-3)
    gain = 10 * np.log10(1.5 * (C0 / (2 * 2.5e-3)) / (2 * WF_WIDE.bandwidth))
    clean = _lone_echoes(1500, axis)
    rec = _lone_echoes(1500, axis, 10.0, seed=3, noise="receiver")
    assert 10 * np.log10(0.25 / np.mean(np.abs(rec - clean) ** 2)) == pytest.approx(
        10 + gain, abs=0.1
    )
    same = _lone_echoes(1500, axis, 10.0 + gain, seed=3)
    np.testing.assert_allclose(same - clean, rec - clean, rtol=1e-3, atol=1e-12)
