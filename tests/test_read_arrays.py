"""Named arrays -> the input schema by a key mapping (rpm_cl.io.mapped, `rpm-cl convert --map`).

The MATLAB fixtures (tests/data/readers, made by benchmarks/readers_fixture.py
to MATLAB's documented layouts: no MATLAB file could be downloaded) hold a
stepped-frequency scan ``F`` (nf, nx) as MATLAB keeps it, ``f`` (1, nf) Hz
and ``da`` (1, nx) mm, with one point target; ``targets.mat`` is a v7 file
(compressed v5, scipy.io.savemat), ``targets_v73.mat`` a v7.3 file (HDF5
with MATLAB's header, reversed axes and a real/imag compound).
"""

import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from rpm_cl.cli import main
from rpm_cl.io import mapped as M
from rpm_cl.io.data import C0, DataWarning, InputError
from rpm_cl.io.formats import load_data, range_compress
from rpm_cl.io.readers import convert

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import readers_fixture as RF

DATA = Path(__file__).parent / "data" / "readers"
MAT5, MAT73 = DATA / "targets.mat", DATA / "targets_v73.mat"
MAP = "spectrum=F,frequency=f,x=da"


def _one_error(capsys, argv) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("rpm-cl: error:") and "\n" not in err
    return err


def _read(path, **kw):
    kw = {"map": MAP, "transpose": True, "scale_x": 1e-3, **kw}
    return convert(path, **kw)[1]


def _echo_ranges(arrays, window="rect"):
    """Each antenna's compressed peak (range, phase relative to -2 k_c R_true)."""
    f = arrays["frequency"]
    fc = float(f.mean())
    s, r = range_compress(arrays["spectrum"], f, fc, window)
    tx, ty = RF.MAT["target"]
    true = np.hypot(arrays["x"] - tx, ty)
    i = np.abs(s).argmax(axis=-1)
    peak = s[np.arange(len(i)), i]
    return r[i], true, np.angle(peak * np.exp(4j * np.pi * fc * true / C0)), r[1] - r[0]


def test_matlab_v7_and_v73_read_alike_and_each_echo_lands_at_its_range():
    a5, a73 = _read(MAT5), _read(MAT73)
    assert a5["spectrum"].shape == (16, 41) and a5["spectrum"].dtype == np.complex128
    for k in ("spectrum", "frequency", "x"):
        np.testing.assert_array_equal(a5[k], a73[k])
    np.testing.assert_allclose(a5["x"], RF.MAT["x_mm"] * 1e-3)
    np.testing.assert_array_equal(a5["spectrum"], RF.mat_spectrum().T)
    got, true, phase, gate = _echo_ranges(a5)
    # the gate grid holds the true range within half a gate; the phase of the
    # peak is -2 k_c R exactly for a real, positive echo amplitude
    assert np.max(np.abs(got - true)) <= 0.5 * gate + 1e-9
    assert np.max(np.abs(phase)) < 1e-6


def test_v73_axes_come_out_as_matlab_shows_them():
    with h5py.File(MAT73, "r") as f:
        assert f["F"].shape == (16, 41)  # HDF5: reversed
        assert f["F"].dtype.names == ("real", "imag")
    with pytest.raises(InputError, match=r"shape \(41, 16\).*--transpose"):
        _read(MAT73, transpose=False)
    with pytest.raises(InputError, match=r"shape \(41, 16\).*--transpose"):
        _read(MAT5, transpose=False)


def test_v73_struct_fields_by_dotted_key(tmp_path):
    path = tmp_path / "s.mat"
    RF.write_mat_v73(path, {"f": RF.MAT["f"], "da": RF.MAT["x_mm"]})
    with h5py.File(path, "r+") as h, h5py.File(MAT73, "r") as src:
        g = h.create_group("meas")
        g.attrs.create("MATLAB_class", np.bytes_("struct"))
        src.copy("F", g)
    out = _read(path, map="spectrum=meas.F,frequency=f,x=da")
    np.testing.assert_array_equal(out["spectrum"], _read(MAT5)["spectrum"])
    with pytest.raises(InputError, match="a MATLAB struct"):
        _read(path, map="spectrum=meas,frequency=f,x=da")


