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
  (``benchmarks/RESULTS.md``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["neighbour_lists"]

_BLOCK = 256  # main RPs per block of the distance sort (memory: block x cluster)


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
    kmax : int
        Longest list, >= 2.
    near : int or None
        How many of the list are the nearest RPs (within ``radius``); the rest
        are spread evenly by distance rank over the cluster's remaining RPs.
        None: all ``kmax`` nearest (within ``radius``).

    Returns
    -------
    nbr : ndarray of int32, shape (N, K)
        Sub-RP indices, the nearest first; K = the longest list (<= kmax);
        -1 pads.
    nnbr : ndarray of int32, shape (N,)
        List lengths.
    """
    x = np.asarray(x, np.float64)
    z = np.asarray(z, np.float64)
    antenna = np.asarray(antenna)
    n = x.size
    kmax = int(kmax)
    n_near = kmax if near is None else max(0, min(int(near), kmax))
    n_far = kmax - n_near
    cstart = np.asarray(cstart, np.int64)
    ccount = np.asarray(ccount, np.int64)
    nbr = np.full((n, kmax), -1, np.int32)
    counts = np.zeros(n, np.int32)
    for s in np.unique(cstart):
        c = int(ccount[s])
        px, pz, ant = x[s:s + c], z[s:s + c], antenna[s:s + c]
        for b0 in range(0, c, _BLOCK):
            b1 = min(c, b0 + _BLOCK)
            d = np.hypot(px[b0:b1, None] - px[None, :], pz[b0:b1, None] - pz[None, :])
            d[ant[b0:b1, None] == ant[None, :]] = np.inf  # itself and its antenna
            order = np.argsort(d, axis=1, kind="stable")
            ds = np.take_along_axis(d, order, axis=1)
            eligible = np.isfinite(ds).sum(axis=1)  # per row, sorted first
            within = (ds <= radius).sum(axis=1)
            t = np.minimum(n_near, within)  # nearest taken
            rows = np.arange(b1 - b0)
            lists = np.full((b1 - b0, kmax), -1, np.int64)
            cols = np.arange(n_near)[None, :]
            take = cols < t[:, None]
            lists[:, :n_near] = np.where(take, order[:, :n_near] if n_near else 0, -1)
            if n_far:
                # the remaining kmax - t slots: ranks spread evenly over
                # t .. eligible-1 (duplicates dropped when fewer remain)
                f = kmax - t
                span = np.maximum(eligible - t, 0)
                j = np.arange(kmax)[None, :]
                frac = j / np.maximum(f - 1, 1)[:, None]
                pos = t[:, None] + np.round(frac * np.maximum(span - 1, 0)[:, None]).astype(np.int64)
                ok = (j < f[:, None]) & (span[:, None] > 0)
                dup = np.zeros_like(ok)
                dup[:, 1:] = pos[:, 1:] == pos[:, :-1]
                ok &= ~dup
                far = np.where(ok, order[rows[:, None], np.minimum(pos, c - 1)], -1)
                lists = np.concatenate([lists[:, :n_near], far], axis=1)
            # compact: valid entries first, in order
            valid = lists >= 0
            comp = np.argsort(~valid, axis=1, kind="stable")
            lists = np.take_along_axis(lists, comp, axis=1)[:, :kmax]
            cnt = np.minimum(valid.sum(axis=1), kmax)
            lists = np.where(np.arange(kmax)[None, :] < cnt[:, None], lists + s, -1)
            nbr[s + b0:s + b1] = lists
            counts[s + b0:s + b1] = cnt
    width = int(counts.max(initial=0))
    return nbr[:, :width].copy(), counts
