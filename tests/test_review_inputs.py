"""Adversarial inputs to the CLI's input checks: each malformed input is
one line ``rpm-cl: error: ...`` and exit code 2."""

import numpy as np
import pytest

from rpm_cl.cli import main
from rpm_cl.io.data import InputError, Truth, load_npz
from rpm_cl.io.formats import load_data

C0 = 299792458.0


def _one_error(capsys, argv):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rpm-cl: error: "), err
    return err[0]


@pytest.mark.parametrize(
    "text, words",
    [
        (b"\xff\xfe[rpm]\n", "not UTF-8"),  # not a UnicodeDecodeError traceback
        (b"rpm = 3\n", "must be a section [rpm]"),  # not an AttributeError traceback
    ],
)
def test_config_not_utf8_or_section_as_value(tmp_path, capsys, p2, text, words):
    cfg = tmp_path / "c.toml"
    cfg.write_bytes(text)
    line = _one_error(capsys, ["params", str(p2), "--config", str(cfg)])
    assert words in line and str(cfg) in line


def _spectrum_file(tmp_path, fc):
    f = np.linspace(19.8e9, 20.2e9, 81)
    x = np.linspace(-0.2, 0.2, 11)
    spec = np.exp(-4j * np.pi * f * 0.5 / C0)[None].repeat(x.size, 0).astype(np.complex64)
    path = tmp_path / "s.npz"
    np.savez(path, spectrum=spec, frequency=f, x=x, fc=np.float64(fc))
    return path


def test_spectrum_fc_outside_band_refused(tmp_path, capsys):
    # fc = 1e15 Hz with a 20 GHz band runs the near-field focus map for minutes
    # (refused as above 10 THz); 1 THz lies below that bound
    path = _spectrum_file(tmp_path, 1e12)
    line = _one_error(capsys, ["image", str(path), "-o", str(tmp_path / "o.npz")])
    assert "within the frequency band" in line
    assert not (tmp_path / "o.npz").exists()
    # inside the band it loads, and the echo is where it was put
    data = load_data(_spectrum_file(tmp_path, 20.05e9))
    assert abs(data.range[np.argmax(np.abs(data.signal[0]))] - 0.5) < 0.01


def test_figure_takes_frame_it_asks_for(tmp_path, capsys, monkeypatch):
    # a stack refused by `figure` asks for "--frame N", which `figure` accepts
    monkeypatch.setenv("MPLBACKEND", "Agg")
    d = dict(np.load(str(_spectrum_file(tmp_path, 20e9))))
    d["spectrum"] = np.stack([d["spectrum"]] * 3)
    stack = tmp_path / "stack.npz"
    np.savez(stack, **d)
    png = tmp_path / "f.png"
    line = _one_error(capsys, ["figure", "rps", str(stack), "--png", str(png)])
    assert "--frame" in line
    line = _one_error(capsys, ["figure", "rps", str(stack), "--frame", "3", "--png", str(png)])
    assert "out of range" in line
    assert (
        main(
            [
                "figure",
                "rps",
                str(stack),
                "--frame",
                "1",
                "--range-window",
                "hamming",
                "--png",
                str(png),
            ]
        )
        == 0
    )
    assert png.stat().st_size > 0


def _h5_copy(arrays, path):
    """The arrays as root datasets of an HDF5 file (strings as UTF-8 strings)."""
    import h5py

    with h5py.File(path, "w") as f:
        for k, v in arrays.items():
            v = np.asarray(v)
            if v.dtype.kind == "U":
                f.create_dataset(k, data=str(v), dtype=h5py.string_dtype("utf-8"))
            else:
                f.create_dataset(k, data=v)
    return path


@pytest.fixture(scope="module")
def empty_stacks(p2, tmp_path_factory):
    """p2 with a signal of shape (0, nx, nr): a stack of no frames, .npz and .h5."""
    d = dict(np.load(str(p2)))
    d["signal"] = np.zeros((0,) + d["signal"].shape, d["signal"].dtype)
    folder = tmp_path_factory.mktemp("empty")
    np.savez(folder / "e.npz", **d)
    return folder / "e.npz", _h5_copy(d, folder / "e.h5")


