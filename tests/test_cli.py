"""The rpm-cl command: round trips, and bad input -> one line, exit code 2."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from rpm_cl.cli import main
from rpm_cl.imaging import DEFAULT_METHOD


@pytest.fixture(scope="module")
def sim_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("sim") / "paper.npz"
    assert (
        main(
            [
                "simulate",
                "paper-2d",
                "-o",
                str(path),
                "--snr",
                "20",
                "--seed",
                "1",
                "--noise",
                "receiver",
            ]
        )
        == 0
    )
    return path


def run_err(capsys, argv):
    code = main(argv)
    err = capsys.readouterr().err.strip()
    return code, err


def test_simulate_then_image_round_trip(sim_file, tmp_path, capsys):
    out = tmp_path / "img.npz"
    assert main(["image", str(sim_file), "-o", str(out)]) == 0
    assert "Err_range<=10mm" in capsys.readouterr().out
    with np.load(out) as f:
        pts = f["points"]
        assert pts.ndim == 2 and pts.shape[1] == 2 and len(pts) > 30
        for key in ("cluster", "score", "rp_x", "rp_range", "rp_amp", "rp_cluster"):
            assert key in f.files
        assert f["cluster"].shape == (len(pts),)
        meta = json.loads(str(f["meta"]))
        assert meta["method"] == DEFAULT_METHOD and "total" in meta["timings"]
        assert np.all(pts[:, 1] > 0)
    assert main(["image", str(sim_file), "-o", str(out), "--method", "mf-rpm"]) == 0


def test_info_lists_devices(capsys):
    assert main(["info"]) == 0
    out = capsys.readouterr().out
    assert "chosen:" in out and "*" in out


def test_reproduce_json_schema(tmp_path, capsys):
    out = tmp_path / "r.json"
    assert main(["reproduce", "paper-2d", "--json", str(out), "--trials", "1"]) == 0
    rows = json.loads(out.read_text())["rows"]
    want = {
        "case",
        "method",
        "snr_db",
        "rp_total",
        "rp_within_10mm",
        "rpm_total",
        "rpm_within_50mm",
        "rpm_within_100mm",
        "seconds",
    }
    assert all(want <= set(r) for r in rows)
    cases = {(r["case"], r["method"], r["snr_db"]) for r in rows}
    for snr in (None, 20.0, 10.0, 0.0):
        assert ("points-5mm", "kspace-rpm", snr) in cases
        assert ("points-5mm", "das", snr) in cases
    assert ("sparse-20mm", "kspace-rpm", None) in cases
    # the sparse array: DAS shows grating lobes (many peaks, few near a
    # target) where k-space RPM places its points (the paper's Fig. 12)
    das = next(r for r in rows if r["case"] == "sparse-20mm" and r["method"] == "das")
    ks = next(r for r in rows if r["case"] == "sparse-20mm" and r["method"] == "kspace-rpm")
    assert das["rpm_total"] > 20 and das["rpm_within_50mm"] < 0.5 * das["rpm_total"]
    assert ks["rpm_within_50mm"] >= 0.9 * ks["rpm_total"]


def write_npz(path, **arrays):
    np.savez(path, **arrays)
    return str(path)


def good_arrays():
    return {
        "signal": np.ones((4, 8), complex),
        "x": np.arange(4) * 5e-3,
        "range": np.arange(8) * 0.01,
        "fc": 20e9,
        "bandwidth": 0.2e9,
    }


@pytest.mark.parametrize(
    "change, words",
    [
        ({"signal": None}, "missing key 'signal'"),
        ({"x": np.array([0, 1, 3, 4.0]) * 1e-3}, "uniformly spaced"),
        ({"x": np.array([3, 2, 1, 0.0])}, "strictly increasing"),
        ({"range": np.arange(7) * 0.01}, "signal must have shape"),
        ({"signal": np.full((4, 8), np.nan, complex)}, "NaN or Inf"),
        ({"fc": -1.0}, "fc must be > 0"),
        ({"bandwidth": 0.0}, "bandwidth must be > 0"),
        ({"signal": np.array(["a"] * 32).reshape(4, 8)}, "complex"),
        ({"x": np.zeros(0)}, "at least 2"),
    ],
)
def test_bad_input_one_line_exit_2(tmp_path, capsys, change, words):
    arrays = good_arrays()
    for k, v in change.items():
        if v is None:
            arrays.pop(k)
        else:
            arrays[k] = v
    path = write_npz(tmp_path / "bad.npz", **arrays)
    out = tmp_path / "out.npz"
    code, err = run_err(capsys, ["image", path, "-o", str(out)])
    assert code == 2
    assert err.count("\n") == 0 and err.startswith("rpm-cl: error:") and words in err, err
    assert not out.exists()


def test_unreadable_truncated_missing_files(tmp_path, capsys, sim_file):
    trunc = tmp_path / "trunc.npz"
    trunc.write_bytes(sim_file.read_bytes()[: os.path.getsize(sim_file) // 2])
    junk = tmp_path / "junk.npz"
    junk.write_text("not a zip")
    for path in (trunc, junk, tmp_path / "missing.npz"):
        code, err = run_err(capsys, ["image", str(path), "-o", str(tmp_path / "o.npz")])
        assert code == 2 and err.count("\n") == 0 and str(path) in err, err


def test_unwritable_output_leaves_nothing(tmp_path, capsys, sim_file):
    code, err = run_err(capsys, ["image", str(sim_file), "-o", str(tmp_path / "no" / "o.npz")])
    assert code == 2 and "does not exist" in err
    code, err = run_err(capsys, ["image", str(sim_file), "-o", str(tmp_path)])
    assert code == 2 and "folder" in err
    assert [p.name for p in tmp_path.iterdir()] == []  # no temporary file left


def test_bad_options_one_line(capsys, sim_file, tmp_path):
    for argv in (
        ["simulate", "nope", "-o", "x.npz"],
        ["image"],
        ["simulate", "paper-2d", "-o", str(tmp_path / "a.npz"), "--snr", "loud"],
        ["image", str(sim_file), "-o", str(tmp_path / "b.npz"), "--sigma-x", "-1"],
        ["info", "--device", "no-such-device"],
    ):
        code, err = run_err(capsys, argv)
        assert code == 2 and err.count("\n") == 0 and err.startswith("rpm-cl: error:"), (argv, err)


def test_no_opencl_platform_says_how_to_install(monkeypatch, capsys):
    import rpm_cl.cl as clmod

    def none():
        raise clmod.NoOpenCLError(clmod.INSTALL_HINT)

    monkeypatch.setattr(clmod, "_platforms", none)
    code, err = run_err(capsys, ["info"])
    assert code == 2 and "pocl" in err.lower() and err.count("\n") == 0


def test_installed_entry_point_runs(tmp_path):
    """The console script exists and errors cleanly (no traceback)."""
    exe = os.path.join(os.path.dirname(sys.executable), "rpm-cl")
    r = subprocess.run(
        [exe, "image", str(tmp_path / "none.npz"), "-o", str(tmp_path / "o.npz")],
        check=False,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 2
    assert "Traceback" not in r.stderr and r.stderr.strip().count("\n") == 0


def test_simulate_noise_model_flag(tmp_path, capsys):
    """--noise picks the model of --snr; in-band by default, receiver as the
    paper's tables are reproduced (rpm_cl.simulate)."""
    from rpm_cl.simulate import simulate_preset

    sig = {}
    for name, tail in (
        ("default", []),
        ("in-band", ["--noise", "in-band"]),
        ("receiver", ["--noise", "receiver"]),
    ):
        out = tmp_path / f"{name}.npz"
        assert (
            main(["simulate", "paper-2d", "-o", str(out), "--snr", "10", "--seed", "2", *tail]) == 0
        )
        sig[name] = np.load(out)["signal"]
    assert "(receiver noise)" in capsys.readouterr().out
    np.testing.assert_array_equal(sig["default"], sig["in-band"])
    np.testing.assert_array_equal(
        sig["receiver"], simulate_preset("paper-2d", 10.0, 2, noise="receiver")[0].signal
    )
    np.testing.assert_array_equal(sig["in-band"], simulate_preset("paper-2d", 10.0, 2)[0].signal)
    code, err = run_err(
        capsys, ["simulate", "paper-2d", "-o", str(tmp_path / "x.npz"), "--noise", "thermal"]
    )
    assert code == 2 and "--noise" in err and err.count("\n") == 0