def test_npz_npy_hdf5_and_matlab_v4_inputs_with_the_same_mapping(tmp_path):
    ref = _read(MAT5)
    F, f, da = RF.mat_spectrum(), RF.MAT["f"], RF.MAT["x_mm"]
    np.savez(tmp_path / "scan.npz", F=F, f=f, da=da)
    for name, v in (("F", F), ("f", f), ("da", da)):
        np.save(tmp_path / f"{name}.npy", v)
    with h5py.File(tmp_path / "scan.h5", "w") as h:
        h["grp/F"], h["f"], h["da"] = F, f, da
    RF.write_mat_v5(tmp_path / "v4.mat", {"F": F, "f": f, "da": da}, compress=False, version="4")
    outs = [
        _read(tmp_path / "scan.npz"),
        _read(tmp_path / "v4.mat"),
        _read([tmp_path / "F.npy", tmp_path / "f.npy", tmp_path / "da.npy"]),
        _read(tmp_path / "scan.h5", map="spectrum=grp/F,frequency=f,x=da"),
    ]
    for out in outs:
        for k in ("spectrum", "frequency", "x"):
            np.testing.assert_array_equal(out[k], ref[k])


def test_time_domain_mapping_and_scales(tmp_path):
    rng = np.random.default_rng(3)
    sig = rng.normal(size=(8, 30)) + 1j * rng.normal(size=(8, 30))
    np.savez(
        tmp_path / "t.npz", s=sig, r=0.01 * np.arange(30), fc=20.0, bw=0.5, pos=np.arange(8) * 5.0
    )
    fmt, out = convert(
        tmp_path / "t.npz",
        map="signal=s,range=r,fc=fc,bandwidth=bw,x=pos",
        scale_x=1e-3,
        scale_f=1e9,
    )
    assert fmt == "arrays"
    assert out["fc"] == pytest.approx(20e9) and out["bandwidth"] == pytest.approx(0.5e9)
    np.testing.assert_allclose(out["x"], np.arange(8) * 5e-3)
    np.testing.assert_array_equal(out["signal"], sig)
    # GHz frequencies: --scale-f 1e9 gives the Hz file's arrays
    np.savez(tmp_path / "g.npz", F=RF.mat_spectrum(), f=RF.MAT["f"] / 1e9, da=RF.MAT["x_mm"])
    ghz = _read(tmp_path / "g.npz", scale_f=1e9)
    np.testing.assert_allclose(ghz["frequency"], RF.MAT["f"], rtol=1e-15)


def test_conjugate_and_a_real_array_taken_as_complex(tmp_path):
    ref = _read(MAT5)
    conj = _read(MAT5, conjugate=True)
    np.testing.assert_array_equal(conj["spectrum"], np.conj(ref["spectrum"]))
    np.savez(tmp_path / "r.npz", F=np.ones((41, 16)), f=RF.MAT["f"], da=RF.MAT["x_mm"])
    with pytest.warns(DataWarning, match=r"spectrum \(F\) is real: .* mirror image"):
        out = _read(tmp_path / "r.npz")
    assert out["spectrum"].dtype == np.complex128 and np.all(out["spectrum"] == 1)
    np.savez(
        tmp_path / "t.npz",
        s=np.ones((16, 16)),
        r=np.arange(16) * 0.01,
        fc=np.float64(20e9),
        bw=np.float64(2e9),
        da=RF.MAT["x_mm"],
    )
    with pytest.warns(DataWarning, match=r"signal \(s\) is real: .* carrier phase"):
        convert(tmp_path / "t.npz", map="signal=s,range=r,fc=fc,bandwidth=bw,x=da", scale_x=1e-3)


def test_planar_mapping_checks_the_z_axis(tmp_path):
    spec = np.zeros((4, 3, 5), complex)
    np.savez(
        tmp_path / "p.npz", S=spec, f=1e9 + np.arange(5) * 1e6, x=np.arange(4.0), z=np.arange(3.0)
    )
    out = convert(tmp_path / "p.npz", map="spectrum=S,frequency=f,x=x,z=z")[1]
    assert out["z"].shape == (3,) and out["spectrum"].shape == (4, 3, 5)
    np.savez(
        tmp_path / "q.npz", S=spec, f=1e9 + np.arange(5) * 1e6, x=np.arange(4.0), z=np.arange(4.0)
    )
    with pytest.raises(InputError, match=r"expected \(4, 4, 5\)"):
        convert(tmp_path / "q.npz", map="spectrum=S,frequency=f,x=x,z=z")


