"""Coherence test of a linear array's image points: a point must sit on a
peak of the coherent image, not on its flank.

Why
---
RPM places a point where the range circles of neighbouring antennas cross.
Where one decomposed echo holds two targets (a long line over a rebar mat:
eighteen bars 0.2 m apart under a 0.15 m range resolution, where each
segment's clusters see several bars at once), its ranges are biased by a
few centimetres and the crossings slide along the circles: the points sit
beside the targets at their depth (``python benchmarks/long_scan.py
--rebar``).  Each such point is consistent with the ranges it came from, so
RPM's density cannot tell it from a true one.  The data themselves can:
the coherent sum of every antenna's profile along the point's own range
(the DAS image, :mod:`rpm_cl.extract.backprojection`) peaks on a scatterer and falls
off within about one cross-range resolution of it, so a point whose
coherent value is well below the image's largest within that distance lies
beside something, not on it.

What is done
------------
For a linear array, per point ``p`` with the antennas within ``reach_deg``
of boresight seen from it and among those whose echoes made it (its
cluster's RPs: a real antenna's beam, not the array's length, sets the
aperture an echo is seen over):

- the cross-range resolution ``dx(p) = lambda_c / (2 (sin t_max - sin
  t_min))`` over the angles ``t`` (from boresight) at which those antennas
  see ``p``;
- ``I(p)``, the DAS magnitude at the point itself;
- the largest DAS magnitude within ``RADIUS_CELLS * dx(p)`` of it, read on
  the nodes of a grid of spacing :data:`STEP_CELLS` times the smallest
  ``dx`` that lie within that radius (each node evaluated once however many
  points read it).

The point is on a peak when ``I(p)`` is at least ``10^(threshold_db / 20)``
times that largest value.  A point off every peak is dropped only where a
point on a peak lies within its radius of the place of its neighbourhood's
largest value: that peak is then marked already, while a peak that no point
marks keeps the points beside it (the best the RPs say about it).  A weak
target within one resolution of a stronger one has no peak of its own in
the coherent image either, so its points go; one resolution or more away it
keeps them.

The test needs an image whose peaks are the scatterers: it runs only where
the band is at least :data:`MIN_FRACTIONAL_BANDWIDTH` of the carrier (an
ultra-wideband radar's, as impulse GPR's).  With a narrower band the DAS
image is close to a one-frequency hologram, whose side lobes beside each
target are local peaks of their own: on 41 antennas at 2 cm at 20 GHz with
0.2 GHz of band the test kept points 13-45 mm from a target on side lobes
and dropped those 4-11 mm from it.

Above a half-space the sums follow the refracted paths of the data as
recorded.  The test is off for planar arrays (a surface has no isolated
peak to test against, and a sum over 27,000 antennas per point would cost
more than the image).
"""

from __future__ import annotations

import numpy as np

from ..io.data import C0, RadarData

__all__ = [
    "MAX_CELLS",
    "MIN_FRACTIONAL_BANDWIDTH",
    "RADIUS_CELLS",
    "STEP_CELLS",
    "coherent_keep",
    "crossrange_resolution",
    "marked",
]

#: Least bandwidth / carrier at which the test runs (module notes): the
#: usual threshold of ultra-wideband radar.
MIN_FRACTIONAL_BANDWIDTH = 0.2
#: Radius of the neighbourhood, cross-range resolutions.
RADIUS_CELLS = 1.2
#: Grid spacing of the neighbourhood maximum, cross-range resolutions.
STEP_CELLS = 0.25
#: Largest radius of a neighbourhood in grid nodes: wider ones (points far
#: deeper than the shallowest, whose resolution sets the grid) are sampled
#: on every stride-th node, so that each point reads at most about
#: pi MAX_CELLS^2 nodes.
MAX_CELLS = 6
#: Pairs (place, mark within its radius in x) :func:`marked` tests at once.
MARK_PAIRS = 1 << 20
#: Beyond this many such pairs in all, :func:`marked` asks a k-d tree.
MARK_PAIRS_TREE = 1 << 24


def crossrange_resolution(
    x: np.ndarray, points: np.ndarray, fc: float, reach_deg: float, seen=None
) -> np.ndarray:
    """Cross-range resolution of a linear array at each point, m.

    Parameters
    ----------
    x : ndarray, shape (A,)
        Antenna positions, m.
    points : ndarray, shape (M, 2)
        (x, y) of the points, m, y > 0.
    fc : float
        Carrier, Hz.
    reach_deg : float
        Antennas farther than this from boresight, seen from the point, do
        not count.
    seen : ndarray, shape (M, 2), optional
        Per point the first and last x of the antennas that saw it (those of
        its cluster's RPs): the others do not count either.

    Returns
    -------
    ndarray, shape (M,)
        ``lambda_c / (2 span)``, span the spread of ``sin t`` over the
        antennas that count (over all antennas where none does).
    """
    x = np.asarray(x, np.float64)
    points = np.asarray(points, np.float64)
    c = np.sin(np.radians(min(reach_deg, 90.0)))
    # the bisection wants sines that grow with x: an increasing line, and
    # points a millionth of a spacing or more in front (nearer, the sines
    # round to +-1 and may step back by an ulp)
    if not (
        points.shape[0]
        and x.size > 1
        and np.all(np.diff(x) > 0)
        and np.all(points[:, 1] > 1e-6 * np.min(np.diff(x)))
    ):
        hi, lo = _sine_span(x, points, c, seen)
    else:
        hi, lo = _sine_span_sorted(x, points, c, reach_deg, seen)
    span = np.maximum(hi - lo, 1e-6)
    return C0 / fc / (2.0 * span)