@pytest.mark.parametrize("ext", [0, 1])
@pytest.mark.parametrize(
    "argv",
    [
        ["image", "{src}", "-o", "{tmp}/o.npz"],
        ["image", "{src}", "-o", "{tmp}/o.npz", "--frame", "0"],
        ["das", "{src}", "-o", "{tmp}/o.npz", "--grid=-0.1:0.1:0.01,0.3:0.6:0.01"],
        ["params", "{src}"],
        ["figure", "kspace", "{src}", "--png", "{tmp}/o.png"],
        ["rma", "{src}", "-o", "{tmp}/o.npz"],
        ["batch", "{src}", "-o", "{tmp}/out"],
    ],
)
def test_empty_stack_is_one_clear_line(empty_stacks, tmp_path, capsys, argv, ext):
    # not "signal is a stack of 0 frames; choose one with frame= (--frame N,
    # 0..-1)", and no batch summary of 0 frames with exit code 0
    argv = [a.format(src=empty_stacks[ext], tmp=tmp_path) for a in argv]
    line = _one_error(capsys, argv)
    assert "holds no frames" in line and str(empty_stacks[ext]) in line
    assert "0..-1" not in line and "--frame" not in line
    assert not list(tmp_path.iterdir())  # nothing written, no summary, no temporary file


@pytest.mark.parametrize("shift", [0.5, 0.0])
@pytest.mark.parametrize("ext", [".npz", ".h5"])
def test_float_truth_rp_antenna_refused(p2, tmp_path, capsys, shift, ext):
    # float indices cast silently would make 3.5 into 3 and score the RP
    # accuracy of `image` against the wrong antennas.  Indices are integers by
    # type, like frame= and a result's cluster: an integral float is refused too.
    d = dict(np.load(str(p2)))
    d["truth_rp_antenna"] = d["truth_rp_antenna"].astype(np.float64) + shift
    src = tmp_path / f"f{ext}"
    np.savez(src, **d) if ext == ".npz" else _h5_copy(d, src)
    line = _one_error(capsys, ["image", str(src), "-o", str(tmp_path / "o.npz")])
    assert "truth_rp_antenna must be an integer array" in line and "float64" in line
    assert not (tmp_path / "o.npz").exists()
    with pytest.raises(InputError, match="truth_rp_antenna"):
        load_npz(src) if ext == ".npz" else load_data(src)


def test_integer_truth_rp_antenna_of_any_width_loads(p2, tmp_path):
    d = dict(np.load(str(p2)))
    want = d["truth_rp_antenna"]
    d["truth_rp_antenna"] = want.astype(np.int16)
    np.savez(tmp_path / "i16.npz", **d)
    got = load_data(tmp_path / "i16.npz").truth.rp_antenna
    assert got.dtype == np.int64 and np.array_equal(got, want)
    # an empty truth (no RPs) needs no dtype
    assert Truth([], [], [[0.0, 1.0]]).rp_antenna.shape == (0,)


def _pixels(png):
    import matplotlib.image as mpimg

    return mpimg.imread(str(png))


def test_view_reads_a_das_h5_image_as_the_npz_one(p2, tmp_path, capsys, monkeypatch):
    # `view IMAGE.h5` of `das -o IMAGE.h5` must read the HDF5 image, not
    # say "not an rpm-cl image result (missing 'points')"
    pytest.importorskip("matplotlib")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    grid = "--grid=-0.3:0.3:0.005,0.2:0.6:0.005"
    for ext in ("npz", "h5"):
        assert (
            main(
                ["das", str(p2), "-o", str(tmp_path / f"d.{ext}"), grid, "--backend", "numpy", "-q"]
            )
            == 0
        )
        assert (
            main(
                [
                    "view",
                    str(tmp_path / f"d.{ext}"),
                    "--png",
                    str(tmp_path / f"{ext}.png"),
                    "--dynamic-range",
                    "30",
                ]
            )
            == 0
        )
    assert np.array_equal(_pixels(tmp_path / "npz.png"), _pixels(tmp_path / "h5.png"))


