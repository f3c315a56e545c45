"""DAS and RMA as imagers: a coherent image on a grid taken from the data,
and its peaks as the image points (:func:`rpm_cl.baselines.peaks.image_peaks`),
those beyond the antennas' reach (``reach_deg`` from boresight, as for
``phase-rpm``) dropped and counted, returned as every imager returns them (:class:`rpm_cl.result.ImageResult`,
without range points).  :mod:`rpm_cl.imaging` registers them as ``das`` and
``rma``; ``rpm-cl das`` and ``rpm-cl rma`` write the image itself on a grid
of the user's choice.
"""

from __future__ import annotations

import time

import numpy as np

from ..extract.rangepoints import RangePoints
from ..io.data import InputError, RadarData
from ..io.images import Grid
from ..io.medium import Medium
from ..io.radar import profile_power
from ..result import Image, ImageResult
from .peaks import image_peaks

__all__ = [
    "ECHO_SPAN_DB",
    "GRID_PIXELS_MAX",
    "PEAK_SIZE",
    "PEAK_THRESHOLD_DB",
    "das_method",
    "default_grid",
    "echo_span",
    "in_reach",
    "rma_method",
]

#: Most pixels (2-D) or voxels (3-D) of the default grid: beyond it the step
#: grows (about 0.2 s of DAS per million pixels from 21 antennas, 1.5 s per
#: 4 million voxels from 187 on the 2-core reference machine).
GRID_PIXELS_MAX = {2: 1_000_000, 3: 4_000_000}
#: Peaks: local maxima over this many pixels per axis (as the 2-D paper
#: tables' DAS rows), at least ``PEAK_THRESHOLD_DB`` of the image's maximum.
#: Half the amplitude: the default grids of the paper's scenes hold near-range
#: artefacts of narrow-band DAS at -6.6 to -10 dB, and sparse arrays'
#: grating lobes (``rpm-cl image --method das`` on ``rpm-cl simulate``'s
#: presets: paper-2d 4 of 4 points within 50 mm at -6 dB against 4 of 30 at
#: -10 dB; paper-2d-sparse 4 of 64 against 6 of 297; the human body 4 of 4
#: against 8 of 8).
PEAK_SIZE = 5
PEAK_THRESHOLD_DB = -6.0
#: The default grid covers the ranges where the echo power summed over the
#: antennas comes within this many dB of its peak, one range resolution
#: either side: the echoes, not the whole unambiguous range (where a
#: narrow-band image's near-range artefacts and noise make peaks of their
#: own).
ECHO_SPAN_DB = -30.0


def echo_span(data: RadarData, floor_db: float = ECHO_SPAN_DB) -> tuple[float, float]:
    """The air-equivalent ranges (first, last) where the profile power
    summed over the antennas reaches ``floor_db`` of its peak, widened by
    one range resolution each way and clipped to the range axis, m.

    A spectrum compressed over its whole unambiguous range (the axis from 0
    to ``c / 2 df``, as :func:`rpm_cl.io.compress.spectrum_data` makes it)
    is circular: an echo within a range resolution of 0 has its main lobe's
    near side at the axis' far end.  Where the gates above the floor touch
    both ends of such an axis, the run at the far end, when it is no longer
    than :data:`WRAPPED_LOBE` range resolutions, is that wrapped lobe (ranges
    below 0) and is left out; every other echo counts (a 0.25 GHz sweep of
    objects at 0.3-0.6 m otherwise spanned its whole 38 m axis, and DAS
    imaged the wrapped lobe at 37 m).
    """
    power = profile_power(data.signal, data.range.size)
    if not power.max() > 0:
        return float(data.range[0]), float(data.range[-1])
    above = power >= power.max() * 10.0 ** (floor_db / 10.0)
    res = data.waveform.range_resolution
    if _circular(data) and above[0] and above[-1] and not above.all():
        tail = int(np.nonzero(~above)[0][-1]) + 1  # the far end's run starts here
        if data.range[-1] - data.range[tail] <= WRAPPED_LOBE * res:
            above = above.copy()
            above[tail:] = False
    on = np.nonzero(above)[0]
    lo = max(float(data.range[on[0]]) - res, float(data.range[0]))
    hi = min(float(data.range[on[-1]]) + res, float(data.range[-1]))
    return lo, hi


#: The longest run above the floor at a circular axis' far end that
#: :func:`echo_span` takes for the wrapped main lobe of an echo near 0,
#: range resolutions (a Hann main lobe reaches about 1.3 resolutions either
#: side of its echo at -30 dB).
WRAPPED_LOBE = 2.0


def _circular(data: RadarData) -> bool:
    """Whether the range axis is a compressed spectrum's whole unambiguous
    range ``[0, c / 2 df)`` (within half a gate)."""
    spec = data.spectrum
    if spec is None or spec.frequency.size < 2 or data.range.size < 2:
        return False
    from ..io.model import C0

    df = abs(float(spec.frequency[1] - spec.frequency[0]))
    span = float(data.range[-1] - data.range[0]) + data.dr
    return abs(float(data.range[0])) < 0.5 * data.dr and abs(span - C0 / (2 * df)) < 0.5 * data.dr


def _depth(medium: Medium, r: float) -> float:
    """The true depth y of a point straight below an antenna at
    air-equivalent range ``r``, m."""
    if medium.half_space:
        h = medium.antenna_height
        return r if r <= h else h + (r - h) / medium.n
    return r / medium.n


