"""GSSI DZT -> the frequency-domain input (rpm_cl.io.dzt, `rpm-cl convert IN.dzt`).

The fixture tests/data/readers/scan.dzt is synthetic (a real GSSI line,
without truth, is tests/test_real_files.py's): benchmarks/readers_fixture.py writes the 1024-byte header and
16-bit samples to the layout of rpm_cl/io/dzt.py's docstring, 48 scans at 2 cm
(50 scans per metre) of a 1.6 GHz Ricker echo from a point 0.9 m below x =
0.47 m (in air), time zero at sample 40.5, and a direct coupling at time
zero, the same in every trace.
"""

import struct
import sys
from pathlib import Path

import numpy as np
import pytest

from rpm_cl.cli import main
from rpm_cl.io import dzt as Z
from rpm_cl.io.data import C0, DataWarning, InputError
from rpm_cl.io.formats import load_data, range_compress
from rpm_cl.io.readers import convert

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import readers_fixture as RF

SCAN = Path(__file__).parent / "data" / "readers" / "scan.dzt"
T0 = RF.DZT_TIME_ZERO


def _one_error(capsys, argv) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("rpm-cl: error:") and "\n" not in err
    return err


def echoes(arrays, window="hann", r_min=0.4, r_max=3.0):
    """Per trace of a line of the fixture's traces (this file's, and the
    DT1 and MALÅ tests' files written from them): the compressed peak
    between r_min and r_max, the true range, the peak's phase relative to
    -2 k_c R_true, the gate."""
    f = arrays["frequency"]
    fc = float(f.mean())
    s, r = range_compress(arrays["spectrum"], f, fc, window)
    tx, ty = RF.DZT["target"]
    true = np.hypot(arrays["x"] - tx, ty)
    keep = (r > r_min) & (r < r_max)
    i = np.abs(s[:, keep]).argmax(axis=1) + np.argmax(keep)
    peak = s[np.arange(len(i)), i]
    return r[i], true, np.angle(peak * np.exp(4j * np.pi * fc * true / C0)), r[1] - r[0]


def test_header_fields_at_their_documented_offsets():
    h = Z.read_header(SCAN)
    assert (h.tag, h.data_offset, h.samples, h.bits, h.zero) == (0x00FF, 1024, 512, 16, 0x8000)
    assert h.scans_per_metre == 50.0 and h.channels == 1 and h.antennas == ("51600S",)
    assert h.window == pytest.approx(20e-9) and h.dt == pytest.approx(20e-9 / 512)
    raw = SCAN.read_bytes()
    assert struct.unpack_from("<H", raw, 4)[0] == 512 and raw[98:104] == b"51600S"


def test_the_echo_lands_at_its_range_with_the_round_trip_phase():
    """Time zero at the fractional sample 40.5 and NumPy's exp(-j 2 pi f t):
    the zero-phase Ricker echo of range R must compress to a peak at R (within
    half a gate) with the phase -2 k_c R (its spectrum is real and positive).
    A wrong sign of the transform or of the time-zero shift moves every peak
    by metres (R_u - R, or 2 x 40.5 samples = 0.91 m)."""
    fmt, out = convert(SCAN, time_zero=T0)
    assert fmt == "dzt"
    # the antenna 51600S is GSSI's 1.6 GHz model: band 0.8 .. 2.4 GHz
    assert_fixture_line(out)


def assert_fixture_line(out):
    """The fixture's line as a reader converts it (this file's, and the DT1
    and MALÅ tests' files written from its traces): 48 traces at 2 cm, the
    band 0.8-2.4 GHz on the 20 ns record's grid, each echo within half a
    gate of its range with the phase -2 k_c R (16-bit quantisation and the
    Ricker's truncation leave a few mrad)."""
    f = out["frequency"]
    assert f[0] == pytest.approx(0.8e9) and f[-1] == pytest.approx(2.4e9)
    np.testing.assert_allclose(np.diff(f), 1 / (2 * 20e-9))
    np.testing.assert_allclose(out["x"], np.arange(48) * 0.02)
    got, true, phase, gate = echoes(out)
    assert np.max(np.abs(got - true)) <= 0.5 * gate + 1e-9
    assert np.max(np.abs(phase)) < 0.02


def test_8_and_32_bit_samples_and_a_second_channel(tmp_path):
    ref = convert(SCAN, time_zero=T0)[1]
    for bits in (8, 32):
        p = tmp_path / f"b{bits}.dzt"
        p.write_bytes(RF.dzt_bytes(RF.dzt_traces(), bits=bits))
        out = convert(p, time_zero=T0)[1]
        got, true, phase, gate = echoes(out)
        assert np.max(np.abs(got - true)) <= 0.5 * gate + 1e-9
        assert np.max(np.abs(phase)) < (0.2 if bits == 8 else 0.02)
    two = tmp_path / "two.dzt"
    two.write_bytes(RF.dzt_bytes(RF.dzt_traces(), channels=2))
    assert Z.read_header(two).data_offset == 2048
    for ch in (0, 1):
        np.testing.assert_array_equal(
            convert(two, time_zero=T0, channel=ch)[1]["spectrum"], ref["spectrum"]
        )


