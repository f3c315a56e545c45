"""Targets, scenes and the paper's presets; truth sampling.

Coordinates are ``(x, y)`` in 2-D and ``(x, y, z)`` in 3-D, in metres, with
the array on ``y = 0`` and targets at ``y > 0``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

from ..io.data import Array, InputError, Waveform

__all__ = [
    "PRESETS",
    "Ellipsoid",
    "PointTarget",
    "Preset",
    "Scene",
    "boundary_samples",
    "get_preset",
    "specular_point",
]


def _vec(name, v, dim=None) -> np.ndarray:
    a = np.asarray(v, np.float64).ravel()
    if a.size not in (2, 3) or (dim is not None and a.size != dim):
        raise InputError(f"{name} must have {dim or '2 or 3'} components, got {a.size}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name} must be finite")
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class PointTarget:
    """An isotropic point scatterer.

    Attributes
    ----------
    position : ndarray, shape (dim,)
        m.
    amplitude : float
        Echo amplitude scale (2-D: ``amplitude / d``; 3-D: ``amplitude / d**2``
        at distance ``d``).
    """

    position: np.ndarray
    amplitude: float = 1.0

    def __post_init__(self):
        object.__setattr__(self, "position", _vec("position", self.position))
        if not (np.isfinite(self.amplitude) and self.amplitude > 0):
            raise InputError(f"amplitude must be > 0, got {self.amplitude}")

    @property
    def dim(self) -> int:
        return self.position.size

    def to_dict(self) -> dict:
        return {"type": "point", "position": self.position.tolist(), "amplitude": self.amplitude}


def _rotation(dim: int, angles) -> np.ndarray:
    a = np.atleast_1d(np.asarray(angles, np.float64))
    if dim == 2:
        (t,) = a[:1] if a.size else (0.0,)
        c, s = np.cos(t), np.sin(t)
        return np.array([[c, -s], [s, c]])
    a = np.concatenate([a, np.zeros(3 - a.size)])[:3]

    def rz(t):
        c, s = np.cos(t), np.sin(t)
        return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])

    def ry(t):
        c, s = np.cos(t), np.sin(t)
        return np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]])

    def rx(t):
        c, s = np.cos(t), np.sin(t)
        return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])

    return rz(a[0]) @ ry(a[1]) @ rx(a[2])


@dataclass(frozen=True)
class Ellipsoid:
    """A perfectly conducting ellipse (2-D) or ellipsoid (3-D).

    Attributes
    ----------
    center : ndarray, shape (dim,)
        m.
    semi_axes : ndarray, shape (dim,)
        Semi-axis lengths along the body axes, m, > 0.
    angles : ndarray
        2-D: one rotation angle, rad (counter-clockwise in the x-y plane).
        3-D: Z-Y-X Euler angles (yaw about z, pitch about y, roll about x), rad.
    amplitude : float
        Reflectivity scale of the geometric-optics echo.
    """

    center: np.ndarray
    semi_axes: np.ndarray
    angles: np.ndarray = (0.0,)
    amplitude: float = 1.0

    def __post_init__(self):
        c = _vec("center", self.center)
        e = _vec("semi_axes", self.semi_axes, c.size)
        if np.any(e <= 0):
            raise InputError(f"semi_axes must be > 0, got {e.tolist()}")
        ang = np.atleast_1d(np.asarray(self.angles, np.float64))
        if not np.all(np.isfinite(ang)):
            raise InputError("angles must be finite")
        object.__setattr__(self, "center", c)
        object.__setattr__(self, "semi_axes", e)
        object.__setattr__(self, "angles", ang)
        if not (np.isfinite(self.amplitude) and self.amplitude > 0):
            raise InputError(f"amplitude must be > 0, got {self.amplitude}")

    @property
    def dim(self) -> int:
        return self.center.size

    @property
    def rotation(self) -> np.ndarray:
        """Body-to-world rotation matrix, shape (dim, dim)."""
        return _rotation(self.dim, self.angles)

    def to_dict(self) -> dict:
        return {
            "type": "ellipsoid",
            "center": self.center.tolist(),
            "semi_axes": self.semi_axes.tolist(),
            "angles": self.angles.tolist(),
            "amplitude": self.amplitude,
        }


@dataclass(frozen=True)
class Scene:
    """A set of targets of one dimension."""

    targets: tuple
    name: str = "scene"

    def __post_init__(self):
        t = tuple(self.targets)
        if not t:
            raise InputError("a scene needs at least one target")
        dims = {x.dim for x in t}
        if len(dims) != 1:
            raise InputError(f"targets mix dimensions {sorted(dims)}")
        object.__setattr__(self, "targets", t)

    @property
    def dim(self) -> int:
        return self.targets[0].dim

    def to_json(self) -> str:
        return json.dumps({"name": self.name, "targets": [t.to_dict() for t in self.targets]})


# --------------------------------------------------------------------------
# Geometric optics of an ellipsoid
# --------------------------------------------------------------------------
def specular_point(ell: Ellipsoid, p: np.ndarray):
    """Specular (nearest) point of an ellipsoid seen from external points.

    For a point outside a convex body the monostatic specular point on the
    visible side is the unique nearest boundary point.  In the body frame with
    semi-axes ``e`` and the point reflected into the first orthant (``y``), the
    nearest point is ``x_i = e_i^2 y_i / (t + e_i^2)`` where ``t > 0`` is the
    root of ``F(t) = sum (e_i y_i / (t + e_i^2))^2 - 1``.  ``F`` decreases
    monotonically on ``[0, |e*y|]`` from ``F(0) > 0`` to ``F <= 0``, so the
    root is bracketed and bisection converges to full float64 precision
    whatever the axis ratio (Eberly, "Distance from a point to an ellipse, an
    ellipsoid, or a hyperellipsoid").

    Parameters
    ----------
    ell : Ellipsoid
    p : ndarray, shape (n, dim)
        Observation points, m.

    Returns
    -------
    point : ndarray, shape (n, dim)
        Specular points (world frame), m; NaN for points inside the body.
    distance : ndarray, shape (n,)
        |p - point|, m; NaN inside.
    radii : ndarray, shape (n, dim-1)
        Principal radii of curvature at the specular point, m.
    """
    p = np.atleast_2d(np.asarray(p, np.float64))
    rot = ell.rotation
    e = ell.semi_axes
    u = (p - ell.center) @ rot  # body frame
    y = np.abs(u)
    outside = np.sum((y / e) ** 2, axis=1) > 1.0
    ey = e * y
    lo = np.zeros(len(p))
    hi = np.linalg.norm(ey, axis=1)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        f = np.sum((ey / (mid[:, None] + e**2)) ** 2, axis=1) - 1.0
        pos = f > 0
        lo = np.where(pos, mid, lo)
        hi = np.where(pos, hi, mid)
        if np.all(hi - lo <= 4 * np.finfo(float).eps * np.maximum(hi, 1e-300)):
            break
    t = 0.5 * (lo + hi)
    xb = np.sign(u) * (e**2 * y / (t[:, None] + e**2))
    point = xb @ rot.T + ell.center
    dist = np.linalg.norm(p - point, axis=1)
    # Principal curvatures: shape operator of F = sum x^2/e^2 - 1 projected on
    # the tangent space, divided by |grad F| (factor 2 cancels).
    g = xb / e**2
    gn = np.linalg.norm(g, axis=1)
    n = g / gn[:, None]
    if ell.dim == 2:
        tang = np.stack([-n[:, 1], n[:, 0]], axis=1)[:, :, None]  # (n, 2, 1)
    else:
        ref = np.where(np.abs(n[:, [0]]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
        t1 = np.cross(ref, n)
        t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
        t2 = np.cross(n, t1)
        tang = np.stack([t1, t2], axis=2)  # (n, 3, 2)
    shape_op = np.einsum("nia,i,nib->nab", tang, 1.0 / e**2, tang) / gn[:, None, None]
    kappa = np.linalg.eigvalsh(shape_op)
    radii = 1.0 / kappa
    bad = ~outside
    point[bad] = np.nan
    dist[bad] = np.nan
    return point, dist, radii


def boundary_samples(target, spacing: float = 1e-3) -> np.ndarray:
    """Dense samples of a target's boundary for Err_RPM.

    Parameters
    ----------
    target : PointTarget or Ellipsoid
    spacing : float
        Approximate sample spacing on the boundary, m.

    Returns
    -------
    ndarray, shape (P, dim)
    """
    if isinstance(target, PointTarget):
        return target.position[None, :].copy()
    e, rot, c = target.semi_axes, target.rotation, target.center
    if target.dim == 2:
        a, b = e
        perim = np.pi * (3 * (a + b) - np.sqrt((3 * a + b) * (a + 3 * b)))
        t = np.linspace(0, 2 * np.pi, max(16, int(np.ceil(perim / spacing))), endpoint=False)
        local = np.stack([a * np.cos(t), b * np.sin(t)], axis=1)
    else:
        a, b, cc = e
        n_theta = max(8, int(np.ceil(np.pi * max(a, b, cc) / spacing)))
        pts = []
        for th in np.linspace(0, np.pi, n_theta + 1):
            ring = 2 * np.pi * max(a, b) * np.sin(th)
            n_phi = max(1, int(np.ceil(ring / spacing)))
            ph = np.linspace(0, 2 * np.pi, n_phi, endpoint=False)
            pts.append(
                np.stack(
                    [
                        a * np.sin(th) * np.cos(ph),
                        b * np.sin(th) * np.sin(ph),
                        np.full(n_phi, cc * np.cos(th)),
                    ],
                    axis=1,
                )
            )
        local = np.concatenate(pts)
    return local @ rot.T + c


# --------------------------------------------------------------------------
# Presets
# --------------------------------------------------------------------------
@dataclass(frozen=True)
class Preset:
    """A named scene with its array, waveform, range axis and default imaging
    settings (those the paper states for it).

    Attributes
    ----------
    scene : Scene
    array : Array
    waveform : Waveform
    range_axis : ndarray, shape (nr,)
        m.
    defaults : dict
        Imaging parameters the paper uses for this case (see
        :class:`rpm_cl.rpm.params.ImagingParams`).
    boundary_spacing : float
        Spacing of the true-boundary samples kept for Err_RPM, m.
    """

    scene: Scene
    array: Array
    waveform: Waveform
    range_axis: np.ndarray
    defaults: dict
    boundary_spacing: float = 1e-3


# The paper's Fig. 4 gives no coordinates; these three point targets follow
# its text: 20 GHz / 0.2 GHz (750 mm range resolution), line-of-sight ranges
# from the array centre of 420, 460 and 490 mm (spread 70 mm < 80 mm, i.e.
# < 0.1 of the range resolution) at directions -28, +3 and +25 degrees, seen by
# 21 antenna positions (63 true RPs, as the paper's tables count).
_PAPER_2D_TARGETS = [(0.42, -28.0), (0.46, 3.0), (0.49, 25.0)]


def _paper_2d(step: float, sigma_x: float) -> Preset:
    targets = tuple(
        PointTarget((r * np.sin(np.radians(a)), r * np.cos(np.radians(a))))
        for r, a in _PAPER_2D_TARGETS
    )
    name = "paper-2d" if step == 5e-3 else "paper-2d-sparse"
    return Preset(
        Scene(targets, name),
        Array((np.arange(21) - 10) * step),
        Waveform(20e9, 0.2e9),
        np.arange(0.0, 1.5, 2.5e-3),
        {"sigma_x": sigma_x, "sigma_r": 0.05, "window_x": 417.0},  # the paper's values,
    )


# The paper's human body (Section VI-B, Fig. 19) is "11 ellipsoids
# corresponding to the head, upper and lower torsos, arms, and legs" with no
# dimensions given.  Ours is an adult of about 1.75 m standing with the front
# of the torso 1 m from the array, arms hanging beside the torso; feet at
# z = 0.  (name, centre (x, y, z), semi-axes (x, y, z)), m.  Neighbouring
# parts overlap a little, as joints do; a specular point inside another part
# is blocked by it and not counted.
HUMAN_BODY_PARTS = (
    ("head", (0.0, 1.07, 1.63), (0.075, 0.095, 0.115)),
    ("upper-torso", (0.0, 1.11, 1.31), (0.17, 0.11, 0.19)),
    ("lower-torso", (0.0, 1.10, 0.99), (0.155, 0.10, 0.15)),
    ("right-upper-arm", (0.235, 1.11, 1.30), (0.045, 0.05, 0.15)),
    ("left-upper-arm", (-0.235, 1.11, 1.30), (0.045, 0.05, 0.15)),
    ("right-forearm", (0.25, 1.09, 0.99), (0.04, 0.045, 0.13)),
    ("left-forearm", (-0.25, 1.09, 0.99), (0.04, 0.045, 0.13)),
    ("right-thigh", (0.10, 1.11, 0.63), (0.075, 0.08, 0.21)),
    ("left-thigh", (-0.10, 1.11, 0.63), (0.075, 0.08, 0.21)),
    ("right-lower-leg", (0.12, 1.12, 0.22), (0.05, 0.055, 0.20)),
    ("left-lower-leg", (-0.12, 1.12, 0.22), (0.05, 0.055, 0.20)),
)
#: Height of the centre of the human-body array, m (chest-abdomen height).
HUMAN_BODY_ARRAY_Z = 1.0


def _human_body() -> Preset:
    # 20 GHz / 3 GHz (50 mm range resolution); 11 x 17 antennas at 7.5 mm
    # (half the 15 mm wavelength) in x and z, centred at (0, 0, 1 m).
    step = 7.5e-3
    targets = tuple(Ellipsoid(c, e, (0.0, 0.0, 0.0)) for _, c, e in HUMAN_BODY_PARTS)
    return Preset(
        Scene(targets, "human-body"),
        Array((np.arange(11) - 5) * step, HUMAN_BODY_ARRAY_Z + (np.arange(17) - 8) * step),
        Waveform(20e9, 3e9),
        np.arange(0.70, 1.70, 2.5e-3),
        # Window periods: the paper gives "0.775 rad/m and 1.21 rad/m, which
        # almost corresponds to a size of spatial resolution in k-space"; the
        # k-space resolution of this array is 2 pi / L = 76 rad/m (x) and
        # 49 rad/m (z), so those numbers cannot be periods in rad/m, and read
        # as rad/mm they span the whole k axis (838 rad/m) and merge clusters
        # (measured: 5 clusters instead of 11).  So the window is left to the
        # planar default (rpm_cl.rpm.params.WINDOW_PLANAR_DEFAULT, 60 rad/m,
        # 0.8-1.2 resolution cells), the measured best with the exhaustive
        # refinement of the 3-D RPM (benchmarks/pareto.py; docs/decisions.md).
        # sigma_D is left to the default too, 2.5 antenna
        # spacings (the paper: 2-3).
        {"sigma_r": 0.05},
        boundary_spacing=3e-3,
    )


PRESETS = {
    "paper-2d": lambda: _paper_2d(5e-3, 0.10),
    "paper-2d-sparse": lambda: _paper_2d(20e-3, 0.40),
    "human-body": _human_body,
}


def get_preset(name: str) -> Preset:
    """The named preset; :data:`PRESETS` lists the names."""
    try:
        return PRESETS[name]()
    except KeyError:
        raise InputError(f"unknown scene {name!r}; choose from {', '.join(PRESETS)}") from None
