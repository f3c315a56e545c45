"""A near-field planar scan as a stepped-frequency scanner records it, made
here and not by rpm_cl.simulate: the sample's echo, the antennas' own
coupling a few mm away and the echo the antennas send back to the sample
once more (the repeat at twice its range).

The coupling (rpm_cl.extract.preprocess.coupling_rps) and the repeat
(rpm_cl.rpm.multipath.repeats) must not become surface points.
"""

import numpy as np
import pytest

from rpm_cl import imaging
from rpm_cl.extract.preprocess import (
    COUPLING_TERMS,
    coupling_rps,
    planar_coupling,
    preprocess,
    without_echo,
)
from rpm_cl.extract.rangepoints import RangePoints
from rpm_cl.io.compress import spectrum_data
from rpm_cl.io.data import C0, Array, RadarData, Waveform
from rpm_cl.rpm.multipath import REPEAT_LEVEL, REPEAT_SHAPE, repeats
from rpm_cl.rpm.params import default_params

#: 11 frequencies over 22.2-26.2 GHz, as the public 24 GHz scanner records
FREQ = np.linspace(22.2e9, 26.2e9, 11)
#: the sample: the front of a sphere of radius RHO, 0.105 m from the centre
#: antenna, its centre 30 mm to the side (the surface tilts across the scan)
RHO = 1.5


def _centre():
    """The sphere's centre: its surface 0.105 m from the antenna at (0, 0, 0)
    (along the line to the centre), 30 mm to the side in x."""
    d = np.array([0.03, 1.0, 0.0])
    d /= np.linalg.norm(d)
    return d * (0.105 + RHO)


def scan(nx=24, nz=20, coupling=3.0, repeat=0.3, snr_db=30.0, seed=0):
    """The scan's spectrum data (Hann compression, as a spectrum file loads)
    and the sample's centre.

    Each antenna at (x, 0, z) records the sample's specular echo at
    ``R = |a - c| - RHO`` (amplitude 0.1 / R), the repeat at ``2 R``
    (``repeat`` times that), and the coupling at 12 mm (``coupling``, the
    same at every antenna); white noise on the samples at ``snr_db``
    (S/N: a unit echo's rect-compressed peak power over the compressed noise
    power)."""
    pitch = 3e-3
    x = (np.arange(nx) - (nx - 1) / 2) * pitch
    z = (np.arange(nz) - (nz - 1) / 2) * pitch
    c = _centre()
    ax, az = np.meshgrid(x, z, indexing="ij")
    r = np.sqrt((ax - c[0]) ** 2 + c[1] ** 2 + (az - c[2]) ** 2) - RHO
    k = 4 * np.pi * FREQ / C0
    amp = (0.1 / r)[..., None]
    y = amp * np.exp(-1j * k * r[..., None])
    y = y + repeat * amp * np.exp(-1j * k * 2 * r[..., None])
    y = y + coupling * np.exp(-1j * k * 0.012 + 0.4j)
    if snr_db is not None:
        s2 = FREQ.size / 10 ** (snr_db / 10)
        g = np.random.default_rng(seed)
        y = y + np.sqrt(s2 / 2) * (g.standard_normal(y.shape) + 1j * g.standard_normal(y.shape))
    return spectrum_data(y, FREQ, Array(x, z)), c


def _off_surface(points, c):
    return np.abs(np.linalg.norm(points - c, axis=1) - RHO)


def test_the_scan_is_what_it_says():
    """The synthesis itself: the compressed profile of the centre antenna
    peaks at the coupling (12 mm), and without it at the sample's range."""
    data, c = scan(snr_db=None, repeat=0.0)
    assert abs(data.range[np.argmax(np.abs(data.signal[12, 10]))] - 0.012) < 0.005
    data, c = scan(snr_db=None, repeat=0.0, coupling=0.0)
    r = np.linalg.norm(np.array([data.array.x[12], 0, data.array.z[10]]) - c) - RHO
    assert abs(data.range[np.argmax(np.abs(data.signal[12, 10]))] - r) < 0.005


