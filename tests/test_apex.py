"""The medium read from the focus at a GPR line's hyperbola apexes
(rpm_cl.extract.apex), where the echo tracks break.

The lines are point echoes at air-equivalent ranges ``n |p - a|`` (the
geometry, not a fit), weighted by a beam ``(d / |p - a|)^beam / |p - a|``
so that each bar is seen over a few of its neighbours' widths only, as
under a GPR antenna; the engine only compresses them (Hann).
"""

import warnings

import numpy as np
import pytest

from rpm_cl.extract.apex import EPS_GRID, apex_eps_r, focus_curve
from rpm_cl.extract.hyperbola import check_medium, fit_eps_r, tracks
from rpm_cl.io.data import C0, Array, DataWarning, RadarData, Waveform
from rpm_cl.io.formats import range_compress, range_sidelobe_db, window_bandwidth
from rpm_cl.io.medium import Medium

X = np.arange(281) * 0.005  # 1.4 m of scan at 5 mm
#: a dense row: bars 0.15 m apart, 0.1 m down (the tracks break)
ROW = np.arange(0.25, 1.2, 0.15)


def _line(eps, bars=ROW, depth=0.1, x=X, band=(0.5e9, 2.5e9), beam=4.0):
    d = np.hypot(x[:, None] - bars[None, :], depth)
    r = np.sqrt(eps) * d
    amp = (depth / d) ** beam / d
    f = np.linspace(*band, 161)
    y = (amp[:, None, :] * np.exp(-4j * np.pi * f[None, :, None] * r[:, None, :] / C0)).sum(axis=2)
    s, rng = range_compress(y, f, f.mean(), "hann")
    w = Waveform(f.mean(), window_bandwidth(f, "hann"))
    return RadarData(s, Array(x), rng, w, None, range_sidelobe_db(f, "hann", w.bandwidth))


@pytest.mark.parametrize("eps", [1.0, 5.0, 12.0])
def test_one_apex_focuses_at_its_eps_r(eps):
    """One bar, its apex given exactly: the focus peaks at the true eps_r
    to within the grid's parabola (2 %), with coherence near 1."""
    data = _line(eps, bars=np.array([0.7]))
    r0 = np.sqrt(eps) * 0.1
    near = np.abs(X - 0.7) <= r0
    curve = focus_curve(X[near], data.signal[near], data.range, data.waveform.kc, 0.7, r0, 0.0)
    i = int(np.argmax(curve))
    assert curve[i] > 0.99
    le = np.log(EPS_GRID[i - 1 : i + 2])
    y0, y1, y2 = curve[i - 1 : i + 2]
    best = np.exp(le[1] + 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2) * (le[2] - le[1]))
    assert best == pytest.approx(eps, rel=0.02)


@pytest.mark.parametrize("eps, depth", [(5.0, 0.1), (9.0, 0.2)])
def test_noise_free_lines_read_their_eps_r(eps, depth):
    """Noise-free bars 0.3 m apart under 2 m of scan at 1 cm: a steep
    trial curve leaves each echo at once and keeps its apex sample alone;
    the focus's floor (FLOOR) keeps such a curve from focusing, and the
    line reads its eps_r within 5 % (without the floor: 5.56 and 62.9)."""
    value, n, _ = apex_eps_r(
        _line(eps, bars=np.arange(0.4, 1.7, 0.3), depth=depth, x=np.arange(201) * 0.01)
    )
    assert n >= 3 and value == pytest.approx(eps, rel=0.05)


@pytest.mark.parametrize("eps", [3.0, 6.0, 12.0])
def test_separate_bars_read_their_eps_r(eps):
    """Bars 0.35 m apart: each apex reads the medium.  The focus of an
    isolated echo is exact (the test above); here the neighbours' tails
    inside the aperture pull it up, never down beyond the grid's 2 %, and
    by at most a tenth (the dense row below, twice as close, by a fifth)."""
    value, n, err = apex_eps_r(_line(eps, bars=np.array([0.35, 0.7, 1.05])))
    assert n == 3
    assert 0.98 * eps <= value <= 1.1 * eps
    assert 0 < err < 0.1 * eps


def test_a_dense_row_breaks_the_tracks_but_warns_from_its_apexes():
    """A row of bars 0.15 m apart 0.1 m down in eps_r 5: no track is long
    enough to fit, the apexes read 5-6.5 (their neighbours' echoes pull the
    focus up), and imaged as air the check warns once,
    naming that value; in its medium it is silent."""
    data = _line(5.0)
    assert fit_eps_r(data.array.positions(), tracks(data))[1] == 0
    value, n, _ = apex_eps_r(data)
    assert n >= 3 and 5.0 <= value <= 6.5
    with pytest.warns(DataWarning, match=r"focused at \d+ apexes") as rec:
        assert check_medium(data, Medium()) == pytest.approx(value)
    assert len([r for r in rec if "range walks" in str(r.message)]) == 1
    assert f"--eps-r {value:.2f}" in str(rec[0].message)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        check_medium(data, Medium(5.0))


def test_air_reads_air():
    """Bars 0.3 m down in air under the whole scan read about 1 (up to the
    neighbours' pull): silent as air; set to eps_r 5 it warns low (here
    from a track, which answers before the apexes)."""
    data = _line(1.0, depth=0.3, bars=np.arange(0.35, 1.1, 0.35))
    value, n, _ = apex_eps_r(data)
    assert n >= 3 and 0.98 <= value <= 1.2
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        check_medium(data, Medium())
    with pytest.warns(DataWarning, match="try --eps-r"):
        check_medium(data, Medium(5.0))