@pytest.mark.parametrize(
    "argv_tail, words",
    [
        (["--seed", "-1"], "seed"),
        (["--snr", "nan"], "S/N"),
        (["--snr", "4000"], "S/N"),
        (["--snr=-1e300"], "S/N"),
    ],
)
def test_bad_simulate_numbers(tmp_path, capsys, argv_tail, words):
    code, err = run_err(capsys, ["simulate", "paper-2d", "-o", str(tmp_path / "s.npz"), *argv_tail])
    assert code == 2 and words in err and err.count("\n") == 0


@pytest.mark.parametrize(
    "change, words",
    [
        ({"signal": np.ones((4, 8))}, "complex"),
        ({"bandwidth": 1e-300}, "range resolution"),
        ({"range": np.arange(8) * 1e-300}, "range resolution"),
        (
            {
                "truth_boundary": np.zeros((3, 3)),
                "truth_rp_antenna": np.zeros(1, int),
                "truth_rp_range": np.ones(1),
            },
            "truth_boundary",
        ),
        (
            {
                "truth_boundary": np.zeros((3, 2)),
                "truth_rp_antenna": np.array([9]),
                "truth_rp_range": np.ones(1),
            },
            "truth_rp_antenna",
        ),
    ],
)
def test_inconsistent_input_rejected(tmp_path, capsys, change, words):
    arrays = {**good_arrays(), **change}
    path = write_npz(tmp_path / "bad.npz", **arrays)
    code, err = run_err(capsys, ["image", path, "-o", str(tmp_path / "o.npz")])
    assert code == 2 and words in err and err.count("\n") == 0, err