@pytest.mark.parametrize(
    "coupling,snr_db", [(3.0, None), (3.0, 30.0), (10.0, 20.0), (0.3, None), (1.0, 20.0)]
)
def test_coupling_and_repeat_leave_the_surface_alone(dev32, coupling, snr_db):
    """Every point phase-rpm keeps lies within 15 mm of the sample, the
    median within 1 mm (0.45-0.6 mm with no coupling at all): the coupling
    comes out of the samples before the imaging, ten times the sample's
    echo or a third of it, and the repeat's points are dropped."""
    data, c = scan(coupling=coupling, snr_db=snr_db)
    res = imaging.run_method("phase-rpm", data, default_params(data), dev32)
    off = _off_surface(res.image.points, c)
    assert len(off) >= data.array.n
    assert np.all(off < 0.015)
    assert np.median(off) < 0.001
    assert res.dropped["multipath"] >= data.array.n // 2


def test_the_coupling_is_taken_out_of_the_samples_as_one_echo():
    """planar_coupling finds the coupling's samples; without_echo leaves
    what the scan would hold without it, in the samples and in the profiles
    (the compression's own window and axis)."""
    data, _ = scan(coupling=3.0, snr_db=None)
    clean, _ = scan(coupling=0.0, snr_db=None)
    k = 4 * np.pi * FREQ / C0
    true = 3.0 * np.exp(0.4j - 1j * k * 0.012)
    got = planar_coupling(data)
    # the fit against the truth: 2 % of the coupling at most (the sample's
    # common part leaks in through the Hann weights' side lobes)
    assert np.abs(got - true).max() < 0.03 * 3.0
    out = without_echo(data, got)
    assert np.abs(out.signal - clean.signal).max() < 0.01 * 3.0
    assert np.abs(out.spectrum.values - clean.spectrum.values).max() < 0.03 * 3.0
    # the exact samples leave the exact clean data (the formula, not the fit)
    scale = np.abs(clean.signal).max()
    exact = without_echo(data, true)
    assert np.allclose(exact.signal, clean.signal, atol=1e-5 * scale)
    # other windows: the profiles as that window compresses the clean samples
    for name in ("rect", "blackman"):
        d_w = spectrum_data(data.spectrum.values, FREQ, data.array, window=name)
        c_w = spectrum_data(clean.spectrum.values, FREQ, data.array, window=name)
        assert np.allclose(without_echo(d_w, true).signal, c_w.signal, atol=1e-5 * scale)
    # none where nothing is common, or on a range-domain scan (no samples)
    assert planar_coupling(clean) is None
    from dataclasses import replace

    assert planar_coupling(replace(data, spectrum=None)) is None


def test_a_coupling_whose_amplitude_falls_across_the_band_is_fitted(monkeypatch):
    """An antenna's mismatch is seldom one clean echo: a coupling falling
    6 dB across the band is fitted by its delay and a linear amplitude
    (COUPLING_TERMS = 2), to 2.5 % of the coupling's largest amplitude at
    the band's edges (0.8 % at its centre); with one term 26 % are left,
    and with three the fit takes in the sample's common echo (15 %)."""
    import rpm_cl.extract.preprocess as pre

    clean, _ = scan(coupling=0.0, snr_db=None)
    k = 4 * np.pi * FREQ / C0
    true = 3.0 * np.exp(-1j * k * 0.012) * np.linspace(0.5, 1.0, FREQ.size)
    data = spectrum_data(clean.spectrum.values + true, FREQ, clean.array)
    assert COUPLING_TERMS == 2
    assert np.abs(planar_coupling(data) - true).max() < 0.03 * 3.0
    monkeypatch.setattr(pre, "COUPLING_TERMS", 1)
    assert np.abs(planar_coupling(data) - true).max() > 0.2 * 3.0
    monkeypatch.setattr(pre, "COUPLING_TERMS", 3)
    assert np.abs(planar_coupling(data) - true).max() > 0.1 * 3.0


def test_auto_background_takes_only_the_coupling_out_of_a_planar_scan():
    data, _ = scan(coupling=3.0, snr_db=30.0)
    out = preprocess(data)
    assert np.array_equal(out.signal, without_echo(data, planar_coupling(data)).signal)
    assert out.spectrum is not None
    assert preprocess(data, background="none") is data


def test_repeat_is_flagged_on_request(dev32):
    """Without the coupling, the repeat makes a cluster of its own at twice
    the sample's range: ``multipath="flag"`` keeps it, flagged, and flags
    nothing on the sample."""
    data, c = scan(coupling=0.0)
    img = imaging.run_method("phase-rpm", data, default_params(data, multipath="flag"), dev32).image
    on = _off_surface(img.points, c) < 0.015
    assert np.count_nonzero(img.multipath) >= data.array.n // 2
    assert not np.any(img.multipath & on)
    assert np.all(img.multipath | on)
    # the flagged points lie about as far again behind the surface
    r = np.linalg.norm(img.points[img.multipath] - c, axis=1) - RHO
    assert np.median(r) < -0.05


