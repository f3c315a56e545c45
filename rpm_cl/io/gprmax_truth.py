"""The input schema's truth from a sidecar's geometry (:func:`truth_arrays`):
boundary samples of each object and the true ranges from every antenna, in
the engine's frame; through a medium, the air-equivalent (optical) ranges."""

from __future__ import annotations

import math

import numpy as np

from .gprmax_sidecar import Sidecar


def truth_arrays(sidecar: Sidecar, x, y_scan: float, step: float = 1e-3) -> dict:
    """The input schema's truth from a sidecar's geometry, in the engine's frame.

    A point ``(X, Y)`` of gprMax's plane is ``(X, |Y - y_scan|)``.  The true
    RPs are, for every antenna and object, the distance to the object's
    nearest surface point (a specular point, or a plate's edge where no
    specular point exists).  With a medium (``sidecar.eps_r``) the distance is
    the air-equivalent range (optical path, :func:`rpm_cl.io.medium.one_way`):
    ``sqrt(eps_r)`` times the distance in a homogeneous medium, Fermat's
    refracted path to the nearest boundary sample above a half-space (the
    ranges :func:`rpm_cl.imaging.run_method` returns its RPs in there).

    Parameters
    ----------
    sidecar : Sidecar
        With cylinders and/or plates.
    x : ndarray, shape (nx,)
        Antenna x, m.
    y_scan : float
        The scan line's y in gprMax's frame, m.
    step : float
        Spacing of the boundary samples, m.

    Returns
    -------
    dict
        ``truth_rp_antenna`` (K,) int64, ``truth_rp_range`` (K,),
        ``truth_boundary`` (P, 2); empty when the sidecar has no geometry.
    """
    x = np.asarray(x, np.float64)
    ant = np.stack([x, np.full_like(x, y_scan)], axis=1)
    medium = sidecar.medium(y_scan)
    bounds, dists = [], []
    for cx, cy, r in sidecar.cylinders:
        n = max(16, math.ceil(2 * math.pi * r / step))
        a = 2 * math.pi * np.arange(n) / n
        bounds.append(np.stack([cx + r * np.cos(a), cy + r * np.sin(a)], axis=1))
        dists.append(np.abs(np.hypot(ant[:, 0] - cx, ant[:, 1] - cy) - r))
    for poly in sidecar.polygons:
        d = np.full(len(ant), np.inf)
        for p, q in zip(poly, np.roll(poly, -1, axis=0)):
            seg = q - p
            n = max(2, math.ceil(np.hypot(*seg) / step) + 1)
            bounds.append(p + np.linspace(0, 1, n)[:, None] * seg)
            u = np.clip(((ant - p) @ seg) / max(seg @ seg, 1e-300), 0, 1)
            d = np.minimum(d, np.linalg.norm(ant - (p + u[:, None] * seg), axis=1))
        dists.append(d)
    if not bounds:
        return {}
    if medium is not None and medium.half_space:
        # refracted: the nearest of boundary samples 0.1 mm apart in optical
        # path (the path is stationary there: off by about (0.1 mm)^2 / r)
        dists = [
            _refracted_min(medium, x, y_scan, b) for b in _dense_boundaries(sidecar, REFRACTED_STEP)
        ]
    elif medium is not None:
        dists = [medium.n * d for d in dists]
    b = np.concatenate(bounds)
    b[:, 1] = np.abs(b[:, 1] - y_scan)
    dist = np.stack(dists, axis=1)  # (nx, objects)
    ant_idx = np.repeat(np.arange(len(x), dtype=np.int64), dist.shape[1])
    return {"truth_rp_antenna": ant_idx, "truth_rp_range": dist.ravel(), "truth_boundary": b}


#: Spacing of the boundary samples of the refracted true ranges, m.
REFRACTED_STEP = 1e-4


def _dense_boundaries(sidecar: Sidecar, step: float) -> list:
    """Boundary samples (k, 2) of each object, cylinders first, in gprMax's
    frame, ``step`` apart."""
    out = []
    for cx, cy, r in sidecar.cylinders:
        n = max(16, math.ceil(2 * math.pi * r / step))
        a = 2 * math.pi * np.arange(n) / n
        out.append(np.stack([cx + r * np.cos(a), cy + r * np.sin(a)], axis=1))
    for poly in sidecar.polygons:
        edges = [
            p
            + np.linspace(0, 1, max(2, math.ceil(np.hypot(*(q - p)) / step) + 1))[:, None] * (q - p)
            for p, q in zip(poly, np.roll(poly, -1, axis=0))
        ]
        out.append(np.concatenate(edges))
    return out


def _refracted_min(medium, x, y_scan: float, boundary: np.ndarray) -> np.ndarray:
    """Least optical path (nx,) from each antenna to a boundary's samples
    (gprMax's frame), in antenna chunks of a few MB, m."""
    from .medium import one_way

    p3 = np.stack(
        [boundary[:, 0], np.abs(boundary[:, 1] - y_scan), np.zeros(len(boundary))], axis=1
    )
    ant = np.stack([x, np.zeros_like(x), np.zeros_like(x)], axis=1)
    step = max(1, (1 << 17) // max(1, len(p3)))
    return np.concatenate(
        [
            one_way(medium, ant[i : i + step, None], p3[None]).min(axis=1)
            for i in range(0, len(ant), step)
        ]
    )