def _sines(x, points):
    """sin t of every antenna seen from every point (from boresight), (M, A)."""
    lat = x[None, :] - points[:, 0:1]
    return lat / np.hypot(lat, points[:, 1:2])


def _sine_span(x, points, c, seen):
    """(largest, smallest) sin t over the antennas that count
    (:func:`crossrange_resolution`), over all where none does: every
    antenna tried, (M, A) work."""
    s = _sines(x, points)
    inside = np.abs(s) <= c
    if seen is not None:
        inside &= (x[None, :] >= seen[:, 0:1]) & (x[None, :] <= seen[:, 1:2])
    hi = np.where(inside, s, -np.inf).max(axis=1)
    lo = np.where(inside, s, np.inf).min(axis=1)
    none = ~inside.any(axis=1)
    hi[none], lo[none] = s[none].max(axis=1), s[none].min(axis=1)
    return hi, lo


def _sine_span_sorted(x, points, c, reach_deg, seen):
    """:func:`_sine_span` for increasing ``x`` and points in front (y > 0),
    in O(M log A).  There sin t grows with the antenna's x, so the antennas
    that count are the run between two indices: each end is found by
    bisection on x and settled by the same test as :func:`_sine_span` on
    its neighbours (the bisection's ``y tan(reach)`` and the test's sine
    may round apart at an antenna exactly at the reach), and the extremes
    are the sines of the run's ends, computed as there."""
    px, py = points[:, 0], points[:, 1]
    n = x.size
    reach = np.tan(np.radians(reach_deg)) * py if reach_deg < 90 else np.full(py.size, np.inf)
    a, b = px - reach, px + reach
    if seen is not None:
        a, b = np.maximum(a, seen[:, 0]), np.minimum(b, seen[:, 1])

    def sine(i):
        lat = x[i] - px
        return lat / np.hypot(lat, py)

    def counts(i):
        ok = (i >= 0) & (i < n)
        j = np.clip(i, 0, n - 1)
        ok &= np.abs(sine(j)) <= c
        if seen is not None:
            ok &= (x[j] >= seen[:, 0]) & (x[j] <= seen[:, 1])
        return ok

    i0 = np.searchsorted(x, a, "left")
    i1 = np.searchsorted(x, b, "right") - 1
    first = np.full(px.size, -1)
    for i in (i0 + 1, i0, i0 - 1):  # the smallest that counts, last written
        first = np.where(counts(i), i, first)
    last = np.full(px.size, -1)
    for i in (i1 - 1, i1, i1 + 1):
        last = np.where(counts(i), i, last)
    none = (first < 0) | (last < 0)
    first = np.where(none, 0, first)
    last = np.where(none, n - 1, last)
    return sine(last), sine(first)