# --- the tests, on RPs made for them ------------------------------------------


def _walk(n=40, seed=0):
    g = np.random.default_rng(seed)
    x = np.linspace(-0.06, 0.06, n)
    return np.arange(n), np.hypot(x - 0.02, 0.3), g


def test_a_repeat_is_n_times_its_leg():
    ant, r, g = _walk()
    lam, res = 0.0124, 0.068
    noise = g.normal(0, 0.05 * REPEAT_SHAPE * lam, r.size)
    leg = (ant, r)
    assert repeats((ant, 2 * r + noise), leg, res, lam)
    assert repeats((ant, 3 * r + noise + 0.5 * REPEAT_LEVEL * res), leg, res, lam)
    # a constant off by more than the level's tolerance
    assert not repeats((ant, 2 * r + 2 * REPEAT_LEVEL * res), leg, res, lam)
    # another wavefront: the walk tilted by a wavelength across the track
    tilt = np.linspace(-0.5, 0.5, r.size) * lam
    assert not repeats((ant, 2 * r + tilt), leg, res, lam)
    # a real object behind: a broadside point twice as far from a nearer one
    x = np.linspace(-0.06, 0.06, r.size)
    near, far = np.hypot(x, 0.35), np.hypot(x, 0.7)
    assert not repeats((ant, far), (ant, near), res, lam)
    # too few antennas shared
    assert not repeats((ant[:10] + 100, 2 * r[:10]), leg, res, lam)


def test_a_leg_with_two_rps_at_an_antenna_answers_with_its_nearer():
    ant, r, _ = _walk()
    leg = (np.r_[ant, ant], np.r_[r, r + 0.2])
    assert repeats((ant, 2 * r), leg, 0.068, 0.0124)


def _rps(antenna, rng, sample, data):
    arr = data.array
    ix, iz = np.unravel_index(antenna, arr.shape)
    n = len(antenna)
    return RangePoints(antenna, arr.x[ix], arr.z[iz], rng, np.ones(n), np.zeros(n, int), sample)


def _planar(n=8):
    x = (np.arange(n) - 3.5) * 3e-3
    rng = np.arange(0, 0.3, 1e-3)
    return RadarData(np.zeros((n, n, rng.size), complex), Array(x, x), rng, Waveform(24.2e9, 2.2e9))


def test_coupling_rps_are_a_common_echo_near_time_zero():
    data = _planar()
    n = data.array.n
    ant = np.arange(n)
    same = np.full(n, 0.3 + 0.4j)
    # the coupling at 12 mm at every antenna, a surface at 0.105 m
    rps = _rps(
        np.r_[ant, ant], np.r_[np.full(n, 0.012), np.full(n, 0.105)], np.r_[same, same], data
    )
    own = coupling_rps(data, rps)
    assert own[:n].all() and not own[n:].any()
    # phases that differ from antenna to antenna: an echo that walks
    g = np.random.default_rng(1)
    walk = np.exp(2j * np.pi * g.uniform(size=n))
    assert not coupling_rps(data, _rps(ant, np.full(n, 0.012), walk, data)).any()
    # at too few antennas
    few = ant[: int(0.8 * n)]
    assert not coupling_rps(data, _rps(few, np.full(few.size, 0.012), same[: few.size], data)).any()
    # beyond a range resolution
    far = np.full(n, 1.1 * data.waveform.range_resolution)
    assert not coupling_rps(data, _rps(ant, far, same, data)).any()
    # a linear array's coupling is removed before the imaging instead
    lin = RadarData(
        np.zeros((8, data.range.size), complex), Array(data.array.x), data.range, data.waveform
    )
    rl = RangePoints(
        ant[:8], data.array.x, None, np.full(8, 0.012), np.ones(8), np.zeros(8, int), same[:8]
    )
    assert not coupling_rps(lin, rl).any()


