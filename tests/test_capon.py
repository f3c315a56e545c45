"""Capon range filter with frequency averaging (rpm_cl.extract.capon)."""

import numpy as np
import pytest

from rpm_cl.extract.capon import (
    CaponParams,
    capon_profiles,
    frequency_samples,
    matched_filter_weight,
    rps_from_capon,
)
from rpm_cl.extract.rangepoints import profile_peaks, rps_from_profiles
from rpm_cl.io.data import C0, Array, InputError, RadarData, Waveform
from rpm_cl.metrics import cumulative, err_range
from rpm_cl.simulate import simulate_preset, synthesize

WF = Waveform(20e9, 3e9)  # 50 mm range resolution


def _data(antenna, ranges, amps, range_axis, waveform=WF, n=2):
    sig = synthesize(
        np.asarray(antenna),
        np.asarray(ranges, float),
        np.asarray(amps, float),
        n,
        waveform,
        range_axis,
    )
    return RadarData(sig, Array(np.arange(n) * 5e-3), range_axis, waveform)


def _fraction(rps, truth):
    return cumulative(err_range(rps.antenna, rps.range, truth), 0.010)


# ---------------------------------------------------------------- samples
@pytest.mark.parametrize("r0", [0.0, 0.5, 0.73])
def test_frequency_samples_phase_reference_any_range_origin(r0):
    """A lone echo gives Y(f) = a exp(-j 4 pi (fc + f) R / c) whatever the
    range axis's origin.  The echo sits 8+ resolutions inside the 1 m window,
    where the cos^4 spectrum's response has fallen below 1e-5, so the FFT
    path is exact to that level (1e-4 allows for the division by W >= 0.01
    at the band edges)."""
    rax = r0 + np.arange(400) * 2.5e-3
    r_e, a = r0 + 0.5123, 0.7
    f, y = frequency_samples(_data([0], [r_e], [a], rax))
    want = a * np.exp(-4j * np.pi * (WF.fc + f) * r_e / C0)
    assert np.max(np.abs(y[0] - want)) < 1e-4 * a
    assert np.all(np.abs(y[1]) < 1e-12)  # the second antenna has no echo
    # the band kept: W(f) >= 0.01, i.e. |f| <= 0.80 B, nothing beyond
    assert np.all(matched_filter_weight(f, WF.bandwidth) >= 0.01)
    assert f[-1] + (f[1] - f[0]) > 0.79 * WF.bandwidth
    # without deconvolution the matched-filter weight stays in
    _, y2 = frequency_samples(_data([0], [r_e], [a], rax), deconvolve=False)
    assert np.allclose(y2[0], want * matched_filter_weight(f, WF.bandwidth), atol=1e-5)


def test_short_window_needs_the_band_limited_fit():
    """paper-2d's window (1.5 m, 2 resolutions of 750 mm, echo 0.45 m from
    R = 0) cuts the echo's response: the FFT's samples are far off (> 10 %),
    the band-limited fit over a 10-resolution period recovers them to better
    than 1e-2 (at 1e-2, the level a 5-resolution period reaches, Capon no
    longer resolves paper-2d's echoes)."""
    wf = Waveform(20e9, 0.2e9)
    rax = np.arange(0.0, 1.5, 2.5e-3)
    data = _data([0], [0.4567], [1.0], rax, wf)
    for cells, ok in ((0.0, False), (10.0, True)):
        f, y = frequency_samples(data, min_period_cells=cells)
        want = np.exp(-4j * np.pi * (wf.fc + f) * 0.4567 / C0)
        err = np.max(np.abs(y[0] - want))
        assert (err < 1e-2) == ok, (cells, err)
        if not ok:
            assert err > 0.1


def test_frequency_samples_rejects_bad_options():
    data = _data([0], [1.0], [1.0], 0.5 + np.arange(400) * 2.5e-3)
    for kw in (
        {"min_weight": 0.0},
        {"min_weight": 1.5},
        {"min_period_cells": -1.0},
        {"zero_pad": 0},
        {"zero_pad": 1.5},
        {"min_weight": 1.0},
    ):
        with pytest.raises(InputError):
            frequency_samples(data, **kw)


# ---------------------------------------------------------------- params
@pytest.mark.parametrize(
    "kw",
    [
        {"n_sub": 1},
        {"n_sub": 2.5},
        {"n_sub": True},
        {"loading": -1e-3},
        {"loading": np.inf},
        {"min_weight": 0.0},
        {"min_period_cells": np.nan},
    ],
)
def test_capon_params_validation(kw):
    with pytest.raises(InputError):
        CaponParams(**kw)


def test_sub_band_longer_than_band_is_an_input_error():
    data = _data([0], [1.0], [1.0], 0.5 + np.arange(400) * 2.5e-3)
    with pytest.raises(InputError, match="n_sub"):
        capon_profiles(data, CaponParams(n_sub=500))
    with pytest.raises(InputError, match="rp_threshold_db"):
        rps_from_capon(data, CaponParams(), rp_threshold_db=0.0)


