"""The ``compare`` figure: k-space RPM points beside the SAR / DAS image of
the same linear-array data on a grid around the scene
(:func:`compare_images` computes the :class:`Comparison`,
:func:`draw_compare` draws it with matplotlib; :func:`auto_grid` is the
default grid).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..io.data import InputError, RadarData
from .decomposition import _params

__all__ = ["Comparison", "auto_grid", "compare_images", "draw_compare"]


@dataclass(frozen=True)
class Comparison:
    """What the ``compare`` figure draws.

    Attributes
    ----------
    points : ndarray, shape (M, 2)
        k-space RPM points (x, y), m.
    cluster : ndarray of int, shape (M,)
    grid : rpm_cl.baselines.das.Grid
        The DAS grid (2-D), m.
    image : ndarray, complex, shape grid.shape
        The DAS image.
    truth : ndarray, shape (P, 2) or None
        True boundary samples, m.
    array_x : ndarray, shape (nx,)
        Antenna x, m.
    """

    points: np.ndarray
    cluster: np.ndarray
    grid: object
    image: np.ndarray
    truth: np.ndarray | None
    array_x: np.ndarray


def auto_grid(data: RadarData, points=None, margin: float = 0.15, max_side: int = 400):
    """A 2-D DAS grid around the scene: the true boundary's box (else the
    points', else the array and the data's range axis) widened by ``margin``
    (m) on each side, pixels of at least 1 mm and at most ``max_side`` per axis.

    Returns
    -------
    rpm_cl.baselines.das.Grid
    """
    from ..baselines.das import Grid

    if data.truth is not None:
        box = data.truth.boundary
    elif points is not None and len(points):
        box = np.asarray(points)
    else:
        box = np.array([[data.array.x[0], data.range[0]], [data.array.x[-1], data.range[-1]]])
    lo = box.min(axis=0) - margin
    hi = box.max(axis=0) + margin
    lo[1] = max(lo[1], 1e-3)
    step = max(1e-3, float(np.max(hi - lo)) / max_side)
    return Grid(np.arange(lo[0], hi[0] + step / 2, step), np.arange(lo[1], hi[1] + step / 2, step))


def compare_images(data: RadarData, engine, das=None, grid=None, params=None) -> Comparison:
    """k-space RPM and the DAS image of a linear-array file, both after
    the steps before imaging of ``params`` (:func:`rpm_cl.imaging.prepared`).

    Parameters
    ----------
    data : RadarData
        Linear array.
    engine : object
        The RPM engine (:class:`rpm_cl.rpm.DeviceRPM` or :mod:`rpm_cl.rpm.reference`).
    das : rpm_cl.baselines.das.DeviceDAS, optional
        Back-projects on the device; None uses :func:`rpm_cl.baselines.das.das_numpy`.
    grid : rpm_cl.baselines.das.Grid, optional
        2 axes; default :func:`auto_grid`.
    params : rpm_cl.rpm.params.ImagingParams, optional
    """
    from ..baselines.das import das_numpy
    from ..imaging import prepared, run_method

    if data.array.planar:
        raise InputError("the compare figure needs a linear-array file (2-D); this array is planar")
    p = _params(data, params)
    res = run_method("kspace-rpm", data, p, engine)
    if grid is None:
        grid = auto_grid(data, res.image.points)
    if grid.dim != 2:
        raise InputError(f"the compare grid needs 2 axes (x, y), got {grid.dim}")
    seen = prepared(data, p)[0]  # the steps before imaging, as for the RPM points
    image = (
        das.backproject(seen, grid, medium=p.medium)
        if das is not None
        else das_numpy(seen, grid, medium=p.medium)
    )
    truth = data.truth.boundary if data.truth is not None else None
    return Comparison(res.image.points, res.image.cluster, grid, image, truth, data.array.x)


def draw_compare(c: Comparison, axes, dynamic_range: float = 40.0):
    """Draw a :class:`Comparison` on two matplotlib axes (DAS, RPM); returns
    the image artist."""
    import matplotlib.pyplot as plt

    from ..metrics import err_rpm

    g = c.grid
    mag = np.abs(c.image)
    top = float(mag.max())
    with np.errstate(divide="ignore"):
        db = 20 * np.log10(np.maximum(mag, 1e-12 * top) / top) if top > 0 else mag - np.inf
    hx = 0.5 * (g.x[1] - g.x[0]) if g.x.size > 1 else 5e-4
    hy = 0.5 * (g.y[1] - g.y[0]) if g.y.size > 1 else 5e-4
    ext = (1e3 * (g.x[0] - hx), 1e3 * (g.x[-1] + hx), 1e3 * (g.y[0] - hy), 1e3 * (g.y[-1] + hy))
    im = axes[0].imshow(
        db.T,
        origin="lower",
        extent=ext,
        cmap="inferno",
        vmin=-dynamic_range,
        vmax=0.0,
        aspect="equal",
        interpolation="nearest",
    )
    axes[0].set_title(f"SAR / DAS |I| (dB), {dynamic_range:g} dB range", fontsize=10)
    cmap = plt.get_cmap("tab10")
    for n, k in enumerate(np.unique(c.cluster)):
        sel = c.cluster == k
        axes[1].plot(
            1e3 * c.points[sel, 0],
            1e3 * c.points[sel, 1],
            "o",
            ms=4,
            color=cmap(n % 10),
            label=f"cluster {k}",
        )
    title = f"k-space RPM: {len(c.points)} points"
    if c.truth is not None:
        for ax, colour in zip(axes, ("white", "black")):
            ax.plot(
                1e3 * c.truth[:, 0],
                1e3 * c.truth[:, 1],
                "x" if len(c.truth) < 50 else ".",
                color=colour,
                ms=8 if len(c.truth) < 50 else 1,
                label="truth",
            )
        if len(c.points):
            ok = int(np.sum(err_rpm(c.points, _boundary_truth(c.truth)) <= 0.05))
            title += f", {ok} within 50 mm of the truth"
    axes[1].set_title(title, fontsize=10)
    for ax in axes:
        ax.set_xlim(ext[0], ext[1])
        ax.set_ylim(ext[2], ext[3])
        ax.set_aspect("equal")
        ax.set_xlabel("x (mm)")
    axes[0].set_ylabel("y (mm)")
    axes[1].grid(alpha=0.3)
    axes[1].legend(loc="upper right", fontsize=8)
    return im


def _boundary_truth(boundary):
    """A Truth holding only the boundary samples, for err_rpm."""
    from ..io.data import Truth

    return Truth(np.zeros(0, np.int64), np.zeros(0), boundary)