def test_subtract_mean_removes_the_direct_coupling():
    plain = convert(SCAN, time_zero=T0)[1]
    clean = convert(SCAN, time_zero=T0, subtract_mean=True)[1]

    def near(a):
        s, r = range_compress(a["spectrum"], a["frequency"], a["frequency"].mean(), "hann")
        return np.abs(s[:, r < 0.15]).max()

    assert near(clean) < 1e-3 * near(plain)
    # the echo stays, though the mean trace holds a blurred copy of its apex
    got, true, _, gate = echoes(clean)
    assert np.max(np.abs(got - true)) <= 4 * gate


def test_dx_and_an_explicit_band(tmp_path):
    out = convert(SCAN, time_zero=T0, dx=0.01, band=(1e9, 2e9))[1]
    np.testing.assert_allclose(out["x"], np.arange(48) * 0.01)
    assert out["frequency"][0] == pytest.approx(1e9) and out["frequency"][-1] == pytest.approx(2e9)


def test_nominal_band_from_the_antenna_name():
    assert Z.nominal_band("3101D") == pytest.approx((450e6, 1350e6))
    assert Z.nominal_band("400MHz") == pytest.approx((200e6, 600e6))
    assert Z.nominal_band("Palm 2.6 GHz") == pytest.approx((1.3e9, 3.9e9))
    assert Z.nominal_band("9999") is None and Z.nominal_band("") is None


def _with(path, offset, fmt, value, data=None):
    raw = bytearray(SCAN.read_bytes() if data is None else data)
    struct.pack_into(fmt, raw, offset, value)
    path.write_bytes(raw)
    return path


@pytest.mark.parametrize(
    "offset, fmt, value, message",
    [
        (6, "<H", 12, "rh_bits 12"),
        (4, "<H", 2, "at least 3 samples"),
        (52, "<H", 0, "rh_nchan 0"),
        (2, "<H", 100, "beyond the file"),
        (26, "<f", 0.0, "time window must be > 0"),
        (14, "<f", -1.0, "scans per metre must be >= 0"),
        (14, "<f", 1e-30, r"1e-30 scans per metre .* is no survey's: give the scan spacing"),
        (14, "<f", 1e30, r"1e\+30 scans per metre .* is no survey's"),
        (4, "<H", 60000, "0 scans of"),
    ],
)
def test_header_errors_are_one_line(tmp_path, offset, fmt, value, message):
    p = _with(tmp_path / "bad.dzt", offset, fmt, value)
    with pytest.raises(InputError, match=message) as info:
        convert(p, time_zero=T0)
    assert "\n" not in str(info.value) and str(p) in str(info.value)


def test_the_tag_is_not_judged_but_a_strangers_file_is_refused(tmp_path):
    """GSSI documents rh_tag 0x00FF, but real files carry others (a
    SIR-3000 400 MHz survey, GPRPy's example FILE____032.DZT: 0x0700): the
    same file under another tag converts to the same arrays, and what is no
    DZT file is refused by its other fields, in one line."""
    want = convert(SCAN, time_zero=T0)[1]
    for tag in (0x0700, 0x1234):
        got = convert(_with(tmp_path / f"t{tag}.dzt", 0, "<H", tag), time_zero=T0)[1]
        assert set(got) == set(want)
        for k in want:
            np.testing.assert_array_equal(np.asarray(got[k]), np.asarray(want[k]), err_msg=k)
    text = tmp_path / "notes.dzt"
    text.write_bytes(b"This is not a radar file at all. " * 200)
    with pytest.raises(InputError, match="rh_nchan") as info:
        convert(text)
    assert "\n" not in str(info.value)


