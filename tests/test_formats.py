"""Input and output formats (rpm_cl/io/formats.py): .npz vs HDF5, stacks,
frequency-domain spectra against analytic truth, outputs by extension read
back, bad inputs as one line with exit code 2, interrupted writes."""

import json
import os

import h5py
import numpy as np
import pytest

from rpm_cl.cli import main
from rpm_cl.extract.rangepoints import RangePoints, profile_peaks
from rpm_cl.imaging import DEFAULT_METHOD, run_method
from rpm_cl.io import formats
from rpm_cl.io.data import C0, InputError, data_arrays, load_npz
from rpm_cl.io.formats import (
    RANGE_OVERSAMPLE,
    RANGE_WINDOWS,
    frame_count,
    load_data,
    range_compress,
    save_data,
    save_result,
    write_volume,
)
from rpm_cl.rpm import reference
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import echoes, simulate_preset
from rpm_cl.simulate.scene import get_preset


def _write_h5(path, arrays: dict) -> None:
    """HDF5 the way another tool would write the schema: root datasets, 0-d
    scalars, truth_scene a string dataset."""
    with h5py.File(path, "w") as f:
        for k, v in arrays.items():
            v = np.asarray(v)
            if v.dtype.kind == "U":
                f.create_dataset(k, data=str(v), dtype=h5py.string_dtype())
            else:
                f.create_dataset(k, data=v)


def _same_data(a, b) -> None:
    assert a.signal.dtype == b.signal.dtype
    np.testing.assert_array_equal(a.signal, b.signal)
    np.testing.assert_array_equal(a.range, b.range)
    np.testing.assert_array_equal(a.array.x, b.array.x)
    assert (a.array.z is None) == (b.array.z is None)
    if a.array.z is not None:
        np.testing.assert_array_equal(a.array.z, b.array.z)
    assert a.waveform == b.waveform
    assert (a.truth is None) == (b.truth is None)
    if a.truth is not None:
        np.testing.assert_array_equal(a.truth.rp_antenna, b.truth.rp_antenna)
        np.testing.assert_array_equal(a.truth.rp_range, b.truth.rp_range)
        np.testing.assert_array_equal(a.truth.boundary, b.truth.boundary)
        assert a.truth.scene == b.truth.scene


@pytest.fixture(scope="module")
def paper():
    data, preset = simulate_preset("paper-2d", 20.0, seed=3, noise="receiver")
    return data, preset


# --------------------------------------------------------------------------
# .npz and HDF5 give the same data and the same images
def test_npz_and_h5_same_data_and_image(paper, tmp_path):
    data, preset = paper
    arrays = data_arrays(data)
    np.savez(tmp_path / "d.npz", **arrays)
    _write_h5(tmp_path / "d.h5", arrays)
    a, b = load_data(tmp_path / "d.npz"), load_data(tmp_path / "d.h5")
    _same_data(a, b)
    _same_data(a, load_npz(tmp_path / "d.npz"))  # today's loader, same contract
    _same_data(a, data)
    params = default_params(a, **preset.defaults)
    ra = run_method("kspace-rpm", a, params, reference)
    rb = run_method("kspace-rpm", b, params, reference)
    assert len(ra.image.points) > 30
    np.testing.assert_array_equal(ra.image.points, rb.image.points)
    np.testing.assert_array_equal(ra.rps.range, rb.rps.range)


def test_npz_and_h5_same_cli_result(paper, tmp_path, capsys):
    data, _ = paper
    save_data(tmp_path / "d.npz", data)
    save_data(tmp_path / "d.h5", data)
    _same_data(load_data(tmp_path / "d.npz"), load_data(tmp_path / "d.h5"))
    for name in ("d.npz", "d.h5"):
        assert main(["image", str(tmp_path / name), "-o", str(tmp_path / f"{name}.out.npz")]) == 0
    with np.load(tmp_path / "d.npz.out.npz") as f1, np.load(tmp_path / "d.h5.out.npz") as f2:
        assert len(f1["points"]) > 30
        for k in ("points", "cluster", "score", "rp_range"):
            np.testing.assert_array_equal(f1[k], f2[k])


