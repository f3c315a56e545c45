"""TI mmWave + DCA1000 raw ADC -> the frequency-domain input (rpm_cl.io.dca1000,
`rpm-cl convert IN.bin`).

The fixture tests/data/readers/capture.bin is synthetic (no capture could be
downloaded): benchmarks/readers_fixture.py writes TI's dechirped IF,
``TX conj(RX) = a exp(+j 2 pi (f0 tau + S tau t - S tau^2 / 2))`` of a point
1.2 m away, in the complex 2-lane layout of xWR16xx/18xx/68xx (SWRA581),
4 receivers, 2 chirps per frame, 20 frames with the radar moved 1 mm
between frames.
"""

import sys
from pathlib import Path

import numpy as np
import pytest

from rpm_cl.cli import main
from rpm_cl.io import dca1000 as D
from rpm_cl.io.data import C0, InputError
from rpm_cl.io.formats import load_data, range_compress
from rpm_cl.io.readers import convert

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import readers_fixture as RF

CAPTURE = Path(__file__).parent / "data" / "readers" / "capture.bin"
P = RF.DCA
CHIRP = {
    "slope": P["slope"],
    "adc_rate": P["adc_rate"],
    "samples": P["samples"],
    "start_freq": P["start_freq"],
    "adc_start_time": P["adc_start_time"],
    "chirps": P["chirps"],
    "rx": P["receivers"],
}
ARGS = [
    "--slope",
    str(P["slope"]),
    "--adc-rate",
    str(P["adc_rate"]),
    "--samples",
    str(P["samples"]),
    "--start-freq",
    str(P["start_freq"]),
    "--adc-start-time",
    str(P["adc_start_time"]),
    "--chirps",
    "2",
    "--rx",
    "4",
]


def _one_error(capsys, argv) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("rpm-cl: error:") and "\n" not in err
    return err


def _peaks(spectrum, frequency, true):
    """Compressed peak ranges of each row, their phase relative to
    -2 k_c R_true, and the gate."""
    fc = float(frequency.mean())
    s, r = range_compress(spectrum, frequency, fc, "hann")
    i = np.abs(s).argmax(axis=-1)
    peak = np.take_along_axis(s, i[..., None], axis=-1)[..., 0]
    return r[i], np.angle(peak * np.exp(4j * np.pi * fc * true / C0)), r[1] - r[0]


def test_layouts_decode_as_ti_documents_them():
    """SWRA581: 2-lane complex groups I(n) I(n+1) Q(n) Q(n+1), receiver after
    receiver in a chirp; 4-lane complex per sample I of lanes 0-3 then Q of
    lanes 0-3; real: receiver after receiver."""
    two = D.Chirp(1e12, 1e6, 2, 77e9, receivers=2, layout="complex-2lane")
    z = D.decode(np.array([1, 2, 3, 4, 5, 6, 7, 8], np.int16), two)
    np.testing.assert_array_equal(z, [[[1 + 3j, 2 + 4j], [5 + 7j, 6 + 8j]]])
    four = D.Chirp(1e12, 1e6, 2, 77e9, receivers=2, layout="complex-4lane")
    v = np.array([1, 2, 0, 0, 3, 4, 0, 0, 5, 6, 0, 0, 7, 8, 0, 0], np.int16)
    np.testing.assert_array_equal(D.decode(v, four), [[[1 + 3j, 5 + 7j], [2 + 4j, 6 + 8j]]])
    real = D.Chirp(1e12, 1e6, 2, 77e9, receivers=2, layout="real")
    np.testing.assert_array_equal(
        D.decode(np.array([1, 2, 3, 4], np.int16), real), [[[1, 2], [3, 4]]]
    )
    # the fixture writer follows the same documented orders
    zz = np.array([[[1 + 3j, 2 + 4j], [5 + 7j, 6 + 8j]]])
    np.testing.assert_array_equal(RF.dca_values(zz, "complex-2lane"), np.arange(1, 9))
    np.testing.assert_array_equal(RF.dca_values(zz.transpose(0, 2, 1), "complex-4lane"), v)


def test_frequency_axis_follows_the_adc_sampling_instants():
    c = D.Chirp(
        **{k: CHIRP[k] for k in ("slope", "adc_rate", "samples", "start_freq", "adc_start_time")}
    )
    f = c.frequency
    assert f[0] == pytest.approx(P["start_freq"] + P["slope"] * P["adc_start_time"])
    np.testing.assert_allclose(np.diff(f), P["slope"] / P["adc_rate"])