def test_view_h5_volume_reads_slabs_like_the_npz(tmp_path, monkeypatch):
    """A 3-D .h5 volume: the same brightest voxel (a blob put at a known
    place), block maxima and planes as the .npz, read slab by slab."""
    import rpm_cl.viz.view as v
    from rpm_cl.baselines.das import Grid
    from rpm_cl.io.formats import write_volume

    g = Grid(np.linspace(-0.2, 0.2, 40), np.linspace(0.8, 1.1, 30), np.linspace(0.5, 1.5, 50))
    centre = (0.05, 0.95, 1.1)

    def fill(out):
        d2 = np.sum((g.points().reshape(out.shape + (3,)) - centre) ** 2, axis=-1)
        out[...] = np.exp(-d2 / (2 * 0.03**2)) + 1e-3

    for ext in ("npz", "h5"):
        write_volume(tmp_path / f"v.{ext}", g, fill, np.complex64, {"method": "das"})
    monkeypatch.setattr(v, "SLAB_BYTES", 3 * 30 * 50 * 4)  # 3 x-planes a slab
    a, b = v.load_das_image(tmp_path / "v.npz"), v.load_das_image(tmp_path / "v.h5")
    assert b.image.shape == a.image.shape and b.meta == a.meta == {"method": "das"}
    assert all(np.array_equal(p, q) for p, q in zip(a.axes, b.axes))
    red_a, axes_a, peak_a, top_a = v._block_max(a, 16)
    red_b, axes_b, peak_b, top_b = v._block_max(b, 16)
    assert all(np.array_equal(p, q) for p, q in zip(axes_a, axes_b))
    want = tuple(int(np.argmin(np.abs(ax - c))) for ax, c in zip(g.axes, centre))
    assert peak_b == peak_a == want and top_b == top_a
    assert np.array_equal(red_a, red_b)
    assert all(np.array_equal(p, q) for p, q in zip(v._planes(a, want), v._planes(b, want)))


@pytest.mark.parametrize("iso", [None, "-6"])
def test_view_h5_volume_renders_as_the_npz(tmp_path, capsys, iso, cl_env):
    # cl_env: PoCL must load its LLVM before VTK's EGL (mesa) loads another;
    # the other order aborts the process ("LLVM ERROR: inconsistency in
    # registered CommandLine options") when a later test builds OpenCL programs
    pytest.importorskip("pyvista")
    from rpm_cl.baselines.das import Grid
    from rpm_cl.io.formats import write_volume

    g = Grid(np.linspace(-0.2, 0.2, 20), np.linspace(0.8, 1.1, 15), np.linspace(0.5, 1.5, 25))

    def fill(out):
        d2 = np.sum((g.points().reshape(out.shape + (3,)) - (0.05, 0.95, 1.1)) ** 2, axis=-1)
        out[...] = np.exp(-d2 / (2 * 0.05**2)) + 1e-3

    for ext in ("npz", "h5"):
        write_volume(tmp_path / f"v.{ext}", g, fill, np.complex64, {"method": "das"})
        argv = ["view", str(tmp_path / f"v.{ext}"), "--png", str(tmp_path / f"{ext}.png")]
        assert main(argv + ([] if iso is None else ["--iso", iso])) == 0
    a, b = _pixels(tmp_path / "npz.png"), _pixels(tmp_path / "h5.png")
    assert a.shape == b.shape and np.mean(np.abs(a - b)) < 1e-3
    assert len(np.unique((a[..., :3] * 255).astype(np.uint8).reshape(-1, 3), axis=0)) > 20


def test_view_odd_h5_image_is_one_line(tmp_path, capsys):
    import h5py

    with h5py.File(tmp_path / "g.h5", "w") as f:
        f.create_dataset("image", data=np.ones((3, 4), np.complex64))
        f.create_group("x")
        f.create_dataset("y", data=np.arange(4.0))
    line = _one_error(capsys, ["view", str(tmp_path / "g.h5"), "--png", str(tmp_path / "g.png")])
    assert "x must be a dataset" in line
    with h5py.File(tmp_path / "s.h5", "w") as f:
        f.create_dataset("image", data=np.ones((3, 4), np.complex64))
        f.create_dataset("x", data=np.arange(3.0))
        f.create_dataset("y", data=np.arange(5.0))
    line = _one_error(capsys, ["view", str(tmp_path / "s.h5"), "--png", str(tmp_path / "g.png")])
    assert "y must be a finite, strictly increasing axis of 4 values" in line
    assert not list(tmp_path.glob("*.png")) and not list(tmp_path.glob(".tmp-*"))