def test_refusals_of_the_conversion(tmp_path, monkeypatch):
    with pytest.raises(InputError, match="give the scan spacing"):
        convert(_with(tmp_path / "t.dzt", 14, "<f", 0.0), time_zero=T0)
    with pytest.raises(InputError, match="no band given and none known for antenna 'XYZ'"):
        convert(_with(tmp_path / "a.dzt", 98, "<14s", b"XYZ"), time_zero=T0)
    with pytest.raises(InputError, match="Nyquist"):
        convert(SCAN, band=(1e9, 20e9))
    with pytest.raises(InputError, match="holds 1 frequency samples"):
        convert(SCAN, band=(1.0e9, 1.01e9))
    with pytest.raises(InputError, match="time zero at sample 511"):
        convert(SCAN, time_zero=511)
    with pytest.raises(InputError, match="channel 1; the file holds 1"):
        convert(SCAN, channel=1)
    short = tmp_path / "short.dzt"
    short.write_bytes(SCAN.read_bytes()[: 1024 + 1024 + 10])
    with pytest.raises(InputError, match="1 scans of 1024 bytes"):
        convert(short)
    monkeypatch.setattr(Z, "MAX_SAMPLES", 1000)
    with pytest.raises(InputError, match="more than 1000"):
        convert(SCAN)


def test_a_part_scan_at_the_end_is_dropped_with_a_warning(tmp_path):
    p = tmp_path / "cut.dzt"
    p.write_bytes(SCAN.read_bytes()[:-100])
    with pytest.warns(DataWarning, match="part scan is dropped"):
        out = convert(p, time_zero=T0)[1]
    assert out["spectrum"].shape[0] == 47


# --------------------------------------------------------------------- CLI
def test_cli_convert_dzt(tmp_path, capsys):
    out = tmp_path / "scan.npz"
    assert main(["convert", str(SCAN), "--time-zero", "40.5", "-o", str(out)]) == 0
    assert "dzt, spectrum (48, 65)" in capsys.readouterr().out
    data = load_data(out)
    assert data.array.n == 48 and data.waveform.fc == pytest.approx(1.6e9)
    copy = tmp_path / "c.dzt"
    copy.write_bytes(SCAN.read_bytes())
    assert "is also an input" in _one_error(capsys, ["convert", str(copy), "-o", str(copy)])
    assert copy.read_bytes() == SCAN.read_bytes()
    assert "--map does not apply to dzt input (it is for arrays)" in _one_error(
        capsys, ["convert", str(SCAN), "--map", "spectrum=a", "-o", str(tmp_path / "o.npz")]
    )
    assert "2 DZT files; convert one at a time" in _one_error(
        capsys, ["convert", str(SCAN), str(copy), "-o", str(tmp_path / "o.npz")]
    )
    assert "time zero must be a sample number" in _one_error(
        capsys, ["convert", str(SCAN), "--time-zero", "-3", "-o", str(tmp_path / "o.npz")]
    )
    assert not (tmp_path / "o.npz").exists()


def test_the_padded_half_is_dropped_on_loading(tmp_path):
    """The conversion's record_range is the window after time zero; loaded,
    the range axis ends there (the padding's half holds nothing recorded),
    the samples kept; a record_range that leaves no gates is one line."""
    from rpm_cl.io.checks import InputError
    from rpm_cl.io.dzt import convert, read_header
    from rpm_cl.io.formats import load_data
    from rpm_cl.io.model import C0

    hdr = read_header(SCAN)
    out = convert(SCAN, time_zero=10.0)
    want = (hdr.samples - 10.0) * hdr.dt * C0 / 2
    assert out["record_range"] == pytest.approx(want)
    path = tmp_path / "s.npz"
    np.savez(path, **out)
    data = load_data(path)
    assert data.range[-1] <= want < data.range[-1] + 2 * data.dr
    assert data.spectrum is not None and data.range_period == 0
    np.savez(path, **{**out, "record_range": 1e-9})
    with pytest.raises(InputError, match="record_range"):
        load_data(path)
    np.savez(path, **{**out, "record_range": np.nan})
    with pytest.raises(InputError, match="record_range must be finite"):
        load_data(path)


def test_no_wrap_warning_within_a_padded_record(tmp_path):
    """An echo at the end of the axis warns that it may have wrapped from
    beyond it; a record that ends at half the axis (its padding the other
    half) holds nothing from beyond, and is not warned of."""
    import warnings

    from rpm_cl.io.checks import DataWarning
    from rpm_cl.io.dzt import convert
    from rpm_cl.io.formats import load_data
    from rpm_cl.io.model import C0

    out = convert(SCAN)
    f = out["frequency"]
    r_u = C0 / (2 * (f[1] - f[0]))
    far = 0.975 * r_u + 0.002 * np.arange(out["x"].size)  # it walks: no coupling
    top = np.abs(out["spectrum"]).max()
    out["spectrum"] = out["spectrum"] + 0.3 * top * np.exp(-4j * np.pi * np.outer(far, f) / C0)
    path = tmp_path / "s.npz"
    np.savez(path, **{k: v for k, v in out.items() if k != "record_range"})
    with pytest.warns(DataWarning, match="wrapped"):
        load_data(path)
    np.savez(path, **out)
    assert out["record_range"] < 0.6 * r_u
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        load_data(path)
