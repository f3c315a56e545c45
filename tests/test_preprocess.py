"""GPR-style steps before imaging (rpm_cl/extract/preprocess.py)."""

import numpy as np
import pytest

from rpm_cl.extract.preprocess import COUPLING_SHARE, coupling_dominates, preprocess
from rpm_cl.imaging import run_method
from rpm_cl.io.data import Array, InputError, RadarData, Waveform
from rpm_cl.rpm import reference
from rpm_cl.rpm.params import ImagingParams, default_params
from rpm_cl.simulate import simulate, synthesize
from rpm_cl.simulate.scene import PointTarget, Scene

X = (np.arange(31) - 15) * 5e-3
AXIS = np.arange(0.0, 1.2, 2.5e-3)
WF = Waveform(20e9, 2e9)


@pytest.fixture(scope="module")
def scene():
    """A point target 0.45 m away and, at every antenna alike, a coupling
    echo at 30 mm four times as strong as the target's."""
    data = simulate(Scene((PointTarget((0.01, 0.45)),)), Array(X), WF, AXIS)
    peak = np.abs(data.signal).max()
    n = X.size
    leak = synthesize(np.arange(n), np.full(n, 0.03), np.full(n, 4 * peak), n, WF, AXIS)
    return data, RadarData(data.signal + leak, data.array, data.range, data.waveform)


def test_all_off_is_the_data_itself(scene):
    assert preprocess(scene[1], background="none") is scene[1]
    # auto: no coupling in the clean scene, nothing done
    assert preprocess(scene[0]) is scene[0]


def test_auto_background_removes_a_dominant_coupling(scene):
    """The leaky scene's strongest echo, at 30 mm at every antenna alike, is
    a coupling: auto removes the mean profile, as "mean" does; the clean
    scene's strongest echo walks across the array and is left alone."""
    clean, leaky = scene
    assert coupling_dominates(leaky) and not coupling_dominates(clean)
    np.testing.assert_array_equal(preprocess(leaky).signal, preprocess(leaky, "mean").signal)
    # counted from time zero: set more than a resolution beyond the echo, it
    # is no coupling there (within one, its lobe straddles time zero)
    res = leaky.waveform.range_resolution
    assert not coupling_dominates(leaky, time_zero=0.03 + 1.2 * res)
    assert coupling_dominates(leaky, time_zero=0.03 + 0.8 * res)
    # a planar array's common echo may be a flat sample's surface: kept
    planar = Array(X[:8], X[:6])
    n = 48
    flat = synthesize(np.arange(n), np.full(n, 0.03), np.ones(n), n, WF, AXIS)
    pd = RadarData(flat.reshape(8, 6, -1), planar, AXIS, WF)
    assert not coupling_dominates(pd)
    lin = RadarData(flat.reshape(48, -1)[:31], Array(X), AXIS, WF)
    assert coupling_dominates(lin)


def test_auto_background_wants_a_common_echo():
    """An echo at the same range at every antenna but with a phase that
    changes across the scan (a tilted plate's specular flash is not; a
    target's range walk below a gate is) is no coupling: the antennas' mean
    keeps under COUPLING_SHARE of its power."""
    n = X.size
    rng = np.random.default_rng(3)
    amp = np.exp(1j * rng.uniform(-np.pi, np.pi, n))
    echo = synthesize(np.arange(n), np.full(n, 0.03), np.ones(n), n, WF, AXIS)
    gate = np.argmin(np.abs(AXIS - 0.03))
    assert coupling_dominates(RadarData(echo, Array(X), AXIS, WF))
    mixed = echo * amp[:, None]
    assert not coupling_dominates(RadarData(mixed, Array(X), AXIS, WF))
    assert np.abs(mixed[:, gate].mean()) ** 2 < COUPLING_SHARE * np.mean(
        np.abs(mixed[:, gate]) ** 2
    )


def test_background_removal_takes_what_every_antenna_sees(scene):
    """The mean profile of a coupling echo common to all antennas is that
    echo: removed to rounding; the target's echo, which walks across the
    array, keeps most of its energy."""
    clean, leaky = scene
    out = preprocess(leaky, background="mean")
    gate = np.argmin(np.abs(AXIS - 0.03))
    assert np.abs(out.signal[:, gate]).max() < 1e-3 * np.abs(leaky.signal[:, gate]).max()
    tgt = np.argmin(np.abs(AXIS - 0.45))
    kept = np.abs(out.signal[:, tgt - 40 : tgt + 40]) ** 2
    assert kept.sum() > 0.5 * (np.abs(clean.signal[:, tgt - 40 : tgt + 40]) ** 2).sum()
    med = preprocess(leaky, background="median")
    assert np.abs(med.signal[:, gate]).max() < 1e-3 * np.abs(leaky.signal[:, gate]).max()


