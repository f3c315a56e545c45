"""Long linear scans decomposed in overlapping segments.

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
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..io.data import Array, RadarData
from .rangepoints import RangePoints

__all__ = [
    "SEGMENTS_ABOVE",
    "SEGMENT_PER_RANGE",
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


def segment_plan(data: RadarData, strongest_range) -> list | None:
    """The segments of a long linear scan, or None where it is decomposed
    whole.

    Parameters
    ----------
    data : RadarData
    strongest_range : callable
        ``strongest_range(data)``: the strongest echo's range, m, or None
        where the data hold no echo (no segments); called for linear arrays
        only (a planar array's profile power is read for nothing otherwise).

    Returns
    -------
    list of (slice, slice) or None
        Per segment, its antennas and the antennas whose RPs it keeps (both
        slices of the antenna axis): the kept ones tile the line, each
        antenna in exactly one segment's.
    """
    arr = data.array
    if arr.planar or arr.n < 2:
        return None
    strongest = strongest_range(data)
    if strongest is None or not strongest > 0:
        return None
    length = SEGMENT_PER_RANGE * strongest
    if float(arr.x[-1] - arr.x[0]) <= SEGMENTS_ABOVE * length:
        return None
    # antennas per segment; the tolerance keeps a ratio that rounding puts
    # either side of an integer (a pitch read from positions 7.5 m along the
    # line) on one side, so that moving the line does not change the cut
    m = max(4, int(np.ceil(length / arr.dx - 1e-6)) + 1)
    step = max(1, m // 2)
    starts = list(range(0, arr.n - m + 1, step))
    if starts[-1] + m < arr.n:
        starts.append(arr.n - m)
    plan = []
    for i, s0 in enumerate(starts):
        # the kept part: from the middle of the overlap with the previous
        # segment to the middle of the overlap with the next
        lo = 0 if i == 0 else (s0 + starts[i - 1] + m) // 2
        hi = arr.n if i == len(starts) - 1 else (starts[i + 1] + s0 + m) // 2
        plan.append((slice(s0, s0 + m), slice(lo, hi)))
    return plan


def segment_data(data: RadarData, antennas: slice) -> RadarData:
    """The scan's antennas ``antennas`` (a slice) as their own RadarData:
    their profiles and frequency samples, no truth."""
    spectrum = data.spectrum
    if spectrum is not None:
        spectrum = dataclasses.replace(spectrum, values=spectrum.values[antennas])
    return dataclasses.replace(
        data,
        signal=data.signal[antennas],
        array=Array(np.asarray(data.array.x)[antennas]),
        truth=None,
        spectrum=spectrum,
    )


def kept_rps(rps: RangePoints, antennas: slice, kept: slice) -> RangePoints:
    """A segment's RPs (found on its antennas ``antennas``) at the antennas
    it keeps, ``kept``, with the whole line's antenna indices."""
    ant = np.asarray(rps.antenna) + antennas.start
    keep = (ant >= kept.start) & (ant < kept.stop)

    def f(a):
        return None if a is None else np.asarray(a)[keep]

    return RangePoints(
        ant[keep], f(rps.x), f(rps.z), f(rps.range), f(rps.amp), f(rps.cluster), f(rps.sample)
    )


def joined_rps(parts: list) -> RangePoints:
    """The segments' kept RPs as one set, each segment's clusters numbered
    after the previous ones' (clusters of different segments stay apart)."""
    offsets = np.cumsum([0] + [int(np.max(p.cluster)) + 1 if len(p) else 0 for p in parts])

    def cat(name):
        return np.concatenate([np.asarray(getattr(p, name)) for p in parts])

    samples = [p.sample for p in parts]
    return RangePoints(
        cat("antenna"),
        cat("x"),
        None,
        cat("range"),
        cat("amp"),
        np.concatenate([np.asarray(p.cluster) + o for p, o in zip(parts, offsets)]),
        None if any(v is None for v in samples) else np.concatenate(samples),
    )
