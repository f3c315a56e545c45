"""Sub-RP lists for 3-D RPM: which RPs a main RP is paired with.

The triplet candidates of a main RP are the pairs of its list (see
:func:`rpm_cl.rpm.reference.pair_table`); the scoring work per main RP grows
as the fourth power of the list length, so the list is bounded (``kmax``).
Which RPs it holds matters:

- The weight g of eq. 11 is a *sum*, ``a_j exp(-D_j^2/2 sigma_D^2) +
  a_k exp(-D_k^2/2 sigma_D^2)``: a pair weighs in when *either* sub RP is near
  the main antenna.  A pair (near j, far k) has a long baseline, so its
  intersection is well conditioned, and it keeps j's weight.
- So a list of the ``near`` nearest RPs (within ``radius``) plus
  ``kmax - near`` RPs spread evenly, by distance rank, over the rest of the
  cluster approximates the exhaustive eq. 10 far better than the ``kmax``
  nearest: on the human body (S/N 20 dB) 94 % of points within 10 mm with 4
  near + 20 spread, against 84 % for the 24 nearest and 97 % exhaustive
  (which takes 1500 times longer), all at 100 % within 50 mm
  (``docs/benchmarks.md``, 100 rad/m, the list's argmax as the point;
  with the mean-shift refinement on, the point is refined to the exhaustive
  argmax, and the list only matters where that refinement does not run).

A cluster of more than :data:`THIN_ABOVE` RPs (an extended surface seen by
a large planar array: one cluster of 26 552 RPs) takes its nearest part
from the RPs within ``radius`` of each block of main RPs only, which is
exact, and spreads its far part over the ranks of a fixed random draw of
:data:`FAR_SAMPLE` of its RPs (rank r of the cluster is about rank r n / N of the
draw): ranking all N RPs against each other costs N^2.  The far part only
has to reach across the cluster.

RPs are ranked by distance and then by index.  Antennas on one uniform grid
(every planar array of the input contract) are ranked by integer keys built
from their offsets in steps (:func:`_ranked_grid`): equal distances tie
exactly, so the lists do not move with the array, and the lists are built
2-3.5 times faster (``python benchmarks/neighbour_lists.py``, interleaved on a
loaded machine: 11 x 17 body 11 against 23 ms, 32 x 32 0.14 against 0.51 s,
64 x 64 (32 613 RPs in 16 clusters) 1.6 against 3.8 s).  Other layouts take
a stable float sort (:func:`_ranked`).  Which of the RPs at equal distances
are taken changes with the tie-break, not the accuracy: RPM points within
10 mm on the body 97.1 -> 97.6 % noise-free, 96.0 -> 96.1 % at 20 dB (seeds
0-9), 32 x 32 97.9 -> 97.9 %, 64 x 64 80.3 -> 80.1 %.
"""

from __future__ import annotations

import numpy as np

__all__ = ["neighbour_lists"]

_BLOCK = 256  # main RPs per block of the distance sort (memory: block x cluster)
#: Clusters of more RPs rank their far sub RPs over a fixed random draw of
#: FAR_SAMPLE of them (module notes): ranking every RP against every other
#: grows as the square of the cluster (a surface of 26 552 RPs: 11 s of a
#: 16 s run).  Their nearest RPs still come from every RP within the radius.
THIN_ABOVE = 8192
#: RPs in that draw: the far part takes some 20 ranks spread over it, and a
#: quantile of 2048 draws lies within about 1 % of the cluster's rank range
#: (its standard error, sqrt(p (1 - p) / 2048)).
FAR_SAMPLE = 2048