def test_rma_writes_what_its_extension_says(p2, tmp_path, capsys):
    # `rma -o X.h5` writes HDF5, not an .npz archive named X.h5, by
    # extension as `das` does, and refuses other extensions
    import h5py

    argv = ["rma", str(p2), "--y-min", "0.3", "--y-max", "0.6", "-o"]
    assert main(argv + [str(tmp_path / "r.npz")]) == 0
    assert main(argv + [str(tmp_path / "r.h5")]) == 0
    assert h5py.is_hdf5(tmp_path / "r.h5")
    with np.load(tmp_path / "r.npz") as a, h5py.File(tmp_path / "r.h5", "r") as b:
        for k in ("image", "x", "y"):
            assert np.array_equal(a[k], b[k][()]), k
        assert str(a["meta"]) and b["meta"][()]
        img, x, y = a["image"], a["x"], a["y"]
    # both hold the image of rma_image
    from rpm_cl.baselines.rma import rma_image

    want = rma_image(load_data(p2), y_min=0.3, y_max=0.6)
    for got, w in zip((img, x, y), want):
        assert np.array_equal(got, w)
    line = _one_error(capsys, argv + [str(tmp_path / "r.txt")])
    assert "unknown image extension '.txt'" in line and ".h5" in line
    assert not (tmp_path / "r.txt").exists()


def test_figure_uses_config_and_flags_like_image(p2, tmp_path, capsys, monkeypatch):
    """`figure kspace|rps --config` applies the file's parameters, not the
    defaults, and flags override the file as for `image`.  The paper-2d
    targets lie at k = 2 k0 sin(theta) = -393, +44 and +354 rad/m; the
    centres are local maxima within a quarter window period in k, so
    window_x = 417 (the default, the paper's) keeps 3 centres, 1300 (+-325
    rad/m) merges +44 and +354 (310 apart) into 2, and 2000 (+-500) leaves
    1."""
    from rpm_cl.viz import figures

    monkeypatch.setenv("MPLBACKEND", "Agg")
    drawn = []
    real = figures.figure
    monkeypatch.setattr(figures, "figure", lambda *a, **k: drawn.append(real(*a, **k)))
    cfg = tmp_path / "c.toml"
    cfg.write_text("[kspace]\nwindow_x = 1300.0\n")
    png = str(tmp_path / "f.png")
    runs = [([], 3), (["--config", str(cfg)], 2), (["--config", str(cfg), "--window-x", "2000"], 1)]
    for extra, want in runs:
        assert main(["figure", "kspace", str(p2), "--png", png, "-q", *extra]) == 0
        assert len(drawn[-1].centres) == want, extra
        assert main(["figure", "rps", str(p2), "--png", png, "-q", *extra]) == 0
        assert np.unique(drawn[-1].cluster).size == want, extra
    # a bad value in the file is read, and refused like `image` refuses it
    cfg.write_text("[kspace]\nwindow_x = -1.0\n")
    line = _one_error(capsys, ["figure", "kspace", str(p2), "--png", png, "--config", str(cfg)])
    assert "window_x" in line


@pytest.fixture(scope="module")
def wide_sparse(tmp_path_factory):
    """An extreme linear array: 21 antennas at 1 m pitch (a 20 m aperture,
    1334 wavelengths at 20 GHz), two point targets, 12 m of range."""
    from rpm_cl.io.data import Array, Waveform
    from rpm_cl.io.formats import save_data
    from rpm_cl.simulate import simulate
    from rpm_cl.simulate.scene import PointTarget, Scene

    data = simulate(
        Scene((PointTarget((0.3, 5.0)), PointTarget((-2.0, 8.0))), "wide"),
        Array((np.arange(21) - 10) * 1.0),
        Waveform(20e9, 0.2e9),
        np.arange(0.0, 12.0, 2.5e-3),
    )
    path = tmp_path_factory.mktemp("wide") / "wide.npz"
    save_data(path, data)
    return path