@pytest.mark.parametrize(
    "mapping, message",
    [
        ("spectrum=F,frequency=f,x=nope", r"no 'nope' \(for x\).*it holds: F, da, f"),
        ("spectrum=F,frequency=f,x=da,foo=f", "unknown name 'foo'"),
        ("spectrum=F,frequency=f,x=da,range=f", "range does not go with spectrum"),
        ("spectrum=F,x=da", "lacks frequency"),
        ("signal=F,range=f,x=da", "lacks fc, bandwidth"),
        ("spectrum=F,signal=F,frequency=f,x=da", "both spectrum and signal"),
        ("frequency=f,x=da", "neither spectrum"),
        ("spectrum=F,frequency=f,x=da,x=f", "x is mapped twice"),
        ("spectrum=F;frequency=f", "NAME=KEY pairs"),
        ("spectrum=F,frequency=da,x=da", "frequency must be > 0 Hz"),
        ("spectrum=F,frequency=f,x=F", r"x \(F\) must be a vector"),
    ],
)
def test_mapping_errors_are_one_line_naming_the_key(mapping, message):
    with pytest.raises(InputError, match=message) as info:
        _read(MAT5, map=mapping)
    assert "\n" not in str(info.value)


def test_refusals_before_reading(tmp_path, monkeypatch):
    from scipy.io import savemat

    savemat(
        tmp_path / "s.mat", {"S": {"F": np.ones((2, 2))}, "C": np.array([[1, "a"]], dtype=object)}
    )
    with pytest.raises(InputError, match="struct of a v4-v7.2 file"):
        convert(tmp_path / "s.mat", map="spectrum=S,frequency=S,x=S")
    with pytest.raises(InputError, match="MATLAB cell"):
        convert(tmp_path / "s.mat", map="spectrum=C,frequency=C,x=C")
    # sizes from the headers: an oversized array is refused before its data
    # are read (the small axes are read first)
    monkeypatch.setattr(M, "MAX_ELEMENTS", 100)
    from scipy.io import loadmat

    def no_read(path, variable_names=(), **k):
        if "F" in variable_names:
            raise AssertionError("data read before the size check")
        return loadmat(path, variable_names=variable_names, **k)

    monkeypatch.setattr("scipy.io.loadmat", no_read)
    with pytest.raises(InputError, match="656 values, more than 100"):
        _read(MAT5)
    with pytest.raises(InputError, match="656 values, more than 100"):
        _read(MAT73)


def test_hdf5_links_out_of_the_file_are_refused(tmp_path):
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as h:
        h["F"] = RF.mat_spectrum()
    with h5py.File(tmp_path / "l.h5", "w") as h:
        h["F"] = h5py.ExternalLink(str(other), "F")
        h["f"], h["da"] = RF.MAT["f"], RF.MAT["x_mm"]
    with pytest.raises(InputError, match="external link"):
        _read(tmp_path / "l.h5")
    with h5py.File(tmp_path / "s.h5", "w") as h:
        h["F"], h["f"], h["da"] = RF.mat_spectrum(), RF.MAT["f"], RF.MAT["x_mm"]
        h["soft"] = h5py.SoftLink("/f")
    with pytest.raises(InputError, match="soft link"):
        _read(tmp_path / "s.h5", map="spectrum=F,frequency=soft,x=da")
    with h5py.File(tmp_path / "e.h5", "w") as h:
        h.create_dataset("F", shape=(16, 41), dtype="c16", external=[(str(other), 0, 1 << 20)])
        h["f"], h["da"] = RF.MAT["f"], RF.MAT["x_mm"]
    with pytest.raises(InputError, match="external files"):
        _read(tmp_path / "e.h5")


def test_a_key_in_two_files_is_refused(tmp_path):
    np.save(tmp_path / "f.npy", RF.MAT["f"])
    with pytest.raises(InputError, match="'f' is in both"):
        _read([MAT5, tmp_path / "f.npy"])


