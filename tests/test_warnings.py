"""Sanity checks on real input: each warning (or refusal) fires on the bad
case, names the fix, and stays silent on good data (the paper's presets, a
correct spectrum).

- a spectrum that looks conjugated (echoes at R_u - R);
- frequencies or x in the wrong unit, alike for time- and frequency-domain
  files (GHz/MHz numbers refused, kHz numbers and x in mm warned);
- range sidelobes of the compression above the k-space peak threshold.
"""

import warnings

import numpy as np
import pytest

from rpm_cl.cli import main
from rpm_cl.imaging import run_method
from rpm_cl.io.data import C0, Array, DataWarning, InputError
from rpm_cl.io.formats import (
    RANGE_WINDOWS,
    load_data,
    range_sidelobe_db,
    save_data,
    window_bandwidth,
)
from rpm_cl.rpm import reference
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import echoes, simulate_preset
from rpm_cl.simulate.scene import PointTarget, Scene

ARRAY = Array((np.arange(21) - 10) * 5e-3)  # 0.1 m: no focusing beyond 0.33 m
SCENE = Scene((PointTarget((0.05, 0.6)), PointTarget((-0.1, 0.8)), PointTarget((0.12, 1.0))))
FREQ = 20e9 + np.linspace(-1.5e9, 1.5e9, 121)  # df = 25 MHz: unambiguous range 6 m


def _spectrum(f=FREQ, scene=SCENE, arr=ARRAY):
    """Y(f) = sum_e a_e exp(-j 4 pi f R_e / c) of the scene's echoes."""
    ant, r_e, a_e, _ = echoes(scene, arr)
    y = np.zeros((arr.n, f.size), complex)
    np.add.at(y, ant, a_e[:, None] * np.exp(-4j * np.pi * f[None] * r_e[:, None] / C0))
    return y


def _file(tmp_path, name, **over):
    arrays = {"spectrum": _spectrum(), "frequency": FREQ, "x": ARRAY.x}
    arrays.update(over)
    path = tmp_path / name
    np.savez(path, **arrays)
    return path


def _silent(fn, *args, **kw):
    """fn(...) with every DataWarning an error."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        return fn(*args, **kw)


def _image(data, **params):
    return run_method("kspace-rpm", data, default_params(data, **params), reference)


# --------------------------------------------------------------------------
# silent on good data
@pytest.mark.parametrize("preset", ["paper-2d", "paper-2d-sparse", "human-body"])
def test_presets_load_and_image_silently(tmp_path, preset):
    data = simulate_preset(preset, 20.0, 0)[0]
    for ext in (".npz", ".h5"):
        save_data(tmp_path / f"p{ext}", data)
        back = _silent(load_data, tmp_path / f"p{ext}")
    if preset != "human-body":  # the body's imaging is tested elsewhere; loading is the point
        _silent(_image, back)


def test_correct_spectrum_is_silent_and_imaged_on_the_targets(tmp_path):
    data = _silent(load_data, _file(tmp_path, "ok.npz"))
    res = _silent(_image, data)
    targets = np.array([t.position for t in SCENE.targets])
    d = np.linalg.norm(res.image.points[:, None] - targets[None], axis=2).min(axis=1)
    assert len(d) >= 60 and np.mean(d < 0.02) >= 0.95


def test_noise_alone_is_not_taken_for_a_conjugated_spectrum(tmp_path):
    """White noise spreads its power evenly: a quarter in the last quarter
    of the range, under the 50 % the check needs."""
    rng = np.random.default_rng(5)
    y = rng.standard_normal((21, FREQ.size)) + 1j * rng.standard_normal((21, FREQ.size))
    _silent(load_data, _file(tmp_path, "noise.npz", spectrum=y))


# --------------------------------------------------------------------------
# conjugated spectrum
def test_conjugated_spectrum_warns_and_conjugate_fixes_it(tmp_path):
    bad = _file(tmp_path, "conj.npz", spectrum=_spectrum().conj())
    with pytest.warns(DataWarning, match=r"looks conjugated.*conjugate=True \(--conjugate\)"):
        data = load_data(bad)
    # the echoes sit at R_u - R (6 m minus 0.6 .. 1.0 m)
    r_peak = data.range[np.argmax(np.abs(data.signal).sum(axis=0))]
    assert r_peak == pytest.approx(C0 / (2 * (FREQ[1] - FREQ[0])) - np.hypot(0.05, 0.6), abs=0.02)
    fixed = _silent(load_data, bad, conjugate=True)
    good = _silent(load_data, _file(tmp_path, "ok.npz"))
    np.testing.assert_allclose(fixed.signal, good.signal, rtol=0, atol=1e-12)


def test_profiles_with_the_opposite_carrier_phase_are_conjugated_too(tmp_path):
    """Range profiles recorded as exp(+j 2 k_c R): the same envelopes, every
    direction mirrored across the array (phase-rpm put the paper scene's
    targets at -x).  --conjugate gives back the schema's profiles."""
    good = load_data(_time_domain(tmp_path))
    flipped = _time_domain(tmp_path, "td_conj.npz", signal=good.signal.conj())
    back = load_data(flipped, conjugate=True)
    np.testing.assert_array_equal(back.signal, good.signal)
    targets = np.array([t.position for t in simulate_preset("paper-2d")[1].scene.targets])
    medians = []
    for data in (load_data(flipped), back):
        pts = run_method("phase-rpm", data, default_params(data), reference).image.points
        d = np.linalg.norm(pts[:, None] - targets[None], axis=2).min(axis=1)
        medians.append(np.median(d))
    # two of the three targets lie 0.2 m off the array's axis: mirrored, most
    # points lie farther than 50 mm from every target; conjugated back, on them
    assert medians[0] > 0.05 and medians[1] < 0.01