def test_background_removal_images_the_target_alone(scene):
    """Without it the coupling echo, the strongest in the data, makes points
    at 30 mm; with it every point lies on the target."""
    _, leaky = scene
    for background, near in (("none", True), ("mean", False)):
        p = default_params(leaky, background=background)
        pts = run_method("phase-rpm", leaky, p, reference).image.points
        d = np.hypot(pts[:, 0] - 0.01, pts[:, 1] - 0.45)
        assert (pts[:, 1] < 0.1).any() == near
        if not near:
            assert len(pts) and np.all(d < 0.01)


def test_time_zero_gain_and_region(scene):
    clean, _ = scene
    out = preprocess(clean, time_zero=0.1, max_range=0.5)
    assert out.range[0] >= 0 and out.range[0] < out.dr and out.range[-1] <= 0.5
    # the echo keeps its place in the data, its range moves by time_zero
    r0 = clean.range[np.argmax(np.abs(clean.signal[15]))]
    r1 = out.range[np.argmax(np.abs(out.signal[15]))]
    assert r1 == pytest.approx(r0 - 0.1, abs=clean.dr)
    g = preprocess(clean, gain_db_per_m=20.0)  # x 10 per metre, 1 at the last gate
    np.testing.assert_allclose(
        np.abs(g.signal), np.abs(clean.signal) * 10 ** (clean.range - clean.range[-1]), rtol=1e-6
    )
    # a gain no float holds as an absolute factor (1000 dB/m over 1.2 m)
    big = preprocess(clean, gain_db_per_m=1000.0)
    assert np.all(np.isfinite(big.signal)) and np.abs(big.signal).max() > 0


@pytest.mark.parametrize(
    "kw, words",
    [
        ({"background": "mode"}, "background must be"),
        ({"time_zero": -0.1}, "time_zero must be"),
        ({"gain_db_per_m": np.inf}, "gain_db_per_m"),
        ({"max_range": 0.0}, "max_range must be"),
        ({"max_range": np.nan}, "max_range must be"),
    ],
)
def test_settings_refused(kw, words):
    with pytest.raises(InputError, match=words):
        ImagingParams(**kw)


def test_max_range_counts_from_time_zero(scene):
    out = preprocess(scene[0], time_zero=0.5, max_range=0.2)
    assert out.range[-1] <= 0.2 and out.range[-1] > 0.2 - 2 * out.dr


def test_nothing_left_refused(scene):
    with pytest.raises(InputError, match="fewer than 2 range gates"):
        preprocess(scene[0], time_zero=5.0, max_range=6.0)


def test_a_coupling_straddling_time_zero_on_a_spectrums_axis_is_found(tmp_path):
    """A spectrum's range axis is periodic: a coupling whose main lobe
    straddles time zero (a GPR trace cut at its direct wave's peak) peaks
    at the axis's end as often as at its start.  auto removes it as it does
    one just after time zero, and the load does not take it for a target
    wrapped from beyond the unambiguous range."""
    import warnings

    from rpm_cl.io.data import C0, DataWarning
    from rpm_cl.io.formats import load_data

    f = np.linspace(1e9, 3e9, 81)
    x = np.arange(24) * 0.02
    target = np.hypot(x - 0.2, 0.3)[:, None]
    spec = 0.2 * np.exp(-4j * np.pi * f[None] * target / C0) / target
    for r_c in (0.01, -0.01):  # just after time zero, and just before it: wrapped
        coupled = spec + 3 * np.exp(-4j * np.pi * f[None] * r_c / C0)
        np.savez(tmp_path / "c.npz", spectrum=coupled, frequency=f, x=x)
        with warnings.catch_warnings():
            warnings.simplefilter("error", DataWarning)
            data = load_data(tmp_path / "c.npz")
        peak = data.range[np.abs(data.signal).mean(axis=0).argmax()]
        assert (peak < 0.1) if r_c > 0 else (peak > data.range[-1] - 0.1)
        assert coupling_dominates(data)
        np.testing.assert_array_equal(preprocess(data).signal, preprocess(data, "mean").signal)