# --------------------------------------------------------------------- CLI
def test_cli_convert_mat_writes_what_load_data_reads(tmp_path, capsys):
    out = tmp_path / "scan.h5"
    assert (
        main(
            [
                "convert",
                str(MAT73),
                "--map",
                MAP,
                "--transpose",
                "--scale-x",
                "1e-3",
                "-o",
                str(out),
            ]
        )
        == 0
    )
    assert "wrote" in capsys.readouterr().out
    data = load_data(out, range_window="rect")
    assert data.array.n == 16 and data.waveform.fc == pytest.approx(RF.MAT["f"].mean())
    # an .h5 with --map is read as arrays, so the written file converts back
    again = tmp_path / "again.npz"
    assert (
        main(
            [
                "convert",
                str(out),
                "--map",
                "spectrum=spectrum,frequency=frequency,x=x",
                "-o",
                str(again),
                "-q",
            ]
        )
        == 0
    )
    np.testing.assert_array_equal(np.load(again)["spectrum"], _read(MAT5)["spectrum"])


def test_cli_convert_arrays_errors_are_one_line(tmp_path, capsys):
    mat = tmp_path / "t.mat"
    mat.write_bytes(MAT5.read_bytes())
    base = ["convert", str(mat), "--map", MAP, "--transpose"]
    assert "is also an input" in _one_error(capsys, base + ["-o", str(mat)])
    assert mat.read_bytes() == MAT5.read_bytes()
    assert "--transpose (transpose=True)" in _one_error(
        capsys, base[:-1] + ["-o", str(tmp_path / "o.npz")]
    )
    assert "--waveform does not apply to arrays input (it is for gprmax)" in _one_error(
        capsys, base + ["--waveform", "ricker:3e9", "-o", str(tmp_path / "o.npz")]
    )
    assert "arrays input needs --map" in _one_error(
        capsys, ["convert", str(mat), "--format", "arrays", "-o", str(tmp_path / "o.npz")]
    )
    bad = tmp_path / "bad.mat"
    bad.write_bytes(b"not a mat file at all" * 10)
    assert "bad.mat" in _one_error(
        capsys, ["convert", str(bad), "--map", MAP, "-o", str(tmp_path / "o.npz")]
    )
    assert not (tmp_path / "o.npz").exists()


# A planar scan as recorders keep it: F(nf, nz, nx), x as MATLAB's meshgrid
# (nz, nx) in mm, both x and the frequencies in decreasing order, the
# positions with a stage's jitter.
PLANAR_TARGET = (0.03, 0.1, 0.02)


def _planar_file(tmp_path, jitter=0.05, rng_seed=1):
    from scipy.io import savemat

    rng = np.random.default_rng(rng_seed)
    f = np.linspace(22.2e9, 26.2e9, 11)
    xs, zs = np.arange(20) * 3e-3, np.arange(16) * 3e-3
    xg, zg = np.meshgrid(xs, zs)  # (nz, nx)
    tx, ty, tz = PLANAR_TARGET
    r = np.sqrt((xg - tx) ** 2 + ty**2 + (zg - tz) ** 2)
    spec = np.exp(-4j * np.pi * f[:, None, None] * r[None] / C0)  # (nf, nz, nx)
    xmm = xg[:, ::-1] * 1e3 + rng.uniform(-jitter, jitter, xg.shape[1])[None, :]
    path = tmp_path / "scan.mat"
    savemat(path, {"F": spec[::-1, :, ::-1], "X": xmm, "zz": zs * 1e3, "fr": f[::-1] / 1e9})
    return path


def _planar_read(path, **kw):
    kw = {
        "map": "spectrum=F,frequency=fr,x=X,z=zz",
        "scale_x": 1e-3,
        "scale_f": 1e9,
        "axes": "f,z,x",
        **kw,
    }
    return convert(path, **kw)[1]


