"""rpm-cl on planar data: simulate, image, view, reproduce paper-3d."""

import json

import numpy as np
import pytest

from rpm_cl.cli import main

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def body_result(tmp_path_factory):
    d = tmp_path_factory.mktemp("body")
    sim, out = d / "hb.npz", d / "out.npz"
    assert (
        main(
            [
                "simulate",
                "human-body",
                "-o",
                str(sim),
                "--snr",
                "20",
                "--seed",
                "3",
                "--noise",
                "receiver",
            ]
        )
        == 0
    )
    assert main(["image", str(sim), "-o", str(out)]) == 0
    return sim, out


def test_image_planar_writes_3d_points_and_the_scene(body_result):
    _, out = body_result
    with np.load(out) as f:
        pts = f["points"]
        assert pts.ndim == 2 and pts.shape[1] == 3 and len(pts) > 1000
        assert "rp_z" in f.files and f["cluster"].shape == (len(pts),)
        meta = json.loads(str(f["meta"]))
    assert len(meta["scene"]["targets"]) == 11
    # the body stands 1.0 - 1.3 m in front of the array
    assert np.all((pts[:, 1] > 0.9) & (pts[:, 1] < 1.4))


def _png_size(path):
    data = path.read_bytes()
    assert data[:8] == PNG_MAGIC
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def test_view_renders_3d_off_screen(body_result, tmp_path):
    pytest.importorskip("pyvista")
    _, out = body_result
    png = tmp_path / "body.png"
    assert main(["view", str(out), "--png", str(png)]) == 0
    assert _png_size(png) == (1000, 800)
    # not a blank picture: the coloured points and surfaces make many colours
    import matplotlib.image as mpimg

    img = mpimg.imread(png)[..., :3]
    colours = np.unique((img * 255).astype(np.uint8).reshape(-1, 3), axis=0)
    assert len(colours) > 50
    assert not list(tmp_path.glob(".tmp-*"))


def test_view_renders_2d_with_matplotlib(tmp_path):
    pytest.importorskip("matplotlib")
    sim, out, png = tmp_path / "p.npz", tmp_path / "o.npz", tmp_path / "p.png"
    assert main(["simulate", "paper-2d", "-o", str(sim)]) == 0
    assert main(["image", str(sim), "-o", str(out)]) == 0
    assert main(["view", str(out), "--png", str(png)]) == 0
    assert _png_size(png)[0] > 100


@pytest.mark.parametrize("case", ["missing", "not-a-result", "bad-suffix", "no-folder"])
def test_view_bad_input_one_line_exit_2(case, body_result, tmp_path, capsys):
    sim, out = body_result
    args = {
        "missing": [str(tmp_path / "nope.npz"), "--png", str(tmp_path / "a.png")],
        "not-a-result": [str(sim), "--png", str(tmp_path / "a.png")],
        "bad-suffix": [str(out), "--png", str(tmp_path / "a.jpg")],
        "no-folder": [str(out), "--png", str(tmp_path / "no" / "a.png")],
    }[case]
    assert main(["view", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("rpm-cl: error:") and "\n" not in err
    assert not list(tmp_path.glob("*.png"))


def test_reproduce_paper_3d_json(tmp_path, capsys):
    out = tmp_path / "r3.json"
    assert (
        main(["reproduce", "paper-3d", "--trials", "1", "--skip-volume", "--json", str(out)]) == 0
    )
    rows = json.loads(out.read_text())["rows"]
    ks = [r for r in rows if r["method"] == "kspace-rpm"]
    das = [r for r in rows if r["method"] == "das"]
    assert [r["grid"] for r in das] == ["section y=1 m, 3 mm"] * 2  # inf and 20 dB
    assert all(r["seconds"] > 0 and r["rpm_total"] > 0 for r in das)
    assert {r["case"] for r in rows} == {"human-body"}
    assert [r["snr_db"] for r in ks] == [None, 20.0]
    for r in ks:  # Tables IV and V
        assert r["rp_within_10mm"] >= 0.98 * r["rp_total"]
        assert r["rpm_within_50mm"] >= 0.95 * r["rpm_total"] and r["rpm_within_50mm"] >= 1155


def test_outputs_get_the_usual_file_mode(body_result, tmp_path):
    """Outputs are written to a private temporary file and renamed; the result
    must still have the mode a plain open() gives (0666 minus the umask)."""
    import os

    umask = os.umask(0)
    os.umask(umask)
    _, out = body_result
    assert os.stat(out).st_mode & 0o777 == 0o666 & ~umask