def neighbour_lists(x, z, antenna, cstart, ccount, radius: float, kmax: int, near=None):
    """Sub-RP list of every RP: its nearest RPs and RPs spread over the cluster.

    Parameters
    ----------
    x, z : ndarray, shape (N,)
        Antenna coordinates of each RP, m.
    antenna : ndarray of int, shape (N,)
        Antenna index of each RP (RPs at the same antenna are never paired:
        their spheres are concentric).
    cstart, ccount : ndarray of int, shape (N,)
        First index and size of each RP's cluster (clusters contiguous).
    radius : float
        The nearest part is taken within this distance in the array plane, m
        (inf: no bound).
    kmax : int or ndarray of int, shape (N,)
        Longest list, >= 2; per RP, the same within a cluster (a cluster's
        lists are built with its first RP's value).
    near : int or None
        How many of the list are the nearest RPs (within ``radius``, at most
        ``kmax``); the rest are spread evenly by distance rank over the
        cluster's remaining RPs.  None: all ``kmax`` nearest (within
        ``radius``).

    Returns
    -------
    nbr : ndarray of int32, shape (N, K)
        Sub-RP indices, the nearest first; K = the longest list (<= max(kmax));
        -1 pads.
    nnbr : ndarray of int32, shape (N,)
        List lengths.
    """
    x = np.asarray(x, np.float64)
    z = np.asarray(z, np.float64)
    antenna = np.asarray(antenna)
    n = x.size
    kmaxs = np.broadcast_to(np.asarray(kmax, np.int64), (n,))
    cstart = np.asarray(cstart, np.int64)
    ccount = np.asarray(ccount, np.int64)
    nbr = np.full((n, int(kmaxs.max(initial=2))), -1, np.int32)
    counts = np.zeros(n, np.int32)
    for s in np.unique(cstart):
        c = int(ccount[s])
        kmax = int(kmaxs[s])
        n_near = kmax if near is None else max(0, min(int(near), kmax))
        n_far = kmax - n_near
        px, pz, ant = x[s : s + c], z[s : s + c], antenna[s : s + c]
        grid = _grid_offsets(px, pz)
        big = c > THIN_ABOVE and n_far > 0 and np.isfinite(radius)
        if big:
            # per RP, how many of the cluster's RPs share its antenna (itself
            # included): never eligible
            _, inv, per_ant = np.unique(ant, return_inverse=True, return_counts=True)
            shared = per_ant[inv]
            # a fixed random draw, not every n-th RP: a stride commensurate
            # with the array's rows would leave whole rows (the far corners)
            # out of the ranks
            thin = np.sort(np.random.default_rng(c).choice(c, FAR_SAMPLE, replace=False))
        for b0 in range(0, c, _BLOCK):
            b1 = min(c, b0 + _BLOCK)
            if big:
                order, _, within = _near_part(px, pz, ant, grid, b0, b1, radius)
                eligible = c - shared[b0:b1]
            else:
                order, eligible, within = _ranked_cols(px, pz, ant, grid, b0, b1, radius, None)
            if order.shape[1] < kmax:  # a cluster smaller than the list
                order = np.pad(order, ((0, 0), (0, kmax - order.shape[1])), constant_values=-1)
            t = np.minimum(n_near, within)  # nearest taken
            lists = np.full((b1 - b0, kmax), -1, np.int64)
            cols = np.arange(n_near)[None, :]
            take = cols < t[:, None]
            lists[:, :n_near] = np.where(take, order[:, :n_near] if n_near else 0, -1)
            if n_far:
                if big:
                    # the far ranks over a random thinning of the cluster:
                    # rank r of the cluster is about rank r * len / eligible
                    # of the thinning (module notes)
                    order, eligible_t, _ = _ranked_cols(px, pz, ant, grid, b0, b1, np.inf, thin)
                    t_far = np.ceil(t * eligible_t / np.maximum(eligible, 1)).astype(np.int64)
                    far = _spread_ranks(order, t_far, eligible_t, kmax - t, kmax)
                    # a thinned RP among the nearest is not taken twice
                    far[(far[:, :, None] == lists[:, None, :n_near]).any(axis=2)] = -1
                else:
                    far = _spread_ranks(order, t, eligible, kmax - t, kmax)
                lists = np.concatenate([lists[:, :n_near], far], axis=1)
            # compact: valid entries first, in order
            valid = lists >= 0
            comp = np.argsort(~valid, axis=1, kind="stable")
            lists = np.take_along_axis(lists, comp, axis=1)[:, :kmax]
            cnt = np.minimum(valid.sum(axis=1), kmax)
            lists = np.where(np.arange(kmax)[None, :] < cnt[:, None], lists + s, -1)
            nbr[s + b0 : s + b1, :kmax] = lists
            counts[s + b0 : s + b1] = cnt
    width = int(counts.max(initial=0))
    return nbr[:, :width].copy(), counts


#: Largest table of grid distance classes (offsets in x times offsets in z)
#: for :func:`_ranked_grid`; sparser layouts take the float path.
_GRID_TABLE_MAX = 1 << 22


def _grid_offsets(x, z):
    """A cluster's antennas as integer offsets on one uniform grid, or None.

    Returns
    -------
    (ix, iz, cls_table, keys, sx) or None
        ``x = x0 + ix sx`` and ``z = z0 + iz sz`` to 1e-6 of a step (int32,
        shape (C,)); ``keys`` the sorted distinct squared distances of the
        offsets in units of ``sx^2``, ``dx^2 + (sz / sx)^2 dz^2``, distances
        within 1e-9 of each other counted as one (they tie: offsets (3, 4)
        and (5, 0) at equal steps, (2, 0) and (0, 3) at steps 7.5 and 5 mm);
        ``cls_table[|dx|, |dz|]`` the rank of an offset's distance in
        ``keys`` (int32).  None when the
        antennas are not on one grid or the table would exceed
        ``_GRID_TABLE_MAX`` entries.
    """
    ints, steps = [], []
    for v in (x, z):
        u = np.unique(v)
        step = float(np.min(np.diff(u))) if u.size > 1 else 0.0
        if step == 0.0:
            ints.append(np.zeros(v.size, np.int32))
            steps.append(0.0)
            continue
        i = np.rint((v - u[0]) / step)
        if not np.all(np.abs(i * step + u[0] - v) <= 1e-6 * step):
            return None
        ints.append(i.astype(np.int32))
        steps.append(step)
    (ix, iz), (sx, sz) = ints, steps
    nx, nz = int(ix.max(initial=0)) + 1, int(iz.max(initial=0)) + 1
    if nx * nz > _GRID_TABLE_MAX:
        return None
    sx, sz = sx or sz or 1.0, sz or sx or 1.0  # one row or column: either step
    dx, dz = np.arange(nx, dtype=np.float64), np.arange(nz, dtype=np.float64)
    d2, inv = np.unique(dx[:, None] ** 2 + (sz / sx) ** 2 * dz[None, :] ** 2, return_inverse=True)
    # distances within 1e-9 (relative) of each other are one class: they tie
    cls = np.cumsum(np.r_[0, np.diff(d2) > 1e-9 * d2[1:]])
    keys = d2[np.r_[True, np.diff(cls) > 0]]  # each class's smallest
    return ix, iz, cls[inv].reshape(nx, nz).astype(np.int32), keys, sx


