"""The medium the waves travel in: air, a homogeneous dielectric, or a
dielectric half-space below antennas in air.

Ranges in the data are *air-equivalent*: an echo delayed by ``tau`` lies at
``R = c tau / 2`` (the input contract: phase ``exp(-2j k_c R)``).  In a
material of relative permittivity ``eps_r`` waves travel at ``c / n``,
``n = sqrt(eps_r)``, so that range is the *optical path*: ``n`` times the
metres travelled in the material.

Homogeneous medium (``antenna_height`` None)
--------------------------------------------
Antennas and targets both in the material.  An echo from true range ``r``
has ``R = n r`` and phase ``exp(-2j k_c n r)``: the data are exactly those
of an air scene with the range axis divided by ``n`` and the carrier
frequency and the bandwidth multiplied by ``n`` (the wavenumber inside is
``n k_c``).  :func:`in_medium` makes that equivalent air scene, so every
imager (each RPM method, DAS, RMA) runs unchanged and reports true metres.

Half-space (``antenna_height`` h)
---------------------------------
Antennas in air at ``y = 0``, a flat surface at ``y = h``, the material
below it (``y > h``).  The optical path from an antenna to a point at depth
``d = y - h`` and horizontal distance ``rho`` is Fermat's minimum over the
surface crossing ``u`` (the distance from the antenna's foot point):

    R(rho, d) = min_u  sqrt(u^2 + h^2) + n sqrt((rho - u)^2 + d^2)

whose minimiser satisfies Snell's law, ``sin(theta_air) = n sin(theta_in)``
(:func:`crossing`: a safeguarded Newton iteration on the convex path, to
1e-13 of the geometry).  In 3-D the crossing lies in the vertical plane
through antenna and point, so the same 1-D problem holds with ``rho`` the
horizontal distance.  Points above the surface (``y <= h``) are reached in a
straight line.

Paraxially (near the normal) the refracted wavefront of an antenna is a
circle (sphere) about a *virtual antenna* ``n h`` above the surface, at
``y_v = h (1 - n)``, with the range ``(R + h (n^2 - 1)) / n``
(:func:`paraxial`).  :func:`paraxial_data` relabels the data so (the
*paraxial scene*: the equivalent scene of a homogeneous medium seen from the
virtual antennas); the RP extraction runs there, and
:mod:`rpm_cl.rpm.halfspace` starts RPM from it and refines against the exact
paths.  In the data as recorded, an echo's range walk is that of an air
target at ``h + d / n`` (0.12-0.2 m for rods 0.1-0.3 m deep under 0.08 m of
air, n = 2.45), a strongly curved, wide-angle track; in the paraxial scene
it is that of a target at ``d + n h`` (0.3-0.5 m), which the k-space
decomposition's windows and curvature model are made for (three synthetic
point targets, 1-3 GHz, noise-free: phase-rpm's RPs 13 mm off at the median
against 1.4 mm).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .data import InputError, RadarData

__all__ = [
    "EPS_R_MAX",
    "Medium",
    "air_ranges",
    "crossing",
    "in_medium",
    "one_way",
    "paraxial",
    "paraxial_data",
    "point_on_ray",
    "ray_through",
    "recorded_data",
    "seen_data",
    "virtual_centre",
]

#: Largest relative permittivity accepted (water, about 80, is the largest
#: of common materials).
EPS_R_MAX = 100.0
#: Largest antenna height accepted, m.
HEIGHT_MAX = 1e3


@dataclass(frozen=True)
class Medium:
    """The material the antennas and targets sit in.

    Attributes
    ----------
    eps_r : float
        Relative permittivity of the material (1 .. 100, lossless; the
        propagation velocity is c / sqrt(eps_r)); 1 is air, and imaging is then
        exactly the free-space imaging.  Echo ranges in the data are
        air-equivalent (c tau / 2); images are in true metres.  "auto" (a
        flag, a config, ``default_params``): read from the echoes'
        hyperbolas after the steps before imaging
        (rpm_cl.extract.hyperbola.read_eps_r; air, with a warning, where
        none pins it).
    antenna_height : float or None
        m (>= 0).  None: the antennas are in the material too (a homogeneous
        medium: ranges are divided by sqrt(eps_r), the carrier wavenumber inside
        is k_c sqrt(eps_r)).  A height h: the antennas lie in air h above a flat
        surface (the plane y = h of the imaging frame) with the material below
        it (y > h, a half-space), and the travel times refract there (Snell,
        Fermat's shortest optical path).  0 is the same as None.
    """

    eps_r: float = 1.0
    antenna_height: float | None = None

    def __post_init__(self):
        e = self.eps_r
        if (
            isinstance(e, bool)
            or not isinstance(e, (int, float, np.floating, np.integer))
            or not (np.isfinite(e) and 1.0 <= e <= EPS_R_MAX)
        ):
            raise InputError(f"eps_r must be a number between 1 (air) and {EPS_R_MAX:g}, got {e!r}")
        object.__setattr__(self, "eps_r", float(e))
        h = self.antenna_height
        if h is not None:
            if (
                isinstance(h, bool)
                or not isinstance(h, (int, float, np.floating, np.integer))
                or not (np.isfinite(h) and 0.0 <= h <= HEIGHT_MAX)
            ):
                raise InputError(
                    f"antenna_height must be a height in m between 0 and "
                    f"{HEIGHT_MAX:g}, or None (the antennas in the medium), "
                    f"got {h!r}"
                )
            object.__setattr__(self, "antenna_height", float(h))

    @property
    def n(self) -> float:
        """Refractive index sqrt(eps_r)."""
        return float(np.sqrt(self.eps_r))

    @property
    def air(self) -> bool:
        """Free space: nothing to do."""
        return self.eps_r == 1.0

    @property
    def half_space(self) -> bool:
        """Antennas in air above the material (refraction at y = h)."""
        return not self.air and bool(self.antenna_height)

    @property
    def homogeneous(self) -> bool:
        """Antennas and targets in one material other than air."""
        return not self.air and not self.half_space


def in_medium(data: RadarData, medium: Medium) -> RadarData:
    """The equivalent air scene of data recorded in a homogeneous medium.

    Range axis divided by ``n``, carrier and bandwidth multiplied by ``n``:
    an echo ``p(R - n r) exp(-2j k_c n r)`` of true range ``r`` is then
    ``p'(R' - r) exp(-2j (n k_c) r)`` on the new axis ``R' = R / n``, the
    contract's form for an air echo of range ``r`` and carrier ``n f_c``.
    The truth (geometry, true metres) is kept.

    Parameters
    ----------
    data : RadarData
    medium : Medium

    Returns
    -------
    RadarData
        ``data`` itself unless ``medium.homogeneous`` (air, and the half-space
        whose refraction the imagers handle themselves).
    """
    if not medium.homogeneous:
        return data
    from .data import Waveform

    n = medium.n
    w = data.waveform
    spectrum = None if data.spectrum is None else data.spectrum.scaled(n)
    return replace(
        data,
        range=data.range / n,
        waveform=Waveform(w.fc * n, w.bandwidth * n),
        spectrum=spectrum,
    )


def paraxial_data(data: RadarData, medium: Medium) -> RadarData:
    """The half-space's paraxial scene: the data relabelled as if recorded
    by the virtual antennas (:func:`paraxial`) in a homogeneous medium.

    The range axis becomes ``(R + h (n^2 - 1)) / n``, carrier and bandwidth
    are multiplied by ``n``, and the signal is multiplied by the constant
    ``exp(-2j n k_c h (n^2 - 1) / n)`` so that an echo of virtual range ``r``
    has the contract's phase ``exp(-2j (n k_c) r)``.  Near the normal an
    echo's range walk is then that of an air target (module notes); off it
    the ranges are only relabelled, and :mod:`rpm_cl.rpm.halfspace` images them
    with the exact paths.

    Returns
    -------
    RadarData
        ``data`` itself unless ``medium.half_space``.
    """
    if not medium.half_space:
        return data
    from .data import Waveform

    _, scale, offset = paraxial(medium)
    w = data.waveform
    kc = w.kc / scale
    sig = data.signal * np.exp(-2j * kc * offset).astype(data.signal.dtype)
    return replace(
        data,
        signal=sig,
        range=data.range * scale + offset,
        waveform=Waveform(w.fc / scale, w.bandwidth / scale),
        spectrum=None,  # the paraxial scene is no scaling of the samples
        compression=None,  # ... and its profiles are resampled
    )


def recorded_data(seen: RadarData, medium: Medium) -> RadarData:
    """The data as recorded (air-equivalent ranges, the radar's own carrier)
    back from the half-space's paraxial scene :func:`paraxial_data` made of
    them; ``seen`` itself unless ``medium.half_space``.  The samples the
    paraxial scene dropped stay dropped."""
    if not medium.half_space:
        return seen
    from .data import Waveform

    _, scale, offset = paraxial(medium)
    w = seen.waveform
    sig = seen.signal * np.exp(2j * w.kc * offset).astype(seen.signal.dtype)
    return replace(
        seen,
        signal=sig,
        range=(seen.range - offset) / scale,
        waveform=Waveform(w.fc * scale, w.bandwidth * scale),
    )


def seen_data(data: RadarData, medium: Medium) -> RadarData:
    """What the RP extraction sees: :func:`in_medium` (homogeneous),
    :func:`paraxial_data` (half-space), or ``data`` itself (air)."""
    return paraxial_data(data, medium) if medium.half_space else in_medium(data, medium)


def air_ranges(medium: Medium, r):
    """Ranges of the scene :func:`seen_data` makes back to the data's own
    air-equivalent ranges (c tau / 2): ``n r`` in a homogeneous medium,
    ``n r - h (n^2 - 1)`` above a half-space, ``r`` in air, m."""
    _, scale, offset = paraxial(medium)
    r = np.asarray(r, np.float64)
    return r if medium.air else (r - offset) / scale


# --------------------------------------------------------------------------
# Fermat's path through a flat surface
def crossing(rho, h: float, d, n: float, tol: float = 1e-13, max_iter: int = 100):
    """Where the shortest optical path from an antenna ``h`` above the
    surface to a point ``d`` below it and ``rho`` aside crosses the surface.

    Minimises ``f(u) = sqrt(u^2 + h^2) + n sqrt((rho - u)^2 + d^2)`` over
    ``0 <= u <= rho``: ``f`` is convex, ``f'(0) <= 0 <= f'(rho)``, so Newton's
    iteration on ``f'`` from the paraxial crossing ``rho h / (h + d / n)``,
    kept inside the shrinking bracket (bisection where a step leaves it),
    converges (quadratically near the root).

    Parameters
    ----------
    rho : ndarray
        Horizontal distance, m (>= 0).
    h : float
        Antenna height above the surface, m (> 0).
    d : ndarray
        Depth below the surface, m (> 0); broadcasts with ``rho``.
    n : float
        Refractive index (>= 1).
    tol : float
        Stop when every step is below ``tol`` times ``rho + h + d``.
    max_iter : int

    Returns
    -------
    ndarray
        ``u`` (m), shape of ``rho`` and ``d`` broadcast.
    """
    rho, d = np.broadcast_arrays(np.asarray(rho, np.float64), np.asarray(d, np.float64))
    lo = np.zeros(rho.shape)
    hi = rho.copy()
    u = rho * h / (h + d / n)
    scale = tol * (rho + h + d)
    h2 = h * h
    for _ in range(max_iter):
        a = np.hypot(u, h)
        b = np.hypot(rho - u, d)
        g = u / a - n * (rho - u) / b
        gp = h2 / a**3 + n * d * d / b**3
        lo = np.where(g < 0, u, lo)
        hi = np.where(g > 0, u, hi)
        with np.errstate(divide="ignore", invalid="ignore"):
            new = u - g / gp
        out = ~((new >= lo) & (new <= hi))  # left the bracket (or NaN): bisect
        new = np.where(out, 0.5 * (lo + hi), new)
        step = np.abs(new - u)
        u = new
        if np.all(step <= scale):
            break
    return u


def _split(antennas, points):
    """Horizontal distance, unit horizontal direction (2 components: x, z)
    and y of ``points`` seen from ``antennas`` (arrays (..., 3) that
    broadcast)."""
    a = np.asarray(antennas, np.float64)
    p = np.asarray(points, np.float64)
    dx = p[..., 0] - a[..., 0]
    dz = p[..., 2] - a[..., 2]
    rho = np.hypot(dx, dz)
    safe = np.where(rho > 0, rho, 1.0)
    e = np.stack([np.where(rho > 0, dx / safe, 1.0), np.where(rho > 0, dz / safe, 0.0)], axis=-1)
    return rho, e, p[..., 1] - a[..., 1]


def one_way(medium: Medium, antennas, points) -> np.ndarray:
    """Air-equivalent one-way range (optical path) from antennas to points, m.

    Parameters
    ----------
    medium : Medium
        Air: ``|p - a|``; homogeneous: ``n |p - a|``; half-space: Fermat's
        path through the surface ``y = h`` (points at ``y <= h`` in a straight
        line).
    antennas, points : ndarray, shape (..., 3)
        (x, y, z), m, broadcasting against each other (antennas at y = 0).

    Returns
    -------
    ndarray
        The broadcast shape without the last axis.
    """
    rho, _, y = _split(antennas, points)
    if not medium.half_space:
        return medium.n * np.hypot(rho, y)
    h, n = medium.antenna_height, medium.n
    d = y - h
    below = d > 0
    dd = np.where(below, d, 1.0)
    u = crossing(rho, h, dd, n)
    path = np.hypot(u, h) + n * np.hypot(rho - u, dd)
    return np.where(below, path, np.hypot(rho, y))


def ray_through(medium: Medium, antennas, points):
    """The ray from each antenna to each point (the half-space's refracted one).

    Returns
    -------
    p : ndarray
        ``sin`` of the ray's angle from the vertical where it leaves the
        antenna (the ray parameter: ``dR/d(antenna position)`` is ``-p`` along
        ``e``), shape of the broadcast.
    e : ndarray, shape (..., 2)
        Unit horizontal (x, z) direction from antenna to point.
    """
    rho, e, y = _split(antennas, points)
    if not medium.half_space:
        return rho / np.maximum(np.hypot(rho, y), 1e-300), e
    h, n = medium.antenna_height, medium.n
    d = y - h
    below = d > 0
    u = crossing(rho, h, np.where(below, d, 1.0), n)
    p = np.where(below, u / np.hypot(u, h), rho / np.maximum(np.hypot(rho, y), 1e-300))
    return p, e


def point_on_ray(medium: Medium, antennas, p, e, r):
    """The point at optical path ``r`` along the ray of parameter ``p`` in
    direction ``e`` from each antenna, and the ray's unit direction there.

    Parameters
    ----------
    medium : Medium
    antennas : ndarray, shape (N, 3)
        m.
    p : ndarray, shape (N,)
        Ray parameter (sine of the angle in air at the antenna), |p| < 1.
    e : ndarray, shape (N, 2)
        Unit horizontal direction (x, z).
    r : ndarray, shape (N,)
        Air-equivalent range, m.

    Returns
    -------
    point : ndarray, shape (N, 3)
        m.
    direction : ndarray, shape (N, 3)
        Unit vector of the ray at the point (pointing away from the antenna).
    """
    a = np.asarray(antennas, np.float64)
    p = np.clip(np.asarray(p, np.float64), 0.0, 1.0 - 1e-12)
    e = np.asarray(e, np.float64)
    r = np.asarray(r, np.float64)
    n = medium.n
    cos_a = np.sqrt(1.0 - p * p)
    t_air = np.stack([p * e[:, 0], cos_a, p * e[:, 1]], axis=1)
    if not medium.half_space:
        return a + (r / n)[:, None] * t_air, t_air
    h = medium.antenna_height
    air_len = h / cos_a
    sin_m = p / n
    t_in = np.stack([sin_m * e[:, 0], np.sqrt(1.0 - sin_m * sin_m), sin_m * e[:, 1]], axis=1)
    cross = a + air_len[:, None] * t_air
    inside = r > air_len
    pt = np.where(
        inside[:, None], cross + ((r - air_len) / n)[:, None] * t_in, a + r[:, None] * t_air
    )
    return pt, np.where(inside[:, None], t_in, t_air)


def paraxial(medium: Medium) -> tuple[float, float, float]:
    """The half-space's paraxial virtual antenna: ``(y_v, scale, offset)``
    with the virtual antenna at ``y = y_v = h (1 - n)`` (``n h`` above the
    surface) and the virtual range ``scale * R + offset`` =
    ``(R + h (n^2 - 1)) / n`` of an air-equivalent range ``R``.

    Near the normal the refracted path is ``R ~ h + n d + rho^2 / (2 (h +
    d / n))`` (the ray parameter ``p ~ rho / (h + d / n)``), and a circle
    about the virtual antenna, ``n sqrt(rho^2 + (d + n h)^2) - h (n^2 - 1)``,
    has the same constant and curvature for every depth ``d``."""
    h, n = float(medium.antenna_height or 0.0), medium.n
    return h * (1.0 - n), 1.0 / n, h * (n * n - 1.0) / n


def virtual_centre(point, direction, y_v: float):
    """The centre on the plane ``y = y_v`` and the radius of the circle
    (sphere) through ``point`` whose normal there is ``direction``: the ray
    extended backwards to that plane.

    Returns
    -------
    centre : ndarray, shape (N, 3)
    radius : ndarray, shape (N,)
    """
    s = (point[:, 1] - y_v) / direction[:, 1]
    return point - s[:, None] * direction, s
