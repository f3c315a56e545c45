"""MALÅ rd3 / rd7 + rad -> the frequency-domain input (rpm_cl.io.mala,
`rpm-cl convert IN.rd3`).

The files are written here, to the layout of rpm_cl/io/mala.py's docstring,
from the traces of the DZT fixture (benchmarks/readers_fixture.py: a 1.6 GHz
Ricker echo from a point 0.9 m below x = 0.47 m, time zero at sample 40.5,
48 traces at 2 cm, 20 ns over 512 samples: 25 600 MHz sampling); the reader
was also checked on a real RAMAC file (ImpDAR's test line ten_col: 10 traces
of 512 samples, a 500 MHz antenna, time-triggered).
"""

import sys
from pathlib import Path

import numpy as np
import pytest

from rpm_cl.cli import main
from rpm_cl.io import mala as M
from rpm_cl.io.data import DataWarning, InputError
from rpm_cl.io.readers import convert

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import readers_fixture as RF
from test_read_dzt import assert_fixture_line

T0 = RF.DZT_TIME_ZERO


def _rad(samples=512, mhz=25600.0, step=0.02, traces=48, antenna="1600 MHz", drop=()):
    lines = {
        "SAMPLES": samples,
        "FREQUENCY": mhz,
        "FREQUENCY STEPS": 17,
        "SIGNAL POSITION": 40.5,
        "DISTANCE FLAG": 1,
        "TIME INTERVAL": 0.0,
        "DISTANCE INTERVAL": step,
        "ANTENNAS": antenna,
        "TIMEWINDOW": 999.0,  # not used (module notes)
        "LAST TRACE": traces,
    }
    return "".join(f"{k}:{v}\n" for k, v in lines.items() if k not in drop)


def _data(traces, per=2):
    full = 30000 if per == 2 else 1 << 28
    q = np.round(traces / np.abs(traces).max() * full) + (2048 if per == 2 else 0)
    return q.astype("<i2" if per == 2 else "<i4").tobytes()


def _write(tmp_path, rad=None, data=None, ext=".rd3"):
    (tmp_path / "LINE.rad").write_text(_rad() if rad is None else rad)
    p = tmp_path / ("LINE" + ext)
    p.write_bytes(_data(RF.dzt_traces(), 2 if ext == ".rd3" else 4) if data is None else data)
    return p


@pytest.mark.parametrize("ext", [".rd3", ".rd7"])
def test_the_echo_lands_at_its_range_with_the_round_trip_phase(tmp_path, ext):
    """dt from FREQUENCY (not TIMEWINDOW), the band from the antenna's
    1600 MHz, the spacing from DISTANCE INTERVAL; 16- and 32-bit samples: the
    echo compresses at its range within half a gate with the phase -2 k_c R."""
    fmt, out = convert(_write(tmp_path, ext=ext), time_zero=T0)
    assert fmt == "mala"
    assert_fixture_line(out)


def test_antenna_names():
    assert M.antenna_frequency("500_shielded_egrip") == 500e6
    assert M.antenna_frequency("250 MHz Shielded") == 250e6
    assert M.antenna_frequency("1.6GHz") == pytest.approx(1.6e9)
    assert M.antenna_frequency("Rough Terrain 100") is None
    assert M.antenna_frequency("0") is None and M.antenna_frequency("") is None


def test_the_cli_and_a_time_triggered_survey(tmp_path, capsys):
    p = _write(tmp_path, rad=_rad(step=0))
    out = tmp_path / "o.npz"
    assert main(["convert", str(p), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "time-triggered survey" in err and "--dx" in err and "\n" not in err
    args = ["convert", str(p), "-o", str(out), "--dx", "0.05", "--time-zero", str(T0), "-q"]
    assert main(args) == 0
    np.testing.assert_allclose(np.load(out)["x"], np.arange(48) * 0.05)


@pytest.mark.parametrize(
    "rad, data, message",
    [
        (_rad(drop=("SAMPLES",)), None, "no 'SAMPLES' line"),
        (_rad(mhz=0), None, "FREQUENCY:0 MHz"),
        (_rad(mhz=1e300), None, "a sample interval of 1e-306 s \\(from FREQUENCY\\) is no GPR's"),
        (_rad(samples=2), None, "SAMPLES:2: samples per trace must be a whole number"),
        (_rad(mhz="2000,5"), None, "FREQUENCY:'2000,5' is no"),
        (_rad(step=1e30), None, "gives a 1e\\+30 m trace spacing, no survey's"),
        (_rad(antenna="custom"), None, "no frequency in the header's ANTENNAS"),
        (_rad().replace("SAMPLES:512", "SAMPLES:1e999"), None, "no \\(finite\\) number"),
        (_rad(step=-1), None, "DISTANCE INTERVAL:-1 m"),
        (None, b"\0" * 1500, "1 traces of 1024 bytes"),
        (_rad(samples=1 << 40), None, "samples per trace must be a whole number, 3 .. 1048576"),
    ],
)
def test_header_errors_are_one_line(tmp_path, rad, data, message):
    p = _write(tmp_path, rad=rad, data=data)
    with pytest.raises(InputError, match=message) as info:
        convert(p, time_zero=T0)
    assert "\n" not in str(info.value)


def test_no_header_beside_it_and_a_cut_off_file(tmp_path):
    alone = tmp_path / "alone.rd3"
    alone.write_bytes(_data(RF.dzt_traces()))
    with pytest.raises(InputError, match="no header alone.rad beside it"):
        convert(alone)
    p = _write(tmp_path, data=_data(RF.dzt_traces())[:-100])
    with pytest.warns(DataWarning) as rec:
        out = convert(p, time_zero=T0)[1]
    words = " ".join(str(r.message) for r in rec)
    assert "part trace is dropped" in words and "47 traces, where LAST TRACE says 48" in words
    assert out["spectrum"].shape[0] == 47