def test_planar_complex64_float32_axes(tmp_path, rng):
    """A planar file with complex64 samples and float32 axes (typical of
    measured data) reads the same from either container."""
    sig = (rng.standard_normal((5, 4, 64)) + 1j * rng.standard_normal((5, 4, 64))).astype(
        np.complex64
    )
    arrays = {
        "signal": sig,
        "x": np.arange(5, dtype=np.float32) * np.float32(0.0075),
        "z": np.arange(4, dtype=np.float32) * np.float32(0.0075),
        "range": (0.5 + 0.005 * np.arange(64)).astype(np.float32),
        "fc": np.float32(20e9),
        "bandwidth": np.float32(3e9),
    }
    np.savez(tmp_path / "p.npz", **arrays)
    _write_h5(tmp_path / "p.h5", arrays)
    a, b = load_data(tmp_path / "p.npz"), load_data(tmp_path / "p.h5")
    _same_data(a, b)
    assert a.signal.dtype == np.complex64 and a.array.planar
    np.testing.assert_array_equal(a.signal, sig)


# --------------------------------------------------------------------------
# stacks
@pytest.fixture(scope="module")
def stack(tmp_path_factory):
    frames = [simulate_preset("paper-2d", 10.0, seed=s, noise="receiver")[0] for s in (11, 12, 13)]
    arrays = data_arrays(frames[0])
    arrays["signal"] = np.stack([f.signal for f in frames])
    folder = tmp_path_factory.mktemp("stack")
    np.savez(folder / "s.npz", **arrays)
    np.savez_compressed(folder / "sc.npz", **arrays)
    _write_h5(folder / "s.h5", arrays)
    return folder, frames


@pytest.mark.parametrize("name", ["s.npz", "sc.npz", "s.h5"])
def test_stack_frames(stack, name):
    folder, frames = stack
    path = folder / name
    assert frame_count(path) == 3
    for i, want in enumerate(frames):
        _same_data(load_data(path, frame=i), want)
    for bad, words in (
        (None, "stack of 3 frames"),
        (3, "out of range"),
        (-1, "out of range"),
        (1.0, "integer"),
    ):
        with pytest.raises(InputError, match=words) as exc:
            load_data(path, frame=bad)
        assert str(exc.value).startswith(str(path))


def test_h5_stack_reads_only_the_frame(stack, monkeypatch):
    folder, frames = stack
    whole = []
    real_read = formats._H5Source.read

    def spy(self, key):
        whole.append(key)
        return real_read(self, key)

    monkeypatch.setattr(formats._H5Source, "read", spy)
    _same_data(load_data(folder / "s.h5", frame=2), frames[2])
    assert "signal" not in whole and "x" in whole


def test_single_frame_file(paper, tmp_path):
    data, _ = paper
    save_data(tmp_path / "one.h5", data)
    assert frame_count(tmp_path / "one.h5") == 1
    _same_data(load_data(tmp_path / "one.h5", frame=0), data)
    with pytest.raises(InputError, match="single frame"):
        load_data(tmp_path / "one.h5", frame=1)


