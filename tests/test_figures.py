"""Pictures of DAS images (``rpm-cl view``) and the paper-style figures
(``rpm-cl figure``): drawn off-screen, checked against the scenes' truth and
against the arrays computed, and bad inputs as one line with exit code 2."""

import json

import numpy as np
import pytest

from rpm_cl.cli import main

pytest.importorskip("matplotlib")
import matplotlib

matplotlib.use("Agg")

C0 = 299_792_458.0


def _colours(png) -> int:
    import matplotlib.image as mpimg

    img = mpimg.imread(png)[..., :3]
    return len(np.unique((img * 255).astype(np.uint8).reshape(-1, 3), axis=0))


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("fig")
    out = {"dir": d}
    for name in ("paper-2d", "human-body"):
        out[name] = d / f"{name}.npz"
        assert main(["simulate", name, "-o", str(out[name])]) == 0
    return out


# ---------------------------------------------------------------- figures
def test_kspace_centres_are_the_targets_directions(files, tmp_path):
    """A point target at angle theta from broadside has k_x = 2 k_c sin(theta)
    (phase exp(-2j k_c R), R ~ R0 - x sin(theta)); the paper-2d targets are at
    -28, +3 and +25 degrees."""
    from rpm_cl.viz.figures import figure

    png = tmp_path / "k.png"
    m = figure("kspace", files["paper-2d"], png)
    kc = 2 * np.pi * 20e9 / C0
    want = 2 * kc * np.sin(np.radians([-28.0, 3.0, 25.0]))
    step = m.kx[1] - m.kx[0]  # 15 rad/m (21 antennas, pad 4)
    got = np.sort(m.centres[:, 0])
    assert len(got) == 3 and np.all(np.abs(got - want) <= step), (got, want)
    assert np.all(np.diff(m.kx) > 0) and m.db.shape == (m.kx.size, m.r.size)
    assert m.db.max() == 0.0 and m.kz is None
    assert png.read_bytes()[:4] == b"\x89PNG" and _colours(png) > 50


def test_kspace_drawn_array_is_the_map(files):
    import matplotlib.pyplot as plt

    from rpm_cl.io.data import load_npz
    from rpm_cl.viz.figures import draw_kspace, kspace_map

    m = kspace_map(load_npz(files["paper-2d"]))
    fig, ax = plt.subplots()
    im = draw_kspace(m, ax, 30.0)
    assert np.array_equal(np.asarray(im.get_array()), m.db.T)
    assert im.get_clim() == (-30.0, 0.0)
    plt.close(fig)


def test_kspace_planar_slices_at_the_strongest_kz(files, tmp_path):
    """Human body: the torso faces the array, so the strongest echo and a
    centre are broadside (k_x ~ 0); the map is the k_z row of the maximum."""
    from rpm_cl.viz.figures import figure

    png = tmp_path / "kp.png"
    m = figure("kspace", files["human-body"], png)
    assert m.kz is not None and abs(m.kz) < 50.0
    assert np.any(np.abs(m.centres[:, 0]) < 20.0)
    assert _colours(png) > 50


def test_rps_figure_draws_the_decomposed_and_true_rps(files, tmp_path):
    from rpm_cl.io.data import load_npz
    from rpm_cl.viz.figures import figure

    png = tmp_path / "r.png"
    s = figure("rps", files["paper-2d"], png)
    data = load_npz(files["paper-2d"])
    # the 63 true RPs (3 targets x 21 antennas), at their true ranges
    assert s.true_x.size == 63
    tx = np.array([[-0.42 * np.sin(np.radians(28)), 0.42 * np.cos(np.radians(28))]])
    r_true = np.hypot(data.array.x - tx[0, 0], tx[0, 1])
    assert np.allclose(np.sort(s.true_r[np.isin(s.true_x, data.array.x)])[:1], r_true.min())
    # the paper's 94 %: most decomposed RPs within 10 mm of a true one, 3 clusters
    assert s.within_10mm >= 0.9 * s.x.size and np.unique(s.cluster).size == 3
    assert _colours(png) > 10


