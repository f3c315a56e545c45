"""Cluster centres one aperture resolution cell apart (KSpaceParams.close_centres,
kspace module notes, step 2), phase-rpm's default.

The paper's window period on a linear array is the carrier wavenumber k_c
(about 440 rad/m at 21 GHz), and its centres are kept a quarter period
apart: two targets closer than 110 rad/m in two-way wavenumber, 7 degrees at
broadside, share one centre, and the window holds both.  The aperture itself
resolves 2 pi / L (58 rad/m for 25 antennas at 4.5 mm), and with
``close_centres`` the centres are kept that far apart.
"""

import numpy as np
import pytest

from rpm_cl.cli.robustness import (
    direction_cells,
    hits,
    loaded_data,
    random_geometry,
    region,
    synthesize,
)
from rpm_cl.extract.kspace import KSpaceParams
from rpm_cl.extract.kspace_detect import _nms_size
from rpm_cl.imaging import run_method
from rpm_cl.io.data import Array, InputError, RadarData, Waveform
from rpm_cl.rpm.params import default_params

PITCH = 4.5e-3
N = 25
L = (N - 1) * PITCH


def _data(nr=40):
    arr = Array((np.arange(N) - (N - 1) / 2) * PITCH)
    rng = np.linspace(0.0, 1.0, nr)
    return RadarData(np.zeros((N, nr), complex), arr, rng, Waveform(21e9, 0.22e9))


def _k_axis(pad=4):
    n = N * pad
    return (np.fft.fftshift(np.fft.fftfreq(n, PITCH)) * 2 * np.pi,)


def test_planar_arrays_keep_the_quarter_period():
    """A planar array whose cell (2 pi / 0.05 m = 126 rad/m) is narrower
    than a quarter of a 600 rad/m window: a linear array of the same
    extent would shrink the neighbourhood, the planar one does not."""
    arr = Array(np.arange(11) * 5e-3, np.arange(11) * 5e-3)
    data = RadarData(
        np.zeros((11, 11, 30), complex), arr, np.linspace(0, 1, 30), Waveform(20e9, 3e9)
    )
    ka = (np.arange(-600, 600, 4.0), np.arange(-600, 600, 4.0))
    assert _nms_size(data, (600.0, 600.0), ka, close=True) == _nms_size(data, (600.0, 600.0), ka)
    line = RadarData(
        np.zeros((11, 30), complex), Array(np.arange(11) * 5e-3), data.range, data.waveform
    )
    assert (
        _nms_size(line, (600.0,), ka[:1], close=True)[0][0]
        < _nms_size(line, (600.0,), ka[:1])[0][0]
    )


def test_suppression_shrinks_to_one_resolution_cell():
    data, ka = _data(), _k_axis()
    dk = ka[0][1] - ka[0][0]
    fixed, _ = _nms_size(data, (440.0,), ka)
    close, _ = _nms_size(data, (440.0,), ka, close=True)
    assert fixed[0] == 2 * int(np.ceil(0.25 * 440.0 / dk)) + 1
    assert close[0] == 2 * int(np.ceil(2 * np.pi / L / dk)) + 1
    assert close[0] < fixed[0]
    assert close[1:] == fixed[1:]


def test_close_centres_is_checked():
    with pytest.raises(InputError, match="close_centres"):
        KSpaceParams(close_centres="yes")


@pytest.mark.parametrize("seed, snr", [(1000, None), (1022, None), (1022, 30.0)])
def test_phase_rpm_resolves_close_directions(dev32, seed, snr):
    """Drawn scenes (the first seeds of ``benchmarks/random_scenes.py``)
    whose targets lie 1.5-3.3 aperture resolution cells from their nearest
    neighbour in direction, closer than a quarter window period: every
    target is hit with close centres, and one is lost with centres a quarter
    window apart (the same data, the same method)."""
    g = random_geometry(seed)
    assert direction_cells(g).min() > 1.0  # the aperture resolves them all
    spec, f, _ = synthesize(g, snr, seed)
    data = loaded_data(g, spec, f)
    close = run_method("phase-rpm", data, default_params(data, max_range=region(g)), dev32)
    fixed = run_method(
        "phase-rpm", data, default_params(data, max_range=region(g), close_centres=False), dev32
    )
    assert hits(close.image.points, g).all()
    assert not hits(fixed.image.points, g).all()
    p = np.asarray(close.image.points)
    d = np.min(np.linalg.norm(p[:, None] - np.asarray(g.targets)[None], axis=2), axis=1)
    assert np.mean(d < 0.05) >= 0.85


def test_kspace_rpm_keeps_the_paper_window(dev32):
    """The paper's method keeps its centres a quarter window apart unless
    told; told, it finds more clusters on this scene."""
    from dataclasses import replace

    g = random_geometry(1000)
    spec, f, _ = synthesize(g, None, 0)
    data = loaded_data(g, spec, f)
    params = default_params(data, max_range=region(g))

    def points(close):
        ks = replace(params.kspace, close_centres=close)
        return run_method("kspace-rpm", data, replace(params, kspace=ks), dev32).image.points

    default = run_method("kspace-rpm", data, params, dev32).image.points
    np.testing.assert_array_equal(default, points(False))
    assert len(points(True)) > len(default)


def test_random_geometry_is_in_the_envelope():
    for seed in range(20):
        g = random_geometry(seed)
        assert 20e9 <= g.fc <= 24e9 and 0.2e9 <= g.band <= 0.25e9
        assert 21 <= g.x[0] <= 31 and 4e-3 <= g.x[1] <= 5e-3
        t = np.asarray(g.targets)
        assert 3 <= len(t) <= 4
        r = np.hypot(t[:, 0], t[:, 1])
        assert np.all((r >= 0.35) & (r <= 0.5))
        assert np.all(np.abs(np.degrees(np.arctan2(t[:, 0], t[:, 1]))) <= 35)
        gap = np.linalg.norm(t[:, None] - t[None], axis=2) + np.eye(len(t))
        assert gap.min() >= 0.06
    assert random_geometry(3) == random_geometry(3)


def test_random_scenes_benchmark_runs(capsys, monkeypatch):
    """``benchmarks/random_scenes.py`` on one scene prints its table."""
    from pathlib import Path

    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import random_scenes

    assert random_scenes.main(["--scenes", "1", "--snr", "inf"]) == 0
    out = capsys.readouterr().out
    assert "r1000 S/N None" in out
    assert out.count("| inf |") == len(random_scenes.METHODS) + 1


def test_cluster_subtraction_benchmark_runs(capsys, monkeypatch):
    """``benchmarks/cluster_subtraction.py`` on one scene prints both rows;
    its phase-rpm row is the random-scenes benchmark's (the same scene,
    noise and scoring)."""
    from pathlib import Path

    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import cluster_subtraction
    import random_scenes

    assert cluster_subtraction.main(["--scenes", "1", "--snr", "inf", "--passes", "1"]) == 0
    rows = [r for r in capsys.readouterr().out.splitlines() if r.startswith("| inf |")]
    assert len(rows) == 2 and "others subtracted, 1 passes" in rows[1]
    assert random_scenes.main(["--scenes", "1", "--snr", "inf"]) == 0
    ref = [r for r in capsys.readouterr().out.splitlines() if r.startswith("| inf | phase-rpm |")]
    # within 50 mm, targets hit, scenes all hit: the same in both tables
    assert rows[0].split("|")[3:6] == ref[0].split("|")[3:6]