def test_cli_stack(stack, tmp_path, capsys):
    folder, _ = stack
    assert (
        main(["image", str(folder / "s.h5"), "-o", str(tmp_path / "f1.npz"), "--frame", "1"]) == 0
    )
    capsys.readouterr()
    assert main(["image", str(folder / "s.h5"), "-o", str(tmp_path / "f.npz")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "stack of 3 frames" in err[0] and "--frame" in err[0]
    assert not (tmp_path / "f.npz").exists()


# --------------------------------------------------------------------------
# frequency-domain input against analytic truth
FC, SPAN = 20e9, 0.4e9


def _band(nf: int) -> np.ndarray:
    return FC - SPAN / 2 + np.arange(nf) * (SPAN / (nf - 1))


def _echoes_spectrum(f, ranges, amps) -> np.ndarray:
    """Y(f) = sum_e a_e exp(-j 4 pi f R_e / c): echoes at known ranges."""
    return (
        np.asarray(amps)[:, None]
        * np.exp(-4j * np.pi * f[None, :] * np.asarray(ranges)[:, None] / C0)
    ).sum(0)


def _peaks(s, rng, rel=0.1):
    _, pos, val = profile_peaks(np.abs(np.atleast_2d(s)), rel)
    return rng[0] + pos * (rng[1] - rng[0]), val


@pytest.mark.parametrize("window", sorted(RANGE_WINDOWS))
def test_lone_echo_range_amplitude_phase(window, rng):
    """A lone echo, for every window: the range point within 0.1 mm of the
    truth (the gates are 1/16 of c/2*span = 23 mm; a three-point parabola on a
    mainlobe 16+ gates wide is biased by far less than 1 % of a gate),
    |s| = a within 1 % (the parabola's peak), and the phase exp(-j 2 k_c R)."""
    f = _band(81)
    kc = 2 * np.pi * FC / C0
    for r_t in rng.uniform(0.3, 20.0, 5):
        a = rng.uniform(0.1, 3.0)
        s, r = range_compress(_echoes_spectrum(f, [r_t], [a])[None], f, FC, window)
        assert r.size >= RANGE_OVERSAMPLE * f.size and r[0] == 0
        assert r[-1] < C0 / (2 * (f[1] - f[0]))  # the unambiguous range
        pos, val = _peaks(s, r, 0.5)
        assert pos.size == 1
        assert abs(pos[0] - r_t) < 1e-4
        assert val[0] == pytest.approx(a, rel=0.01)
        # at the nearest gate the symmetric window's response is real and > 0
        g = int(np.argmin(np.abs(r - r_t)))
        assert abs(np.angle(s[0, g] * np.exp(2j * kc * r_t))) < 1e-6


def test_phase_reference_off_centre():
    """fc need not be the band centre: an echo exactly on a gate comes out
    as a exp(-j 2 k_c R) with k_c from the given fc."""
    f = _band(64)
    fc = f[0] + 0.3 * SPAN
    _, r = range_compress(np.zeros((1, f.size), complex), f, fc, "hann")
    r_t = r[517]
    s, _ = range_compress(_echoes_spectrum(f, [r_t], [2.0])[None], f, fc, "hann")
    want = 2.0 * np.exp(-2j * (2 * np.pi * fc / C0) * r_t)
    assert abs(s[0, 517] - want) < 1e-9


@pytest.mark.parametrize("window", ["hann", "blackman"])
def test_separated_echoes(window):
    """Three echoes 5.5-6.7 m apart (15+ resolution cells): every range within
    0.5 mm and every amplitude within 1 % (the low sidelobes of hann/blackman
    barely pull a neighbour's peak)."""
    f = _band(81)
    ranges, amps = [2.1234, 7.6543, 14.3217], [1.0, 0.5, 0.25]
    s, r = range_compress(_echoes_spectrum(f, ranges, amps)[None], f, FC, window)
    pos, val = _peaks(s, r)
    assert pos.size == 3
    np.testing.assert_allclose(pos, ranges, atol=5e-4)
    np.testing.assert_allclose(val, amps, rtol=0.01)


def test_spectrum_file_rule_and_dtypes(tmp_path):
    """fc and bandwidth omitted: band centre, and the window's full width at
    half amplitude (hann: half the nf*df span, rect: all of it); complex64 in,
    complex64 out; .npz and .h5 alike."""
    f = _band(101)
    df = f[1] - f[0]
    y = np.stack([_echoes_spectrum(f, [1.5 + 0.01 * i], [1.0]) for i in range(4)])
    arrays = {"spectrum": y.astype(np.complex64), "frequency": f, "x": 0.005 * np.arange(4)}
    np.savez(tmp_path / "f.npz", **arrays)
    _write_h5(tmp_path / "f.h5", arrays)
    for name in ("f.npz", "f.h5"):
        d = load_data(tmp_path / name)
        assert d.signal.dtype == np.complex64
        assert d.waveform.fc == pytest.approx((f[0] + f[-1]) / 2, rel=1e-12)
        assert d.waveform.bandwidth == pytest.approx(f.size * df / 2, rel=2e-3)
        assert load_data(tmp_path / name, range_window="rect").waveform.bandwidth == pytest.approx(
            f.size * df, rel=1e-9
        )
        pos, _ = _peaks(d.signal, d.range, 0.5)
        np.testing.assert_allclose(np.sort(pos), 1.5 + 0.01 * np.arange(4), atol=2e-4)
    _same_data(load_data(tmp_path / "f.npz"), load_data(tmp_path / "f.h5"))
    arrays.update(fc=np.float64(20.05e9), bandwidth=np.float64(0.3e9))
    _write_h5(tmp_path / "g.h5", arrays)
    assert load_data(tmp_path / "g.h5").waveform.bandwidth == 0.3e9


def test_image_of_frequency_domain_paper_2d(tmp_path, capsys):
    """The paper-2d scene re-synthesised in the frequency domain (every
    specular echo as a exp(-j 4 pi f R / c)) and imaged by `rpm-cl image`:
    the points sit on the three true targets."""
    preset = get_preset("paper-2d")
    ant, r_e, a_e, _ = echoes(preset.scene, preset.array)
    f = _band(41)  # 0.4 GHz around 20 GHz: the hann window's half width is the preset's 0.2 GHz
    y = np.zeros((preset.array.n, f.size), complex)
    np.add.at(y, ant, a_e[:, None] * np.exp(-4j * np.pi * f[None] * r_e[:, None] / C0))
    _write_h5(tmp_path / "fd.h5", {"spectrum": y, "frequency": f, "x": preset.array.x})
    assert (
        main(
            [
                "image",
                str(tmp_path / "fd.h5"),
                "-o",
                str(tmp_path / "img.h5"),
                "--sigma-x",
                "0.1",
                "--window-x",
                "417",
            ]
        )
        == 0
    )
    with h5py.File(tmp_path / "img.h5") as g:
        pts = g["points"][()]
        meta = json.loads(g["meta"][()])
    assert meta["range_window"] == "hann" and meta["method"] == DEFAULT_METHOD
    targets = np.array([t.position for t in preset.scene.targets])
    d = np.linalg.norm(pts[:, None, :] - targets[None], axis=2)
    assert len(pts) >= 40
    assert np.mean(d.min(axis=1) < 0.05) >= 0.9  # the simulator's file: 61/63 (README)
    assert np.all(np.sum(d < 0.05, axis=0) >= 10)  # every target found


# --------------------------------------------------------------------------
# outputs by extension
@pytest.fixture(scope="module")
def result(paper):
    data, preset = paper
    return run_method("kspace-rpm", data, default_params(data, **preset.defaults), reference)


def _result_3d(rng):
    from rpm_cl.result import Image, ImageResult

    m, k = 40, 60
    rps = RangePoints(
        np.arange(k),
        rng.normal(size=k),
        rng.normal(size=k),
        rng.uniform(0.5, 1.5, k),
        rng.uniform(size=k),
        np.sort(rng.integers(0, 4, k)),
    )
    img = Image(rng.normal(size=(m, 3)), rng.integers(0, 4, m), rng.uniform(size=m), np.arange(m))
    return ImageResult("kspace-rpm", rps, img, {"total": 0.5})


def test_result_npz_h5_same_content(result, tmp_path):
    from rpm_cl.io.formats import save_result as imaging_save_result

    meta = {"version": "x", "device": "dev", "params": {"a": 1}}
    imaging_save_result(tmp_path / "ref.npz", result, meta)
    save_result(tmp_path / "r.npz", result, meta)
    save_result(tmp_path / "r.h5", result, meta)
    with (
        np.load(tmp_path / "ref.npz") as ref,
        np.load(tmp_path / "r.npz") as r,
        h5py.File(tmp_path / "r.h5") as h,
    ):
        assert set(ref.files) == set(r.files) == set(h.keys())
        for k in ref.files:
            if k == "meta":
                want = json.loads(str(ref[k]))
                assert json.loads(str(r[k])) == want == json.loads(h[k][()])
                assert want["device"] == "dev" and "total" in want["timings"]
            else:
                np.testing.assert_array_equal(r[k], ref[k])
                np.testing.assert_array_equal(h[k][()], ref[k])
    # and `rpm-cl view` reads the .h5 like the .npz
    from rpm_cl.viz.view import load_result

    a, b = load_result(tmp_path / "r.npz"), load_result(tmp_path / "r.h5")
    np.testing.assert_array_equal(a["points"], b["points"])
    assert a["meta"] == b["meta"]


@pytest.mark.parametrize("dim", [2, 3])
def test_point_clouds_read_back(dim, result, tmp_path, rng):
    meshio = pytest.importorskip("meshio")
    pv = pytest.importorskip("pyvista")
    res = result if dim == 2 else _result_3d(rng)
    pts = res.image.points
    want = pts if dim == 3 else np.column_stack([pts, np.zeros(len(pts))])
    save_result(tmp_path / "c.ply", res, {"version": "x"})
    save_result(tmp_path / "c.vtp", res, {"version": "x"})
    m = meshio.read(tmp_path / "c.ply")
    np.testing.assert_array_equal(m.points, want)
    np.testing.assert_array_equal(m.point_data["cluster"], res.image.cluster)
    np.testing.assert_array_equal(m.point_data["score"], res.image.score)
    ply = pv.read(tmp_path / "c.ply")  # VTK (ParaView's reader) opens it
    assert ply.n_points == len(pts)
    np.testing.assert_allclose(ply.points, want, atol=1e-6)  # VTK reads PLY as float32
    vtp = pv.read(tmp_path / "c.vtp")
    np.testing.assert_array_equal(vtp.points, want)
    np.testing.assert_array_equal(vtp.point_data["cluster"], res.image.cluster)
    np.testing.assert_array_equal(vtp.point_data["score"], res.image.score)
    assert json.loads(vtp.field_data["meta"][0])["version"] == "x"


def _grid(dim):
    from rpm_cl.baselines.das import Grid

    x, y = -0.2 + 0.01 * np.arange(7), 0.5 + 0.02 * np.arange(5)
    return Grid(x, y, 1.0 + 0.005 * np.arange(3)) if dim == 3 else Grid(x, y)


def _analytic(grid):
    """image(x, y[, z]) = x + 2y + 3z + j(xy - z): every voxel distinct."""
    g = np.meshgrid(*grid.axes, indexing="ij")
    z = g[2] if grid.dim == 3 else 0.0
    return (g[0] + 2 * g[1] + 3 * z + 1j * (g[0] * g[1] - z)).astype(np.complex64)


@pytest.mark.parametrize("dim", [2, 3])
def test_volumes_read_back(dim, tmp_path):
    pv = pytest.importorskip("pyvista")
    grid = _grid(dim)
    want = _analytic(grid)

    def fill(out):
        for i in range(out.shape[0]):  # row by row, like the back-projection
            out[i] = want[i]

    for ext in ("npz", "h5", "vti"):
        write_volume(tmp_path / f"v.{ext}", grid, fill, np.complex64, {"grid": "g"})
    with np.load(tmp_path / "v.npz") as f:
        np.testing.assert_array_equal(f["image"], want)
    with h5py.File(tmp_path / "v.h5") as f:
        assert f["image"].chunks is not None and f["image"].dtype == np.complex64
        np.testing.assert_array_equal(f["image"][()], want)
        for name, axis in zip("xyz", grid.axes):
            np.testing.assert_array_equal(f[name][()], axis)
        assert json.loads(f["meta"][()]) == {"grid": "g"}
    vol = pv.read(tmp_path / "v.vti")
    dims = grid.shape + ((1,) if dim == 2 else ())
    assert tuple(vol.dimensions) == dims
    np.testing.assert_allclose(vol.spacing[:dim], [0.01, 0.02, 0.005][:dim], rtol=1e-9)
    np.testing.assert_allclose(vol.origin[:dim], [-0.2, 0.5, 1.0][:dim], rtol=1e-12)
    # the voxel at (x, y, z) holds image(x, y, z): VTK's x-fastest order is right
    for idx in [(0, 0, 0), (6, 4, 2), (3, 1, 2), (5, 2, 1)]:
        idx = idx[:dim]
        p = vol.find_closest_point([grid.axes[a][idx[a]] for a in range(dim)] + [0.0] * (3 - dim))
        assert vol.point_data["magnitude"][p] == pytest.approx(abs(want[idx]), rel=1e-6)
        assert vol.point_data["real"][p] == pytest.approx(want[idx].real, rel=1e-6)
        assert vol.point_data["imag"][p] == pytest.approx(want[idx].imag, rel=1e-6, abs=1e-7)


def test_cli_das_h5_and_vti(paper, tmp_path, capsys):
    pv = pytest.importorskip("pyvista")
    data, _ = paper
    save_data(tmp_path / "d.h5", data)
    grid = "-0.3:0.3:0.01,0.3:0.6:0.01"
    for ext in ("npz", "h5", "vti"):
        assert (
            main(
                [
                    "das",
                    str(tmp_path / "d.h5"),
                    "-o",
                    str(tmp_path / f"o.{ext}"),
                    "--grid",
                    grid,
                    "--backend",
                    "numpy",
                ]
            )
            == 0
        )
    with np.load(tmp_path / "o.npz") as f, h5py.File(tmp_path / "o.h5") as g:
        np.testing.assert_array_equal(f["image"], g["image"][()])
        mag = np.abs(f["image"])
    vol = pv.read(tmp_path / "o.vti")
    np.testing.assert_allclose(
        vol.point_data["magnitude"], mag.ravel(order="F").astype(np.float64), rtol=1e-12
    )


# --------------------------------------------------------------------------
# bad input: one line, exit code 2
def _bad_files(folder, data):
    good = data_arrays(data)
    files = {}

    def h5(name, **change):
        arrays = {k: v for k, v in good.items() if change.get(k, 0) is not None}
        arrays.update({k: v for k, v in change.items() if v is not None})
        _write_h5(folder / name, arrays)
        files[name] = folder / name

    h5("nox.h5", x=None)
    h5("shape.h5", signal=good["signal"][:, :-1])
    h5("real.h5", signal=good["signal"].real)
    h5("nan.h5", signal=np.where(np.arange(600) == 7, np.nan, good["signal"]))
    h5("both.h5", spectrum=good["signal"])
    f = _band(32)
    spec = {"x": good["x"], "spectrum": np.ones((21, 32), complex), "frequency": f}
    _write_h5(folder / "nonuni.h5", {**spec, "frequency": f + np.where(np.arange(32) == 9, 1e6, 0)})
    _write_h5(folder / "negf.h5", {**spec, "frequency": f - 30e9})
    _write_h5(folder / "specnan.h5", {**spec, "spectrum": np.full((21, 32), np.nan + 0j)})
    _write_h5(folder / "specrange.h5", {**spec, "range": good["range"]})
    h5("group.h5", x=None)
    with h5py.File(folder / "group.h5", "a") as g:
        g.create_group("x")
    _write_h5(folder / "full.h5", good)
    raw = (folder / "full.h5").read_bytes()
    (folder / "trunc.h5").write_bytes(raw[: len(raw) // 2])
    (folder / "text.h5").write_text("not hdf5\n")
    (folder / "data.txt").write_text("x\n")
    return folder


BAD = [
    ("nox.h5", [], "missing key 'x'"),
    ("shape.h5", [], "signal must have shape"),
    ("real.h5", [], "complex"),
    ("nan.h5", [], "NaN"),
    ("both.h5", [], "both signal and spectrum"),
    ("nonuni.h5", [], "uniformly spaced"),
    ("negf.h5", [], "> 0 Hz"),
    ("specnan.h5", [], "spectrum contains NaN"),
    ("specrange.h5", [], "'range' goes with 'signal'"),
    ("group.h5", [], "not a group"),
    ("trunc.h5", [], "HDF5"),
    ("text.h5", [], "not a readable HDF5 file"),
    ("data.txt", [], "supported: .npz, .h5, .hdf5"),
    ("full.h5", ["--frame", "1"], "out of range"),
    ("missing.h5", [], "no such file"),
]


@pytest.fixture(scope="module")
def bad_folder(paper, tmp_path_factory):
    return _bad_files(tmp_path_factory.mktemp("bad"), paper[0])


@pytest.mark.parametrize("command", ["image", "das"])
@pytest.mark.parametrize("name,extra,words", BAD)
def test_bad_input_one_line(bad_folder, command, name, extra, words, capsys, tmp_path):
    path = str(bad_folder / name)
    argv = [command, path, "-o", str(tmp_path / "out.npz"), *extra]
    if command == "das":
        argv += ["--grid", "-0.1:0.1:0.05,0.3:0.5:0.05", "--backend", "numpy"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith(f"rpm-cl: error: {path}") and words in err[0], err[0]
    assert not os.listdir(tmp_path)


def test_bad_window_and_output_extension(paper, tmp_path, capsys):
    data, _ = paper
    save_data(tmp_path / "d.h5", data)
    assert (
        main(
            [
                "image",
                str(tmp_path / "d.h5"),
                "-o",
                str(tmp_path / "o.npz"),
                "--range-window",
                "kaiser",
            ]
        )
        == 2
    )
    assert "invalid choice" in capsys.readouterr().err
    for cmd, out, extra in (
        ("image", "o.xyz", []),
        ("das", "o.ply", ["--grid", "0:0.1:0.05,0.3:0.4:0.05"]),
        ("simulate", "o.vtp", []),
    ):
        argv = [cmd, "paper-2d"] if cmd == "simulate" else [cmd, str(tmp_path / "d.h5")]
        assert main(argv + ["-o", str(tmp_path / out), *extra]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "supported:" in err[0] and ".npz" in err[0], err
        assert not (tmp_path / out).exists()
    with pytest.raises(InputError, match="unknown range window"):
        load_data(tmp_path / "d.h5", range_window="kaiser")


# --------------------------------------------------------------------------
# interrupted writes leave nothing behind
@pytest.mark.parametrize(
    "ext,writer", [(".h5", "_h5_write_arrays"), (".ply", "_write_ply"), (".vtp", "_write_vtp")]
)
def test_interrupted_result_write_leaves_no_file(ext, writer, result, tmp_path, monkeypatch):
    def broken(tmp, arrays):
        with open(tmp, "wb") as fh:
            fh.write(b"half a file")
        raise KeyboardInterrupt

    monkeypatch.setattr(formats, writer, broken)
    with pytest.raises(KeyboardInterrupt):
        save_result(tmp_path / f"r{ext}", result, {})
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("ext", ["npz", "h5", "vti"])
def test_interrupted_volume_write_leaves_no_file(ext, tmp_path):
    grid = _grid(3)

    def fill(out):
        out[0] = 1.0
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_volume(tmp_path / f"v.{ext}", grid, fill)
    assert os.listdir(tmp_path) == []


def test_interrupted_data_write_leaves_no_file(paper, tmp_path, monkeypatch):
    def broken(tmp, arrays):
        with open(tmp, "wb") as fh:
            fh.write(b"\x89HDF")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(formats, "_h5_write_arrays", broken)
    with pytest.raises(InputError, match="cannot write"):
        save_data(tmp_path / "d.h5", paper[0])
    assert os.listdir(tmp_path) == []
