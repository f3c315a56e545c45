"""Float64 NumPy references of every RPM OpenCL kernel.

Each function here has the same signature and returns the same arrays as the
method of the same name on :class:`rpm_cl.rpm.device.DeviceRPM`; tests compare
the two on fresh random inputs.  The maths is documented once, in the kernel
files (``kernels/circles.cl``, ``kernels/score.cl``) and repeated in short here.

Layout shared with the kernels: ``n`` main RPs, each with ``maxc`` candidate
slots; candidate coordinates are ``DIM`` planes of shape ``(n, maxc)`` in the
main RP's local frame (origin at the main antenna).
"""

from __future__ import annotations

import numpy as np

__all__ = ["intersect_circles", "score_candidates", "argmax_candidates", "rpm_circles"]


def intersect_circles(x, r, amp, cstart, ccount, maxc, sigma_x, i0=0, n=None):
    """Intersections of each main RP's circle with the circles of its cluster.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Antenna x coordinate of each RP, m (any common origin).
    r : ndarray, shape (n,)
        RP range, m.
    amp : ndarray, shape (n,)
        RP amplitude |s(q)|, >= 0.
    cstart, ccount : ndarray of int, shape (n,)
        Index of the first RP of each RP's cluster and the cluster size; the
        RPs of a cluster are contiguous.
    maxc : int
        Candidate slots per main RP (>= the largest cluster).
    sigma_x : float
        sigma_x of eq. 6, m.
    i0, n : int
        The main RPs are ``i0 .. i0+n-1`` (a chunk; default all RPs).

    Returns
    -------
    cand : ndarray, shape (2, n, maxc)
        (x, y) of the y > 0 intersection in the main antenna's frame, m; 0 where
        invalid.
    w : ndarray, shape (n, maxc)
        amp_j * exp(-(X_i - X_j)^2 / (2 sigma_x^2)); 0 where invalid.
    valid : ndarray of int8, shape (n, maxc)
        1 where the pair has two distinct real intersections, else 0.
    """
    x = np.asarray(x, np.float64)
    r = np.asarray(r, np.float64)
    amp = np.asarray(amp, np.float64)
    cstart = np.asarray(cstart, np.int64)
    ccount = np.asarray(ccount, np.int64)
    n = x.size - i0 if n is None else n
    js = np.arange(maxc)[None, :]
    i = i0 + np.arange(n)[:, None]
    j = cstart[i] + js
    inrange = js < ccount[i]
    jj = np.where(inrange, j, i)  # any safe index where out of range
    d = x[jj] - x[i]
    ad = np.abs(d)
    s = r[i] + r[jj]
    e = r[i] - r[jj]
    ae = np.abs(e)
    ok = inrange & (jj != i) & (d != 0) & (s - ad > 0) & (ad - ae > 0)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        cx = (e * s + d * d) / (2 * d)
        cy = np.sqrt((s - ad) * (s + ad)) * np.sqrt((ad - ae) * (ad + ae)) / (2 * ad)
        wt = amp[jj] * np.exp(-d * d / (2.0 * sigma_x**2))
    cand = np.zeros((2, n, maxc))
    cand[0] = np.where(ok, cx, 0.0)
    cand[1] = np.where(ok, cy, 0.0)
    w = np.where(ok, wt, 0.0)
    return cand, w, ok.astype(np.int8)


def score_candidates(cand, w, valid, sigma_r):
    """Weighted Gaussian kernel-density score of every candidate (eq. 6/10).

    Parameters
    ----------
    cand : ndarray, shape (DIM, n, maxc)
        Candidate coordinates in each main RP's local frame, m.
    w : ndarray, shape (n, maxc)
        Candidate weights (0 where invalid).
    valid : ndarray, shape (n, maxc)
        Nonzero where the candidate exists.
    sigma_r : float
        sigma_r of eq. 6/10, m.

    Returns
    -------
    score : ndarray, shape (n, maxc)
        sum_c w_c exp(-|p_c - p_l|^2 / (2 sigma_r^2)) for valid l, else -1.
    """
    cand = np.asarray(cand, np.float64)
    w = np.asarray(w, np.float64)
    d2 = np.zeros(cand.shape[1:] + (cand.shape[2],))
    for plane in cand:  # plane: (n, maxc)
        diff = plane[:, None, :] - plane[:, :, None]  # (n, l, c)
        d2 += diff * diff
    acc = np.einsum("nlc,nc->nl", np.exp(-d2 / (2.0 * sigma_r**2)), w)
    return np.where(np.asarray(valid) != 0, acc, -1.0)


def argmax_candidates(score, cand):
    """Best candidate of each main RP.

    Parameters
    ----------
    score : ndarray, shape (n, maxc)
        Scores, negative where the candidate is invalid.
    cand : ndarray, shape (DIM, n, maxc)
        Candidate coordinates, m.

    Returns
    -------
    best : ndarray of int32, shape (n,)
        First index of the largest non-negative score, -1 if none.
    best_score : ndarray, shape (n,)
        That score, -1 if none.
    point : ndarray, shape (DIM, n)
        The chosen candidate's coordinates, 0 where none.
    """
    score = np.asarray(score, np.float64)
    cand = np.asarray(cand, np.float64)
    n, maxc = score.shape
    if maxc == 0:
        return np.full(n, -1, np.int32), np.full(n, -1.0), np.zeros((cand.shape[0], n))
    masked = np.where(score >= 0, score, -np.inf)
    best = np.argmax(masked, axis=1).astype(np.int32)
    best_score = masked[np.arange(n), best]
    none = ~np.isfinite(best_score)
    best[none] = -1
    best_score[none] = -1.0
    point = cand[:, np.arange(n), np.maximum(best, 0)]
    point[:, none] = 0.0
    return best, best_score, point


def rpm_circles(x, r, amp, cstart, ccount, maxc, sigma_x, sigma_r, i0=0, n=None):
    """Whole 2-D RPM step: intersect, score, argmax (eq. 6).

    Parameters are those of :func:`intersect_circles` plus ``sigma_r`` (m).

    Returns
    -------
    best, best_score, point
        As :func:`argmax_candidates`; ``point`` is in each main antenna's
        frame (add ``x`` to its first row for absolute x).
    """
    cand, w, valid = intersect_circles(x, r, amp, cstart, ccount, maxc, sigma_x, i0, n)
    return argmax_candidates(score_candidates(cand, w, valid, sigma_r), cand)