def test_synthetic_aperture_echo_lands_at_its_range_with_the_right_phase_sign():
    """One position per frame (--dx), receiver 0 (at the transmitter): each
    position's compressed peak at its true range within half a gate, with the
    phase -2 k_c R. Without the conjugate, TI's exp(+j 2 pi f_n tau) would
    put the echo at the unambiguous range minus R (checked below), so a
    conjugation mistake fails the range test; the phase test catches a
    frequency axis off by the ADC start time (0.18 GHz: 9 rad at 1.2 m)."""
    fmt, out = convert(CAPTURE, dx=P["dx"], **CHIRP)
    assert fmt == "dca1000" and out["spectrum"].shape == (20, 64)
    np.testing.assert_allclose(out["x"], np.arange(20) * P["dx"])
    tx, ty = P["target"]
    true = np.hypot(out["x"] - tx, ty)
    got, phase, gate = _peaks(out["spectrum"], out["frequency"], true)
    assert np.max(np.abs(got - true)) <= 0.5 * gate + 1e-9
    # the residual video phase pi S tau^2 (6 mrad) and int16 rounding remain
    assert np.max(np.abs(phase)) < 0.02
    wrong, _, _ = _peaks(np.conj(out["spectrum"]), out["frequency"], true)
    r_u = C0 / (2 * (out["frequency"][1] - out["frequency"][0]))
    np.testing.assert_allclose(wrong, r_u - true, atol=gate)


def test_receivers_as_the_array_at_their_midpoints():
    """--rx-spacing: receiver k at k d / 2 (its midpoint with the
    transmitter); 20 frames make a stack, frame 0 has the radar at x = 0.
    The fixture's echoes are the exact bistatic ones; the midpoint model's
    ranges differ from them by at most b^2 / (8 R) for a pair b apart (3.6 um
    for the outer receiver, 0.011 rad of phase at 77 GHz)."""
    out = convert(CAPTURE, rx_spacing=P["rx_spacing"], **CHIRP)[1]
    assert out["spectrum"].shape == (20, 4, 64)
    np.testing.assert_allclose(out["x"], np.arange(4) * P["rx_spacing"] / 2)
    tx, ty = P["target"]
    bistatic = (np.hypot(tx, ty) + np.hypot(np.arange(4) * P["rx_spacing"] - tx, ty)) / 2
    b = np.arange(4) * P["rx_spacing"]
    assert np.all(np.abs(bistatic - np.hypot(out["x"] - tx, ty)) <= b**2 / (8 * ty) + 1e-12)
    got, phase, gate = _peaks(out["spectrum"][0], out["frequency"], bistatic)
    assert np.max(np.abs(got - bistatic)) <= 0.5 * gate + 1e-9
    assert np.max(np.abs(phase)) < 0.02


def test_four_lane_and_split_captures_read_alike(tmp_path):
    ref = convert(CAPTURE, dx=P["dx"], **CHIRP)[1]
    four = tmp_path / "four.bin"
    four.write_bytes(RF.dca_values(RF.dca_if(), "complex-4lane").tobytes())
    out = convert(four, dx=P["dx"], layout="complex-4lane", **CHIRP)[1]
    np.testing.assert_array_equal(out["spectrum"], ref["spectrum"])
    raw = CAPTURE.read_bytes()
    a, b = tmp_path / "cap_Raw_0.bin", tmp_path / "cap_Raw_1.bin"
    a.write_bytes(raw[:1000])
    b.write_bytes(raw[1000:])
    np.testing.assert_array_equal(
        convert([a, b], dx=P["dx"], **CHIRP)[1]["spectrum"], ref["spectrum"]
    )


def test_chirps_of_a_frame_are_averaged():
    per_chirp = convert(CAPTURE, dx=P["dx"], **{**CHIRP, "chirps": 1})[1]["spectrum"]
    per_frame = convert(CAPTURE, dx=P["dx"], **CHIRP)[1]["spectrum"]
    assert per_chirp.shape == (40, 64)
    np.testing.assert_allclose(per_frame, per_chirp.reshape(20, 2, 64).mean(axis=1))


