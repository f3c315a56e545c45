"""The coherent sum of the range profiles along a point's own ranges,

    I(p) = sum_a s_a(|p - a|) exp(+j 2 k_c |p - a|),

with s_a linearly interpolated along the range axis (0 outside it): the
delay-and-sum value at ``p``.  :mod:`rpm_cl.baselines.das` forms whole
images of it; the RPM family reads it at single points
(:mod:`rpm_cl.rpm.coherence`).  Both take the interpolation weights from
:func:`weights`, so the two agree to rounding.
"""

from __future__ import annotations

import numpy as np

from ..io.data import C0, InputError, RadarData

__all__ = [
    "BYTES_PER_TERM",
    "BYTES_PER_TERM_REFRACTED",
    "antennas",
    "at_points",
    "phased_pairs",
    "points3",
    "summed",
    "weights",
]

#: Bytes per (point, antenna) of a chunk's temporaries: straight lines
#: (the measured peak of :func:`weights` and the gather), and refracted
#: paths (:func:`rpm_cl.io.medium.crossing` holds about a dozen float64 arrays
#: more).
BYTES_PER_TERM = 160
BYTES_PER_TERM_REFRACTED = 400


def weights(p: np.ndarray, ant: np.ndarray, r0: float, dr: float, nr: int, k2: float, medium=None):
    """Interpolation weights of the sum at points ``p``.

    Parameters
    ----------
    p : ndarray, shape (n, 3)
        Points (x, y, z), m.
    ant : ndarray, shape (A, 3)
        Antennas (x, 0, z), m.
    r0, dr : float
        First range gate and gate spacing, m.
    nr : int
        Range gates.
    k2 : float
        2 k_c, rad/m.
    medium : rpm_cl.io.medium.Medium, optional
        A half-space: refracted ranges; else straight lines.

    Returns
    -------
    i : ndarray of int64, shape (n, A)
        The lower sample's index (0 where the range is off the axis).
    w0, w1 : ndarray, complex, shape (n, A)
        The weights of samples ``i`` and ``i + 1`` (0 off the axis).
    """
    if medium is not None and medium.half_space:
        from ..io.medium import one_way

        d = one_way(medium, ant[None, :, :], p[:, None, :])
    else:
        d = np.square(p[:, 0:1] - ant[None, :, 0])
        d += np.square(p[:, 1:2] - ant[None, :, 1])
        d += np.square(p[:, 2:3] - ant[None, :, 2])
        np.sqrt(d, out=d)
    ph = np.exp(1j * k2 * d)
    d -= r0
    d /= dr  # d is now the fractional sample index t
    i = np.floor(d)
    d -= i  # the fraction
    inside = (i >= 0) & (i < nr - 1)
    ph *= inside
    i[~inside] = 0
    w1 = ph * d
    ph -= w1  # ph (1 - fr)
    return i.astype(np.int64), ph, w1


def antennas(array) -> np.ndarray:
    """The antennas (x, 0, z) of an :class:`rpm_cl.io.data.Array`, m, shape
    (A, 3) (z = 0 for a linear array)."""
    pos = array.positions()
    ant = np.zeros((pos.shape[0], 3))
    ant[:, 0] = pos[:, 0]
    if array.planar:
        ant[:, 2] = pos[:, 2]
    return ant


def phased_pairs(data: RadarData) -> np.ndarray:
    """The OpenCL sums' input (kernels/das.cl): per antenna a zero row, then
    for each sample i < nr - 1 the pair (u'_i, w'_i) = (s[i], s[i+1] - s[i])
    exp(j 2 k_c (R_i + dr/2)) (float64 phases), then a zero row; shape
    (n_ant, nr + 1, 2), complex128."""
    nr = data.range.size
    s = data.signal.reshape(-1, nr).astype(np.complex128)
    k2 = 4 * np.pi * data.waveform.fc / C0
    ph = np.exp(1j * k2 * (data.range[:-1] + 0.5 * data.dr))[None, :]
    out = np.zeros((s.shape[0], nr + 1, 2), np.complex128)
    out[:, 1:-1, 0] = s[:, :-1] * ph
    out[:, 1:-1, 1] = (s[:, 1:] - s[:, :-1]) * ph
    return out