def test_huge_near_field_search_is_refused_at_once(wide_sparse, tmp_path, capsys, monkeypatch):
    # unbounded it runs for minutes: its focused map has 22079 directions x
    # 21 antennas x ~800 range samples (4e8 terms, 16 s each, recomputed
    # 15-35 times).  It is refused before the first map, in one line that
    # says why and what to do.  (Its 20 m aperture is 27 range resolutions
    # long, so by default it takes the plane-wave path, nearfield.near_field_wanted; asked for, the
    # near-field search is refused.)
    from rpm_cl.extract import nearfield

    maps = []
    real = nearfield._Search.focus_map
    monkeypatch.setattr(nearfield._Search, "focus_map", lambda s, x: maps.append(1) or real(s, x))
    out = tmp_path / "o.npz"
    # -q: its 67-wavelength pitch is also warned about (x in cm?)
    line = _one_error(
        capsys, ["image", str(wide_sparse), "-o", str(out), "--near-field", "true", "-q"]
    )
    assert "near-field search" in line and "too large" in line and "--near-field false" in line
    assert "22079 directions x 21 antennas" in line  # 4 pad L / lambda = 4 x 4 x 21 m / 15 mm
    assert maps == [] and not out.exists()
    # the plane-wave decomposition it points to images the file
    assert main(["image", str(wide_sparse), "-o", str(out), "--near-field", "false", "-q"]) == 0
    assert out.exists()


def test_automatic_near_field_gives_way_to_the_plane_wave_path(tmp_path, capsys):
    """128 antennas at 1.5 wavelengths (77 GHz, 0.74 m: within 1.2 range
    resolutions of a 0.2 GHz band) are what the near-field search is chosen
    for, but its map would hold 3025 directions x 128 antennas x ~250 range
    samples.  By default the plane-wave path images the file (exit 0);
    asked for, the search is refused in one line."""
    from rpm_cl.extract import nearfield
    from rpm_cl.io.data import Array, Waveform
    from rpm_cl.io.formats import save_data
    from rpm_cl.simulate import simulate
    from rpm_cl.simulate.scene import PointTarget, Scene

    targets = np.array([(0.1, 0.5), (-0.3, 1.0), (0.2, 1.9)])
    data = simulate(
        Scene(tuple(PointTarget(tuple(t)) for t in targets), "dense aperture"),
        Array((np.arange(128) - 63.5) * 5.84e-3),
        Waveform(77e9, 0.2e9),
        np.arange(0.0, 2.5, 5e-3),
    )
    assert nearfield.near_field_wanted(data)
    path, out = tmp_path / "wide77.npz", tmp_path / "o.npz"
    save_data(path, data)
    assert main(["image", str(path), "-o", str(out), "-q"]) == 0
    got = np.load(out)["points"]
    # the nearest, strongest target at least (an aperture sampled at 1.5
    # wavelengths aliases the plane-wave path's k axis: what that path makes
    # of the farther ones is the pitch's limit, not this test's subject)
    assert np.min(np.linalg.norm(got - targets[0], axis=1)) < 0.05
    out.unlink()
    line = _one_error(capsys, ["image", str(path), "-o", str(out), "--near-field", "true", "-q"])
    assert "too large" in line and not out.exists()
    # the k-space figure names the path that ran
    from rpm_cl.viz.decomposition import kspace_map

    assert not kspace_map(data).near_field


def test_paper_sparse_map_is_far_inside_the_bound():
    """The bound must not touch the paper's sparse case: its map has 441
    directions x 21 antennas x 104 samples, under a sixteenth of the bound
    (the result itself is checked against the targets in test_nearfield)."""
    from rpm_cl.extract import nearfield
    from rpm_cl.simulate import simulate_preset

    data = simulate_preset("paper-2d-sparse")[0]
    s = nearfield._Search(data, 10 ** (-20 / 20), 4)
    assert s.u_det.size * s.n * s.r_det.size < nearfield.MAP_TERMS_MAX / 16
