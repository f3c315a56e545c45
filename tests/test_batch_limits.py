"""`rpm-cl batch` per-frame limits: a frame over its time or memory limit is
stopped (its worker killed by the watchdog), reported failed with the limit
named, leaves no output behind, and the other frames are done."""

import os
import subprocess
import sys
import time

import distributed
import pytest

from rpm_cl.cli import main
from rpm_cl.cli.batch import BatchConfig
from rpm_cl.cli.watchdog import Watchdog, limit_reason
from rpm_cl.io.data import InputError, save_npz
from rpm_cl.simulate import simulate_preset

SEEDS = (11, 12, 13)
#: The stalled frame's limit, s: far above what a paper-2d frame with its DAS image
#: takes on a 2-core machine (tens of ms), far below the stall (60 s).
TIMEOUT_S = 4.0
#: The memory limit, bytes: 4x a worker's resident memory after a frame
#: (0.25 GB), below what the bloated frame takes (4 GB).
MEMORY = 1e9


class _Hooks(distributed.WorkerPlugin):
    """Test only: on a worker, the frame named ``stall*`` hangs while its
    result is being written (its DAS image already written, a temporary file
    begun), and the frame named ``bloat*`` takes 4 GB as it is read."""

    def __init__(self, reached):
        self.reached = str(reached)

    def setup(self, worker):
        import numpy as np

        import rpm_cl.cli.batch
        import rpm_cl.io.formats
        from rpm_cl.io.data import _atomic_file

        save = rpm_cl.io.formats.save_result
        reached = self.reached

        def hooked(path, result, meta):
            name = os.path.basename(path)
            if name.startswith("stall"):

                def hang(tmp):
                    with open(tmp, "wb") as fh:
                        fh.write(b"partial")
                    open(os.path.join(reached, name), "w").close()
                    time.sleep(60)

                _atomic_file(path, hang)
            return save(path, result, meta)

        def load(path, frame):
            name = os.path.basename(path)
            if name.startswith("bloat"):
                open(os.path.join(reached, name), "w").close()
                held = [np.ones(12_500_000) for _ in range(40)]  # 40 x 100 MB, touched
                del held
            return load_frame(path, frame)

        rpm_cl.io.formats.save_result = hooked
        load_frame = rpm_cl.cli.batch._load_frame
        rpm_cl.cli.batch._load_frame = load


def _local_cluster():
    import warnings

    from distributed import LocalCluster

    with warnings.catch_warnings():  # "Port 8787 is already in use": another port is taken
        warnings.filterwarnings("ignore", message="Port .* is already in use")
        return LocalCluster(
            n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None
        )


@pytest.fixture(scope="module")
def frames_dir(tmp_path_factory):
    """Folder ``time``: two noisy paper-2d frames and ``stall``; folder
    ``memory``: one and ``bloat`` (one limit each, so that a slow machine
    cannot stop the bloated frame by its time instead)."""
    d = tmp_path_factory.mktemp("frames")
    for sub, seeds, hooked in (("time", SEEDS[:2], "stall"), ("memory", SEEDS[2:], "bloat")):
        (d / sub).mkdir()
        for seed in seeds:
            data = simulate_preset("paper-2d", 20.0, seed, noise="receiver")[0]
            save_npz(d / sub / f"scan{seed}.npz", data)
        save_npz(d / sub / f"{hooked}.npz", data)
    return d