def test_float32_axes_accepted(sim_file, tmp_path, capsys):
    with np.load(sim_file) as f:
        arrays = {k: f[k] for k in f.files}
    arrays["range"] = arrays["range"].astype(np.float32)
    arrays["x"] = arrays["x"].astype(np.float32)
    arrays["signal"] = arrays["signal"].astype(np.complex64)
    path = write_npz(tmp_path / "f32.npz", **arrays)
    assert main(["image", path, "-o", str(tmp_path / "o.npz")]) == 0


def test_rma_and_das_cli_write_images(sim_file, tmp_path, capsys):
    out = tmp_path / "rma.npz"
    assert main(["rma", str(sim_file), "-o", str(out), "--y-min", "0.2", "--y-max", "0.7"]) == 0
    with np.load(out) as f:
        assert f["image"].shape == (f["x"].size, f["y"].size) and np.iscomplexobj(f["image"])
        assert f["y"].min() >= 0.2 - 1e-9 and f["y"].max() <= 0.7 + 1e-9
    out = tmp_path / "das.npz"
    # a grid starting at a negative x: the value binds to --grid
    assert main(["das", str(sim_file), "-o", str(out), "--grid", "-0.1:0.1:0.01,0.3:0.6:0.01"]) == 0
    with np.load(out) as f:
        assert f["image"].shape == (21, 31) and json.loads(str(f["meta"]))["backend"] == "opencl"
    assert "back-projections/s" in capsys.readouterr().out


