"""Sensors & Software pulseEKKO DT1 + HD -> the frequency-domain input
(rpm_cl.io.dt1, `rpm-cl convert IN.DT1`).

The files are written here, to the layout of rpm_cl/io/dt1.py's docstring,
from the traces of the DZT fixture (benchmarks/readers_fixture.py: a 1.6 GHz
Ricker echo from a point 0.9 m below x = 0.47 m, time zero at sample 40.5,
48 traces at 2 cm); the reader was also checked on a real pulseEKKO PRO line
(GPRPy's example XLINE00, 531 traces of 1500 samples, 50 MHz, feet).
"""

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from rpm_cl.cli import main
from rpm_cl.io import dt1 as D
from rpm_cl.io.data import C0, DataWarning, InputError
from rpm_cl.io.readers import convert

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import readers_fixture as RF
from test_read_dzt import assert_fixture_line

T0 = RF.DZT_TIME_ZERO


def _hd(traces=48, samples=512, window=20.0, step=2.0, units="cm", mhz=1600.0, drop=()):
    lines = {
        "NUMBER OF TRACES": traces,
        "NUMBER OF PTS/TRC": samples,
        "TIMEZERO AT POINT": 40.5,
        "TOTAL TIME WINDOW": window,
        "STARTING POSITION": 0.0,
        "FINAL POSITION": (traces - 1) * step,
        "STEP SIZE USED": step,
        "POSITION UNITS": units,
        "NOMINAL FREQUENCY": mhz,
        "ANTENNA SEPARATION": 0.06,
    }
    body = "".join(f"{k:<19}= {v}\n" for k, v in lines.items() if k not in drop)
    return "1234\nData Collected with pE PRO\n2026-11-29\n" + body


def _dt1(traces, step=2.0, per=2, samples=None, window_word=800.0):
    n = traces.shape[1]
    full = 30000 if per == 2 else 1 << 28
    q = np.round(traces / np.abs(traces).max() * full)
    out = b""
    for i, row in enumerate(q):
        head = np.zeros(32, "<f4")
        head[0], head[1], head[2] = i + 1, i * step, n if samples is None else samples
        head[5], head[6], head[7] = per, window_word, 8
        out += head.tobytes() + row.astype("<i2" if per == 2 else "<i4").tobytes()
    return out


def _write(tmp_path, name="LINE", hd=None, data=None, ext=".HD"):
    (tmp_path / (name + ext)).write_text(_hd() if hd is None else hd)
    p = tmp_path / (name + ".DT1")
    p.write_bytes(_dt1(RF.dzt_traces()) if data is None else data)
    return p


@pytest.mark.parametrize("per", [2, 4])
def test_the_echo_lands_at_its_range_with_the_round_trip_phase(tmp_path, per):
    """The HD's window (not the trace headers' word 6) sets the samples'
    spacing, the step in cm the positions, the nominal 1600 MHz the band
    (0.8-2.4 GHz); time zero at sample 40.5: the echo compresses at its range
    within half a gate with the phase -2 k_c R, from 2- and 4-byte samples."""
    p = _write(tmp_path, data=_dt1(RF.dzt_traces(), per=per))
    fmt, out = convert(p, time_zero=T0)
    assert fmt == "dt1"
    assert_fixture_line(out)
    assert out["record_range"] == pytest.approx((512 - T0) * 20e-9 / 512 * C0 / 2)