def default_grid(data: RadarData, medium: Medium | None = None) -> Grid:
    """The grid ``das`` images on when not told: the depths of the echoes
    (:func:`echo_span`), and sideways the array's extent plus the largest
    depth on each side (45 deg from its ends); step a quarter of the carrier
    wavelength in the medium or of the range resolution, whichever is
    finer, coarsened until at most :data:`GRID_PIXELS_MAX` points.

    Returns
    -------
    Grid
        (x, y) for a linear array, (x, y, z) for a planar one, m.
    """
    medium = medium or Medium()
    r_lo, r_hi = echo_span(data)
    y_hi = _depth(medium, r_hi)
    y_lo = max(_depth(medium, max(r_lo, 0.0)), 0.0)
    if not y_hi > y_lo:
        raise InputError(f"the range axis {data.range[0]:g} .. {data.range[-1]:g} m holds no depth")
    lam = 2 * np.pi / (data.waveform.kc * medium.n)
    step = min(lam, data.waveform.range_resolution / medium.n) / 4
    pos = data.array.positions()
    spans = [(float(pos[:, 0].min()) - y_hi, float(pos[:, 0].max()) + y_hi), (y_lo, y_hi)]
    if data.array.planar:
        spans.append((float(pos[:, 2].min()) - y_hi, float(pos[:, 2].max()) + y_hi))
    dim = len(spans)

    def counts(step):
        return [int(np.floor((hi - lo) / step)) + 1 for lo, hi in spans]

    while np.prod(counts(step), dtype=float) > GRID_PIXELS_MAX[dim]:
        step *= max(1.01, (np.prod(counts(step), dtype=float) / GRID_PIXELS_MAX[dim]) ** (1 / dim))
    return Grid(*(lo + step * np.arange(n) for (lo, _), n in zip(spans, counts(step))))


def _no_rps(data: RadarData) -> RangePoints:
    e = np.zeros(0)
    return RangePoints(
        np.zeros(0, int), e, e if data.array.planar else None, e, e, np.zeros(0, int)
    )


def in_reach(positions: np.ndarray, points: np.ndarray, reach_deg: float) -> np.ndarray:
    """Whether each point lies within ``reach_deg`` of boresight (+y) of
    the antenna nearest to it sideways, bool, shape (M,).

    Parameters
    ----------
    positions : ndarray, shape (A, 2) or (A, 3)
        Antennas (x, y[, z]), m.
    points : ndarray, shape (M, 2) or (M, 3)
        m.
    """
    lat = [0] if points.shape[1] == 2 else [0, 2]
    d = points[:, None, lat] - positions[None, :, lat]
    side = np.min(np.linalg.norm(d, axis=2), axis=1) if len(points) else np.zeros(0)
    return np.degrees(np.arctan2(side, points[:, 1])) <= reach_deg


def _result(name, data: RadarData, img, axes, reach_deg: float, t0: float, t1: float):
    pts, lev = image_peaks(img, axes, threshold_db=PEAK_THRESHOLD_DB, size=PEAK_SIZE)
    keep = in_reach(data.array.positions(), pts, reach_deg)
    t2 = time.perf_counter()
    pts, lev = pts[keep], lev[keep]
    k = len(pts)
    # one cluster: the peaks of one image
    image = Image(pts, np.zeros(k, int), 10.0 ** (lev / 20.0), np.full(k, -1))
    timings = {"image": t1 - t0, "peaks": t2 - t1, "total": t2 - t0}
    return ImageResult(name, _no_rps(data), image, timings, {"reach": int(np.sum(~keep))})


def das_method(data: RadarData, params, engine) -> ImageResult:
    """DAS (:mod:`rpm_cl.baselines.das`) on :func:`default_grid`: the
    engine's OpenCL device in its precision where it has one, else the
    float64 NumPy back-projection; the medium is ``params.medium``."""
    from .das import DeviceDAS, das_numpy

    medium = params.medium
    grid = default_grid(data, medium)
    t0 = time.perf_counter()
    env = getattr(engine, "env", None)
    if env is not None:
        img = DeviceDAS(env, getattr(engine, "precision", "float32")).backproject(
            data, grid, medium=medium
        )
    else:
        img = das_numpy(data, grid, medium=medium)
    return _result("das", data, img, grid.axes, params.reach_deg, t0, time.perf_counter())


def rma_method(data: RadarData, params, engine) -> ImageResult:
    """RMA (:mod:`rpm_cl.baselines.rma`, x pixels a quarter of the pitch,
    depths of the echoes, :func:`echo_span`) of a linear array's data in
    ``params.medium``; ``engine`` is not used (RMA
    runs on the host)."""
    from .rma import rma_image

    if data.array.planar:
        raise InputError("rma images linear arrays only; this array is planar (use das)")
    medium = params.medium
    r_lo, r_hi = echo_span(data)
    surface = medium.antenna_height if medium.half_space else 0.0
    t0 = time.perf_counter()
    img, x, y = rma_image(
        data,
        upsample_x=4,
        medium=medium,
        # above a half-space RMA images the material only (y >= h)
        y_min=max(_depth(medium, max(r_lo, 0.0)), surface),
        y_max=max(_depth(medium, r_hi), surface + 1e-3),
    )
    return _result("rma", data, img, (x, y), params.reach_deg, t0, time.perf_counter())