@pytest.mark.parametrize(
    "argv, words",
    [
        (["das", "{sim}", "-o", "{tmp}/a.npz", "--grid", "0:1:0.1,0:1:0.1,0:1:0.1"], "needs 2"),
        (["das", "{sim}", "-o", "{tmp}/a.npz", "--grid", "0:1"], "--grid needs"),
        (["das", "{sim}", "-o", "{tmp}/a.npz", "--grid", "0:1:-1,0:1:1"], "step > 0"),
    ],
)
def test_das_bad_grid_one_line_exit_2(argv, words, sim_file, tmp_path, capsys):
    argv = [a.format(sim=sim_file, tmp=tmp_path) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("rpm-cl: error:") and words in err and "\n" not in err
    assert not list(tmp_path.glob("*.npz"))


@pytest.mark.parametrize("method", ["kspace-rpm", "mf-rpm", "capon-rpm"])
@pytest.mark.parametrize("planar", [False, True])
def test_all_zero_input_is_valid_and_empty(method, planar, tmp_path, capsys):
    """A target-free (all-zero) file images to nothing, with every method."""
    shape = (11, 17, 300) if planar else (21, 300)
    arrays = {
        "signal": np.zeros(shape, complex),
        "x": (np.arange(shape[0]) - 5) * 7.5e-3,
        "range": 0.5 + np.arange(300) * 2.5e-3,
        "fc": 20e9,
        "bandwidth": 3e9,
    }
    if planar:
        arrays["z"] = (np.arange(17) - 8) * 7.5e-3
    src = write_npz(tmp_path / "zero.npz", **arrays)
    out = tmp_path / "out.npz"
    assert main(["image", src, "-o", str(out), "--method", method]) == 0
    with np.load(out) as f:
        assert f["points"].shape == (0, 3 if planar else 2) and f["rp_range"].size == 0


def test_bad_values_one_line_exit_2(sim_file, tmp_path, capsys):
    """Each of these inputs is one error line and exit 2, never a traceback."""
    from rpm_cl.io.data import InputError, load_npz

    with np.load(sim_file) as f:
        arrays = {k: f[k] for k in f.files}
    bad_scene = write_npz(tmp_path / "scene.npz", **{**arrays, "truth_scene": np.array("not json")})
    cases = [
        ["image", bad_scene, "-o", str(tmp_path / "a.npz")],
        ["das", str(sim_file), "-o", str(tmp_path / "a.npz"), "--grid", "0:1e308:1e-10,0:1:1"],
        [
            "das",
            str(sim_file),
            "-o",
            str(tmp_path / "a.npz"),
            "--grid",
            "0:1:0.1,0:1:0.1",
            "--memory-budget",
            "nan",
        ],
        ["das", str(sim_file), "-o", str(tmp_path), "--grid", "0:0.1:0.1,0.3:0.4:0.1"],
        ["rma", str(sim_file), "-o", str(tmp_path / "a.npz"), "--y-min", "1e300"],
        ["rma", str(sim_file), "-o", str(tmp_path / "a.npz"), "--y-min", "0.6", "--y-max", "0.5"],
    ]
    for argv in cases:
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert err.startswith("rpm-cl: error:") and "\n" not in err, (argv, err)
    assert not list(tmp_path.glob("a.npz")) and not list(tmp_path.glob(".tmp-*"))
    with pytest.raises(InputError, match="truth_scene"):
        load_npz(bad_scene)


def test_negative_values_bind_to_their_flag(sim_file, tmp_path):
    """'--y-min -1e-3' is a value, not an option."""
    out = tmp_path / "r.npz"
    assert main(["rma", str(sim_file), "-o", str(out), "--y-min", "-1e-3", "--y-max", "0.5"]) == 0
    with np.load(out) as f:
        assert f["y"].min() >= -1e-3 - 1e-9


def test_constant_planar_input_gives_no_clusters(tmp_path):
    """A flat signal has no k-space peak (plateaus are not maxima) and the
    alignment keeps the principal alias on a tie: no clusters, no points."""
    arrays = {
        "signal": np.ones((11, 17, 200), complex),
        "x": (np.arange(11) - 5) * 7.5e-3,
        "z": (np.arange(17) - 8) * 7.5e-3,
        "range": 0.7 + np.arange(200) * 2.5e-3,
        "fc": 20e9,
        "bandwidth": 3e9,
    }
    src = write_npz(tmp_path / "c.npz", **arrays)
    out = tmp_path / "o.npz"
    assert main(["image", src, "-o", str(out)]) == 0
    with np.load(out) as f:
        assert f["points"].shape == (0, 3)


def test_bench_table_and_kernel_profile(capsys, dev32):
    """``rpm-cl bench`` on the dense 2-D scene: a row per method (two S/N),
    the kernel columns filled for the device engine, and the kernel
    profile's medians consistent with its rate (evals / median score time);
    k-space RPM at the paper's Table I / II noise-free figures or better
    (94 % RP <= 10 mm, 67 % RPM <= 50 mm)."""
    from rpm_cl.cli.bench import bench_case, kernel_profile
    from rpm_cl.imaging import RPM_METHODS
    from rpm_cl.rpm.params import default_params
    from rpm_cl.simulate import simulate_preset

    assert (
        main(["bench", "--scene", "points-5mm", "--repeats", "1", "--no-das", "--no-roofline"]) == 0
    )
    out = capsys.readouterr().out
    for method in RPM_METHODS:
        assert sum(f" {method} " in line for line in out.splitlines()) == 2, method
    b = bench_case(dev32, "paper-2d", None, "kspace-rpm", repeats=1)
    assert b["rp10"] >= 0.94 and b["rpm50"] >= 0.67
    assert b["kernel_evals"] > 0 and b["score_ms"] > 0
    assert b["kernel_evals_per_s"] == pytest.approx(b["kernel_evals"] / (1e-3 * b["score_ms"]))
    data, pre = simulate_preset("paper-2d", None, 0)
    p = kernel_profile(dev32, "kspace-rpm", data, default_params(data, **pre.defaults), runs=3)
    assert p["kernel_evals"] == b["kernel_evals"] and not dev32.timing


def test_image_scores_a_truth_with_the_boundary_only(tmp_path, capsys, sim_file):
    """A file with truth_boundary and no truth_rp_* (a surveyed boundary of
    measured data) loads and is scored: Err_RPM as with the full truth,
    Err_range unavailable.  One of the two RP keys alone is refused."""
    from rpm_cl.io.formats import load_data

    full = dict(np.load(sim_file))
    part = {k: v for k, v in full.items() if k not in ("truth_rp_antenna", "truth_rp_range")}
    src = tmp_path / "boundary_only.npz"
    np.savez(src, **part)
    data = load_data(src)
    assert data.truth is not None and not data.truth.has_rps
    np.testing.assert_array_equal(data.truth.boundary, full["truth_boundary"])
    assert main(["image", str(src), "-o", str(tmp_path / "b.npz")]) == 0
    line_b = capsys.readouterr().out.strip().splitlines()[-1]
    assert main(["image", str(sim_file), "-o", str(tmp_path / "f.npz")]) == 0
    line_f = capsys.readouterr().out.strip().splitlines()[-1]
    assert line_b.startswith("Err_range<=10mm unavailable (no truth_rp_*)")
    # the Err_RPM part of the line is the full truth's
    assert line_b.split(", Err_RPM")[1] == line_f.split(", Err_RPM")[1]
    assert "Err_range<=10mm unavailable" not in line_f
    one = dict(part, truth_rp_range=full["truth_rp_range"])
    np.savez(tmp_path / "one.npz", **one)
    code, err = run_err(capsys, ["image", str(tmp_path / "one.npz"), "-o", str(tmp_path / "o.npz")])
    assert code == 2 and "give both or neither" in err


def test_boundary_only_truth_round_trips_and_summary(tmp_path):
    from rpm_cl.extract.rangepoints import RangePoints
    from rpm_cl.io.data import InputError, Truth, load_npz
    from rpm_cl.io.formats import load_data, save_data
    from rpm_cl.metrics import echoes_found, summary
    from rpm_cl.result import Image
    from rpm_cl.simulate import simulate_preset

    data = simulate_preset("paper-2d")[0]
    bare = type(data)(
        data.signal,
        data.array,
        data.range,
        data.waveform,
        Truth(None, None, data.truth.boundary, data.truth.scene),
    )
    for path in (tmp_path / "t.npz", tmp_path / "t.h5"):
        save_data(path, bare)
        for back in (load_data(path),) + ((load_npz(path),) if path.suffix == ".npz" else ()):
            assert not back.truth.has_rps and back.truth.rp_antenna is None
            np.testing.assert_array_equal(back.truth.boundary, data.truth.boundary)
    pts = data.truth.boundary[:2] + [[0.0, 0.03], [0.0, 0.2]]
    rps = RangePoints(
        np.array([10, 12]),
        data.array.x[[10, 12]],
        None,
        np.array([0.4, 0.5]),
        np.ones(2),
        np.zeros(2, int),
    )
    img = Image(pts, np.zeros(2, int), np.ones(2), np.arange(2))
    s = summary(rps, img, bare.truth)
    assert s["rp_within_10mm"] is None and s["rp_total"] == 2
    assert s["rpm_total"] == 2 and s["rpm_within_50mm"] == 1 and s["rpm_within_100mm"] == 1
    assert summary(rps, img, data.truth)["rp_within_10mm"] is not None
    with pytest.raises(InputError, match="no true RPs"):
        echoes_found(rps.antenna, rps.range, bare.truth)


def test_bench_roofline_and_equal_accuracy(capsys):
    """``rpm-cl bench`` with DAS: the measured limits, a roofline row per
    stage of the default method and for DAS, and one equal-accuracy line per
    tolerance and S/N whose times are those of points that reach it."""
    from rpm_cl.imaging import DEFAULT_METHOD

    assert main(["bench", "--scene", "points-5mm", "--repeats", "1"]) == 0
    out = capsys.readouterr().out
    assert "machine limits" in out and "GFLOP/s" in out
    lines = out.splitlines()
    for stage in ("decompose", "rpm", "intersect", "score"):
        assert sum(f" {DEFAULT_METHOD} " in ln and f" {stage} " in ln for ln in lines) == 2, stage
    das = [ln for ln in lines if ln.split()[2:4] == ["das", "das"]]
    assert len(das) == 2 and all(float(ln.split()[9]) > 0 for ln in das)  # % of peak
    equal = [ln for ln in lines if " mm  both reach " in ln]
    assert len(equal) == 4 and all("RPM / DAS = " in ln for ln in equal)


def test_das_and_rma_take_the_steps_before_imaging(tmp_path, capsys):
    """A B-scan whose strongest echo is the antennas' own coupling: das and
    rma remove it as image does (background auto: the mean profile), take
    --background and --config [imaging] too, and --time-zero."""
    from rpm_cl.io.data import C0

    f = np.linspace(1e9, 3e9, 81)
    x = np.arange(24) * 0.02
    r = np.hypot(x - 0.23, 0.3)[:, None]
    spec = 0.2 * np.exp(-4j * np.pi * f[None] * r / C0) / r + 3 * np.exp(
        -4j * np.pi * f * 0.01 / C0
    )
    np.savez(tmp_path / "b.npz", spectrum=spec, frequency=f, x=x)
    grid = ["--grid", "0:0.46:0.01,0.005:0.6:0.005", "--backend", "numpy"]
    images = {}
    for name, extra in (
        ("auto", []),
        ("mean", ["--background", "mean"]),
        ("none", ["--background", "none"]),
        ("cfg", ["--config", str(tmp_path / "c.toml")]),
    ):
        (tmp_path / "c.toml").write_text('[imaging]\nbackground = "none"\n')
        out = tmp_path / f"{name}.npz"
        assert main(["das", str(tmp_path / "b.npz"), "-o", str(out), *grid, *extra]) == 0
        images[name] = np.abs(np.load(out)["image"])
    capsys.readouterr()
    np.testing.assert_array_equal(images["auto"], images["mean"])
    np.testing.assert_array_equal(images["cfg"], images["none"])
    # the coupling's side lobes add to every pixel where it is left in
    assert np.max(np.abs(images["none"] - images["auto"])) > 0.1 * images["auto"].max()
    assert main(["rma", str(tmp_path / "b.npz"), "-o", str(tmp_path / "r.npz")]) == 0
    assert (
        main(
            ["rma", str(tmp_path / "b.npz"), "-o", str(tmp_path / "r0.npz"), "--time-zero", "0.05"]
        )
        == 0
    )
    assert np.load(tmp_path / "r0.npz")["y"][0] >= 0
