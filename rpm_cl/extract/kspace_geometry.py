"""The array's geometry as the k-space decomposition (:mod:`rpm_cl.extract.kspace`)
uses it, and the range gates each step applies to.

The antennas' coordinates along each array axis and their offsets from the
array's centre, the wavefront curvature of a target at a range, the Fresnel
factor that dechirps a gate before detection (step 2), and per range gate
whether clusters are aligned (step 4), focused (step 5) and detected on the
dechirped spectrum (step 2).

The steps named in the docstrings below ("module notes, step N") are those
of the notes of :mod:`rpm_cl.extract.kspace`.
"""

from __future__ import annotations

import numpy as np

from ..io.data import RadarData
from .kspace_params import KSpaceParams


def _array_axes(arr) -> list:
    """The antenna coordinates along each array axis, m: [x], or [x, z]."""
    return [arr.x, arr.z] if arr.planar else [arr.x]


def _centred_grids(axes_x) -> list:
    """Each antenna's offset from the array's centre along each array axis,
    m: one array of the array's shape per axis."""
    centres = [0.5 * (ax[0] + ax[-1]) for ax in axes_x]
    return np.meshgrid(*[ax - c for ax, c in zip(axes_x, centres)], indexing="ij")


def _half_diagonal2(axes_x) -> float:
    """Squared distance from the array's centre to its corners, m^2."""
    return sum((0.5 * (ax[-1] - ax[0])) ** 2 for ax in axes_x)


def _max_curvature(axes_x, kc_w: float, r_c):
    """Curvature phase at the array's corners for a broadside target at range
    ``r_c`` (m, a number or an array of them), rad."""
    return 2 * kc_w * _half_diagonal2(axes_x) / (2.0 * np.maximum(r_c, 1e-9))


def _curvature(u, axes_x, r_c: float) -> np.ndarray:
    """q(X) = (|dX|^2 - (u . dX)^2) / (2 r_c), m: the curvature term of the
    range of a target at range r_c with range slope u (step 5)."""
    grids = _centred_grids(axes_x)
    d2 = sum(g * g for g in grids)
    ud = sum(u[a] * grids[a] for a in range(len(u)))
    return (d2 - ud * ud) / (2.0 * max(r_c, 1e-9))


def _fresnel(data: RadarData, on: np.ndarray, ranges: np.ndarray) -> np.ndarray:
    """exp(j k_c |X - X_c|^2 / R) per antenna and gate where ``on``, else 1;
    shape (nx[, nz], n_gates): the curvature phase of :func:`_curvature` at
    u = 0, removed as :func:`_align` removes it."""
    axes_x = _array_axes(data.array)
    half_d2 = _curvature(np.zeros(len(axes_x)), axes_x, 1.0)  # |X - X_c|^2 / 2
    phase = 2 * data.waveform.kc * half_d2[..., None] / np.maximum(ranges, 1e-9)[None, :]
    return np.exp(1j * phase * on[None, :])


def _dechirp_gates(data: RadarData, params: KSpaceParams) -> np.ndarray | None:
    """Gates whose clusters are focused (step 5) and where the Fresnel
    (quadratic) phase describes a point's wavefront: there detection runs on
    the spectrum with that phase removed (step 2).  None: no gate.

    The gate is a broadside criterion: the next term of the expansion of the
    two-way path of a broadside point, ``2 k_c h^4 / (8 R^3)`` at the array's
    corners (``h`` the half-diagonal), stays under a quarter cycle: 1.3 rad
    for the human body seen by a 64 x 64 array at 1 m, 72 rad for a 1 m
    linear array at 0.45 m (whose detection keeps the plain spectrum).  An
    oblique target keeps more (``k_c (u . dX)^2 / R``, about 10 rad at
    ``|u| = 0.5`` on 64 x 64), but its peak still gains (8.5 times for
    u = (-0.3, -0.2), 19 times at broadside, in a check at 1 m).  Dechirped
    and plain gates are thresholded apart (:func:`_regimes`)."""
    focused = _focused_gates(data, params)
    if not focused.any():
        return None
    h2 = _half_diagonal2(_array_axes(data.array))
    r = np.maximum(data.range, 1e-9)
    on = focused & (2 * data.waveform.kc * h2 * h2 / (8 * r**3) < 0.5 * np.pi)
    return on if on.any() else None


def _focused_gates(data: RadarData, params: KSpaceParams) -> np.ndarray:
    """Per range gate, whether a cluster centred there is focused (step 5):
    never without the alignment, everywhere or nowhere by ``focus``, and by
    default where the curvature phase at the array's corners exceeds pi.
    Detection (:func:`_dechirp_gates`) and the clusters (:func:`_clusters`)
    both ask this."""
    if not _align_on(data, params):
        return np.zeros(data.range.size, bool)
    if params.focus is not None:
        return np.full(data.range.size, bool(params.focus))
    return _max_curvature(_array_axes(data.array), data.waveform.kc, data.range) > np.pi


#: The range-walk alignment is on by default where the aperture spans at
#: least this many range resolutions (a target's walk across it can then be
#: a sizeable part of the resolution; below it, interpolation and leakage
#: cost more than the alignment gains: KSpaceParams.align).
ALIGN_MIN_APERTURE = 0.25


def _align_on(data: RadarData, params: KSpaceParams) -> bool:
    """Whether clusters get the range-walk alignment (step 4): ``align``, or by
    default where the aperture spans a quarter range resolution."""
    if params.align is not None:
        return bool(params.align)
    extent = max(float(ax[-1] - ax[0]) for ax in _array_axes(data.array))
    return extent >= ALIGN_MIN_APERTURE * data.waveform.range_resolution
