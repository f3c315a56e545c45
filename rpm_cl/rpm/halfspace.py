"""RPM for antennas in air above a dielectric half-space.

RPM intersects each range point's (RP's) circle (sphere) of equal travel
time with its neighbours' and keeps the densest crossing (eq. 6/10).  Below
a surface the curve of equal travel time from an antenna in air is no
circle: the rays bend at the surface (:mod:`rpm_cl.io.medium`).  The kernels
intersect circles about antennas on one line (plane), so each RP is given a
*virtual* antenna and range whose circle stands in for its refracted curve
where it matters, near the RP's scatterer, and each image point is then
put on the exact crossing of the refracted curves its circles stood for:

1. *Paraxial start.*  Every RP's circle about the paraxial virtual antenna,
   ``n h`` above the surface, with the range ``(R + h (n^2 - 1)) / n``
   (:func:`rpm_cl.io.medium.paraxial`): exact in constant and curvature along
   the normal, centimetres off at wide angles.  RPM runs on these circles.
2. *Exact crossing* (``polish``).  Each point is a crossing of its main RP's
   circle with one other RP's (2-D) or two others' (3-D): those whose
   circles pass through it.  Newton's iteration on the exact travel times
   of those RPs (:func:`rpm_cl.io.medium.one_way`; gradients ``n`` times the
   ray's direction) moves it onto the crossing of their refracted curves,
   as free-space RPM puts a point on the crossing of its circles.  A point
   whose partners are not found, or whose iteration does not converge below
   the surface, stays where it is.
3. *Tangent matching* (:data:`ITERATIONS` passes).  Each RP that gave an
   image point ``q`` is re-centred: the refracted ray from its antenna
   through ``q`` meets its exact curve at ``P`` (optical path ``R``), and its
   new circle is the one through ``P`` with the ray's direction as normal,
   centred where the ray extended backwards meets the virtual plane
   ``y = h (1 - n)``.  The circle touches the exact curve at ``P``, so the
   crossings RPM scores are those of the exact curves up to second-order
   terms, and its density picks among them as it does in free space; RPM
   runs again, then step 2.

With exact RPs step 2 alone puts every point on its target (any crossing of
one target's exact curves is the target); with noisy RPs step 3 matters:
the paraxial circles' crossings scatter by their own error, so the density
chooses among wrong candidates.  ``benchmarks/halfspace_rpm.py`` measures
both against the exact Fermat geometry (docs/decisions.md).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..extract.rangepoints import RangePoints
from ..io.medium import (
    Medium,
    air_ranges,
    one_way,
    paraxial,
    point_on_ray,
    ray_through,
    virtual_centre,
)
from ..result import Image
from .params import RPMParams
from .pipeline import rpm_image

__all__ = [
    "ITERATIONS",
    "PARTNER_TOL",
    "exact_crossing",
    "halfspace_rpm",
    "to_air",
    "travel_gradient",
]

#: Tangent-matching passes after the paraxial one (module notes, step 3).
ITERATIONS = 2
#: A sub RP is a point's partner when its circle passes within this fraction
#: of sigma_r of the point (the kernels' float32 crossings are exact to about
#: 1e-7 of the range).
PARTNER_TOL = 1e-3


def to_air(rps: RangePoints, medium: Medium) -> RangePoints:
    """RPs of the scene :func:`rpm_cl.io.medium.seen_data` makes (the paraxial
    scene of a half-space) with their air-equivalent ranges
    (:func:`rpm_cl.io.medium.air_ranges`: ``R = n r - h (n^2 - 1)``)."""
    return rps if medium.air else replace(rps, range=air_ranges(medium, rps.range))


def _antennas(rps: RangePoints) -> np.ndarray:
    """(x, 0, z) of each RP's antenna, shape (K, 3), m."""
    out = np.zeros((len(rps), 3))
    out[:, 0] = rps.x
    if rps.z is not None:
        out[:, 2] = rps.z
    return out


def _xyz(points: np.ndarray) -> np.ndarray:
    p = np.asarray(points, np.float64)
    return p if p.shape[1] == 3 else np.column_stack([p, np.zeros(len(p))])


def travel_gradient(medium: Medium, antennas, points):
    """Optical path from antennas to points and its gradient with respect to
    the point: ``n`` (the local index) times the ray's unit direction there.

    Parameters
    ----------
    antennas, points : ndarray, shape (N, 3)
        m.

    Returns
    -------
    r : ndarray, shape (N,)
        m.
    grad : ndarray, shape (N, 3)
        dimensionless.
    """
    r = one_way(medium, antennas, points)
    p, e = ray_through(medium, antennas, points)
    _, t = point_on_ray(medium, antennas, p, e, r)
    if medium.half_space:
        index = np.where(np.asarray(points)[:, 1] > medium.antenna_height, medium.n, 1.0)
    else:
        index = np.full(len(r), medium.n)
    return r, index[:, None] * t


