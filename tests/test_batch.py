"""`rpm-cl batch`: frames on a Dask cluster give the single-run results, a
restart skips what is done, a corrupt frame is reported while the rest go on,
user errors are one line, and a frame whose worker dies is retried."""

import json
import os
import sys

import distributed
import numpy as np
import pytest

from rpm_cl.cli import main
from rpm_cl.imaging import DEFAULT_METHOD, run_method
from rpm_cl.io.data import InputError, load_npz, save_npz
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import simulate_preset

SEEDS = (11, 12, 13)
# the paper-2d targets (scene.py: range r at angle a from the array centre), m
TARGETS = np.array(
    [
        (r * np.sin(np.radians(a)), r * np.cos(np.radians(a)))
        for r, a in ((0.42, -28.0), (0.46, 3.0), (0.49, 25.0))
    ]
)


@pytest.fixture(scope="module")
def frames_dir(tmp_path_factory):
    """Three noisy paper-2d frames (different noise seeds)."""
    d = tmp_path_factory.mktemp("frames")
    for seed in SEEDS:
        save_npz(
            d / f"scan{seed}.npz", simulate_preset("paper-2d", 20.0, seed, noise="receiver")[0]
        )
    return d


def _local_cluster(workers=1):
    import warnings

    from distributed import LocalCluster

    with warnings.catch_warnings():  # "Port 8787 is already in use": another port is taken
        warnings.filterwarnings("ignore", message="Port .* is already in use")
        return LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
        )


@pytest.fixture(scope="module")
def client():
    """One embedded cluster for the tests that do not go through the CLI."""
    from distributed import Client

    with _local_cluster() as cluster, Client(cluster) as c:
        yield c


def _summary(out):
    return json.loads((out / "summary.json").read_text())


def test_cli_batch_equals_single_runs_and_reports_corrupt_frame(
    frames_dir, tmp_path, dev32, capsys
):
    inp = tmp_path / "in"
    inp.mkdir()
    for f in frames_dir.iterdir():
        (inp / f.name).write_bytes(f.read_bytes())
    (inp / "broken.npz").write_bytes(b"PK\x03\x04 not a zip at all")
    out = tmp_path / "out"
    code = main(["batch", str(inp), "-o", str(out), "--workers", "2"])
    cap = capsys.readouterr()
    assert code == 1  # some frames failed
    s = _summary(out)
    assert (s["frames"], s["done"], s["skipped"], s["workers"]) == (4, 3, 0, 2)
    assert [f["frame"] for f in s["failed"]] == ["broken"]
    assert "broken.npz" in s["failed"][0]["error"] and "\n" not in s["failed"][0]["error"]
    assert "failed broken" in cap.err and "Traceback" not in cap.err
    assert s["frames_per_s"] > 0 and s["stage_median_s"]["rpm"] > 0 and s["device"]
    assert not (out / "broken.npz").exists()
    for seed in SEEDS:
        data = load_npz(inp / f"scan{seed}.npz")
        want = run_method(DEFAULT_METHOD, data, default_params(data), dev32)
        with np.load(out / f"scan{seed}.npz") as got:
            # same kernels, same device, same inputs: the same image
            np.testing.assert_allclose(got["points"], want.image.points, rtol=0, atol=1e-9)
            np.testing.assert_array_equal(got["rp_range"], want.rps.range)
            meta = json.loads(str(got["meta"]))
            assert meta["method"] == DEFAULT_METHOD and meta["input"].endswith(f"scan{seed}.npz")
            pts = got["points"]
        # and the image is where the targets are: most points within 50 mm of one
        d = np.min(np.linalg.norm(pts[:, None, :] - TARGETS[None], axis=2), axis=1)
        assert len(pts) > 30 and np.mean(d <= 0.05) > 0.4


def test_restart_skips_done_frames(frames_dir, tmp_path, client):
    from rpm_cl.cli.batch import run_batch

    out = tmp_path / "out"
    s = run_batch(frames_dir, out, client=client)
    assert (s.done, s.skipped, s.failed) == (3, 0, [])
    first = {p.name: p.stat().st_mtime_ns for p in out.glob("scan*.npz")}
    assert len(first) == 3
    (out / "scan12.npz").unlink()
    s = run_batch(frames_dir, out, client=client)
    assert (s.frames, s.done, s.skipped) == (3, 1, 2)
    again = {p.name: p.stat().st_mtime_ns for p in out.glob("scan*.npz")}
    assert again["scan11.npz"] == first["scan11.npz"] and again["scan13.npz"] == first["scan13.npz"]
    # nothing left to do: no cluster is needed at all
    s = run_batch(frames_dir, out)
    assert (s.done, s.skipped, s.workers) == (0, 3, 0)
    assert _summary(out)["skipped"] == 3


