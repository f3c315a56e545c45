"""No command writes over a file it reads (issue: `image a.npz -o a.npz`
replaced the radar data with the result)."""

import os

import pytest

from rpm_cl.cli import main


def _one_error(capsys, argv):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rpm-cl: error:")
    return err[0]


@pytest.mark.parametrize(
    "argv",
    [
        ["image", "{f}", "-o", "{f}"],
        ["das", "{f}", "-o", "{f}", "--grid", "-0.1:0.1:0.01,0.3:0.5:0.01"],
        ["rma", "{f}", "-o", "{f}"],
        ["params", "{f}", "-o", "{f}"],
        ["image", "{f}", "-o", "{link}"],
        ["image", "{f}", "-o", "{f}", "--config", "{f}"],
    ],
)
def test_output_is_never_an_input(tmp_path, capsys, p2, argv):
    f = tmp_path / "in.npz"
    f.write_bytes(p2.read_bytes())
    link = tmp_path / "link.npz"
    os.symlink(f, link)
    before = f.read_bytes()
    line = _one_error(capsys, [a.format(f=f, link=link) for a in argv])
    assert "is also an input" in line
    assert f.read_bytes() == before


def test_figure_png_over_its_input_is_refused(tmp_path, capsys, p2):
    f = tmp_path / "in.npz"
    f.write_bytes(p2.read_bytes())
    assert "is also an input" in _one_error(capsys, ["figure", "kspace", str(f), "--png", str(f)])