def _spread_ranks(order, t, eligible, f, kmax: int) -> np.ndarray:
    """The far part of each row's list: ``f`` slots at ranks spread evenly
    over ``t .. eligible - 1`` of ``order`` (duplicates dropped when fewer
    remain), -1 where none; shape (rows, kmax)."""
    rows = np.arange(order.shape[0])
    span = np.maximum(eligible - t, 0)
    j = np.arange(kmax)[None, :]
    frac = j / np.maximum(f - 1, 1)[:, None]
    pos = t[:, None] + np.round(frac * np.maximum(span - 1, 0)[:, None]).astype(np.int64)
    ok = (j < f[:, None]) & (span[:, None] > 0)
    dup = np.zeros_like(ok)
    dup[:, 1:] = pos[:, 1:] == pos[:, :-1]
    ok &= ~dup
    return np.where(ok, order[rows[:, None], np.minimum(pos, order.shape[1] - 1)], -1)


def _ranked_cols(px, pz, ant, grid, b0, b1, radius, cols):
    """Rows b0..b1 of a cluster ranked against the RPs ``cols`` (indices
    into the cluster, increasing; None: all of them), by :func:`_ranked` or,
    on a uniform grid, :func:`_ranked_grid`; ``order`` holds cluster
    indices."""
    cols = np.arange(px.size) if cols is None else cols
    same = ant[b0:b1, None] == ant[None, cols]  # itself and its antenna
    if grid is None:
        return _ranked(px, pz, same, b0, b1, radius, cols)
    return _ranked_grid(grid, same, b0, b1, radius, cols)


def _near_part(px, pz, ant, grid, b0, b1, radius):
    """:func:`_ranked_cols` of rows b0..b1 against only the RPs within
    ``radius`` of their bounding box: every RP within ``radius`` of a row
    is among them, so ``within`` and the ranks below it are the whole
    cluster's (``eligible`` is not)."""
    pad = radius * (1.0 + 1e-9)
    box = (
        (px >= px[b0:b1].min() - pad)
        & (px <= px[b0:b1].max() + pad)
        & (pz >= pz[b0:b1].min() - pad)
        & (pz <= pz[b0:b1].max() + pad)
    )
    return _ranked_cols(px, pz, ant, grid, b0, b1, radius, np.flatnonzero(box))


def _ranked(px, pz, same, b0, b1, radius, cols):
    """Rows b0..b1 of a cluster: the RPs ``cols`` by (distance, index), the
    RPs at other antennas among them and those within ``radius``."""
    d = np.hypot(px[b0:b1, None] - px[None, cols], pz[b0:b1, None] - pz[None, cols])
    d[same] = np.inf
    rank = np.argsort(d, axis=1, kind="stable")
    ds = np.take_along_axis(d, rank, axis=1)
    ok = np.isfinite(ds)  # RPs at the same antenna (inf) are never within, even an inf radius
    return cols[rank], ok.sum(axis=1), (ok & (ds <= radius)).sum(axis=1)


def _ranked_grid(grid, same, b0, b1, radius, cols):
    """:func:`_ranked` for antennas on a uniform grid, where the distance of
    two RPs is a function of their offset in steps: each offset's distance
    class (its rank among the grid's distances) times the cluster size plus
    the RP index is a unique integer key in (distance, index) order, and
    integer keys sort faster than a stable float sort (module notes).  Distances
    come from the integer offsets, so equal distances tie exactly wherever
    the array is (the float differences of coordinates broke such ties by
    rounding, so the lists moved with the array)."""
    ix, iz, cls_table, keys, sx = grid
    c, nz = ix.size, cls_table.shape[1]
    ncls = keys.size
    flat = np.abs(ix[b0:b1, None] - ix[None, cols]) * nz + np.abs(iz[b0:b1, None] - iz[None, cols])
    cls = cls_table.ravel()[flat]
    cls[same] = ncls  # after every distance
    within = (cls < np.searchsorted(keys, (radius / sx) ** 2 * (1 + 1e-12), side="right")).sum(
        axis=1
    )
    # int32 wherever the keys fit: they sort faster than int64
    kt = np.int32 if (ncls + 1) * c < 2**31 else np.int64
    key = np.sort(cls.astype(kt) * kt(c) + cols.astype(kt)[None, :], axis=1)
    order = key % c
    return order, (key < ncls * c).sum(axis=1), within
