"""``rpm-cl view`` on odd result files and unwritable outputs.

Every case must end in exit status 2 with one line on stderr (an
:class:`~rpm_cl.io.data.InputError`), never a traceback, and leave neither the
picture nor a temporary file behind.  The result files are written here with
NumPy (no OpenCL run needed): :func:`rpm_cl.viz.view.load_result` reads only
``points``, ``cluster``, ``rp_x``, ``rp_z`` and ``meta``.
"""

import json
import os
import subprocess
import sys
import tempfile

import numpy as np
import pytest

from rpm_cl.cli import main

ELL2 = {
    "type": "ellipsoid",
    "center": [0.0, 0.5],
    "semi_axes": [0.1, 0.05],
    "angles": [0.3],
    "amplitude": 1.0,
}
PT2 = {"type": "point", "position": [0.05, 0.4], "amplitude": 1.0}


def _result_2d(**override):
    m, k = 12, 8
    t = np.linspace(0, np.pi, m)
    out = {
        "points": np.stack([0.1 * np.cos(t), 0.5 - 0.05 * np.sin(t)], 1),
        "cluster": np.arange(m) // 6,
        "rp_x": np.linspace(-0.2, 0.2, k),
        "meta": {"method": "kspace-rpm", "scene": {"name": "t", "targets": [ELL2, PT2]}},
    }
    out.update(override)
    return out


def _result_3d(**override):
    m, k = 10, 6
    out = {
        "points": np.column_stack([np.linspace(-0.1, 0.1, m), np.full(m, 1.0), np.zeros(m)]),
        "cluster": np.zeros(m, np.int64),
        "rp_x": np.linspace(-0.2, 0.2, k),
        "rp_z": np.zeros(k),
        "meta": {
            "method": "kspace-rpm",
            "scene": {
                "targets": [
                    {
                        "type": "ellipsoid",
                        "center": [0, 1, 0],
                        "semi_axes": [0.1, 0.1, 0.3],
                        "angles": [0, 0, 0],
                    }
                ]
            },
        },
    }
    out.update(override)
    return out


def _write(path, res):
    res = {k: v for k, v in res.items() if v is not None}
    if not isinstance(res.get("meta"), (np.ndarray, type(None))):
        res["meta"] = np.array(json.dumps(res["meta"]))
    np.savez(path, **res)
    return path