def test_cli_on_an_existing_scheduler(frames_dir, tmp_path, client, capsys):
    from rpm_cl.cli.batch import PLUGIN_NAME

    out = tmp_path / "out"
    assert (
        main(["batch", str(frames_dir), "-o", str(out), "--scheduler", client.scheduler.address])
        == 0
    )
    assert "3 done" in capsys.readouterr().out
    s = _summary(out)
    assert s["scheduler"] == client.scheduler.address and s["workers"] == 1 and s["done"] == 3
    # the cluster is not ours: the workers' OpenCL state is released afterwards
    held = client.run(lambda dask_worker: PLUGIN_NAME in dask_worker.plugins)
    assert held and not any(held.values())


def test_das_per_frame_with_reuse_tables(frames_dir, tmp_path, client, cl_env):
    from rpm_cl.baselines.das import DeviceDAS, parse_grid
    from rpm_cl.cli.batch import BatchConfig, run_batch

    grid = "-0.3:0.3:0.01,0.3:0.6:0.01"
    data = load_npz(frames_dir / "scan13.npz")
    want = DeviceDAS(cl_env).backproject(data, parse_grid(grid))
    cases = [
        ("plan", {"das_reuse": "plan"}),
        ("direct", {"das_reuse": "direct"}),
        # tables over the budget: direct whatever asked
        ("direct", {"das_reuse": "plan", "memory_budget": 1e3}),
        (None, {}),
    ]
    for k, (mode, kw) in enumerate(cases):
        out = tmp_path / f"out{k}"
        s = run_batch(frames_dir, out, BatchConfig(das_grid=grid, **kw), client=client)
        assert s.done == 3 and s.stage_median_s["das"] > 0
        # auto picks by time on the first frame: either, one per worker and geometry
        assert s.das_modes == [mode] if mode else s.das_modes in (["plan"], ["direct"])
        with np.load(out / "scan13_das.npz") as f:
            got = f["image"]
            assert f["x"].shape == (61,) and json.loads(str(f["meta"]))["das_mode"] in s.das_modes
        # reuse tables (complex64 weights) and the float32 kernel agree with a
        # fresh direct back-projection to float32 rounding of the sum
        assert np.abs(got - want).max() <= 1e-4 * np.abs(want).max()


def _err(capsys, argv):
    code = main(argv)
    return code, capsys.readouterr().err.strip()


