"""Paper-style figures: ``rpm-cl figure {kspace,rps,compare} IN.npz --png OUT``.

Each figure is computed first, into a small frozen dataclass holding exactly
the arrays drawn (so tests can check them against the truth), then drawn with
matplotlib:

- ``kspace`` (:func:`kspace_map`): the k-space map ``|S(k_x, R)|`` in dB of
  a linear-array file with the detected cluster centres marked (the paper's
  Fig. 3/7); for planar data the ``k_x``-``R`` map at the strongest ``k_z``,
  with the centres within a quarter window period of that ``k_z``.
- ``rps`` (:func:`rp_sets`): the decomposed range points per cluster (antenna
  x against range, coloured by cluster) over the true RPs when the file
  carries them (Fig. 4/8); for planar data the antenna row at the middle z.
- ``compare`` (:func:`compare_images`): k-space RPM points beside the SAR /
  DAS image of the same linear-array data on a grid around the scene
  (Fig. 5/10/12).

matplotlib is imported lazily (``pip install 'rpm-cl[view]'``).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ..io.data import InputError, RadarData

__all__ = [
    "FIGURES",
    "Comparison",
    "KSpaceMap",
    "RPSets",
    "auto_grid",
    "compare_images",
    "draw_compare",
    "draw_kspace",
    "draw_rps",
    "figure",
    "kspace_map",
    "rp_sets",
]


def _wrap(k, period: float):
    return (np.asarray(k) + 0.5 * period) % period - 0.5 * period


@dataclass(frozen=True)
class KSpaceMap:
    """What the ``kspace`` figure draws.

    Attributes
    ----------
    kx : ndarray, shape (nk,)
        Ascending k_x, rad/m.
    r : ndarray, shape (nr,)
        Range, m.
    db : ndarray, shape (nk, nr)
        ``20 log10 |S(k_x, R)| / max``, dB (<= 0).
    centres : ndarray, shape (M, 2)
        (k_x wrapped onto the axis, R) of the cluster centres shown, rad/m and m.
    kz : float or None
        The k_z of the slice (planar data), rad/m.
    near_field : bool
        The centres come from the near-field decomposition (sparse arrays).
    """

    kx: np.ndarray
    r: np.ndarray
    db: np.ndarray
    centres: np.ndarray
    kz: float | None
    near_field: bool


def _params(data: RadarData, params):
    from ..rpm.params import default_params

    return default_params(data) if params is None else params


def kspace_map(data: RadarData, params=None) -> KSpaceMap:
    """The k-space map of ``data`` and its cluster centres (eq. 2-3 / 7-8).

    Parameters
    ----------
    data : RadarData
    params : rpm_cl.rpm.params.ImagingParams, optional
        Default :func:`rpm_cl.rpm.params.default_params` of the data.
    """
    from ..extract.kspace import decompose
    from ..extract.nearfield import near_field_wanted
    from ..io.medium import air_ranges, seen_data

    pp = _params(data, params)
    p = pp.kspace
    seen = seen_data(data, pp.medium)  # in a medium: what the decomposition sees
    dec = decompose(seen, p)
    arr = data.array
    kx = dec.k_axes[0]
    kp_x = 2 * np.pi / arr.dx
    mag = dec.magnitude
    kz = None
    centres = [(c.k[0], float(air_ranges(pp.medium, c.r_centre))) for c in dec.clusters]
    if arr.planar:
        iz = int(np.unravel_index(int(np.argmax(mag)), mag.shape)[1])
        kz = float(dec.k_axes[1][iz])
        kp_z = 2 * np.pi / arr.dz
        quarter = 0.25 * (p.window_z or p.window_x)
        centres = [
            (c.k[0], float(air_ranges(pp.medium, c.r_centre)))
            for c in dec.clusters
            if abs(_wrap(c.k[1] - kz, kp_z)) <= quarter
        ]
        mag = mag[:, iz, :]
    order = np.argsort(kx)
    top = float(mag.max()) if mag.size else 0.0
    with np.errstate(divide="ignore"):
        db = (
            20 * np.log10(np.maximum(mag[order], 1e-12 * top) / top)
            if top > 0
            else np.full(mag.shape, -np.inf)
        )
    c = np.array(centres, np.float64).reshape(-1, 2)
    c[:, 0] = _wrap(c[:, 0], kp_x)
    nf = not arr.planar and (p.near_field or (p.near_field is None and near_field_wanted(seen)))
    return KSpaceMap(kx[order], np.array(air_ranges(pp.medium, seen.range)), db, c, kz, bool(nf))


def draw_kspace(m: KSpaceMap, ax, dynamic_range: float = 40.0):
    """Draw a :class:`KSpaceMap` on a matplotlib axes; returns the image artist."""
    dk = m.kx[1] - m.kx[0] if m.kx.size > 1 else 1.0
    dr = m.r[1] - m.r[0]
    im = ax.imshow(
        m.db.T,
        origin="lower",
        aspect="auto",
        cmap="viridis",
        vmin=-dynamic_range,
        vmax=0.0,
        interpolation="nearest",
        extent=(
            m.kx[0] - dk / 2,
            m.kx[-1] + dk / 2,
            1e3 * (m.r[0] - dr / 2),
            1e3 * (m.r[-1] + dr / 2),
        ),
    )
    if len(m.centres):
        ax.plot(
            m.centres[:, 0],
            1e3 * m.centres[:, 1],
            "r+",
            ms=12,
            mew=2,
            label=f"{len(m.centres)} cluster centres",
        )
        ax.legend(loc="upper right", fontsize=8)
    ax.set_xlabel("$k_x$ (rad/m)")
    ax.set_ylabel("R (mm)")
    title = "|S($k_x$, R)| (dB)"
    if m.kz is not None:
        title += f" at the strongest $k_z$ = {m.kz:.0f} rad/m (centres within a quarter window)"
    if m.near_field:
        title += "; centres of the near-field decomposition"
    ax.set_title(title, fontsize=10)
    return im


@dataclass(frozen=True)
class RPSets:
    """What the ``rps`` figure draws.

    Attributes
    ----------
    x, r : ndarray, shape (K,)
        Antenna x and range of each decomposed RP, m.
    cluster : ndarray of int, shape (K,)
    true_x, true_r : ndarray, shape (T,) or None
        The true RPs, m (None when the file carries no truth).
    within_10mm : int or None
        RPs within 10 mm of a true RP at their antenna (Err_range).
    row_z : float or None
        Planar data: the z of the antenna row drawn, m.
    """

    x: np.ndarray
    r: np.ndarray
    cluster: np.ndarray
    true_x: np.ndarray | None
    true_r: np.ndarray | None
    within_10mm: int | None
    row_z: float | None


def rp_sets(data: RadarData, params=None) -> RPSets:
    """The decomposed RPs per cluster (eq. 5) and the true RPs.

    Parameters
    ----------
    data : RadarData
    params : rpm_cl.rpm.params.ImagingParams, optional
    """
    from ..extract.kspace import decompose
    from ..extract.rangepoints import rps_from_decomposition
    from ..io.medium import seen_data
    from ..metrics import err_range
    from ..rpm.halfspace import to_air

    p = _params(data, params)
    seen = seen_data(data, p.medium)  # in a medium: what the decomposition sees
    rps = to_air(
        rps_from_decomposition(seen, decompose(seen, p.kspace), p.rp_threshold_db), p.medium
    )
    arr = data.array
    keep = np.ones(len(rps), bool)
    row_z = None
    if arr.planar:
        iz = arr.z.size // 2
        row_z = float(arr.z[iz])
        keep = np.unravel_index(rps.antenna, arr.shape)[1] == iz
    tx = tr = within = None
    if data.truth is not None and data.truth.has_rps:
        t = data.truth
        within = int(np.sum(err_range(rps.antenna[keep], rps.range[keep], t) <= 0.010))
        ix = t.rp_antenna
        tkeep = np.ones(ix.size, bool)
        if arr.planar:
            ix, izs = np.unravel_index(t.rp_antenna, arr.shape)
            tkeep = izs == arr.z.size // 2
        tx, tr = arr.x[ix[tkeep]], t.rp_range[tkeep]
    return RPSets(rps.x[keep], rps.range[keep], rps.cluster[keep], tx, tr, within, row_z)


def draw_rps(s: RPSets, ax) -> None:
    """Draw :class:`RPSets` on a matplotlib axes (x in mm, range in mm)."""
    import matplotlib.pyplot as plt

    if s.true_x is not None:
        ax.plot(
            1e3 * s.true_x, 1e3 * s.true_r, "o", mfc="none", mec="black", ms=9, label="true RPs"
        )
    cmap = plt.get_cmap("tab10")
    for n, c in enumerate(np.unique(s.cluster)):
        sel = s.cluster == c
        ax.plot(
            1e3 * s.x[sel],
            1e3 * s.r[sel],
            ".",
            ms=7,
            color=cmap(n % 10),
            label=f"cluster {c} ({sel.sum()} RPs)",
        )
    ax.set_xlabel("antenna x (mm)")
    ax.set_ylabel("range (mm)")
    ax.grid(alpha=0.3)
    title = f"{s.x.size} decomposed RPs in {np.unique(s.cluster).size} clusters"
    if s.within_10mm is not None:
        title += f"; {s.within_10mm}/{s.x.size} within 10 mm of a true RP"
    if s.row_z is not None:
        title += f"\n(planar array: the antenna row at z = {1e3 * s.row_z:.1f} mm)"
    ax.set_title(title, fontsize=10)
    ax.legend(loc="best", fontsize=8)


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
    """k-space RPM and the DAS image of a linear-array file.

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
    from ..imaging import run_method

    if data.array.planar:
        raise InputError("the compare figure needs a linear-array file (2-D); this array is planar")
    p = _params(data, params)
    res = run_method("kspace-rpm", data, p, engine)
    if grid is None:
        grid = auto_grid(data, res.image.points)
    if grid.dim != 2:
        raise InputError(f"the compare grid needs 2 axes (x, y), got {grid.dim}")
    image = (
        das.backproject(data, grid, medium=p.medium)
        if das is not None
        else das_numpy(data, grid, medium=p.medium)
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


#: Figure names.
FIGURES = ("kspace", "rps", "compare")


def figure(
    name: str,
    path,
    png=None,
    *,
    size=(1200, 700),
    dynamic_range: float = 40.0,
    grid=None,
    engine=None,
    das=None,
    frame: int | None = None,
    range_window: str = "hann",
    params=None,
    conjugate: bool = False,
) -> object:
    """Compute and draw one paper-style figure of a data file.

    Parameters
    ----------
    name : {"kspace", "rps", "compare"}
    path : str or path-like
        An input ``.npz`` (input contract).
    png : str or path-like, optional
        Picture to write (off-screen, atomically); None opens a window.
    size : (int, int)
        Picture size, pixels.
    dynamic_range : float
        dB below the maximum shown on the maps (> 0).
    grid : rpm_cl.baselines.das.Grid, optional
        ``compare``: the DAS grid; default :func:`auto_grid`.
    engine : object
        ``compare``: the RPM engine (required there).
    das : rpm_cl.baselines.das.DeviceDAS, optional
        ``compare``: DAS on the device; None uses NumPy.
    frame : int, optional
        Frame of a stacked input (as :func:`rpm_cl.load_data`).
    range_window : str
        Range window of a frequency-domain input (as :func:`rpm_cl.load_data`).
    params : rpm_cl.rpm.params.ImagingParams or callable, optional
        The imaging parameters of the figure, or a function of the loaded
        :class:`~rpm_cl.io.data.RadarData` returning them (how ``rpm-cl figure``
        applies ``--config`` and the flags over the defaults derived from the
        data, as ``rpm-cl image`` does).  Default
        :func:`rpm_cl.rpm.params.default_params` of the data.
    conjugate : bool
        Conjugate a frequency-domain input first (as :func:`rpm_cl.load_data`).

    Returns
    -------
    KSpaceMap, RPSets or Comparison
        The arrays drawn.

    Raises
    ------
    InputError
        Unknown name, unreadable or invalid input, planar data for
        ``compare``, a bad option or output path.
    """
    from ..io.formats import load_data
    from .view import _atomic_png, _finish_mpl, _pyplot

    if name not in FIGURES:
        raise InputError(f"unknown figure {name!r}; choose from {', '.join(FIGURES)}")
    if not (np.isfinite(dynamic_range) and dynamic_range > 0):
        raise InputError(f"the dynamic range must be > 0 dB, got {dynamic_range:g}")
    if png is not None:  # check the output before computing
        from ..io.data import output_path

        if not os.fspath(png).lower().endswith(".png"):
            raise InputError(f"{os.fspath(png)}: the picture must be a .png file")
        output_path(png)
    data = load_data(path, frame=frame, range_window=range_window, conjugate=conjugate)
    if callable(params):
        params = params(data)
    if name == "kspace":
        what = kspace_map(data, params)
    elif name == "rps":
        what = rp_sets(data, params)
    else:
        if engine is None:
            raise InputError("the compare figure needs an RPM engine")
        what = compare_images(data, engine, das, grid, params)

    def render(out):
        plt = _pyplot(out, "figures")
        ncols = 2 if name == "compare" else 1
        fig, axes = plt.subplots(
            1, ncols, figsize=(size[0] / 100, size[1] / 100), dpi=100, squeeze=False
        )
        axes = axes[0]
        if name == "kspace":
            fig.colorbar(draw_kspace(what, axes[0], dynamic_range), ax=axes[0], label="dB")
        elif name == "rps":
            draw_rps(what, axes[0])
        else:
            from mpl_toolkits.axes_grid1 import make_axes_locatable

            im = draw_compare(what, axes, dynamic_range)
            cax = make_axes_locatable(axes[0]).append_axes("right", size="4%", pad=0.08)
            fig.colorbar(im, cax=cax, label="dB")
        fig.suptitle(f"{os.path.basename(os.fspath(path))}: {name}", fontsize=11)
        fig.tight_layout()
        _finish_mpl(fig, out)

    if png is None:
        render(None)
    else:
        _atomic_png(png, render)
    return what