def test_a_flat_sample_parallel_to_the_scan_is_no_coupling():
    """A plate parallel to the scan at 0.105 m is common to every antenna,
    its range side lobes within a resolution of the antennas too: they are
    under the window's side lobe level, no coupling, the data left alone.
    The same plate within a resolution of the antennas is taken for one."""
    x = (np.arange(10) - 4.5) * 3e-3
    arr = Array(x, x)
    k = 4 * np.pi * FREQ / C0
    plate = np.broadcast_to(np.exp(-1j * k * 0.105), (10, 10, FREQ.size))
    data = spectrum_data(plate.copy(), FREQ, arr)
    assert planar_coupling(data) is None
    assert preprocess(data) is data
    near_echo = np.exp(-1j * k * 0.03)
    near = spectrum_data(np.broadcast_to(near_echo, plate.shape).copy(), FREQ, arr)
    assert np.abs(planar_coupling(near) - near_echo).max() < 1e-3


def test_what_the_fit_leaves_of_a_coupling_wraps_and_is_dropped(dev32):
    """A coupling of two echoes (12 and 25 mm) is one echo with a linear
    amplitude only roughly: the fit leaves part of it, some before 0, which
    the compression wraps to the end of the unambiguous range (0.375 m).
    Its RPs are near time zero on the periodic axis, and their points go
    (without the wrap: a third of the points, at 0.345 m)."""
    data, c = scan(coupling=0.0)
    k = 4 * np.pi * FREQ / C0
    two = 3.0 * np.exp(-1j * k * 0.012) + 1.5 * np.exp(1j - 1j * k * 0.025)
    d = spectrum_data(data.spectrum.values + two, FREQ, data.array)
    res = imaging.run_method("phase-rpm", d, default_params(d), dev32)
    off = _off_surface(res.image.points, c)
    assert len(off) >= data.array.n
    assert np.all(off < 0.015)
    assert np.median(off) < 0.001
    assert res.dropped["coupling"] >= 0.9 * data.array.n


def test_a_range_domain_scan_drops_its_coupling_points(dev32):
    """Without frequency samples there is nothing to fit the coupling to: it
    is imaged, and its points (every antenna's, 12 mm before it) go."""
    from dataclasses import replace

    data, c = scan(coupling=3.0, repeat=0.0)
    profiles = replace(data, spectrum=None)
    res = imaging.run_method("phase-rpm", profiles, default_params(profiles), dev32)
    off = _off_surface(res.image.points, c)
    assert len(off) >= data.array.n
    assert np.all(off < 0.015)
    assert res.dropped["coupling"] >= 0.9 * data.array.n


def test_the_coupling_is_sought_from_time_zero():
    """A scan whose axis starts 0.1 m before the antennas (time zero at 0.1
    m, the coupling at 0.112 m): the region of interest's path
    (rpm_cl.imaging.prepared, which removes the background before it cuts
    the axis) seeks the coupling from time zero too."""
    from rpm_cl.imaging import prepared

    data, _ = scan(coupling=3.0, repeat=0.0, snr_db=None)
    k = 4 * np.pi * FREQ / C0
    shifted = spectrum_data(data.spectrum.values * np.exp(-1j * k * 0.1), FREQ, data.array)
    out, _ = prepared(shifted, default_params(shifted, time_zero=0.1, max_range=0.2))
    near = (out.range >= 0.0) & (out.range <= 0.03)
    assert np.abs(out.signal[..., near].mean(axis=(0, 1))).max() < 0.05 * 3.0


def test_coupling_rps_test_each_zone_apart():
    """The coupling's RPs near 0 go even where the end of the unambiguous
    range holds other RPs that are not common; a spectrum of too few
    frequencies has no wrapped zone (and no fit)."""
    x = (np.arange(8) - 3.5) * 3e-3
    arr = Array(x, x)
    n = arr.n
    k = 4 * np.pi * FREQ / C0
    data = spectrum_data(
        np.broadcast_to(np.exp(-1j * k * 0.05), (8, 8, FREQ.size)).copy(), FREQ, arr
    )
    ant = np.arange(n)
    same = np.full(n, 0.3 + 0.4j)
    g = np.random.default_rng(2)
    walk = np.exp(2j * np.pi * g.uniform(size=n))
    end = C0 / (2 * (FREQ[1] - FREQ[0])) - 0.01
    rps = _rps(np.r_[ant, ant], np.r_[np.full(n, 0.012), np.full(n, end)], np.r_[same, walk], data)
    own = coupling_rps(data, rps)
    assert own[:n].all() and not own[n:].any()
    # the wrapped zone alone, common: flagged
    rps = _rps(ant, np.full(n, end), same, data)
    assert coupling_rps(data, rps).all()
    few = spectrum_data(data.spectrum.values[..., :5], FREQ[:5], arr, window="rect")
    assert not coupling_rps(few, rps).any()
    assert planar_coupling(few) is None