def test_rps_figure_without_truth_and_planar_row(files, tmp_path):
    from rpm_cl.viz.figures import figure

    with np.load(files["paper-2d"]) as f:
        bare = {k: f[k] for k in ("signal", "x", "range", "fc", "bandwidth")}
    np.savez(tmp_path / "bare.npz", **bare)
    s = figure("rps", tmp_path / "bare.npz", tmp_path / "b.png")
    assert s.true_x is None and s.within_10mm is None and s.x.size > 0
    p = figure("rps", files["human-body"], tmp_path / "p.png")
    assert p.row_z == pytest.approx(1.0) and p.true_x.size > 0
    assert p.within_10mm >= 0.95 * p.x.size


def test_compare_figure_rpm_on_targets_and_das_is_das(files, tmp_path, cl_env, dev32):
    from rpm_cl.baselines.das import DeviceDAS, das_numpy
    from rpm_cl.io.data import load_npz
    from rpm_cl.metrics import err_rpm
    from rpm_cl.viz.figures import figure

    png = tmp_path / "c.png"
    c = figure("compare", files["paper-2d"], png, engine=dev32, das=DeviceDAS(cl_env))
    data = load_npz(files["paper-2d"])
    # the grid holds the scene with its margin
    b = data.truth.boundary
    assert c.grid.x[0] < b[:, 0].min() - 0.1 and c.grid.x[-1] > b[:, 0].max() + 0.1
    assert c.grid.y[0] < b[:, 1].min() - 0.1 and c.grid.y[-1] > b[:, 1].max() + 0.1
    # the RPM points are on the targets (paper Table I: 67 % within 50 mm, ours 97 %)
    assert np.mean(err_rpm(c.points, data.truth) <= 0.05) >= 0.9
    # the image drawn is the DAS sum (float32 kernel against the float64 spec)
    ref = das_numpy(data, c.grid)
    assert np.max(np.abs(c.image - ref)) <= 1e-3 * np.max(np.abs(ref))
    assert _colours(png) > 50


def test_compare_cli_numpy_backend_and_grid(files, tmp_path, capsys):
    png = tmp_path / "c.png"
    assert (
        main(
            [
                "figure",
                "compare",
                str(files["paper-2d"]),
                "--png",
                str(png),
                "--backend",
                "numpy",
                "--grid",
                "-0.3:0.3:0.004,0.2:0.6:0.004",
            ]
        )
        == 0
    )
    assert "wrote" in capsys.readouterr().out and _colours(png) > 50


# ---------------------------------------------------------------- DAS view
def _blob_volume(path, centre, shape=(40, 30, 50)):
    """A 3-D image with one Gaussian blob (complex) at ``centre``, m."""
    from rpm_cl.baselines.das import Grid, write_image

    g = Grid(
        np.linspace(-0.2, 0.2, shape[0]),
        np.linspace(0.8, 1.1, shape[1]),
        np.linspace(0.5, 1.5, shape[2]),
    )

    def fill(out):
        p = g.points().reshape(shape + (3,))
        d2 = np.sum((p - np.asarray(centre)) ** 2, axis=-1)
        out[...] = np.exp(-d2 / (2 * 0.03**2)) * np.exp(1j * 40 * p[..., 1]) + 1e-3

    write_image(path, g, fill, np.complex64, {"method": "das"})
    return g