def exact_crossing(medium: Medium, antennas, ranges, start, max_iter: int = 30, tol: float = 1e-9):
    """The point whose optical paths from ``dim`` antennas are ``ranges``
    (Newton's iteration from ``start``).

    Parameters
    ----------
    medium : Medium
    antennas : ndarray, shape (M, dim, 3)
        m.
    ranges : ndarray, shape (M, dim)
        Air-equivalent ranges, m.
    start : ndarray, shape (M, 3)
        m (z = 0 in 2-D, where ``dim`` is 2 and z is not solved for).
    max_iter : int
    tol : float
        Converged when every path is within ``tol`` m of its range.

    Returns
    -------
    point : ndarray, shape (M, 3)
        m.
    converged : ndarray of bool, shape (M,)
    """
    m, dim, _ = antennas.shape
    p = np.array(start, np.float64, copy=True)
    axes = [0, 1] if dim == 2 else [0, 1, 2]
    ok = np.zeros(m, bool)
    for _ in range(max_iter):
        r, g = travel_gradient(medium, antennas.reshape(-1, 3), np.repeat(p, dim, axis=0))
        f = r.reshape(m, dim) - ranges
        ok = np.all(np.abs(f) < tol, axis=1)
        if np.all(ok):
            break
        jac = g.reshape(m, dim, 3)[:, :, axes]
        good = np.abs(np.linalg.det(jac)) > 1e-12
        step = np.zeros((m, dim))
        step[good] = np.linalg.solve(jac[good], -f[good][..., None])[..., 0]
        p[:, axes] += np.where(ok[:, None], 0.0, step)
    return p, ok & np.all(np.isfinite(p), axis=1)


def _partners(rps_virtual: RangePoints, centres_y: float, image: Image, tol: float, dim: int):
    """For each image point, the ``dim - 1`` RPs of its cluster (not its
    main RP) whose virtual circles pass nearest to it; -1 where fewer than
    that pass within ``tol`` (m)."""
    pts = _xyz(image.points)
    ant = _antennas(rps_virtual)
    ant[:, 1] = centres_y
    rv = np.asarray(rps_virtual.range, np.float64)
    start, count = rps_virtual.cluster_bounds()
    out = np.full((len(pts), dim - 1), -1, np.int64)
    main = np.asarray(image.rp_index)
    for s in np.unique(start[main]):
        rows = np.nonzero(start[main] == s)[0]
        members = np.arange(s, s + count[s])
        res = np.abs(np.linalg.norm(pts[rows, None, :] - ant[None, members], axis=2) - rv[members])
        res[members[None, :] == main[rows, None]] = np.inf
        order = np.argsort(res, axis=1)[:, : dim - 1]
        near = np.take_along_axis(res, order, axis=1) < tol
        out[rows] = np.where(near, members[order], -1)
    return out


def _polish(pts, virt, y_v, image, ant, r_air, medium, params, dim):
    """Each point moved onto the exact crossing of the refracted curves of
    its main RP and the partner(s) whose circles (spheres) it lies on
    (module notes, step 2); points without partners, or whose crossing does
    not converge or lies above the surface, stay."""
    local = replace(image, points=pts)
    part = _partners(virt, y_v, local, PARTNER_TOL * params.sigma_r, dim)
    found = np.all(part >= 0, axis=1)
    if not np.any(found):
        return pts
    rows = np.nonzero(found)[0]
    who = np.column_stack([np.asarray(image.rp_index)[rows], part[rows]])  # (M, dim)
    new, conv = exact_crossing(medium, ant[who], r_air[who], _xyz(pts[rows]))
    keep = conv & (new[:, 1] > medium.antenna_height)
    out = pts.copy()
    out[rows[keep]] = new[keep, :dim]
    return out


def halfspace_rpm(
    rps: RangePoints,
    params: RPMParams,
    engine,
    medium: Medium,
    iterations: int = ITERATIONS,
    polish: bool = True,
) -> Image:
    """RPM of air-equivalent RPs of antennas above a half-space (module notes).

    Parameters
    ----------
    rps : RangePoints
        Air-equivalent ranges (c tau / 2), antennas at y = 0.
    params : RPMParams
    engine : object
        As for :func:`rpm_cl.rpm.pipeline.rpm_image`.
    medium : Medium
        ``medium.half_space`` must hold.
    iterations : int
        Tangent-matching passes (>= 0).
    polish : bool
        Move each point onto the exact crossing of its RPs' refracted curves.

    Returns
    -------
    Image
        Points in the imaging frame (antennas at y = 0, the surface at
        y = h), true metres.
    """
    if not medium.half_space:
        raise ValueError("halfspace_rpm needs a half-space medium")
    dim = rps.dim
    y_v, scale, offset = paraxial(medium)
    ant = _antennas(rps)
    r_air = np.asarray(rps.range, np.float64)
    xv = np.array(rps.x, np.float64, copy=True)
    zv = None if rps.z is None else np.array(rps.z, np.float64, copy=True)
    rv = scale * r_air + offset
    for it in range(iterations + 1):
        virt = replace(rps, x=xv.copy(), z=None if zv is None else zv.copy(), range=rv.copy())
        image = rpm_image(virt, params, engine)
        pts = np.array(image.points, np.float64, copy=True)
        pts[:, 1] += y_v
        if len(pts) == 0:
            break
        if polish:
            pts = _polish(pts, virt, y_v, image, ant, r_air, medium, params, dim)
        if it == iterations:
            break
        i = np.asarray(image.rp_index)
        p, e = ray_through(medium, ant[i], _xyz(pts))
        on, t = point_on_ray(medium, ant[i], p, e, r_air[i])
        centre, radius = virtual_centre(on, t, y_v)
        good = np.all(np.isfinite(centre), axis=1) & np.isfinite(radius) & (radius > 0)
        xv[i[good]] = centre[good, 0]
        if zv is not None:
            zv[i[good]] = centre[good, 2]
        rv[i[good]] = radius[good]
    return Image(pts, image.cluster, image.score, image.rp_index)