def test_conjugate_flag_on_the_command_line(tmp_path, capsys):
    bad = _file(tmp_path, "conj.npz", spectrum=_spectrum().conj())
    assert main(["image", str(bad), "-o", str(tmp_path / "a.npz")]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rpm-cl: warning: the spectrum looks conjugated")
    assert "--conjugate" in err[0]
    assert main(["image", str(bad), "-o", str(tmp_path / "b.npz"), "--conjugate"]) == 0
    assert capsys.readouterr().err == ""
    assert main(["image", str(_file(tmp_path, "ok.npz")), "-o", str(tmp_path / "c.npz")]) == 0
    assert capsys.readouterr().err == ""
    np.testing.assert_array_equal(
        np.load(tmp_path / "b.npz")["points"], np.load(tmp_path / "c.npz")["points"]
    )
    assert main(["image", str(bad), "-o", str(tmp_path / "d.npz"), "-q"]) == 0
    assert capsys.readouterr().err == ""  # -q: errors only


# --------------------------------------------------------------------------
# units: both input paths alike
def _time_domain(tmp_path, name="td.npz", **over):
    data = simulate_preset("paper-2d")[0]
    arrays = {
        "signal": data.signal,
        "range": data.range,
        "x": data.array.x,
        "fc": np.float64(20e9),
        "bandwidth": np.float64(0.2e9),
    }
    arrays.update(over)
    path = tmp_path / name
    np.savez(path, **arrays)
    return path


@pytest.mark.parametrize("factor, unit", [(1e-9, "GHz numbers"), (1e-6, "MHz numbers")])
def test_gigahertz_and_megahertz_numbers_refused_in_both_domains(tmp_path, capsys, factor, unit):
    spec = _file(tmp_path, "f.npz", frequency=FREQ * factor)
    td = _time_domain(tmp_path, fc=np.float64(20e9 * factor), bandwidth=np.float64(0.2e9 * factor))
    for path in (spec, td):
        assert main(["image", str(path), "-o", str(tmp_path / "o.npz")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("rpm-cl: error:") and unit in err[0]
        assert "give" in err[0] and "in Hz" in err[0]


def test_kilohertz_numbers_warned_in_both_domains(tmp_path):
    spec = _file(tmp_path, "f.npz", frequency=FREQ * 1e-3)
    td = _time_domain(tmp_path, fc=np.float64(20e6), bandwidth=np.float64(0.2e6))
    for path in (spec, td):
        with pytest.warns(DataWarning, match=r"kHz numbers\? give them in Hz"):
            load_data(path)


def test_x_in_micrometres_is_blamed_on_x_not_on_the_carrier(tmp_path):
    """A 5 um pitch at 20 GHz: the carrier is a radar's, so the positions
    are named (a scale applied twice), not the frequencies."""
    spec = _file(tmp_path, "f.npz", x=ARRAY.x * 1e-3)
    with pytest.warns(DataWarning, match=r"is x in um, or scaled to m twice\? give x in m"):
        load_data(spec)


def test_x_in_millimetres_warned_in_both_domains(tmp_path, capsys):
    spec = _file(tmp_path, "f.npz", x=ARRAY.x * 1e3)
    td = _time_domain(tmp_path, x=simulate_preset("paper-2d")[0].array.x * 1e3)
    for path in (spec, td):
        with pytest.warns(DataWarning, match=r"is x in mm or cm\? give x in m"):
            load_data(path)
    assert main(["params", str(td)]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rpm-cl: warning: the antenna pitch 5 m")


def test_range_in_millimetres_refused_naming_the_unit(tmp_path, capsys):
    data = simulate_preset("paper-2d")[0]
    td = _time_domain(tmp_path, range=data.range * 1e3)
    assert main(["image", str(td), "-o", str(tmp_path / "o.npz")]) == 2
    assert "millimetre numbers" in capsys.readouterr().err


# --------------------------------------------------------------------------
# range sidelobes against the k-space peak threshold
def test_range_sidelobe_levels():
    """Against independent values: the peak sidelobes of the continuous
    windows (rect's sinc -13.26 dB, hann -31.47 dB, hamming about -42.7 dB,
    blackman -58.1 dB) within 0.3 dB (81 samples, gates 1/16 of the band's
    resolution: the sampled maxima lie within 0.2 dB of the true ones).  With
    a bandwidth so small that half a resolution covers rect's first
    sidelobe, the level is its second, -17.83 dB (sinc)."""
    f = 20e9 + np.arange(81) * 5e6
    want = {"rect": -13.26, "hann": -31.47, "hamming": -42.7, "blackman": -58.1}
    for w, level in want.items():
        assert range_sidelobe_db(f, w, window_bandwidth(f, w)) == pytest.approx(level, abs=0.3)
    # rect's first sidelobe lies 1.43 band resolutions out, its second 2.46:
    # a bandwidth of a third of the span puts 1.5 of them in half a resolution
    assert range_sidelobe_db(f, "rect", 81 * 5e6 / 3) == pytest.approx(-17.83, abs=0.3)


def test_rect_window_warns_and_hann_is_silent(tmp_path, capsys):
    path = _file(tmp_path, "ok.npz")
    rect = _silent(load_data, path, range_window="rect")  # loading alone is fine
    with pytest.warns(
        DataWarning,
        match=r"sidelobes reach -13\.3 dB, above the k-space peak "
        r"threshold -20 dB.*--range-window hann",
    ):
        res_rect = _image(rect)
    res_hann = _silent(_image, _silent(load_data, path))
    # the sidelobes' centres are dropped (above_leakage: 7 clusters of RPs
    # and 133 points without it): the warning is about what they mask
    assert len(set(res_hann.rps.cluster.tolist())) == 3
    assert len(set(res_rect.rps.cluster.tolist())) == 3
    assert len(res_rect.image.points) == len(res_hann.image.points)
    _silent(_image, rect, peak_threshold_db=-12.0)  # above the sidelobes: no warning
    hann = _silent(load_data, path)
    with pytest.warns(
        DataWarning,
        match=r"sidelobes reach -31\.5 dB, above the k-space peak "
        r"threshold -40 dB.*--range-window hamming \(-4\d\.\d dB\) or --range-window "
        r"blackman \(-5\d\.\d dB\)",
    ):
        _image(hann, peak_threshold_db=-40.0)  # names windows below -40 dB, not hann
    with pytest.warns(DataWarning, match=r"threshold -60 dB.*raise --peak-threshold-db"):
        _image(hann, peak_threshold_db=-60.0)  # below every window's sidelobes
    assert main(["image", str(path), "-o", str(tmp_path / "o.npz"), "--range-window", "rect"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rpm-cl: warning: the range compression's")
    for w in sorted(set(RANGE_WINDOWS) - {"rect"}):
        assert main(["image", str(path), "-o", str(tmp_path / "o.npz"), "--range-window", w]) == 0
        assert capsys.readouterr().err == "", w


def test_echo_near_the_unambiguous_range_warned(tmp_path):
    """df = 25 MHz: the range axis ends at 6 m.  A target 5.8 m away (within
    5 % of it) may as well be one at 11.8 m, wrapped: warned, naming both;
    the three targets at 0.6-1 m are not.  (A far echo alone, most of the
    power in the last quarter, reads as a conjugated spectrum instead.)"""
    far = Scene(SCENE.targets + (PointTarget((0.0, 5.8), 3.0),))
    spec = _file(tmp_path, "far.npz", spectrum=_spectrum(scene=far))
    with pytest.warns(
        DataWarning,
        match=r"an echo at 5\.8\d* m lies within 5% of the "
        r"unambiguous range c/\(2 df\) = 6 m",
    ):
        load_data(spec)
    _silent(load_data, _file(tmp_path, "near.npz"))


def test_a_bandwidth_wider_than_the_samples_span_is_refused(tmp_path):
    span = FREQ[-1] - FREQ[0] + (FREQ[1] - FREQ[0])
    _silent(load_data, _file(tmp_path, "ok.npz", bandwidth=np.float64(span)))
    with pytest.raises(InputError, match="wider than the .* Hz the frequency samples span"):
        load_data(_file(tmp_path, "wide.npz", bandwidth=np.float64(3 * span)))


@pytest.mark.parametrize(
    "window, snr_db, warned",
    [("rect", None, True), ("hann", None, False), ("rect", 30.0, True), ("hann", 16.0, False)],
)
def test_profiles_compressed_without_a_window_are_warned(tmp_path, window, snr_db, warned):
    """Range profiles given without their samples: the sidelobes are
    measured about each echo (-13.3 dB for a plain inverse FFT, -31.5 for
    Hann), against the k-space peak threshold (-20 dB); noise, symmetric
    about an echo too, is no sidelobe (Hann profiles 16 dB over their
    noise read -16 dB without that guard)."""
    from rpm_cl.imaging import profile_sidelobe_db
    from rpm_cl.io.formats import range_compress

    sig, rng = range_compress(_spectrum(), FREQ, 20e9, window)
    if snr_db is not None:
        noise = np.random.default_rng(3).standard_normal(sig.shape + (2,)) @ [1, 1j]
        peak = np.abs(sig).max(axis=1).mean()
        sig = sig + noise * peak / np.sqrt(2) / 10 ** (snr_db / 20)
    path = tmp_path / f"{window}.npz"
    np.savez(path, signal=sig, range=rng, x=ARRAY.x, fc=np.float64(20e9), bandwidth=np.float64(3e9))
    data = load_data(path)
    level = profile_sidelobe_db(data)
    if snr_db is None:
        assert level == pytest.approx(-13.3 if window == "rect" else -31.5, abs=1.5)
    elif window == "rect":  # the noise moves the -13.3 dB a little
        assert -18 < level < -11
    else:  # -31.5 dB sidelobes lie below the noise: none measured
        assert level is None or level < -25
    if warned:
        with pytest.warns(DataWarning, match=r"profiles' sidelobes reach -1\d\.\d dB .* window"):
            _image(data)
    else:
        _silent(_image, data)


def test_true_range_points_without_a_boundary_are_said_to_be_unscored(tmp_path):
    rp = {"truth_rp_antenna": np.arange(3), "truth_rp_range": np.full(3, 0.6)}
    with pytest.warns(
        DataWarning, match="truth_rp_antenna and truth_rp_range without truth_boundary"
    ):
        data = load_data(_file(tmp_path, "t.npz", **rp))
    assert data.truth is None
    bound = {**rp, "truth_boundary": np.array([[0.05, 0.6]])}
    assert _silent(load_data, _file(tmp_path, "b.npz", **bound)).truth is not None
