"""The robustness benchmark's synthesis, noise and bounds (rpm_cl.cli.robustness)."""

import numpy as np
import pytest

from rpm_cl.cli.robustness import GEOMETRIES_2D, GEOMETRY_3D, crb, radar_data, synthesize, table


def test_in_band_noise_has_the_stated_snr():
    """S/N = peak compressed power / mean compressed noise power, compression
    the plain sum over the band: measured on the noise alone over 200 draws
    the mean compressed noise power is sigma^2 / nf within 3 % (the standard
    error of 200 x 64 exponential samples is 0.6 %)."""
    g = GEOMETRIES_2D[0]
    clean, _, _ = synthesize(g, None)
    n = 16 * g.nf
    peak = np.max(np.abs(np.fft.ifft(clean, n, axis=-1) * n / g.nf)) ** 2
    powers = []
    for seed in range(200):
        noisy, _, sigma2 = synthesize(g, 20.0, seed)
        noise = noisy - clean
        powers.append(np.mean(np.abs(np.sum(noise, axis=-1) / g.nf) ** 2))
        assert sigma2 == pytest.approx(peak / 100 * g.nf)
    assert np.mean(powers) == pytest.approx(peak / 100, rel=0.03)


def test_echo_peaks_at_its_range():
    g = GEOMETRIES_2D[1]
    spec, f, _ = synthesize(g, None)
    data = radar_data(g, spec, f)
    centre = data.array.n // 2
    t = np.asarray(g.targets)
    r_true = np.linalg.norm(t - [data.array.x[centre], 0.0], axis=1)
    # one range cell holds all targets: the profile's peak lies among them
    r_peak = data.range[np.argmax(np.abs(data.signal[centre]))]
    assert r_true.min() - 0.1 < r_peak < r_true.max() + 0.1
    assert data.waveform.fc == pytest.approx(g.fc)


def test_crb_scales_with_noise_and_bandwidth():
    """Both bounds go as sigma; the range bound of one antenna is the textbook
    c / (4 pi B_rms sqrt(2 E / sigma^2)) for a flat sweep (B_rms = band /
    sqrt(12) for a large nf, here nf = 96: within 2 %)."""
    g = GEOMETRY_3D
    r1, p1 = crb(g, 1e-6)
    r2, p2 = crb(g, 4e-6)
    assert r2 == pytest.approx(2 * r1, rel=1e-6) and p2 == pytest.approx(2 * p1, rel=1e-6)
    assert p1 < r1
    from rpm_cl.cli.robustness import _echoes, _positions

    pos = _positions(g)
    centre = int(np.argmin(np.linalg.norm(pos - pos.mean(axis=0), axis=1)))
    _, aa = _echoes(g, pos[centre : centre + 1])
    f = g.fc - g.band / 2 + np.arange(g.nf) * g.band / (g.nf - 1)
    b_rms = np.std(f)
    want = [299792458.0 / (4 * np.pi * b_rms * np.sqrt(2 * g.nf * a**2 / 1e-6)) for a in aa[0]]
    assert r1 == pytest.approx(float(np.median(want)), rel=0.02)


def test_table_lists_every_row():
    rows = [
        {
            "scene": "s",
            "snr": None,
            "method": "m",
            "fraction": 1.0,
            "median": 0.001,
            "hit": 3,
            "targets": 3,
            "points": 10,
            "seconds": 0.01,
            "crb_range": 0.0,
            "crb_position": 0.0,
            "tol": 0.05,
        }
    ]
    text = table(rows)
    assert "| s | inf | m | 100.0 % (<= 50 mm) | 1.0 | 3/3 | 10 |" in text