def test_das_volume_is_memory_mapped_and_reduced_exactly(tmp_path, monkeypatch):
    import rpm_cl.viz.view as v

    g = _blob_volume(tmp_path / "v.npz", (0.05, 0.95, 1.1))
    img = v.load_das_image(tmp_path / "v.npz")
    assert img.mapped and isinstance(img.image, np.memmap)
    full = np.abs(np.asarray(img.image))
    monkeypatch.setattr(v, "SLAB_BYTES", 3 * 30 * 50 * 4)  # 3 x-planes a slab
    red, axes, peak, top = v._block_max(img, 16)
    # the brightest voxel is the blob's centre
    want = [int(np.argmin(np.abs(a - c))) for a, c in zip(g.axes, (0.05, 0.95, 1.1))]
    assert list(peak) == want and top == pytest.approx(full.max())
    # block maxima, 3 x 2 x 4 blocks (40/16, 30/16, 50/16 rounded up)
    assert red.shape == (14, 15, 13)
    assert red[5, 7, 3] == pytest.approx(full[15:18, 14:16, 12:16].max())
    assert np.max(red) == pytest.approx(full.max())
    assert np.allclose(axes[0][:2], [g.x[0:3].mean(), g.x[3:6].mean()])
    # the planes through the maximum, read slab by slab, are the image's planes
    i, j, k = peak
    px, py, pz = v._planes(img, peak)
    vol = np.asarray(img.image)
    assert np.array_equal(px, vol[i]) and np.array_equal(py, vol[:, j])
    assert np.array_equal(pz, vol[:, :, k])


@pytest.mark.parametrize("iso", [None, -6.0])
def test_view_das_volume_slices_and_iso_render(tmp_path, capsys, iso):
    pytest.importorskip("pyvista")
    _blob_volume(tmp_path / "v.npz", (0.05, 0.95, 1.1))
    png = tmp_path / "v.png"
    argv = ["view", str(tmp_path / "v.npz"), "--png", str(png)]
    assert main(argv + ([] if iso is None else ["--iso", str(iso)])) == 0
    assert png.read_bytes()[:4] == b"\x89PNG" and _colours(png) > 50
    assert not list(tmp_path.glob(".tmp-*"))


def test_view_das_2d_image_draws_the_image_in_db(files, tmp_path, capsys):
    from rpm_cl.viz.view import _block_max, load_das_image

    das = tmp_path / "d.npz"
    assert (
        main(
            [
                "das",
                str(files["paper-2d"]),
                "-o",
                str(das),
                "--backend",
                "numpy",
                "--grid",
                "-0.3:0.3:0.005,0.2:0.6:0.005",
            ]
        )
        == 0
    )
    png = tmp_path / "d.png"
    assert main(["view", str(das), "--png", str(png), "--dynamic-range", "30"]) == 0
    assert _colours(png) > 50
    # the brightest pixel is on a target's line of sight (0.2 GHz: a streak
    # along the range), within 3 degrees of one of -28, 3, 25 degrees
    img = load_das_image(das)
    _, _, peak, _ = _block_max(img, 2000)
    ang = np.degrees(np.arctan2(img.axes[0][peak[0]], img.axes[1][peak[1]]))
    assert np.min(np.abs(ang - np.array([-28.0, 3.0, 25.0]))) < 3.0


# ---------------------------------------------------------------- errors
def _bad_image(path, **over):
    arrs = {
        "image": np.ones((4, 5), np.complex64),
        "x": np.arange(4.0),
        "y": np.arange(5.0),
        "meta": np.array(json.dumps({"method": "das"})),
    }
    arrs.update(over)
    np.savez(path, **arrs)
    return str(path)