def test_frames_over_their_limits_fail_and_the_rest_are_done(frames_dir, tmp_path):
    import cloudpickle
    from distributed import Client

    from rpm_cl.cli.batch import run_batch

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers cannot import tests/
    reached = tmp_path / "reached"
    reached.mkdir()
    grid = "-0.3:0.3:0.02,0.2:0.6:0.02"
    timed = BatchConfig(das_grid=grid, das_reuse="plan", frame_timeout=TIMEOUT_S)
    sized = BatchConfig(
        das_grid=grid, das_reuse="plan", frame_timeout=float("inf"), frame_memory=MEMORY
    )
    t0 = time.perf_counter()
    with _local_cluster() as cluster, Client(cluster) as c:
        c.register_plugin(_Hooks(reached), name="limit-hooks")
        s_time = run_batch(frames_dir / "time", tmp_path / "time", timed, client=c)
        wall = time.perf_counter() - t0
        s_mem = run_batch(frames_dir / "memory", tmp_path / "memory", sized, client=c)
    # the hooks ran: the stalled frame had written its DAS image and begun its result
    assert sorted(os.listdir(reached)) == ["bloat.npz", "stall.npz"]
    assert (s_time.done, s_mem.done) == (2, 1)
    assert [(f["frame"], f["error"]) for f in s_time.failed] == [
        ("stall", limit_reason("time", TIMEOUT_S))
    ]
    assert [f["frame"] for f in s_mem.failed] == ["bloat"]
    assert s_mem.failed[0]["error"].startswith(limit_reason("memory", MEMORY)[:-1])
    assert "1 GB per-frame memory limit" in s_mem.failed[0]["error"]
    assert wall < 40  # the stall (60 s) was cut short
    # nothing of the stopped frames is left (hidden temporary files and markers included)
    assert sorted(os.listdir(tmp_path / "time")) == [
        "scan11.npz",
        "scan11_das.npz",
        "scan12.npz",
        "scan12_das.npz",
        "summary.json",
    ]
    assert sorted(os.listdir(tmp_path / "memory")) == [
        "scan13.npz",
        "scan13_das.npz",
        "summary.json",
    ]


def test_watchdog_stops_a_process_that_holds_the_gil(tmp_path):
    """A catastrophic regular expression runs in C with the GIL held: only a
    watchdog outside the process can stop it."""
    child = subprocess.Popen(
        [sys.executable, "-c", "import re; re.match(r'(a+)+$', 'a' * 64 + 'b')"]
    )
    marker = tmp_path / "reason"
    dog = Watchdog(child.pid)
    try:
        dog.arm(str(marker), 0.3, float("inf"))
        child.wait(timeout=10)
        assert marker.read_text().strip() == limit_reason("time", 0.3)
    finally:
        child.kill()
        dog.close()


def test_watchdog_disarmed_leaves_the_process_alone(tmp_path):
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    marker = tmp_path / "reason"
    dog = Watchdog(child.pid)
    try:
        dog.arm(str(marker), 0.2, 1e15)
        dog.disarm()
        time.sleep(0.6)
        assert child.poll() is None and not marker.exists()
        dog.arm(str(marker), 10.0, 1.0)  # 1 byte: over at once
        child.wait(timeout=10)
        assert marker.read_text().startswith("exceeded the 1 B per-frame memory limit")
    finally:
        child.kill()
        dog.close()


@pytest.mark.parametrize(
    "field, value",
    [("frame_timeout", 0.0), ("frame_timeout", float("nan")), ("frame_memory", -1.0)],
)
def test_config_refuses_limits_that_are_not_positive(field, value):
    with pytest.raises(InputError, match=field):
        BatchConfig(**{field: value})


@pytest.mark.parametrize(
    "flag, value",
    [
        ("--frame-timeout", "0"),
        ("--frame-timeout", "soon"),
        ("--frame-memory", "-2G"),
        ("--frame-memory", "lots"),
    ],
)
def test_bad_limit_flags_are_one_line(flag, value, frames_dir, tmp_path, capsys):
    code = main(["batch", str(frames_dir / "time"), "-o", str(tmp_path / "out"), flag, value])
    err = capsys.readouterr().err.strip()
    assert code == 2 and flag.lstrip("-").replace("-", " ") in err and "\n" not in err
    assert not (tmp_path / "out").exists()


def test_limit_flags_reach_the_config(monkeypatch, frames_dir, tmp_path):
    import rpm_cl.cli.batch

    seen = {}

    def fake_run(source, out, config, **kw):
        seen["config"] = config
        raise InputError("stop here")

    monkeypatch.setattr(rpm_cl.cli.batch, "run_batch", fake_run)
    main(
        [
            "batch",
            str(frames_dir / "time"),
            "-o",
            str(tmp_path / "o"),
            "--frame-timeout",
            "2m",
            "--frame-memory",
            "1.5GiB",
        ]
    )
    assert (seen["config"].frame_timeout, seen["config"].frame_memory) == (120.0, 1.5 * 2**30)
    main(["batch", str(frames_dir / "time"), "-o", str(tmp_path / "o"), "--frame-timeout", "none"])
    assert seen["config"].frame_timeout == float("inf") and seen["config"].frame_memory is None
