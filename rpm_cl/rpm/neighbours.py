"""Sub-RP lists for 3-D RPM: which RPs a main RP is paired with.

The weight g of eq. 11 decays as exp(-D^2 / 2 sigma_D^2) with the distance D
between antennas, so a triplet whose two sub RPs are both far from the main
antenna contributes (almost) nothing to any score.  Each main RP is therefore
paired only with RPs of its cluster at other antennas within ``radius``
(a multiple of sigma_D), the nearest ``kmax`` at most.  The triplet
candidates of a main RP are the pairs of its list (see
:func:`rpm_cl.rpm.reference.pair_table`).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["neighbour_lists"]


def neighbour_lists(x, z, antenna, cstart, ccount, radius: float, kmax: int):
    """Nearest other-antenna RPs of the same cluster within ``radius``.

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
        Pairing radius in the array plane, m (inf: the whole cluster).
    kmax : int
        Longest list kept (the nearest RPs first), >= 2.

    Returns
    -------
    nbr : ndarray of int32, shape (N, K)
        Sub-RP indices, nearest first; K = the longest list (<= kmax); -1 pads.
    nnbr : ndarray of int32, shape (N,)
        List lengths.
    """
    x = np.asarray(x, np.float64)
    z = np.asarray(z, np.float64)
    antenna = np.asarray(antenna)
    n = x.size
    cstart = np.asarray(cstart, np.int64)
    ccount = np.asarray(ccount, np.int64)
    rows, counts = [], np.zeros(n, np.int32)
    width = 0
    for s in np.unique(cstart):
        c = int(ccount[s])
        sl = slice(s, s + c)
        pos = np.stack([x[sl], z[sl]], axis=1)
        ant = antenna[sl]
        mult = int(np.max(np.unique(ant, return_counts=True)[1]))
        kq = min(c, kmax + mult)
        if kq < 2:
            rows.append((s, np.full((c, 0), -1, np.int64)))
            continue
        d, idx = cKDTree(pos).query(pos, k=kq, distance_upper_bound=radius)
        found = np.isfinite(d)
        idx_safe = np.where(found, idx, 0)
        ok = found & (ant[idx_safe] != ant[:, None])
        order = np.argsort(~ok, axis=1, kind="stable")[:, :kmax]
        keep = np.take_along_axis(ok, order, axis=1)
        lists = np.where(keep, np.take_along_axis(idx_safe, order, axis=1) + s, -1)
        counts[sl] = keep.sum(axis=1)
        width = max(width, int(counts[sl].max(initial=0)))
        rows.append((s, lists))
    nbr = np.full((n, width), -1, np.int32)
    for s, lists in rows:
        w = min(width, lists.shape[1])
        nbr[s:s + lists.shape[0], :w] = lists[:, :w]
    return nbr, counts