def _cases(files, d):
    sim = str(files["paper-2d"])
    return {
        "fig-unknown-name": ["figure", "nope", sim, "--png", str(d / "a.png")],
        "fig-missing-file": ["figure", "kspace", str(d / "none.npz"), "--png", str(d / "a.png")],
        "fig-bad-suffix": ["figure", "rps", sim, "--png", str(d / "a.jpg")],
        "fig-no-folder": ["figure", "rps", sim, "--png", str(d / "no" / "a.png")],
        "fig-range": ["figure", "kspace", sim, "--png", str(d / "a.png"), "--dynamic-range", "-3"],
        "fig-not-input": ["figure", "kspace", _bad_image(d / "img.npz"), "--png", str(d / "a.png")],
        "fig-compare-planar": [
            "figure",
            "compare",
            str(files["human-body"]),
            "--png",
            str(d / "a.png"),
        ],
        "fig-compare-3-axes": [
            "figure",
            "compare",
            sim,
            "--png",
            str(d / "a.png"),
            "--grid",
            "0:1:0.1,0:1:0.1,0:1:0.1",
        ],
        "view-iso-2d": ["view", _bad_image(d / "i2.npz"), "--png", str(d / "a.png"), "--iso", "-6"],
        "view-iso-positive": [
            "view",
            _bad_image(d / "i3.npz"),
            "--png",
            str(d / "a.png"),
            "--iso",
            "6",
        ],
        "view-axis-length": [
            "view",
            _bad_image(d / "i4.npz", x=np.arange(3.0)),
            "--png",
            str(d / "a.png"),
        ],
        "view-axis-unsorted": [
            "view",
            _bad_image(d / "i5.npz", y=np.array([0, 2, 1, 3, 4.0])),
            "--png",
            str(d / "a.png"),
        ],
        "view-image-nan": [
            "view",
            _bad_image(d / "i6.npz", image=np.full((4, 5), np.nan)),
            "--png",
            str(d / "a.png"),
        ],
        "view-image-text": [
            "view",
            _bad_image(d / "i7.npz", image=np.full((4, 5), "a")),
            "--png",
            str(d / "a.png"),
        ],
        "view-no-y": ["view", str(d / "i8.npz"), "--png", str(d / "a.png")],
    }


#: case -> what the one line must say
CASES = {
    "fig-unknown-name": "invalid choice",
    "fig-missing-file": "no such file",
    "fig-bad-suffix": "must be a .png",
    "fig-no-folder": "does not exist",
    "fig-range": "dynamic range",
    "fig-not-input": "missing key",
    "fig-compare-planar": "needs a linear-array file",
    "fig-compare-3-axes": "2 axes",
    "view-iso-2d": "needs a 3-D image",
    "view-iso-positive": "below the maximum",
    "view-axis-length": "x must be a finite, strictly increasing axis of 4",
    "view-axis-unsorted": "y must be a finite, strictly increasing",
    "view-image-nan": "i6.npz: the image contains NaN",
    "view-image-text": "numeric",
    "view-no-y": "missing 'y'",
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_inputs_one_line_exit_2(case, files, tmp_path, capsys):
    np.savez(tmp_path / "i8.npz", image=np.ones((4, 5), np.complex64), x=np.arange(4.0))
    argv = _cases(files, tmp_path)[case]
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("rpm-cl: error:") and "\n" not in err and "Traceback" not in err, err
    assert CASES[case] in err, err
    assert not list(tmp_path.glob("*.png")) and not list(tmp_path.glob(".tmp-*"))


def test_compare_das_panel_takes_the_steps_before_imaging(files):
    """The DAS panel images the data as ``rpm-cl das`` does, after the
    background removal ``auto`` chooses: a coupling common to every
    antenna, four times the targets' strongest echo, is gone from it."""
    from rpm_cl.baselines.das import das_numpy
    from rpm_cl.extract.preprocess import preprocess
    from rpm_cl.io.data import RadarData, load_npz
    from rpm_cl.rpm import reference
    from rpm_cl.simulate import synthesize
    from rpm_cl.viz.compare import compare_images

    data = load_npz(files["paper-2d"])
    n = data.array.x.size
    peak = np.abs(data.signal).max()
    leak = synthesize(
        np.arange(n), np.full(n, 0.03), np.full(n, 4 * peak), n, data.waveform, data.range
    )
    leaky = RadarData(data.signal + leak, data.array, data.range, data.waveform, data.truth)
    c = compare_images(leaky, reference)
    want = das_numpy(preprocess(leaky, "mean"), c.grid)
    assert np.max(np.abs(c.image - want)) <= 1e-9 * np.max(np.abs(want))
    raw = das_numpy(leaky, c.grid)
    assert np.max(np.abs(raw - want)) > 0.5 * np.max(np.abs(want))