# ---------------------------------------------------------------- filter
def test_capon_profiles_match_a_per_gate_reference(rng):
    """The batched, eigen-factored spectrum equals the textbook formula
    evaluated gate by gate with an explicit inverse (loading 1e-3 keeps the
    matrices well conditioned, so the two agree to rounding: rtol 1e-8)."""
    n = 3
    ranges = 0.9 + 0.2 * rng.random(6)
    data = _data(
        np.repeat(np.arange(n), 2), ranges, 0.5 + rng.random(6), 0.5 + np.arange(400) * 2.5e-3, n=n
    )
    params = CaponParams(n_sub=7, loading=1e-3)
    got = capon_profiles(data, params)
    f, y = frequency_samples(data)
    m, k = 7, f.size - 7 + 1
    for ant in range(n):
        rxx = sum(np.outer(y[ant, i : i + m], y[ant, i : i + m].conj()) for i in range(k)) / k
        rxx += 1e-3 * np.real(np.trace(rxx)) / m * np.eye(m)
        rinv = np.linalg.inv(rxx)
        for g in range(0, data.range.size, 37):
            a = np.exp(-4j * np.pi * f[:m] * data.range[g] / C0)
            want = 1.0 / np.real(a.conj() @ rinv @ a)
            assert got[ant, g] == pytest.approx(want, rel=1e-8)


def test_lone_echo_power_and_planar_shape():
    """A lone echo of amplitude a gives P = a^2 at its range (|a(R)|^2 = M
    normalisation); planar data keep their (nx, nz, nr) shape."""
    rax = 0.5 + np.arange(400) * 2.5e-3
    sig = synthesize(np.array([0, 3]), np.array([1.0, 1.1]), np.array([0.7, 1.3]), 4, WF, rax)
    data = RadarData(sig.reshape(2, 2, -1), Array([0.0, 0.005], [0.0, 0.005]), rax, WF)
    p = capon_profiles(data)
    assert p.shape == (2, 2, 400) and np.all(p >= 0)
    rps = rps_from_capon(data)
    assert rps.antenna.tolist() == [0, 3] and rps.z is not None
    assert np.allclose(rps.range, [1.0, 1.1], atol=1e-5)
    assert np.allclose(rps.amp, [0.7, 1.3], rtol=1e-3)


def test_two_echoes_within_a_resolution_cell_resolved():
    """Two echoes 30 mm and 20 mm apart (0.6 and 0.4 of the 50 mm range
    resolution): the matched filter shows one peak per antenna between them,
    Capon (noise-free) two peaks, each within 1 mm of its echo (measured:
    0.01 mm; the frequency samples are exact to 1e-5 here)."""
    res = WF.range_resolution
    rax = 0.5 + np.arange(400) * 2.5e-3
    r1 = 1.0012
    truth = {0: (r1, r1 + 0.6 * res), 1: (r1, r1 + 0.4 * res)}
    data = _data([0, 0, 1, 1], [r1, r1 + 0.6 * res, r1, r1 + 0.4 * res], [1.0, 0.8, 1.0, 0.8], rax)
    row, pos, _ = profile_peaks(np.abs(data.signal), 0.0)
    near = np.abs(rax[0] + pos * data.dr - r1) < res
    assert sorted(row[near].tolist()) == [0, 1]  # one matched-filter peak each
    rps = rps_from_capon(data)
    for ant, (ra, rb) in truth.items():
        got = np.sort(rps.range[rps.antenna == ant])
        assert got.size == 2, got
        assert np.all(np.abs(got - [ra, rb]) < 1e-3), got


# ---------------------------------------------------------------- presets
def test_paper_2d_capon_beats_matched_filter_noise_free_and_degrades_with_noise():
    """paper-2d: three echoes within 0.05-0.15 of the 750 mm resolution at
    every antenna.  Noise-free, Capon's RPs are more accurate than the
    matched filter's (measured 89 % (16/18) against 65 % (11/17)); the
    margin asked, 15 points, is half that gap, and at least 12 RPs (more
    than half the 21 antennas) keeps a handful of lucky peaks from passing.
    At 20 dB (seeds 0-2 pooled) the accuracy falls (measured 72 %, 28/39;
    70 % over seeds 0-9): asked, at least 10 points below noise-free.  The fall is smaller than the
    paper's (0 %) because Err_range <= 10 mm counts a peak near *any* of
    three echoes 30-110 mm apart, which a peak in the right place by chance
    often is (the matched filter scores 64 % with a single merged peak)."""
    data, _ = simulate_preset("paper-2d")
    cap_k, cap_n = _fraction(rps_from_capon(data), data.truth)
    mf_k, mf_n = _fraction(rps_from_profiles(data, -10.0), data.truth)
    assert cap_n >= 12
    assert cap_k / cap_n >= mf_k / mf_n + 0.15, (cap_k, cap_n, mf_k, mf_n)
    k = n = 0
    for seed in range(3):
        noisy, _ = simulate_preset("paper-2d", 20.0, seed, noise="receiver")
        a, b = _fraction(rps_from_capon(noisy), noisy.truth)
        k, n = k + a, n + b
    assert n > 0 and k / n <= cap_k / cap_n - 0.10, (k, n, cap_k, cap_n)


def test_human_body_capon_accurate_noise_free_degrades_at_20_db():
    """The 3-D human body (50 mm resolution, up to 11 echoes per antenna):
    noise-free Capon RPs are as accurate as the paper's (100 %, 678/678;
    measured 388/388) -- asked: >= 97 % of at least 250 RPs, well above the
    matched filter's 65 %.  At 20 dB (seed 0) the accuracy falls below 80 %
    (measured 58 %, 170/291; 59 % over seeds 0-9; the paper's 2.6 %: see
    the paper-2d test for why this metric does not fall to 0)."""
    data, _ = simulate_preset("human-body")
    k, n = _fraction(rps_from_capon(data), data.truth)
    assert n >= 250 and k / n >= 0.97, (k, n)
    noisy, _ = simulate_preset("human-body", 20.0, 0, noise="receiver")
    k2, n2 = _fraction(rps_from_capon(noisy), noisy.truth)
    assert n2 > 0 and k2 / n2 < 0.80, (k2, n2)