def test_axes_order_meshgrid_and_decreasing_axes_give_the_schemas_spectrum(tmp_path):
    with pytest.warns(DataWarning, match=r"x \(X\) is not uniformly spaced"):
        out = _planar_read(_planar_file(tmp_path))
    x, z, f = out["x"], out["z"], out["frequency"]
    assert out["spectrum"].shape == (20, 16, 11)
    assert np.all(np.diff(x) > 0) and np.all(np.diff(f) > 0)
    # every sample is the echo of the target at its antenna: the data were
    # permuted and reversed with their axes (a reversed axis alone, or a
    # swapped x and z, puts the phases radians off)
    tx, ty, tz = PLANAR_TARGET
    r = np.sqrt((x[:, None] - tx) ** 2 + ty**2 + (z[None, :] - tz) ** 2)
    want = np.exp(-4j * np.pi * f[None, None, :] * r[..., None] / C0)
    # the jitter left after the snap: 0.05 mm at most, 2 k 0.05 mm = 0.055 rad
    assert np.abs(np.angle(out["spectrum"] * np.conj(want))).max() < 0.06
    # the same file read by its reversed axes (--transpose) is the same
    with pytest.warns(DataWarning, match="not uniformly spaced"):
        again = _planar_read(tmp_path / "scan.mat", axes=None, transpose=True)
    np.testing.assert_array_equal(again["spectrum"], out["spectrum"])


def test_positions_on_a_uniform_grid_when_they_lie_near_one(tmp_path):
    with pytest.warns(DataWarning, match=r"up to .* m \(.* % of the 0.003.* m step\)"):
        x = _planar_read(_planar_file(tmp_path, jitter=0.2))["x"]
    assert np.ptp(np.diff(x)) < 1e-12  # uniform
    # a third of a step off is not a uniform scan: refused by the schema's check
    with pytest.raises(InputError, match="x must be uniformly spaced"):
        _planar_read(_planar_file(tmp_path, jitter=1.0))


def test_an_exactly_uniform_axis_is_kept_without_a_warning(tmp_path):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = _planar_read(_planar_file(tmp_path, jitter=0.0))
    np.testing.assert_allclose(out["x"], np.arange(20) * 3e-3, atol=1e-12)


def test_a_stack_in_any_axis_order(tmp_path):
    spec = np.arange(2 * 5 * 4, dtype=float).reshape(5, 2, 4) + 1j  # (nf, frames, nx)
    np.savez(tmp_path / "s.npz", S=spec, f=1e9 + np.arange(5) * 1e6, x=np.arange(4.0))
    out = convert(tmp_path / "s.npz", map="spectrum=S,frequency=f,x=x", axes="f,frame,x")[1]
    np.testing.assert_array_equal(out["spectrum"], spec.transpose(1, 2, 0))


def test_a_shape_that_another_axis_order_fits_is_named(tmp_path):
    spec = np.zeros((3, 4, 5), complex)  # (nz, nx, nf)
    np.savez(
        tmp_path / "p.npz", S=spec, f=1e9 + np.arange(5) * 1e6, x=np.arange(4.0), z=np.arange(3.0)
    )
    with pytest.raises(InputError, match="fit as --axes z,x,f") as info:
        convert(tmp_path / "p.npz", map="spectrum=S,frequency=f,x=x,z=z")
    assert "\n" not in str(info.value)
    out = convert(tmp_path / "p.npz", map="spectrum=S,frequency=f,x=x,z=z", axes="z,x,f")[1]
    assert out["spectrum"].shape == (4, 3, 5)
    np.savez(
        tmp_path / "q.npz",
        S=np.zeros((4, 3, 5), complex),
        f=1e9 + np.arange(5) * 1e6,
        x=np.arange(4.0),
        z=np.arange(3.0),
    )
    with pytest.raises(InputError, match="fits in the file's own order"):
        convert(tmp_path / "q.npz", map="spectrum=S,frequency=f,x=x,z=z", axes="z,x,f")


@pytest.mark.parametrize(
    "axes, message",
    [
        ("f,x,q", "unknown axis 'q'"),
        ("f,f", "names the f, frequency axis twice"),
        ("x,z", "lacks f, frequency"),
        ("r,x", "axis 'r' does not go with spectrum"),
        ("frame,f,x", "names 3 axes"),
        ("f,z,x", "names z, but the mapping gives no z"),
    ],
)
def test_axes_order_errors_are_one_line(axes, message):
    with pytest.raises(InputError, match=message) as info:
        _read(MAT5, transpose=False, axes=axes)
    assert "\n" not in str(info.value)


def test_axes_and_transpose_together_are_refused():
    with pytest.raises(InputError, match="either --axes"):
        _read(MAT5, axes="f,x")