def _assert_clean_failure(argv, folder, capsys):
    assert main(["view", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("rpm-cl: error:") and "\n" not in err, err
    assert "Traceback" not in err
    assert not list(folder.glob("*.png")), "a picture was written"
    assert not list(folder.glob(".tmp-*")), "a temporary file was left"
    return err


def test_control_well_formed_2d_result_renders(tmp_path):
    """The synthetic result used below is valid as it is: the failures that
    follow come from the one field each case spoils."""
    pytest.importorskip("matplotlib")
    src = _write(tmp_path / "ok.npz", _result_2d())
    assert main(["view", str(src), "--png", str(tmp_path / "ok.png")]) == 0
    assert (tmp_path / "ok.png").read_bytes()[:4] == b"\x89PNG"
    assert not list(tmp_path.glob(".tmp-*"))


BAD = {
    # meta not a JSON object
    "meta-list": (_result_2d(meta=[1, 2]), "meta must be a JSON object"),
    "meta-str": (_result_2d(meta="hello"), "meta must be a JSON object"),
    "meta-not-json": (_result_2d(meta=np.array("{not json")), "not a readable result file"),
    # scene / targets
    "scene-list": (_result_2d(meta={"scene": [1, 2]}), "meta.scene must be a JSON object"),
    "targets-dict": (_result_2d(meta={"scene": {"targets": {"a": 1}}}), "targets must be a list"),
    "target-not-dict": (_result_2d(meta={"scene": {"targets": [3]}}), "targets[0] must be"),
    "target-unknown-type": (
        _result_2d(meta={"scene": {"targets": [{"type": "cube"}]}}),
        "unknown type",
    ),
    "point-no-position": (
        _result_2d(meta={"scene": {"targets": [ELL2, {"type": "point"}]}}),
        "targets[1]: the point target has no position",
    ),
    "ellipsoid-no-semi-axes": (
        _result_2d(meta={"scene": {"targets": [{"type": "ellipsoid", "center": [0, 1]}]}}),
        "has no semi_axes",
    ),
    "ellipsoid-no-center": (
        _result_2d(meta={"scene": {"targets": [{"type": "ellipsoid", "semi_axes": [1, 1]}]}}),
        "has no center",
    ),
    "ellipsoid-text-angles": (
        _result_2d(meta={"scene": {"targets": [dict(ELL2, angles="up")]}}),
        "not numeric",
    ),
    "ellipsoid-negative-axis": (
        _result_2d(meta={"scene": {"targets": [dict(ELL2, semi_axes=[-1, 1])]}}),
        "semi_axes",
    ),
    "ellipsoid-3d-no-semi-axes": (
        _result_3d(meta={"scene": {"targets": [{"type": "ellipsoid", "center": [0, 1, 0]}]}}),
        "has no semi_axes",
    ),
    # arrays
    "points-1d": (_result_2d(points=np.zeros(4)), "points must be"),
    "points-text": (_result_2d(points=np.full((12, 2), "a")), "points must be"),
    "cluster-short": (_result_2d(cluster=np.zeros(3, int)), "cluster must be"),
    "cluster-2d": (_result_2d(cluster=np.zeros((12, 1), int)), "cluster must be"),
    "cluster-text": (_result_2d(cluster=np.full(12, "0")), "cluster must be"),
    "cluster-short-3d": (_result_3d(cluster=np.zeros(5, int)), "cluster must be"),
    "rp_x-2d": (_result_2d(rp_x=np.zeros((2, 2))), "rp_x must be a finite 1-D array"),
    "rp_x-nan": (_result_2d(rp_x=np.array([0.0, np.nan])), "rp_x must be a finite 1-D array"),
    "rp_z-2d": (_result_3d(rp_z=np.zeros((6, 1))), "rp_z must be a finite 1-D array"),
    "rp_z-short": (_result_3d(rp_z=np.zeros(5)), "rp_x and rp_z must have the same length"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_odd_result_file_is_an_input_error(case, tmp_path, capsys):
    res, expect = BAD[case]
    src = _write(tmp_path / "odd.npz", res)
    err = _assert_clean_failure([str(src), "--png", str(tmp_path / "odd.png")], tmp_path, capsys)
    assert expect in err


def test_mkstemp_failure_is_an_input_error(tmp_path, capsys, monkeypatch):
    """An output folder that cannot be written (simulated: the tests may run as
    root, who can write anywhere) gives an InputError, not an OSError."""
    src = _write(tmp_path / "ok.npz", _result_2d())

    def refuse(*a, **k):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(tempfile, "mkstemp", refuse)
    err = _assert_clean_failure([str(src), "--png", str(tmp_path / "a.png")], tmp_path, capsys)
    assert "Permission denied" in err


@pytest.mark.skipif(
    not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root writes into read-only folders"
)
def test_read_only_folder_is_an_input_error(tmp_path, capsys):
    src = _write(tmp_path / "ok.npz", _result_2d())
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        _assert_clean_failure([str(src), "--png", str(ro / "a.png")], ro, capsys)
    finally:
        ro.chmod(0o755)


def test_write_failure_while_rendering_leaves_nothing(tmp_path, capsys, monkeypatch):
    """A render that fails half-way (disk full, say) maps to InputError and the
    half-written temporary picture is removed."""
    import rpm_cl.viz.view as view_mod

    src = _write(tmp_path / "ok.npz", _result_2d())

    def half_write(res, png, size):
        with open(png, "wb") as fh:
            fh.write(b"\x89PNG half")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(view_mod, "_render_2d", half_write)
    err = _assert_clean_failure([str(src), "--png", str(tmp_path / "a.png")], tmp_path, capsys)
    assert "No space left" in err


def test_png_that_is_a_folder_is_an_input_error(tmp_path, capsys):
    src = _write(tmp_path / "ok.npz", _result_2d())
    (tmp_path / "d.png").mkdir()
    assert main(["view", str(src), "--png", str(tmp_path / "d.png")]) == 2
    err = capsys.readouterr().err.strip()
    assert "is a folder" in err and "\n" not in err
    assert not list(tmp_path.glob(".tmp-*"))


def test_result_without_scene_or_with_empty_points_still_renders(tmp_path):
    """Leniency kept: ``meta`` and ``meta.scene`` are optional and an image
    with no points is drawn (an empty picture is a true answer)."""
    pytest.importorskip("matplotlib")
    res = _result_2d(points=np.zeros((0, 2)), cluster=np.zeros(0, np.int64), meta=None)
    src = _write(tmp_path / "e.npz", res)
    assert main(["view", str(src), "--png", str(tmp_path / "e.png")]) == 0
    src = _write(tmp_path / "n.npz", _result_2d(meta={"method": "x", "scene": None}))
    assert main(["view", str(src), "--png", str(tmp_path / "n.png")]) == 0


@pytest.mark.parametrize("ext", [".ply", ".vtp", ".vti"])
def test_view_refuses_vtk_outputs_with_a_plain_line(tmp_path, capsys, ext):
    """Point clouds and volumes written for ParaView are not view's input:
    one line that says so, not a NumPy message about pickled data."""
    from rpm_cl.cli import main

    f = tmp_path / f"out{ext}"
    f.write_bytes(b"not npz")
    assert main(["view", str(f)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "ParaView" in err


def test_render_then_opencl_build_in_one_process(tmp_path):
    # VTK's off-screen (EGL) renderer and PoCL both bring an LLVM; loaded in
    # that order the next OpenCL program build can abort the process
    # ("LLVM ERROR: inconsistency in registered CommandLine options").  A
    # fresh process renders a 3-D result, then builds and runs a kernel.
    pytest.importorskip("pyvista")
    from rpm_cl.imaging import run_method
    from rpm_cl.io.formats import save_result
    from rpm_cl.rpm import reference
    from rpm_cl.rpm.params import default_params
    from rpm_cl.simulate import simulate
    from rpm_cl.simulate.scene import get_preset

    pre = get_preset("human-body")
    data = simulate(pre.scene, pre.array, pre.waveform, pre.range_axis, None, 0)
    res = run_method("mf-rpm", data, default_params(data, **pre.defaults), reference)
    out = tmp_path / "r.npz"
    save_result(str(out), res, {"scene": json.loads(data.truth.scene)})
    code = (
        "import sys, numpy as np\n"
        "from rpm_cl.viz import view\n"
        "view.view(sys.argv[1], sys.argv[2])\n"
        "from rpm_cl.cl import create_env\n"
        "from rpm_cl.rpm import DeviceRPM\n"
        "s = DeviceRPM(create_env()).score_candidates(np.zeros((3, 1, 8)), np.ones((1, 8)),\n"
        "                                             np.ones((1, 8), np.int8), 0.05)\n"
        "print('score', s[0, 0])\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    res = subprocess.run(
        [sys.executable, "-c", code, str(out), str(tmp_path / "r.png")],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
        check=False,
        cwd=tmp_path,
    )  # not the checkout: import the installed package
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.strip().endswith("score 8.0")
    assert (tmp_path / "r.png").stat().st_size > 0