@pytest.mark.parametrize(
    "change",
    [
        {"x": np.arange(61) * 0.005 + 0.4},  # 0.3 m of scan: under 40 degrees either side
        {"band": (1.8e9, 2.2e9)},  # a band of 0.2 of the centre frequency
    ],
    ids=["short scan", "narrow band"],
)
def test_no_reading_where_the_data_do_not_pin_the_curvature(change):
    """A scan that does not see any apex 40 degrees either side, or a
    band under 0.4 of its centre frequency: no reading at all."""
    assert apex_eps_r(_line(5.0, **change))[1] == 0


def test_tiny_inputs_read_nothing():
    """Two antennas, or profiles of zeros: no reading."""
    assert apex_eps_r(_line(5.0, x=X[:2]))[1] == 0
    line = _line(5.0)
    value, n, err = apex_eps_r(
        RadarData(np.zeros_like(line.signal), Array(X), line.range, line.waveform)
    )
    assert np.isnan(value) and n == 0 and err == np.inf


def test_noise_reads_nothing():
    """Lines of white noise alone: a maximum may focus by chance, never
    three in one line (the estimate needs MIN_APEXES)."""
    line = _line(5.0)
    rng = np.random.default_rng(7)
    for _ in range(10):
        noise = rng.standard_normal(line.signal.shape) + 1j * rng.standard_normal(line.signal.shape)
        data = RadarData(noise, Array(X), line.range, line.waveform)
        assert apex_eps_r(data)[1] == 0


def test_eps_r_auto_reads_the_medium():
    """``default_params(data, eps_r="auto")`` images in the medium the
    hyperbolas read (the apexes' here); a scan where nothing pins it is
    imaged as air, with one warning saying so."""
    from rpm_cl.rpm.params import default_params
    from rpm_cl.simulate import simulate_preset

    data = _line(5.0)
    reading = apex_eps_r(data)[0]
    assert default_params(data, eps_r="auto").medium.eps_r == pytest.approx(reading)
    assert default_params(data, eps_r="AUTO").medium.eps_r == pytest.approx(reading)
    air = simulate_preset("paper-2d", None, seed=0)[0]  # narrow band: no apex is read
    with pytest.warns(DataWarning, match="eps_r auto: no echo track or apex") as rec:
        assert default_params(air, eps_r="auto").medium.eps_r == 1.0
    assert len(rec) == 1
    with pytest.warns(DataWarning, match="planar arrays are not read"):
        assert default_params(simulate_preset("human-body")[0], eps_r="auto").medium.eps_r == 1.0


def test_cli_eps_r_auto(tmp_path, capsys):
    """``--eps-r auto`` on the command line and ``eps_r = "auto"`` in a
    config: image, das and rma read the row's medium, print it with -v and
    draw no medium warning; another word is one error line, exit 2."""
    from rpm_cl.cli import main
    from rpm_cl.io.formats import save_data

    path = tmp_path / "row.npz"
    save_data(path, _line(5.0))
    cfg = tmp_path / "c.toml"
    cfg.write_text('[medium]\neps_r = "auto"\n')
    out = str(tmp_path / "o.npz")
    for argv in (
        ["image", str(path), "-o", out, "--eps-r", "auto", "-v"],
        ["image", str(path), "-o", out, "--config", str(cfg), "-v"],
        [
            "das",
            str(path),
            "-o",
            out,
            "--grid",
            "0:1.4:0.01,0.05:0.4:0.01",
            "--eps-r",
            "auto",
            "-v",
        ],
        ["rma", str(path), "-o", out, "--eps-r", "auto", "-v"],
    ):
        assert main(argv) == 0, argv
        err = capsys.readouterr().err
        assert "eps_r auto: 5." in err or "eps_r auto: 6." in err, err
        assert "range walks" not in err
    from rpm_cl.cli.batch_config import BatchConfig

    BatchConfig(overrides=((("medium", "eps_r"), " Auto "),))  # read per frame
    assert main(["image", str(path), "-o", out, "--eps-r", "auto5"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "must be a number or 'auto'" in err[0]


def test_a_reading_is_kept_by_its_datas_content(monkeypatch):
    """``--eps-r auto`` reads the medium in the parameters and the run's
    check meets the same data again: the second is served from the kept
    reading, and any change to what a reading reads (a sample, a position,
    the band, the antenna height) reads anew."""
    from dataclasses import replace

    from rpm_cl.extract import hyperbola

    calls = []
    read = hyperbola._read
    monkeypatch.setattr(hyperbola, "_read", lambda *a: calls.append(1) or read(*a))
    monkeypatch.setattr(hyperbola, "_readings", {})
    data = _line(5.0)
    first = hyperbola._estimate(data, None)
    assert hyperbola._estimate(replace(data, signal=data.signal.copy()), None) == first
    assert len(calls) == 1
    changed = data.signal.copy()
    changed[140, 40] += 1e-3 * np.abs(changed).max()
    other_x = Array(X + 1e-3)
    for again in (
        replace(data, signal=changed),
        RadarData(data.signal, other_x, data.range, data.waveform),
        replace(data, waveform=Waveform(data.waveform.fc, 0.9 * data.waveform.bandwidth)),
    ):
        hyperbola._estimate(again, None)
    hyperbola._estimate(data, 0.05)
    assert len(calls) == 5
    assert len(hyperbola._readings) == hyperbola.READINGS_KEPT
    # the oldest went first: read once more, then kept, and warned each time
    for _ in range(2):
        with pytest.warns(DataWarning, match="range walks"):
            check_medium(data, Medium())
    assert len(calls) == 6