def points3(data: RadarData, points) -> np.ndarray:
    """Points (M, dim) as (x, y, z), float64, shape (M, 3) (z = 0 for a
    linear array); InputError where ``points`` is not (M, dim)."""
    points = np.asarray(points, np.float64)
    if points.ndim != 2 or points.shape[1] != data.array.dim:
        raise InputError(f"points must have shape (M, {data.array.dim}), got {points.shape}")
    p3 = np.zeros((points.shape[0], 3))
    p3[:, : points.shape[1]] = points
    return p3


def summed(p3, ant, sig, r0: float, dr: float, k2: float, medium=None) -> np.ndarray:
    """I(p) at points ``p3`` (n, 3) over the antennas ``ant`` (A, 3) whose
    profiles are the rows of ``sig`` (A, nr), complex128: :func:`weights`,
    the gather of the two samples and the sum, shape (n,)."""
    i, w0, w1 = weights(p3, ant, r0, dr, sig.shape[1], k2, medium)
    rows = np.arange(len(ant))[None, :]
    w0 *= sig[rows, i]
    w1 *= sig[rows, i + 1]
    w0 += w1
    return w0.sum(axis=1)


def at_points(
    data: RadarData, points: np.ndarray, memory_budget: float = 2e8, medium=None
) -> np.ndarray:
    """I(p) at scattered points, float64.

    Parameters
    ----------
    data : RadarData
        As recorded (air-equivalent ranges).
    points : ndarray, shape (M, dim)
        (x, y) for linear arrays, (x, y, z) for planar ones, m.
    memory_budget : float
        Bound on the temporaries, bytes (:data:`BYTES_PER_TERM` per point
        and antenna of a chunk, :data:`BYTES_PER_TERM_REFRACTED` above a
        half-space).
    medium : rpm_cl.io.medium.Medium, optional
        A half-space: the ranges are the refracted paths
        (:func:`rpm_cl.io.medium.one_way`); else straight lines (a
        homogeneous medium's data go in as its equivalent air scene,
        :func:`rpm_cl.io.medium.in_medium`).

    Returns
    -------
    ndarray, complex, shape (M,)
    """
    p3 = points3(data, points)
    ant = antennas(data.array)
    sig = np.ascontiguousarray(data.signal.reshape(-1, data.range.size), np.complex128)
    k2 = 4 * np.pi * data.waveform.fc / C0
    out = np.empty(p3.shape[0], np.complex128)
    refr = medium if medium is not None and medium.half_space else None
    per = BYTES_PER_TERM if refr is None else BYTES_PER_TERM_REFRACTED
    for rows, cols in _chunks(p3, ant, float(data.range[-1]), memory_budget, per, refr):
        out[rows] = summed(p3[rows], ant[cols], sig[cols], float(data.range[0]), data.dr, k2, refr)
    return out


def _chunks(p3: np.ndarray, ant: np.ndarray, r_max: float, budget: float, per: int, refr):
    """(point rows, antenna columns) chunks of :func:`at_points`, each at
    most ``budget`` bytes of temporaries.  On a linear array in straight
    lines the points go in order of x and each chunk takes only the
    antennas within ``r_max`` (the range axis's end) of one of its points:
    the others' ranges lie beyond the axis, where their weights are 0, so
    the sums are those over every antenna (a 2000-trace line with a 1.5 m
    axis sums a tenth of them)."""
    n = max(1, int(budget // (per * len(ant))))
    every = np.arange(len(ant))
    if refr is not None or ant[:, 2].any():
        return [(np.arange(lo, min(len(p3), lo + n)), every) for lo in range(0, len(p3), n)]
    order = np.argsort(p3[:, 0], kind="stable")
    by_x = np.argsort(ant[:, 0], kind="stable")
    xs = ant[by_x, 0]
    out = []
    for lo in range(0, len(order), n):
        rows = order[lo : lo + n]
        a = np.searchsorted(xs, float(p3[rows, 0].min()) - r_max, "left")
        b = np.searchsorted(xs, float(p3[rows, 0].max()) + r_max, "right")
        # in the array's order, as the sum over every antenna takes them
        cols = np.sort(by_x[a:b]) if b > a else every[:1]
        out.append((rows, cols))
    return out