def test_the_cli_converts_by_extension_and_refuses_a_dzt_option(tmp_path, capsys):
    p = _write(tmp_path, hd=_hd(units="ft", step=0.1), ext=".hd")
    out = tmp_path / "o.npz"
    assert main(["convert", str(p), "-o", str(out), "--time-zero", str(T0), "-q"]) == 0
    np.testing.assert_allclose(np.load(out)["x"], np.arange(48) * 0.1 * 0.3048)
    assert main(["convert", str(p), "-o", str(out), "--channel", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--channel does not apply to dt1 input" in err and "\n" not in err


@pytest.mark.parametrize(
    "hd, data, message",
    [
        (_hd(units="furlong"), None, "POSITION UNITS 'furlong'; known: .* or give the trace"),
        (_hd(drop=("NUMBER OF PTS/TRC",)), None, "no 'NUMBER OF PTS/TRC' line"),
        (_hd(window=0), None, "TOTAL TIME WINDOW = 0 ns"),
        (_hd(window=1e30), None, "a sample interval of 1.95e\\+18 s \\(from TOTAL TIME WINDOW"),
        (_hd(samples=500), None, "first trace says 512 samples, the HD 500"),
        (_hd(drop=("STEP SIZE USED",)), None, "no STEP SIZE USED: give the trace spacing"),
        (_hd(drop=("NOMINAL FREQUENCY",)), None, "no NOMINAL FREQUENCY: give --band"),
        (None, b"\0" * 100, "shorter than a trace header"),
        (_hd().replace("= 512", "= lots"), None, "is no \\(finite\\) number"),
        (_hd().replace("= 512", "= 1e400"), None, "is no \\(finite\\) number"),
        (_hd(samples=2**40), None, "samples per trace must be a whole number, 3 .. 1048576"),
        (_hd(samples=100.5), None, "samples per trace must be a whole number"),
        (_hd(window="50,5"), None, "TOTAL TIME WINDOW = '50,5' is no"),
        (_hd(step=1e30), None, "gives a 1e\\+28 m trace spacing, no survey's"),
    ],
)
def test_header_errors_are_one_line(tmp_path, hd, data, message):
    p = _write(tmp_path, hd=hd, data=data)
    with pytest.raises(InputError, match=message) as info:
        convert(p, time_zero=T0)
    assert "\n" not in str(info.value)


def test_a_trace_of_another_length_midway_is_refused(tmp_path):
    raw = bytearray(_dt1(RF.dzt_traces()))
    trace = 128 + 2 * 512
    raw[10 * trace + 8 : 10 * trace + 12] = np.float32(256).tobytes()
    with pytest.raises(InputError, match="trace 11 says 256 samples"):
        convert(_write(tmp_path, data=bytes(raw)), time_zero=T0)


def test_no_header_beside_it(tmp_path):
    p = tmp_path / "alone.DT1"
    p.write_bytes(_dt1(RF.dzt_traces()))
    with pytest.raises(InputError, match="no header alone.HD beside it"):
        convert(p)


def test_a_cut_off_file_and_a_miscounted_header_warn(tmp_path):
    raw = _dt1(RF.dzt_traces())
    p = _write(tmp_path, data=raw[:-100])
    with pytest.warns(DataWarning) as rec:
        out = convert(p, time_zero=T0)[1]
    words = " ".join(str(r.message) for r in rec)
    assert "part trace is dropped" in words and "47 traces, where the HD says 48" in words
    assert out["spectrum"].shape[0] == 47
    with pytest.raises(InputError, match="a B-scan needs at least 2"):
        convert(_write(tmp_path, data=raw[: 128 + 2 * 512]), time_zero=T0)


def test_time_zero_outside_the_trace_and_a_band_past_nyquist(tmp_path):
    p = _write(tmp_path)
    with pytest.raises(InputError, match="time zero at sample 600"):
        convert(p, time_zero=600)
    with pytest.raises(InputError, match="Nyquist"):
        convert(p, band=(1e9, 20e9))
    assert D.read_hd(p).time_zero == 40.5


def test_a_strangers_header(tmp_path):
    """Keys with doubled blanks and units spelt out are read; a unit the
    reader does not know is no matter when --dx is given; a header that is
    no regular file, or too long, is refused in one line; a trace of
    another length midway is refused before anything is read or warned."""
    hd = _hd(units="metres", step=0.02).replace("NUMBER OF PTS/TRC", "NUMBER OF  PTS/TRC")
    np.testing.assert_allclose(convert(_write(tmp_path, hd=hd), time_zero=T0)[1]["x"][1], 0.02)
    other = tmp_path / "o"
    other.mkdir()
    p = _write(other, hd=_hd(units="furlong"))
    assert convert(p, time_zero=T0, dx=0.03)[1]["x"][1] == pytest.approx(0.03)
    odd = tmp_path / "odd"
    odd.mkdir()
    (odd / "L.DT1").write_bytes(_dt1(RF.dzt_traces()))
    (odd / "L.HD").symlink_to("/dev/zero")
    with pytest.raises(InputError, match="must be a regular file"):
        convert(odd / "L.DT1")
    (odd / "L.HD").unlink()
    (odd / "L.HD").write_text(_hd() + "X = 1\n" * 20000)
    with pytest.raises(InputError, match="no GPR header"):
        convert(odd / "L.DT1")
    raw = bytearray(_dt1(RF.dzt_traces()))
    raw[30 * (128 + 1024) + 8 : 30 * (128 + 1024) + 12] = np.float32(7).tobytes()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(InputError, match="trace 31 says 7 samples"):
            convert(_write(tmp_path, data=bytes(raw)[:-100]), time_zero=T0)