def coherent_keep(
    data: RadarData,
    points: np.ndarray,
    threshold_db: float,
    reach_deg: float,
    medium=None,
    seen=None,
    sums=None,
) -> np.ndarray:
    """Which points sit on a peak of the coherent image (module notes).

    Parameters
    ----------
    data : RadarData
        A linear array's data, as the method imaged them.
    points : ndarray, shape (M, 2)
        Image points, m.
    threshold_db : float
        How far (dB, <= 0) below its neighbourhood's largest DAS magnitude
        a point's own may lie.
    reach_deg : float
        The antennas' reach (:func:`crossrange_resolution`).
    medium : rpm_cl.io.medium.Medium, optional
        A half-space, with ``data`` as recorded: the sums follow the
        refracted paths, and the resolution is the material's wavelength's
        seen from the paraxial virtual antennas
        (:func:`rpm_cl.io.medium.paraxial`).  Else ``data`` is the scene in
        air (a homogeneous medium's equivalent air scene).
    seen : ndarray, shape (M, 2), optional
        Per point the first and last x of the antennas whose echoes made it
        (:func:`crossrange_resolution`); None: every antenna in reach.
    sums : callable, optional
        ``sums(data, points)``: I(p) at points (M, 2), complex, shape (M,),
        in straight lines (the device's
        :meth:`rpm_cl.extract.backprojection_cl.PointSums.at_points`); None:
        :func:`rpm_cl.extract.backprojection.at_points`.  Not for a
        half-space, whose sums follow refracted paths.

    Returns
    -------
    ndarray of bool, shape (M,)
    """
    from ..extract.backprojection import at_points

    points = np.asarray(points, np.float64)
    if points.shape[0] == 0:
        return np.zeros(0, bool)
    half = medium is not None and medium.half_space
    if half:
        from ..io.medium import paraxial

        virtual = points - [0.0, paraxial(medium)[0]]
        dx = crossrange_resolution(
            data.array.x, virtual, data.waveform.fc * medium.n, reach_deg, seen
        )
    else:
        dx = crossrange_resolution(data.array.x, points, data.waveform.fc, reach_deg, seen)
    radius = RADIUS_CELLS * dx
    lo = points.min(axis=0) - radius.max()
    hi = points.max(axis=0) + radius.max()
    lo[1] = max(lo[1], 0.5 * float(points[:, 1].min()))
    step = STEP_CELLS * float(dx.min())
    n = np.ceil((hi - lo) / step).astype(np.int64) + 1
    # the grid nodes within each point's radius, each evaluated once; a
    # radius of more than MAX_CELLS nodes is sampled every stride-th node
    cells = np.maximum(1, np.round(radius / step).astype(int))
    stride = np.maximum(1, np.ceil(cells / MAX_CELLS).astype(int))
    cells = np.minimum(cells, MAX_CELLS * stride)
    ix = np.clip(np.round((points[:, 0] - lo[0]) / step).astype(int), 0, n[0] - 1)
    iy = np.clip(np.round((points[:, 1] - lo[1]) / step).astype(int), 0, n[1] - 1)
    nodes, owner = [], []
    for c, k in set(zip(cells.tolist(), stride.tolist())):
        sel = np.flatnonzero((cells == c) & (stride == k))
        u = np.arange(-c, c + 1, k)
        du, dv = np.meshgrid(u, u, indexing="ij")
        disc = np.hypot(du, dv) <= c
        gx = np.clip(ix[sel, None] + du[disc][None, :], 0, n[0] - 1)
        gy = np.clip(iy[sel, None] + dv[disc][None, :], 0, n[1] - 1)
        nodes.append((gx * n[1] + gy).ravel())
        owner.append(np.repeat(sel, disc.sum()))
    nodes, owner = np.concatenate(nodes), np.concatenate(owner)
    flat, where = np.unique(nodes, return_inverse=True)
    xy = np.stack([lo[0] + step * (flat // n[1]), lo[1] + step * (flat % n[1])], axis=1)
    refr = medium if half else None
    if sums is None or half:
        sums = lambda d, p: at_points(d, p, medium=refr)
    value = np.abs(sums(data, xy))[where]
    # each point's largest neighbour: the last of its nodes by value
    order = np.lexsort((value, owner))
    last = order[np.r_[np.flatnonzero(np.diff(owner[order])), order.size - 1]]
    peak, at = value[last], xy[where[last]]
    own = np.abs(sums(data, points))
    on = own >= 10.0 ** (threshold_db / 20.0) * peak
    if on.all() or not on.any():
        return on
    # a point off its peak goes only where points on a peak mark that peak
    keep = on.copy()
    keep[~on] = ~marked(at[~on], points[on], radius[~on])
    return keep


def marked(places: np.ndarray, marks: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Whether a mark lies within ``radius`` of each place: the distance
    ``sqrt(dx^2 + dy^2)`` to the nearest mark at most the place's radius,
    as a k-d tree's nearest distance (``scipy.spatial.cKDTree``) decides it.

    Parameters
    ----------
    places : ndarray, shape (P, 2)
    marks : ndarray, shape (Q, 2), Q >= 1
    radius : ndarray, shape (P,)

    Returns
    -------
    ndarray of bool, shape (P,)

    Notes
    -----
    The marks within ``radius`` of each place in x (a bisection on the
    marks sorted by x, the window widened by a part in 1e9 so that rounding
    keeps none out) are tested pair by pair, at most :data:`MARK_PAIRS`
    pairs at a time; where the windows hold more pairs in all than
    :data:`MARK_PAIRS_TREE`, a k-d tree answers (its import, about 0.17 s,
    is paid only then).
    """
    order = np.argsort(marks[:, 0], kind="stable")
    mx, my = marks[order, 0], marks[order, 1]
    wide = radius * (1 + 1e-9) + 1e-300
    lo = np.searchsorted(mx, places[:, 0] - wide, "left")
    hi = np.searchsorted(mx, places[:, 0] + wide, "right")
    counts = hi - lo
    if int(counts.sum()) > MARK_PAIRS_TREE:
        from scipy.spatial import cKDTree

        return ~(cKDTree(marks).query(places)[0] > radius)
    out = np.zeros(places.shape[0], bool)
    ends = np.cumsum(counts)
    start = 0
    while start < places.shape[0]:
        # the places whose pairs fit in this pass (at least one)
        stop = max(
            start + 1, int(np.searchsorted(ends, ends[start] - counts[start] + MARK_PAIRS, "right"))
        )
        rows = np.arange(start, min(stop, places.shape[0]))
        k = counts[rows]
        who = np.repeat(rows, k)
        j = lo[who] + np.arange(int(k.sum())) - np.repeat(np.cumsum(k) - k, k)
        dx = mx[j] - places[who, 0]
        dy = my[j] - places[who, 1]
        hit = np.sqrt(dx * dx + dy * dy) <= radius[who]
        out[rows] = np.bincount(who - start, hit, minlength=rows.size) > 0
        start = rows[-1] + 1
    return out
