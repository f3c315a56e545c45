"""Long linear scans decomposed in overlapping segments, large planar arrays
in tiles.

A GPR line is often many times as long as its targets are deep (4 m over
rebar 0.3 m down).  The k-space decomposition of the whole line then puts
every target seen at one angle into one cluster, each at its own place
along the line, while its alignment and near-field focus (kspace module
notes, steps 4-5) are the range walk and wavefront of one point seen from
the line's centre: 1.5 m along the line that wavefront is over a metre off
a target there, whose echo leaves its cluster's gates.  Six targets under
a 4 m line lost the two nearest its ends (``benchmarks/long_scan.py``);
with phase-rpm's close centres (``KSpaceParams.close_centres``) the whole
line finds them, but 95 % of its points lie within 30 mm of a target
noise-free and 81 % at 20 dB, against 99.6 % and 98.7 % segmented
(``tests/test_segments.py``'s scene).

Where the line is longer than :data:`SEGMENTS_ABOVE` segments, it is cut
into segments of :data:`SEGMENT_PER_RANGE` times the strongest echo's range
(the range the derived sigma_x is bounded by,
:func:`rpm_cl.rpm.params._strongest_range`, handed in by the caller), each
overlapping its neighbours by half; each segment is decomposed on its own
(its RPs are the k-space decomposition's of that stretch of line), and
each keeps the RPs of its antennas in its middle half (the first and last
segments also their outer quarter, :func:`kept_rps`), so that every
antenna's RPs come from the segment it is most central in.  The segments'
clusters stay apart (:func:`joined_rps`); RPM then images all RPs as one
set.  The paper's scenes and the gprMax fixture are not long by this
measure and are decomposed whole.

A planar array is cut along each axis longer than :data:`TILES_ABOVE`
tiles of :data:`TILE_PER_RANGE` times the strongest echo's range, but only
where such a tile is at least ``2 pi / window`` long (the decomposition's
window period, 60 rad/m by default: 0.105 m), so that its aperture
resolves the window; shorter tiles cannot be decomposed, and the array is
decomposed whole (the near-field scan of a surface 0.1 m away, whose focus
fits the whole aperture).  A planar window of 60 rad/m holds the echoes of
a small patch of directions; over an aperture as wide as the range, a
sphere's directions sweep across many windows, each with one wavefront
model for the whole array: three spheres 0.55-0.7 m before a 128 x 128
array at 7.5 mm gave 15 RPs per antenna where each sees three echoes, and
61 % of the points within 20 mm; in tiles of 0.3 R it gives three RPs per
antenna and every point within 20 mm (``benchmarks/planar_tiles.py``,
docs/benchmarks.md, "Large planar arrays in tiles").  An axis takes the
fewest tiles that cover it, spread evenly (:func:`_tiles`), each keeping
its antennas up to the middle of its overlaps: tiles overlapping by half,
as the segments of a line do, decompose each antenna about four times and
measured the same share within 20 mm (the kept antennas at a tile's edge
are no worse placed than the array's own edges) in about twice the time
(``python benchmarks/planar_tiles.py --overlap half``).  The human body's
array (0.12 m) and the robustness benchmark's (0.1 m) are whole.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..io.data import Array, RadarData
from .rangepoints import RangePoints

__all__ = [
    "SEGMENTS_ABOVE",
    "SEGMENT_PER_RANGE",
    "TILES_ABOVE",
    "TILE_PER_RANGE",
    "joined_rps",
    "kept_rps",
    "segment_data",
    "segment_plan",
]

#: Segment length as a multiple of the strongest echo's range.  Measured on
#: six targets 0.30-0.34 m under a 4 m line (``benchmarks/long_scan.py``'s
#: scene, phase-rpm; noise-free, 20 dB seeds 0 and 1; every factor hits all
#: six targets): points within 30 mm 93 / 91 / 87 % at 1.5, 93 / 94 / 89 %
#: at 2, 67 / 62 / 57 % at 2.7, 66 / 66 / 62 % at 3.3; the whole line, with
#: centres a quarter window apart, hits 4 of 6.
SEGMENT_PER_RANGE = 2.0
#: A line is segmented where it is longer than this many segments (a 1 m
#: line over a point 0.45 m away is not: it is imaged as one aperture).
SEGMENTS_ABOVE = 2.0
#: Tile side of a planar array as a multiple of the strongest echo's range
#: (module notes).  Three spheres before a 128 x 128 array at 7.5 mm,
#: noise-free (``python benchmarks/planar_tiles.py --sizes 128 --snr inf
#: --no-whole --tile-per-range F``): points within 20 mm 93.0 / 100 / 100 /
#: 100 % at F = 0.5 / 0.4 / 0.3 / 0.2, medians 0.30 / 0.23 / 0.17 / 0.16 mm,
#: engine 12.0 / 9.3 / 8.7 / 8.2 s.  0.2 does as well here, but its tiles
#: fall below ``2 pi / window`` (0.105 m) wherever the strongest echo is
#: nearer than 0.53 m, and such arrays would be decomposed whole; at 0.3
#: below 0.35 m.
TILE_PER_RANGE = 0.3
#: A planar array is tiled along an axis where it is longer than this many
#: tiles (``benchmarks/planar_tiles.py``, noise-free, 20 and 10 dB: 45 x 45,
#: two tiles long, whole 94 / 98 / 77 % of the points within 20 mm, in
#: tiles 100 % at each; 30 x 30, 1.3 tiles long, whole 100 % at each).
TILES_ABOVE = 1.5


def _kept(n: int, m: int, starts: list) -> list:
    """Runs of ``m`` antennas at ``starts`` on an axis of ``n``: per run, its
    antennas and the antennas whose RPs it keeps (from the middle of the
    overlap with the previous run to the middle of the overlap with the
    next; the first and last runs to the axis's ends), so that the kept
    parts tile the axis."""
    out = []
    for i, s0 in enumerate(starts):
        lo = 0 if i == 0 else (s0 + starts[i - 1] + m) // 2
        hi = n if i == len(starts) - 1 else (starts[i + 1] + s0 + m) // 2
        out.append((slice(s0, s0 + m), slice(lo, hi)))
    return out


def _cuts(n: int, m: int) -> list:
    """One axis of ``n`` antennas cut into runs of ``m`` overlapping by
    half (:func:`_kept`)."""
    if m >= n:
        return [(slice(0, n), slice(0, n))]
    step = max(1, m // 2)
    starts = list(range(0, n - m + 1, step))
    if starts[-1] + m < n:
        starts.append(n - m)
    return _kept(n, m, starts)


def _tiles(n: int, m: int) -> list:
    """One axis of ``n`` antennas cut into the fewest runs of ``m`` that
    cover it, spread evenly (neighbours overlap by what the division leaves,
    less than a run; :func:`_kept`)."""
    if m >= n:
        return [(slice(0, n), slice(0, n))]
    k = -(-n // m)
    return _kept(n, m, [int(s) for s in np.round(np.linspace(0, n - m, k))])


def _run_length(length: float, pitch: float) -> int:
    """Antennas in a run of ``length`` m at ``pitch`` m; the tolerance keeps
    a ratio that rounding puts either side of an integer (a pitch read from
    positions 7.5 m along the line) on one side, so that moving the array
    does not change the cut."""
    return max(4, int(np.ceil(length / pitch - 1e-6)) + 1)


def segment_plan(data: RadarData, strongest_range, window: float | None = None) -> list | None:
    """The segments of a long linear scan or the tiles of a large planar
    array, or None where it is decomposed whole.

    Parameters
    ----------
    data : RadarData
    strongest_range : callable
        ``strongest_range(data)``: the strongest echo's range, m, or None
        where the data hold no echo (no segments); not called for a planar
        array no longer along either axis than :data:`TILES_ABOVE` of the
        shortest tiles that resolve ``window`` (its profile power is read
        for nothing otherwise).
    window : float, optional
        Planar arrays: the decomposition's window period, rad/m (the
        narrower of ``window_x`` and ``window_z``); a tile is at least
        ``2 pi / window`` long, so that its aperture resolves the window,
        else the array is decomposed whole.  None: planar arrays are whole.

    Returns
    -------
    list of (tuple, tuple) or None
        Per segment or tile, its antennas and the antennas whose RPs it
        keeps, each a tuple of slices, one per array axis: the kept ones
        tile the array, each antenna in exactly one segment's.
    """
    arr = data.array
    if arr.n < 2:
        return None
    axes = [np.asarray(arr.x)] + ([np.asarray(arr.z)] if arr.planar else [])
    extent = [float(ax[-1] - ax[0]) for ax in axes]
    if arr.planar:
        if window is None or not window > 0:
            return None
        shortest = 2 * np.pi / window
        if max(extent) <= TILES_ABOVE * shortest:
            return None
        factor, above = TILE_PER_RANGE, TILES_ABOVE
    else:
        factor, above, shortest = SEGMENT_PER_RANGE, SEGMENTS_ABOVE, 0.0
    strongest = strongest_range(data)
    if strongest is None or not strongest > 0:
        return None
    length = factor * strongest
    if length < shortest:
        return None
    pitches = [arr.dx] + ([arr.dz] if arr.planar else [])
    per_axis, cut = [], False
    for ax, ext, pitch in zip(axes, extent, pitches):
        m = _run_length(length, pitch)
        if ext > above * length and m < ax.size:
            per_axis.append((_tiles if arr.planar else _cuts)(ax.size, m))
            cut = True
        else:
            per_axis.append([(slice(0, ax.size), slice(0, ax.size))])
    if not cut:
        return None
    if len(per_axis) == 1:
        return [((a,), (k,)) for a, k in per_axis[0]]
    return [((ax, az), (kx, kz)) for ax, kx in per_axis[0] for az, kz in per_axis[1]]


def segment_data(data: RadarData, antennas: tuple) -> RadarData:
    """The antennas ``antennas`` (a slice per array axis) as their own
    RadarData: their profiles and frequency samples, no truth."""
    spectrum = data.spectrum
    if spectrum is not None:
        spectrum = dataclasses.replace(spectrum, values=spectrum.values[antennas])
    arr = data.array
    sub = Array(
        np.asarray(arr.x)[antennas[0]], np.asarray(arr.z)[antennas[1]] if arr.planar else None
    )
    return dataclasses.replace(
        data, signal=data.signal[antennas], array=sub, truth=None, spectrum=spectrum
    )


def kept_rps(rps: RangePoints, antennas: tuple, kept: tuple, shape: tuple) -> RangePoints:
    """A segment's RPs (found on its antennas ``antennas``) at the antennas
    it keeps, ``kept`` (slices per array axis), with the whole array's flat
    antenna indices (C order of ``shape``, the whole array's)."""
    sub = tuple(a.stop - a.start for a in antennas)
    idx = np.unravel_index(np.asarray(rps.antenna, np.int64), sub)
    full = tuple(i + a.start for i, a in zip(idx, antennas))
    keep = np.ones(len(rps), bool)
    for i, k in zip(full, kept):
        keep &= (i >= k.start) & (i < k.stop)
    ant = np.ravel_multi_index(full, shape) if len(rps) else np.zeros(0, np.int64)

    def f(a):
        return None if a is None else np.asarray(a)[keep]

    return RangePoints(
        np.asarray(ant, np.int64)[keep],
        f(rps.x),
        f(rps.z),
        f(rps.range),
        f(rps.amp),
        f(rps.cluster),
        f(rps.sample),
    )


def joined_rps(parts: list) -> RangePoints:
    """The segments' kept RPs as one set, each segment's clusters numbered
    after the previous ones' (clusters of different segments stay apart)."""
    offsets = np.cumsum([0] + [int(np.max(p.cluster)) + 1 if len(p) else 0 for p in parts])

    def cat(name):
        return np.concatenate([np.asarray(getattr(p, name)) for p in parts])

    samples = [p.sample for p in parts]
    zs = [p.z for p in parts]
    return RangePoints(
        cat("antenna"),
        cat("x"),
        None if any(z is None for z in zs) else np.concatenate(zs),
        cat("range"),
        cat("amp"),
        np.concatenate([np.asarray(p.cluster) + o for p, o in zip(parts, offsets)]),
        None if any(v is None for v in samples) else np.concatenate(samples),
    )
