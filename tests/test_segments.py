"""Long linear scans are decomposed in overlapping segments
(:mod:`rpm_cl.extract.segments`): which scans, how they are cut, and that
the targets near a long line's ends are imaged."""

import numpy as np
import pytest

from rpm_cl.extract import segments
from rpm_cl.imaging import run_method
from rpm_cl.io.data import Array, Waveform
from rpm_cl.rpm.params import _strongest_range, default_params
from rpm_cl.simulate import simulate, simulate_preset
from rpm_cl.simulate.scene import PointTarget, Scene

TARGETS = np.array(
    [(t, 0.30 + 0.02 * (i % 3)) for i, t in enumerate((-1.5, -0.9, -0.3, 0.4, 1.0, 1.6))]
)


def _line(snr=None, seed=0):
    xs = np.arange(200) * 0.02 - 2.0
    scene = Scene(tuple(PointTarget(tuple(t)) for t in TARGETS))
    return simulate(scene, Array(xs), Waveform(1.5e9, 1.0e9), np.arange(0, 1.5, 0.005), snr, seed)


@pytest.mark.parametrize("preset", ["paper-2d", "paper-2d-sparse"])
def test_short_apertures_are_decomposed_whole(preset):
    data, _ = simulate_preset(preset)
    assert segments.segment_plan(data, _strongest_range) is None


def test_a_metre_line_over_a_near_point_is_whole():
    data = simulate(
        Scene((PointTarget((-0.1, 0.45)),)),
        Array((np.arange(201) - 100) * 5e-3),
        Waveform(20e9, 0.2e9),
        np.arange(0.0, 1.5, 2.5e-3),
    )
    assert segments.segment_plan(data, _strongest_range) is None


def test_segments_overlap_by_half_and_their_kept_parts_tile_the_line():
    data = _line()
    strongest = _strongest_range(data)
    plan = segments.segment_plan(data, _strongest_range)
    assert plan is not None and len(plan) >= 4
    length = segments.SEGMENT_PER_RANGE * strongest
    covered = np.zeros(data.array.n, int)
    for i, (ant, kept) in enumerate(plan):
        n = ant.stop - ant.start
        assert n - 1 == int(np.ceil(length / data.array.dx - 1e-6))
        assert ant.start <= kept.start < kept.stop <= ant.stop
        covered[kept] += 1
        if i:
            prev = plan[i - 1][0]
            assert prev.stop - ant.start >= n // 2  # at least half overlaps
    assert np.all(covered == 1)
    # no echo, no segments
    assert segments.segment_plan(data, lambda d: None) is None


def test_planar_arrays_are_whole_without_reading_their_echoes():
    body, _ = simulate_preset("human-body")

    def unread(data):
        raise AssertionError("the strongest range of a planar array was asked for")

    assert segments.segment_plan(body, unread) is None


@pytest.mark.parametrize("snr", [None, 20.0])
def test_the_line_ends_targets_are_imaged(dev32, snr, monkeypatch):
    """Six points under a 4 m line: phase-rpm puts a point within 30 mm of
    every one and most of its points on them.  Decomposed whole, the line's
    focus (one point at its centre) is wrong for the targets near its ends:
    with centres a quarter window apart they are lost; with close centres
    (the default) they are found, but fewer of the points lie on targets."""
    data = _line(snr)
    pts = run_method("phase-rpm", data, default_params(data), dev32).image.points
    d = np.linalg.norm(pts[:, None] - TARGETS[None], axis=2)
    assert np.all(d.min(axis=0) <= 0.03)
    on = np.mean(d.min(axis=1) <= 0.03)
    assert on >= 0.9
    monkeypatch.setattr(segments, "SEGMENTS_ABOVE", np.inf)
    whole = run_method("phase-rpm", data, default_params(data), dev32).image.points
    dw = np.linalg.norm(whole[:, None] - TARGETS[None], axis=2)
    assert np.mean(dw.min(axis=1) <= 0.03) < on - 0.03
    apart = default_params(data, close_centres=False)
    whole = run_method("phase-rpm", data, apart, dev32).image.points
    dw = np.linalg.norm(whole[:, None] - TARGETS[None], axis=2)
    assert np.sum(dw.min(axis=0) > 0.1) >= 1


def test_moving_a_segmented_line_moves_its_image(dev32):
    """The same profiles with the positions 7.5 m further along: the same
    segments and the same image, moved."""
    import dataclasses

    data = _line()
    moved = dataclasses.replace(data, array=Array(data.array.x + 7.5), truth=None)
    a = run_method("phase-rpm", data, default_params(data), dev32).image.points
    b = run_method("phase-rpm", moved, default_params(moved), dev32).image.points
    assert a.shape == b.shape
    np.testing.assert_allclose(b - [7.5, 0.0], a, atol=1e-6)