def test_a_position_grid_that_changes_along_both_axes_is_refused(tmp_path):
    xg, zg = np.meshgrid(np.arange(4.0), np.arange(3.0))
    np.savez(
        tmp_path / "g.npz",
        S=np.zeros((4, 3, 5), complex),
        f=1e9 + np.arange(5) * 1e6,
        x=xg + 0.1 * zg,  # a rotated scan
        z=np.arange(3.0),
    )
    with pytest.raises(InputError, match=r"x \(x\) is a 3 x 4 grid whose values change along both"):
        convert(tmp_path / "g.npz", map="spectrum=S,frequency=f,x=x,z=z")


def test_cli_convert_axes(tmp_path, capsys):
    path = _planar_file(tmp_path, jitter=0.0)
    out = tmp_path / "o.npz"
    argv = ["convert", str(path), "-o", str(out), "--map", "spectrum=F,frequency=fr,x=X,z=zz"]
    argv += ["--scale-x", "1e-3", "--scale-f", "1e9"]
    assert main(argv + ["--axes", "f,z,x"]) == 0
    assert load_data(out).signal.shape[:2] == (20, 16)
    out.unlink()
    assert "--axes" in _one_error(capsys, argv + ["--axes", "f,x"])
    assert not out.exists()


def test_a_decreasing_axis_in_a_schema_file_names_the_fix(tmp_path):
    rng = np.random.default_rng(3)
    spec = rng.standard_normal((5, 8)) + 1j * rng.standard_normal((5, 8))
    f = 1e9 + np.arange(8) * 1e6
    np.savez(tmp_path / "d.npz", spectrum=spec, frequency=f, x=np.arange(5.0)[::-1])
    with pytest.raises(InputError, match="it decreases: reverse it .*rpm-cl convert"):
        load_data(tmp_path / "d.npz")
    out = convert(tmp_path / "d.npz", map="spectrum=spectrum,frequency=frequency,x=x")[1]
    np.testing.assert_array_equal(out["x"], np.arange(5.0))
    np.testing.assert_array_equal(out["spectrum"], spec[::-1])


def test_float32_frequency_and_range_axes_load_and_convert(tmp_path):
    """Axes stored as float32 (MATLAB single, GHz): their rounding is far
    below the uniformity test's, in a schema file and through --map."""
    f = np.linspace(18e9, 26e9, 161)
    spec = np.exp(-4j * np.pi * f[None, :] * np.array([0.4, 0.41, 0.42])[:, None] / C0)
    np.savez(
        tmp_path / "s.npz", spectrum=spec, frequency=f.astype(np.float32), x=np.arange(3.0) * 4e-3
    )
    data = load_data(tmp_path / "s.npz")
    assert data.spectrum.frequency.dtype == np.float64
    np.testing.assert_allclose(data.spectrum.frequency, f, rtol=1e-7)
    np.savez(tmp_path / "g.npz", F=spec.T, f=(f / 1e9).astype(np.float32), x=np.arange(3.0) * 4e-3)
    out = convert(
        tmp_path / "g.npz", map="spectrum=F,frequency=f,x=x", transpose=True, scale_f=1e9
    )[1]
    np.testing.assert_allclose(out["frequency"], f, rtol=1e-7)
    assert np.ptp(np.diff(out["frequency"])) < 1e-3  # uniform to the Hz
    r = np.arange(64) * 0.01
    np.savez(
        tmp_path / "t.npz",
        signal=np.ones((3, 64), complex),
        range=r.astype(np.float32),
        x=np.arange(3.0) * 4e-3,
        fc=20e9,
        bandwidth=2e9,
    )
    np.testing.assert_allclose(load_data(tmp_path / "t.npz").range, r, atol=1e-7)


