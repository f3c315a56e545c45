"""The noise power behind the k-space floor, measured on the whole range axis
before a region of interest cuts it (``rpm_cl.imaging.prepared``).

The scenes are the robustness benchmark's narrow-band 2-D ones
(``rpm_cl.cli.robustness``): 64 frequencies over 0.22 GHz, so the whole
axis spans 63 range resolutions (c / 2 df = 47 m) while the scene's gates,
0-1.5 m, span two, every one inside the echoes' main lobes.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from rpm_cl.cli import robustness as R
from rpm_cl.extract.kspace import NOISE_ESTIMATE_CELLS, _taper, measured_noise_power, noise_floor
from rpm_cl.imaging import prepared, run_method
from rpm_cl.io.compress import range_compress
from rpm_cl.io.data import RadarData
from rpm_cl.rpm.params import default_params

SCENE = next(g for g in R.GEOMETRIES_2D if g.name == "2d-d")


def _scene(seed: int, snr_db: float = 20.0):
    """(whole-axis data as the loader compresses a spectrum, the ROI that
    keeps the scene's gates, the true noise power per range sample)."""
    spec, f, _ = R.synthesize(SCENE, snr_db, seed)
    cut = R.radar_data(SCENE, spec, f)
    s, rng = range_compress(spec, f, 0.5 * (f[0] + f[-1]), "hann")
    whole = RadarData(s, cut.array, rng, cut.waveform)
    noise = spec - R.synthesize(SCENE, None, seed)[0]
    power = float(np.mean(np.abs(range_compress(noise, f, whole.waveform.fc, "hann")[0]) ** 2))
    return whole, float(cut.range[-1]), power


@pytest.mark.parametrize("seed", [0, 1])
def test_whole_axis_noise_power_is_the_noise(seed):
    """The median over the whole axis's gates (echoes in 3 of 63
    resolutions) reads the noise's own power per sample, within 20 %; the
    scene's gates alone are too few for that estimate (None)."""
    whole, roi, power = _scene(seed)
    assert measured_noise_power(whole) == pytest.approx(power, rel=0.2)
    kept = whole.range <= roi
    cut = RadarData(whole.signal[:, kept], whole.array, whole.range[kept], whole.waveform)
    assert cut.range[-1] < NOISE_ESTIMATE_CELLS * cut.waveform.range_resolution
    assert measured_noise_power(cut) is None


def test_prepared_passes_the_whole_axis_power_on():
    """A region of interest cuts the axis: the parameters carry the power
    measured before the cut, and the floor it gives lies within 10 % of the
    floor of the true power, where the estimate from the kept gates' k-space
    map (echoes in most of its cells) reads far higher."""
    whole, roi, power = _scene(0)
    params = default_params(whole, max_range=roi)
    data, run = prepared(whole, params)
    assert data.range[-1] <= roi < whole.range[-1]
    assert run.kspace.noise_power == pytest.approx(power, rel=0.2)
    w = _taper(data.array.shape)
    pfa = run.kspace.noise_pfa
    true_floor = noise_floor(data, w, pfa, power)
    assert noise_floor(data, w, pfa, run.kspace.noise_power) == pytest.approx(true_floor, rel=0.1)
    assert noise_floor(data, w, pfa) > 1.5 * true_floor


def test_prepared_leaves_the_power_alone_where_it_should():
    """No cut, a power given by the user, or a gain (noise power changing
    along the range): the parameters stay as they are."""
    whole, roi, _ = _scene(0)
    plain = default_params(whole)
    assert prepared(whole, plain)[1] == plain
    given = replace(plain, max_range=roi, kspace=replace(plain.kspace, noise_power=1.0))
    assert prepared(whole, given)[1].kspace.noise_power == 1.0
    gain = replace(plain, max_range=roi, gain_db_per_m=3.0)
    assert prepared(whole, gain)[1].kspace.noise_power is None


@pytest.mark.parametrize("seed", [4, 5])
def test_roi_keeps_weak_targets_at_20db(seed, dev32):
    """Four point targets at 20 dB in-band S/N, imaged by phase-rpm through
    a region of interest: every target has a point within 25 mm.  With the
    floor from the kept gates alone (no whole axis to measure on) these
    seeds lose one and three targets: their k-space peaks sit under a
    floor 2-3 times too high."""
    whole, roi, _ = _scene(seed)
    result = run_method("phase-rpm", whole, default_params(whole, max_range=roi), dev32)
    pts = result.image.points
    targets = np.asarray(SCENE.targets)
    nearest = np.min(np.linalg.norm(pts[:, None] - targets[None], axis=2), axis=0)
    assert np.all(nearest < 0.025), nearest
