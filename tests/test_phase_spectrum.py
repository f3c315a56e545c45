"""phase-rpm's coherent level formed from the frequency samples a spectrum
input carries (``RadarData.spectrum``, ``rpm_cl.extract.phase._spectral_profile``).
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from rpm_cl.cli import robustness as R
from rpm_cl.extract import phase as PH
from rpm_cl.extract.preprocess import preprocess
from rpm_cl.io.compress import range_compress
from rpm_cl.io.data import InputError, RadarData, Spectrum
from rpm_cl.io.load import load_data
from rpm_cl.io.medium import Medium, in_medium, paraxial_data

SCENE = next(g for g in R.GEOMETRIES_2D if g.name == "2d-a")


def _with_samples(snr_db, seed, g=SCENE):
    spec, f, _ = R.synthesize(g, snr_db, seed)
    return replace(R.radar_data(g, spec, f), spectrum=Spectrum(spec, f))


def _profile_sum(data, antenna, r_fit, weights, c):
    """The coherent sum of the range profiles themselves at gate-aligned
    shifts (no interpolation): ``sum_i weights_i s(X_i, r_i + c)``."""
    sig = data.signal.reshape(-1, data.range.size)
    gates = np.rint((r_fit[:, None] + c[None, :] - data.range[0]) / data.dr).astype(int)
    return np.abs(np.sum(weights[:, None] * sig[antenna[:, None], gates], axis=0))


@pytest.mark.parametrize("medium_n", [1.0, 2.0])
def test_spectral_sum_is_the_profiles_sum(monkeypatch, rng, medium_n):
    """With the compression's own window the sum formed from the samples is
    the sum of the compressed profiles, on the data as given and on the
    scene a homogeneous medium makes of them (frequencies times n, ranges
    over n): the phase convention, the carrier and the medium's scaling
    agree.  A sign of kappa, a missing carrier or an unscaled frequency
    axis moves the sums apart by far more than the tolerance."""
    monkeypatch.setattr(PH, "LEVEL_WINDOW", "hann")
    data = _with_samples(None, 0)
    if medium_n != 1.0:
        data = in_medium(data, Medium(eps_r=medium_n**2))
    n = 9
    antenna = rng.choice(data.array.n, n, replace=False)
    gate = rng.integers(5, data.range.size - 10, n)
    r_fit = data.range[gate]
    weights = rng.uniform(0.2, 1.0, n) * np.exp(2j * data.waveform.kc * r_fit)
    c = np.arange(-4, 5) * data.dr
    spectral = PH._spectral_profile(data, antenna, r_fit, weights)(c)
    assert np.allclose(spectral, _profile_sum(data, antenna, r_fit, weights, c), rtol=1e-9)


def test_level_from_the_samples_is_sharper():
    """Four noise seeds of the three-target scene at 20 dB: the RMS error of
    the tracks' range constants (``benchmarks/phase_level.py``) is 0.69 of
    the profiles' (Taylor against Hann: 1.09 / 1.57 in theory,
    phase.LEVEL_WINDOW), below 0.85 here."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from phase_level import _errors

    def rms(samples):
        errs = [e for seed in range(4) for e in _errors(SCENE, 20.0, seed, samples=samples)]
        assert len(errs) >= 10
        return float(np.sqrt(np.mean(np.square(errs))))

    assert rms(True) < 0.85 * rms(False)


def test_spectrum_travels_with_the_data(tmp_path):
    """A spectrum file's samples ride along (conjugated when asked); a
    range-domain file has none; preprocessing keeps them for a cut of the
    range axis only; the paraxial scene of a half-space drops them."""
    spec, f, _ = R.synthesize(SCENE, 30.0, 0)
    x = R._axis(SCENE.x)
    path = tmp_path / "s.npz"
    np.savez(path, spectrum=spec, frequency=f, x=x)
    data = load_data(path)
    assert data.spectrum is not None
    assert np.array_equal(data.spectrum.values, spec)
    assert np.array_equal(data.spectrum.frequency, f)
    conj = load_data(path, conjugate=True)
    assert np.array_equal(conj.spectrum.values, np.conj(spec))
    s, rng = range_compress(spec, f, data.waveform.fc, "hann")
    assert RadarData(s, data.array, rng, data.waveform).spectrum is None
    assert preprocess(data, max_range=1.0).spectrum is data.spectrum
    for kw in ({"background": "mean"}, {"time_zero": 0.1}, {"gain_db_per_m": 3.0}):
        assert preprocess(data, **kw).spectrum is None
    half = paraxial_data(data, Medium(eps_r=4.0, antenna_height=0.05))
    assert half.spectrum is None


def test_spectrum_is_checked():
    """Samples that do not fit the array or their frequency axis are refused."""
    data = _with_samples(None, 0)
    spec, f = data.spectrum.values, data.spectrum.frequency
    with pytest.raises(InputError, match="must have shape"):
        replace(data, spectrum=Spectrum(spec[:-1], f))
    with pytest.raises(InputError, match="last axis"):
        Spectrum(spec[:, :-1], f)
    with pytest.raises(InputError, match="complex"):
        Spectrum(spec.real, f)
    with pytest.raises(InputError, match="frequency"):
        Spectrum(spec, -f[::-1])


def test_benchmark_loads_as_the_loader_does(tmp_path):
    """The robustness benchmark's ``loaded_data`` is what ``load_data`` makes
    of the same samples written as a spectrum file (``spectrum``,
    ``frequency``, ``x``), profile for profile."""
    spec, f, _ = R.synthesize(SCENE, 20.0, 1)
    path = tmp_path / "s.npz"
    np.savez(path, spectrum=spec, frequency=f, x=R._axis(SCENE.x))
    ours, theirs = R.loaded_data(SCENE, spec, f), load_data(path)
    assert np.array_equal(ours.signal, theirs.signal)
    assert np.array_equal(ours.range, theirs.range)
    assert ours.waveform == theirs.waveform
    assert ours.range_sidelobe_db == theirs.range_sidelobe_db
    assert np.array_equal(ours.spectrum.values, theirs.spectrum.values)
    assert ours.range[-1] > 10 * R.region(SCENE)