def test_a_frequency_axis_rounded_on_export_is_put_on_its_grid(tmp_path):
    f = np.linspace(22.2e9, 26.2e9, 11)
    spec = np.ones((3, 11), complex)
    rounded = np.round(f / 1e9 + [0, 0, 0.002, 0, 0, 0, 0, 0, 0, 0, 0], 4)  # 2 MHz off
    np.savez(tmp_path / "g.npz", F=spec, f=rounded, x=np.arange(3.0))
    with pytest.warns(DataWarning, match=r"frequency \(f\) is not uniformly spaced"):
        out = convert(tmp_path / "g.npz", map="spectrum=F,frequency=f,x=x", scale_f=1e9)[1]
    np.testing.assert_allclose(out["frequency"], f, atol=1e6)
    bad = rounded.copy()
    bad[2] += 0.02  # 20 MHz: 5 % of a step
    np.savez(tmp_path / "b.npz", F=spec, f=bad, x=np.arange(3.0))
    with pytest.raises(InputError, match="frequency must be uniformly spaced"):
        convert(tmp_path / "b.npz", map="spectrum=F,frequency=f,x=x", scale_f=1e9)


def test_convert_refuses_deflated_bombs_and_checks_the_shape_unread(tmp_path, monkeypatch):
    """A deflated .mat variable or HDF5 dataset declaring a hundred times
    its stored bytes is refused from its header (the threshold lowered here
    so that a small file shows it), and a data array of the wrong shape is
    refused before its data are read."""
    from scipy.io import loadmat, savemat

    from rpm_cl.io import guard

    monkeypatch.setattr(guard, "BOMB_MIN_BYTES", 1 << 10)
    f, x = 1e9 + np.arange(300) * 1e6, np.arange(200) * 1e-3
    savemat(tmp_path / "b.mat", {"F": np.zeros((300, 200)), "f": f, "x": x}, do_compression=True)
    with pytest.raises(InputError, match="F declares .* compression bomb"):
        convert(tmp_path / "b.mat", map="spectrum=F,frequency=f,x=x", transpose=True)
    with h5py.File(tmp_path / "b.h5", "w") as h:
        h.create_dataset("F", data=np.zeros((200, 300)), compression="gzip", chunks=(200, 300))
        h["f"], h["x"] = f, x
    with pytest.raises(InputError, match="F declares .* compression bomb"):
        convert(tmp_path / "b.h5", map="spectrum=F,frequency=f,x=x")
    monkeypatch.setattr(guard, "BOMB_MIN_BYTES", 1 << 40)
    savemat(tmp_path / "w.mat", {"F": np.ones((300, 201)), "f": f, "x": x})

    def no_data(path, variable_names=(), **k):
        if "F" in variable_names:
            raise AssertionError("data read before the shape check")
        return loadmat(path, variable_names=variable_names, **k)

    monkeypatch.setattr("scipy.io.loadmat", no_data)
    with pytest.raises(InputError, match=r"has shape \(300, 201\); expected \(200, 300\)"):
        convert(tmp_path / "w.mat", map="spectrum=F,frequency=f,x=x", transpose=True)


@pytest.mark.parametrize("f0, df", [(77e9, 3e6), (24e9, 50e3)])
def test_a_float32_frequency_axis_through_map_is_silent(tmp_path, f0, df):
    """float32 rounds 77 GHz to 4.6 kHz, 0.15 % of a 3 MHz step, and 24 GHz
    to 1.4 kHz, 3 % of a 50 kHz one: the stored type's rounding, not an
    axis off its grid (the schema reader takes both)."""
    import warnings

    f = f0 + df * np.arange(201)
    spec = np.ones((3, f.size), complex)
    np.savez(tmp_path / "g.npz", F=spec, f=f.astype(np.float32), x=np.arange(3.0) * 4e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = convert(tmp_path / "g.npz", map="spectrum=F,frequency=f,x=x")[1]
    np.testing.assert_allclose(out["frequency"], f, rtol=0, atol=1e4)


def test_a_single_frame_stack_that_matlab_saved_without_its_axis(tmp_path):
    """MATLAB drops a trailing axis of length one: F(nf, nx, 1) is saved as
    F(nf, nx), and --axes f,x,frame still reads it (as one frame)."""
    from scipy.io import savemat

    f = 1e9 + np.arange(5) * 1e6
    spec = np.arange(20.0).reshape(5, 4) + 1j
    savemat(tmp_path / "s.mat", {"F": spec, "f": f, "x": np.arange(4) * 1e-3})  # as MATLAB keeps it
    out = convert(tmp_path / "s.mat", map="spectrum=F,frequency=f,x=x", axes="f,x,frame")[1]
    np.testing.assert_array_equal(out["spectrum"], spec.T)
