"""Long linear scans are decomposed in overlapping segments and large planar
arrays in tiles (:mod:`rpm_cl.extract.segments`): which arrays,
how they are cut, and that the targets near a long line's ends and the
spheres before a wide planar array are imaged."""

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
    for i, ((ant,), (kept,)) in enumerate(plan):
        n = ant.stop - ant.start
        assert n - 1 == int(np.ceil(length / data.array.dx - 1e-6))
        assert ant.start <= kept.start < kept.stop <= ant.stop
        covered[kept] += 1
        if i:
            prev = plan[i - 1][0][0]
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
    (the default) they are found, but fewer of the points lie on targets
    (noise-free 95.9 % against 98.7 %, at 20 dB 83 % against 99 %)."""
    data = _line(snr)
    pts = run_method("phase-rpm", data, default_params(data), dev32).image.points
    d = np.linalg.norm(pts[:, None] - TARGETS[None], axis=2)
    assert np.all(d.min(axis=0) <= 0.03)
    on = np.mean(d.min(axis=1) <= 0.03)
    assert on >= 0.9
    monkeypatch.setattr(segments, "SEGMENTS_ABOVE", np.inf)
    whole = run_method("phase-rpm", data, default_params(data), dev32).image.points
    dw = np.linalg.norm(whole[:, None] - TARGETS[None], axis=2)
    assert np.mean(dw.min(axis=1) <= 0.03) < on - 0.02
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


# --- planar arrays in tiles ---------------------------------------------------


def _planar(n, pitch=7.5e-3, nr=8):
    from rpm_cl.io.data import RadarData

    axis = (np.arange(n) - (n - 1) / 2) * pitch
    return RadarData(
        np.zeros((n, n, nr), complex),
        Array(axis, axis),
        np.arange(nr) * 0.01,
        Waveform(20e9, 3e9),
    )


def test_planar_tiles_are_the_fewest_that_cover_and_their_kept_parts_tile_the_array():
    """64 antennas a side at 7.5 mm, the strongest echo 0.55 m away: tiles
    of 0.3 x 0.55 m = 0.165 m (23 antennas); the fewest that cover an axis
    are three (ceil(64 / 23)), spread evenly from one end to the other, so
    neighbours overlap by 3 and 2 antennas ((3 x 23 - 64) / 2 on average),
    not by half a tile;
    every antenna is kept by exactly one tile, the tile it lies in."""
    data = _planar(64)
    plan = segments.segment_plan(data, lambda d: 0.55, 60.0)
    assert plan is not None
    length = segments.TILE_PER_RANGE * 0.55
    m = int(np.ceil(length / 7.5e-3 - 1e-6)) + 1
    assert m == 23
    covered = np.zeros(data.array.shape, int)
    starts = set()
    for (ax, az), (kx, kz) in plan:
        for a, k in ((ax, kx), (az, kz)):
            assert a.stop - a.start == m
            assert a.start <= k.start < k.stop <= a.stop
        starts.add(ax.start)
        covered[kx, kz] += 1
    assert np.all(covered == 1)
    assert len(plan) == 9 and sorted(starts) == [0, 20, 41]
    # the kept parts split each overlap at its middle
    cut = sorted({k.start for (_, _), (k, _) in plan})
    assert cut == [0, (20 + 23) // 2, (41 + 20 + 23) // 2]
    # a tile resolves the window: 2 pi / 60 rad/m = 0.105 m <= 0.165 m
    assert (m - 1) * 7.5e-3 >= 2 * np.pi / 60.0
    # an axis of whole tiles is cut without overlap; a line's segments
    # still overlap by half
    assert [a for a, _ in segments._tiles(46, 23)] == [slice(0, 23), slice(23, 46)]
    assert [a.start for a, _ in segments._cuts(46, 23)] == [0, 11, 22, 23]


def test_planar_arrays_whose_tiles_cannot_resolve_the_window_are_whole():
    """A surface 0.1 m under a 0.5 m scan: a tile of 0.3 R (0.03 m) is
    shorter than 2 pi / window (0.105 m), so the array is decomposed
    whole; without a window, or within 1.5 tiles, too."""
    data = _planar(167, pitch=3e-3)
    assert segments.segment_plan(data, lambda d: 0.1, 60.0) is None
    assert segments.segment_plan(data, lambda d: 0.55, None) is None
    assert segments.segment_plan(_planar(30), lambda d: 0.55, 60.0) is None
    assert segments.segment_plan(_planar(45), lambda d: 0.55, 60.0) is not None


def test_kept_rps_map_a_tiles_antennas_to_the_arrays(rng):
    from rpm_cl.extract.rangepoints import RangePoints

    shape, tile, kept = (40, 30), (slice(10, 27), slice(5, 25)), (slice(14, 23), slice(9, 18))
    sub = (17, 20)
    k = 200
    ix, iz = rng.integers(0, sub[0], k), rng.integers(0, sub[1], k)
    rps = RangePoints(
        ix * sub[1] + iz,
        rng.uniform(size=k),
        rng.uniform(size=k),
        rng.uniform(size=k),
        rng.uniform(size=k),
        np.sort(rng.integers(0, 3, k)),
        None,
    )
    out = segments.kept_rps(rps, tile, kept, shape)
    want = []
    for a, b in zip(ix + 10, iz + 5):
        if 14 <= a < 23 and 9 <= b < 18:
            want.append(a * shape[1] + b)
    np.testing.assert_array_equal(out.antenna, want)
    inside = (ix + 10 >= 14) & (ix + 10 < 23) & (iz + 5 >= 9) & (iz + 5 < 18)
    np.testing.assert_array_equal(out.range, rps.range[inside])


def test_a_planar_array_in_tiles_images_the_spheres(dev32):
    """The robustness benchmark's three spheres before a 45 x 45 array (0.33
    m at 0.55-0.7 m) at 10 dB in-band: in tiles every antenna has its three
    echoes and nearly every point lies within 20 mm of a sphere; decomposed
    whole, the wide aperture's directions spread each sphere over several
    windows and a quarter of the points fall off."""
    from dataclasses import replace

    from rpm_cl.cli import robustness as rb

    g = replace(rb.GEOMETRY_3D, x=(45, 7.5e-3), z=(45, 7.5e-3))
    spec, f, _ = rb.synthesize(g, 10.0, 0)
    data = rb.loaded_data(g, spec, f)
    sph = np.asarray(g.targets)

    def within(params):
        res = run_method("phase-rpm", data, params, dev32)
        p = res.image.points
        d = np.abs(np.linalg.norm(p[:, None] - sph[None, :, :3], axis=2) - sph[:, 3]).min(axis=1)
        return len(res.rps) / data.array.n, float(np.mean(d <= 0.02))

    per_antenna, share = within(default_params(data, max_range=rb.region(g)))
    assert per_antenna <= 3.05 and share >= 0.97
    _, whole = within(default_params(data, max_range=rb.region(g), segments=False))
    assert whole < share - 0.1


def test_a_moved_planar_array_is_cut_the_same():
    """The cut counts antennas, so the array's positions as recorded (7.5 m
    and -3.2 m off) cut the same tiles as the array centred."""
    import dataclasses

    data = _planar(64)
    moved = dataclasses.replace(
        data, array=Array(np.asarray(data.array.x) + 7.5, np.asarray(data.array.z) - 3.2)
    )
    a = segments.segment_plan(data, lambda d: 0.55, 60.0)
    assert a is not None and a == segments.segment_plan(moved, lambda d: 0.55, 60.0)


def test_a_long_line_of_fewer_antennas_than_a_segment_is_whole():
    """Three antennas 1 m apart over an echo at 0.3 m: longer than two
    segments, but a segment would need four antennas; the line is decomposed
    whole (the cut's start list was empty, and indexing it raised)."""
    from rpm_cl.io.data import RadarData

    data = RadarData(
        np.zeros((3, 8), complex), Array(np.arange(3.0)), np.arange(8) * 0.1, Waveform(1e9, 0.5e9)
    )
    assert segments.segment_plan(data, lambda d: 0.3) is None


@pytest.mark.slow
def test_a_128_array_in_tiles_keeps_every_sphere_echo(dev32):
    """The three spheres before a 128 x 128 array (+-0.48 m at 0.55-0.7 m),
    noise-free, in 5 x 5 tiles: every antenna's three echoes become points
    within 20 mm of a sphere; none is taken for a double bounce (a corner
    tile's patch of the far sphere, weaker by the spreading than what nearer
    tiles saw, was: rpm_cl.rpm.multipath's module notes)."""
    from dataclasses import replace

    from rpm_cl.cli import robustness as rb

    g = replace(rb.GEOMETRY_3D, x=(128, 7.5e-3), z=(128, 7.5e-3))
    spec, f, _ = rb.synthesize(g, None, 0)
    data = rb.loaded_data(g, spec, f)
    res = run_method("phase-rpm", data, default_params(data, max_range=rb.region(g)), dev32)
    sph = np.asarray(g.targets)
    p = res.image.points
    d = np.abs(np.linalg.norm(p[:, None] - sph[None, :, :3], axis=2) - sph[:, 3]).min(axis=1)
    assert len(res.rps) == 3 * 128 * 128 and len(p) == len(res.rps)
    assert res.dropped["multipath"] == 0 and np.all(d <= 0.02)
