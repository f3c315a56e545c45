"""Progress bars: off in the library by default, on a terminal from the CLI,
never with --quiet or when stderr is not a terminal."""

import io
import sys

import pytest

from rpm_cl.cli import main
from rpm_cl.progress import bars_off, callback, progress


class FakeTTY(io.StringIO):
    """A stderr that says it is a terminal (tqdm's disable=None test)."""

    def isatty(self):
        return True


@pytest.fixture
def tty(monkeypatch):
    """Call it inside the test: pytest's own capture sets sys.stderr again
    after the fixtures are set up."""

    def install():
        err = FakeTTY()
        monkeypatch.setattr(sys, "stderr", err)
        return err

    return install


def drain(bar_iterable):
    return list(bar_iterable)


def test_no_bar_when_stderr_is_not_a_terminal(capsys):
    assert drain(progress(range(5), desc="counting", enabled=None)) == list(range(5))
    assert capsys.readouterr().err == ""


def test_bar_when_forced(capsys):
    assert drain(progress(range(5), desc="counting", enabled=True)) == list(range(5))
    err = capsys.readouterr().err
    assert "counting" in err and "/5" in err


def test_bar_on_a_terminal_only_when_asked(tty):
    tty = tty()
    drain(progress(range(3), desc="default-off"))  # the library default
    assert tty.getvalue() == ""
    drain(progress(range(3), desc="auto", enabled=None))
    assert "auto" in tty.getvalue()


def test_bars_off_beats_forced(capsys):
    with bars_off():
        drain(progress(range(3), desc="hidden", enabled=True))
        with callback(True, desc="hidden") as cb:
            assert cb is None
    drain(progress(range(3), desc="shown", enabled=True))
    err = capsys.readouterr().err
    assert "hidden" not in err and "shown" in err


def test_callback_forms(capsys):
    def mine(done, total):
        seen.append((done, total))

    seen = []
    with callback(mine) as cb:
        assert cb is mine
    with callback(False) as cb:
        assert cb is None
    with callback(True, desc="voxels") as cb:
        for done in (10, 20, 40):
            cb(done, 40)
    assert "voxels" in capsys.readouterr().err


def test_simulation_silent_by_default_on_a_terminal(tty):
    tty = tty()
    from rpm_cl.simulate import simulate_preset

    simulate_preset("paper-2d", 10.0, seed=1)
    assert tty.getvalue() == ""
    simulate_preset("paper-2d", 10.0, seed=1, progress=True)
    assert "simulate" in tty.getvalue()


def test_das_numpy_reports_every_voxel(capsys):
    """The callback reaches the grid size (known: 11 x 11 voxels)."""
    from rpm_cl.baselines.das import das_numpy, parse_grid
    from rpm_cl.simulate import simulate_preset

    data, _ = simulate_preset("paper-2d")
    seen = []
    das_numpy(
        data,
        parse_grid("-0.05:0.05:0.01,0.4:0.5:0.01"),
        memory_budget=160 * 21 * 10,
        progress=lambda d, t: seen.append((d, t)),
    )
    assert seen[-1] == (121, 121) and len(seen) == 13  # 10 voxels a chunk
    assert [d for d, _ in seen] == sorted(d for d, _ in seen)


@pytest.fixture(scope="module")
def sim_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("prog") / "p.npz"
    assert main(["simulate", "paper-2d", "-o", str(path), "-q"]) == 0
    return path


def test_cli_das_bar_on_terminal_not_with_quiet(sim_file, tmp_path, tty, capsys):
    tty = tty()
    argv = [
        "das",
        str(sim_file),
        "-o",
        str(tmp_path / "d.npz"),
        "--backend",
        "numpy",
        "--grid",
        "-0.05:0.05:0.01,0.4:0.5:0.01",
        "--memory-budget",
        "0.001",
    ]
    assert main(argv) == 0
    assert "das" in tty.getvalue() and "voxel" in tty.getvalue()
    assert "wrote" in capsys.readouterr().out
    tty.seek(0)
    tty.truncate()
    assert main([*argv, "--quiet"]) == 0
    assert tty.getvalue() == "" and capsys.readouterr().out == ""


def test_cli_no_bar_when_not_a_terminal(sim_file, tmp_path, capsys):
    argv = [
        "das",
        str(sim_file),
        "-o",
        str(tmp_path / "d.npz"),
        "--backend",
        "numpy",
        "--grid",
        "-0.05:0.05:0.01,0.4:0.5:0.01",
        "--memory-budget",
        "0.001",
    ]
    assert main(argv) == 0
    out, err = capsys.readouterr()
    assert err == "" and "wrote" in out