@pytest.mark.parametrize(
    "case",
    [
        "no-input",
        "empty-dir",
        "out-parent",
        "out-file",
        "out-is-in",
        "workers-0",
        "workers-and-scheduler",
        "bad-scheduler",
        "bad-grid",
        "bad-sigma",
    ],
)
def test_user_errors_are_one_line(case, frames_dir, tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    (tmp_path / "file").write_text("x")
    inp, out, extra = str(frames_dir), str(tmp_path / "out"), []
    if case == "no-input":
        inp = str(tmp_path / "missing")
    elif case == "empty-dir":
        inp = str(tmp_path / "empty")
    elif case == "out-parent":
        out = str(tmp_path / "no" / "such" / "out")
    elif case == "out-file":
        out = str(tmp_path / "file")
    elif case == "out-is-in":
        out = str(frames_dir)
    elif case == "workers-0":
        extra = ["--workers", "0"]
    elif case == "workers-and-scheduler":
        extra = ["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"]
    elif case == "bad-scheduler":
        extra = ["--scheduler", "not a scheduler address"]
    elif case == "bad-grid":
        extra = ["--das-grid", "0:1"]
    elif case == "bad-sigma":
        extra = ["--sigma-r", "-0.05"]
    code, err = _err(capsys, ["batch", inp, "-o", out, *extra])
    assert code == 2
    assert err.startswith("rpm-cl: error:") and "\n" not in err
    assert not (tmp_path / "out" / "summary.json").exists()


class _KillOnce(distributed.WorkerPlugin):
    """Test only: the first frame to start executing kills its worker process
    (marker file says it happened), as a crash of the OpenCL driver would."""

    def __init__(self, marker):
        self.marker = str(marker)

    def transition(self, key, start, finish, **kwargs):
        if finish == "executing" and "image_frame" in str(key) and not os.path.exists(self.marker):
            with open(self.marker, "w") as fh:
                fh.write(str(key))
            os._exit(1)


def test_frame_of_a_dead_worker_is_retried(frames_dir, tmp_path):
    import cloudpickle
    from distributed import Client

    from rpm_cl.cli.batch import run_batch

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers cannot import tests/
    marker = tmp_path / "killed"
    with _local_cluster() as cluster, Client(cluster) as c:
        c.register_plugin(_KillOnce(marker), name="kill-once")
        s = run_batch(frames_dir, tmp_path / "out", client=c)
    assert marker.exists()  # a worker did die mid-frame
    assert (s.done, s.failed) == (3, [])
    assert len(list((tmp_path / "out").glob("scan*.npz"))) == 3


def test_hdf5_stack_frames(tmp_path, dev32):
    """An HDF5 stack (signal with a leading frame axis) gives one result per
    frame, named by its index, each equal to imaging that frame alone; a
    single-frame .h5 beside it gives one result named after the file."""
    import h5py

    from rpm_cl.cli.batch import frame_sources, run_batch
    from rpm_cl.io.formats import save_data

    frames = [simulate_preset("paper-2d", 20.0, seed, noise="receiver")[0] for seed in SEEDS]
    inp = tmp_path / "in"
    inp.mkdir()
    save_data(inp / "single.h5", frames[0])
    with h5py.File(inp / "stack.h5", "w") as f:
        f["signal"] = np.stack([d.signal for d in frames])
        f["x"] = frames[0].array.x
        f["range"] = frames[0].range
        f["fc"] = frames[0].waveform.fc
        f["bandwidth"] = frames[0].waveform.bandwidth
    names = [s.name for s in frame_sources(inp)]
    assert names == ["single", "stack_f0000", "stack_f0001", "stack_f0002"]
    s = run_batch(inp, tmp_path / "out")
    assert (s.done, s.failed) == (4, [])
    for i, d in enumerate(frames):
        want = run_method(DEFAULT_METHOD, d, default_params(d), dev32).image.points
        got = np.load(tmp_path / "out" / f"stack_f{i:04d}.npz")["points"]
        np.testing.assert_allclose(got, want, atol=1e-9)
    (inp / "single.npz").write_bytes(b"")  # single.npz and single.h5: one output name
    with pytest.raises(InputError, match="same result"):
        frame_sources(inp)


def test_halfspace_frames(tmp_path, client, dev32):
    """A medium reaches every frame: the points and the DAS image (the reuse
    tables built with the refracted ranges, or the direct host
    back-projection) are those of the single runs."""
    from test_medium import EPS, TARGETS, H, _ranges, _spectrum_data

    from rpm_cl.baselines.das import das_numpy, parse_grid
    from rpm_cl.cli.batch import BatchConfig, run_batch
    from rpm_cl.io.formats import load_data, save_data
    from rpm_cl.io.medium import Medium

    frames = tmp_path / "frames"
    frames.mkdir()
    save_data(frames / "hs.npz", _spectrum_data(_ranges(TARGETS[:3])))
    data = load_data(frames / "hs.npz")
    grid = "-0.3:0.3:0.004,0.1:0.4:0.004"
    medium = (("medium", "eps_r"), EPS), (("medium", "antenna_height"), H)
    want_pts = run_method(
        DEFAULT_METHOD, data, default_params(data, eps_r=EPS, antenna_height=H), dev32
    ).image.points
    want = das_numpy(data, parse_grid(grid), medium=Medium(EPS, H))
    for k, reuse in enumerate(("plan", "direct")):
        out = tmp_path / f"out{k}"
        s = run_batch(
            frames,
            out,
            BatchConfig(overrides=medium, das_grid=grid, das_reuse=reuse),
            client=client,
        )
        assert s.done == 1 and s.das_modes == [reuse]
        np.testing.assert_allclose(np.load(out / "hs.npz")["points"], want_pts, atol=1e-6)
        with np.load(out / "hs_das.npz") as f:
            assert np.abs(f["image"] - want).max() <= 1e-4 * np.abs(want).max()