def test_real_samples_through_their_analytic_signal(tmp_path):
    """Real-only ADC output: the analytic signal of a chirp of 1.5 beat
    cycles carries edge errors, so the bounds are one gate and 0.1 rad."""
    p = tmp_path / "real.bin"
    p.write_bytes(RF.dca_values(RF.dca_if(real=True), "real").tobytes())
    out = convert(p, dx=P["dx"], layout="real", **CHIRP)[1]
    tx, ty = P["target"]
    true = np.hypot(out["x"] - tx, ty)
    got, phase, gate = _peaks(out["spectrum"], out["frequency"], true)
    assert np.max(np.abs(got - true)) <= gate
    assert np.max(np.abs(phase)) < 0.1


@pytest.mark.parametrize(
    "change, message",
    [
        ({"samples": 65}, "not a whole number of frames"),
        ({"chirps": 3}, "not a whole number of frames"),
        ({"rx": 3}, "hold 1, 2 or 4 receivers"),
        ({"rx": 5}, "receivers must be 1 .. 4"),
        ({"layout": "iq"}, "layout 'iq' is not one of"),
        ({"receiver": 4}, "receiver 4: the capture holds 4"),
        ({"dx": None}, "--dx .* or --rx-spacing"),
        ({"rx_spacing": 2e-3}, "--dx .* or --rx-spacing"),
        ({"start_freq": 1e9, "slope": -1.0}, "slope must be > 0"),
        ({"start_freq": 77.0}, r"start frequency 77 Hz .* GHz numbers"),
        ({"slope": 29.982e6}, r"ramp sweeps .* is the slope 2.9982e\+07 in MHz/us x 1e6"),
    ],
)
def test_capture_errors_are_one_line(change, message):
    kw = {**CHIRP, "dx": P["dx"], **change}
    with pytest.raises(InputError, match=message) as info:
        convert(CAPTURE, **{k: v for k, v in kw.items() if v is not None})
    assert "\n" not in str(info.value)


def test_one_frame_and_one_receiver_are_refused(tmp_path, monkeypatch):
    with pytest.raises(InputError, match="one frame"):
        convert(CAPTURE, dx=P["dx"], **{**CHIRP, "chirps": 40})
    with pytest.raises(InputError, match="one receiver"):
        convert(CAPTURE, rx_spacing=2e-3, **{**CHIRP, "rx": 1, "chirps": 8})
    monkeypatch.setattr(D, "MAX_VALUES", 1000)
    with pytest.raises(InputError, match="more than 2000"):
        convert(CAPTURE, dx=P["dx"], **CHIRP)


# --------------------------------------------------------------------- CLI
def test_cli_convert_dca1000(tmp_path, capsys):
    out = tmp_path / "sar.h5"
    assert main(["convert", str(CAPTURE), *ARGS, "--dx", "1e-3", "-o", str(out)]) == 0
    assert "dca1000, spectrum (20, 64)" in capsys.readouterr().out
    data = load_data(out)
    assert data.array.n == 20
    stack = tmp_path / "stack.npz"
    assert (
        main(
            [
                "convert",
                str(CAPTURE),
                *ARGS,
                "--rx-spacing",
                str(P["rx_spacing"]),
                "-o",
                str(stack),
                "-q",
            ]
        )
        == 0
    )
    assert load_data(stack, frame=3).array.n == 4


def test_cli_convert_dca1000_errors_are_one_line(tmp_path, capsys):
    copy = tmp_path / "c.bin"
    copy.write_bytes(CAPTURE.read_bytes())
    o = str(tmp_path / "o.npz")
    assert "is also an input" in _one_error(
        capsys, ["convert", str(copy), *ARGS, "--dx", "1e-3", "-o", str(copy)]
    )
    assert copy.read_bytes() == CAPTURE.read_bytes()
    assert "dca1000 input needs --slope" in _one_error(capsys, ["convert", str(copy), "-o", o])
    assert "--time-zero does not apply to dca1000 input (it is for dzt, dt1, mala)" in _one_error(
        capsys, ["convert", str(copy), *ARGS, "--dx", "1e-3", "--time-zero", "3", "-o", o]
    )
    assert "--slope does not apply to dzt input" in _one_error(
        capsys, ["convert", str(copy), "--format", "dzt", "--slope", "3e13", "-o", o]
    )
    assert "not a whole number of frames" in _one_error(
        capsys, ["convert", str(copy), *ARGS[:-1], "2", "--dx", "1e-3", "--samples", "48", "-o", o]
    )
    assert not (tmp_path / "o.npz").exists()
