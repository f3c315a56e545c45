"""The figures of the k-space decomposition, each computed into a frozen
dataclass holding exactly the arrays drawn, then drawn with matplotlib:
``kspace`` (:func:`kspace_map`, :func:`draw_kspace`: the map
``|S(k_x, R)|`` in dB with the cluster centres) and ``rps`` (:func:`rp_sets`,
:func:`draw_rps`: the decomposed range points per cluster over the true
ones).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..io.data import RadarData

__all__ = ["KSpaceMap", "RPSets", "draw_kspace", "draw_rps", "kspace_map", "rp_sets"]


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
    from ..io.medium import air_ranges, seen_data

    pp = _params(data, params)
    p = pp.kspace
    seen = seen_data(data, pp.medium)  # in a medium: what the decomposition sees
    dec = decompose(seen, p)
    arr = data.array
    kx = dec.k_axes[0]
    kp_x = 2 * np.pi / arr.dx
    mag = dec.full_magnitude(seen.range.size)
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
    # the path the decomposition took (the automatic near-field choice gives
    # way to the plane-wave path where its map would be too large)
    nf = bool(dec.near_field)
    return KSpaceMap(kx[order], np.array(air_ranges(pp.medium, seen.range)), db, c, kz, nf)


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
