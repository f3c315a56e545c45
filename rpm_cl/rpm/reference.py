"""Float64 NumPy references of every RPM OpenCL kernel.

Each function here has the same signature and returns the same arrays as the
method of the same name on :class:`rpm_cl.rpm.device.DeviceRPM`; tests compare
the two on fresh random inputs.  The maths is documented once, in the kernel
files (``kernels/circles.cl``, ``kernels/spheres.cl``, ``kernels/score.cl``,
``kernels/meanshift.cl``) and repeated in short here.

Layout shared with the kernels: ``n`` main RPs, each with ``maxc`` candidate
slots; candidate coordinates are ``DIM`` planes of shape ``(n, maxc)`` in the
main RP's local frame (origin at the main antenna).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "EPS_DET",
    "MS_CUTOFF",
    "MS_DENSITY_T",
    "MS_NEAR_K",
    "MS_NEWTON_PIVOT",
    "MS_PAIR_CUTOFF",
    "MS_TOL",
    "argmax_candidates",
    "density_spheres",
    "intersect_circles",
    "intersect_spheres",
    "meanshift_spheres",
    "pair_table",
    "rpm_circles",
    "rpm_spheres",
    "score_candidates",
]

#: Triplets whose antennas are this close to collinear (|det| relative to
#: |a_j| |a_k|, the sine of the angle at the main antenna) are skipped: below
#: it, float32 rounding of det is comparable to det itself.
EPS_DET = 1e-4

#: Mean shift (:func:`meanshift_spheres`): candidates farther than
#: ``MS_CUTOFF * sigma_r`` from the current point do not enter the sums (their
#: kernel value is below exp(-MS_CUTOFF^2 / 2) = 3.4e-4 of a coincident one).
MS_CUTOFF = 4.0
#: Mean shift: pairs whose two sub RPs both lie farther than ``MS_PAIR_CUTOFF
#: * sigma_D`` from the main antenna are skipped (g of eq. 11 below
#: 2 exp(-MS_PAIR_CUTOFF^2 / 2) = 6.7e-4 of the largest amplitude, 1).
MS_PAIR_CUTOFF = 4.0
#: Mean shift stops when a step is shorter than ``MS_TOL * sigma_r`` (0.5 mm
#: at the body's 50 mm: far below the 10 mm accuracy figure).
MS_TOL = 1e-2
#: Mean shift: the step is Newton's on log f where every Cholesky pivot of
#: I - V / sigma_r^2 (V the kernel-weighted covariance of the candidates about
#: their weighted mean) is at least this, i.e. where log f is concave enough
#: for the Newton step to be at most 1 / MS_NEWTON_PIVOT times the mean-shift
#: step; else the mean-shift step (``kernels/meanshift.cl``, newton_step).
MS_NEWTON_PIVOT = 0.1
#: Mean shift: how many of the candidates nearest to the start of the last
#: step are returned (the exhaustive argmax is sought among them).
MS_NEAR_K = 16
#: :func:`density_spheres`: most points per main RP in one call.
MS_DENSITY_T = 4


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


def pair_table(kmax: int):
    """Slot -> pair of neighbour-list positions, colex order.

    Parameters
    ----------
    kmax : int
        Length of the neighbour lists.

    Returns
    -------
    pa, pb : ndarray of int32, shape (kmax*(kmax-1)//2,)
        ``pa[s] < pb[s]``; the first ``m*(m-1)//2`` slots are exactly the
        pairs of positions ``< m``.
    """
    kmax = int(kmax)
    b = np.repeat(np.arange(kmax), np.arange(kmax))
    start = b * (b - 1) // 2
    a = np.arange(b.size) - start
    return a.astype(np.int32), b.astype(np.int32)


def intersect_spheres(x, z, r, amp, nbr, nnbr, sigma_d, i0=0, n=None):
    """Intersections of each main RP's sphere with pairs of its sub RPs' spheres.

    Parameters
    ----------
    x, z : ndarray, shape (N,)
        Antenna coordinates of each RP, m (any common origin).
    r : ndarray, shape (N,)
        RP ranges, m.
    amp : ndarray, shape (N,)
        RP amplitudes |s(q)|, >= 0.
    nbr : ndarray of int, shape (N, kmax)
        Sub-RP indices of each RP (same cluster, other antennas); entries at
        positions >= ``nnbr`` are ignored.
    nnbr : ndarray of int, shape (N,)
        Length of each list, <= kmax.
    sigma_d : float
        sigma_D of eq. 11, m.
    i0, n : int
        The main RPs are ``i0 .. i0+n-1`` (a chunk; default all RPs).

    Returns
    -------
    cand : ndarray, shape (3, n, maxc), maxc = kmax*(kmax-1)//2
        (x, y, z) of the y > 0 intersection in the main antenna's frame, m; 0
        where invalid.  Slot order: :func:`pair_table`.
    w : ndarray, shape (n, maxc)
        The weight g of eq. 11; 0 where invalid.
    valid : ndarray of int8, shape (n, maxc)
        1 where the triplet has a real, non-tangent intersection and
        non-collinear antennas (see :data:`EPS_DET`), else 0.
    """
    x, z, r, amp = (np.asarray(v, np.float64) for v in (x, z, r, amp))
    nbr = np.asarray(nbr, np.int64).reshape(x.size, -1)
    nnbr = np.asarray(nnbr, np.int64)
    kmax = nbr.shape[1]
    n = x.size - i0 if n is None else n
    pa, pb = pair_table(kmax)
    i = i0 + np.arange(n)[:, None]
    inrange = pb[None, :] < nnbr[i]
    j = np.where(inrange, nbr[i, pa[None, :]], i)
    k = np.where(inrange, nbr[i, pb[None, :]], i)
    px, py, pz, ok, g, _ = _triplet(x, z, r, amp, i, j, k, sigma_d)
    ok &= inrange
    cand = np.zeros((3, n, pa.size))
    cand[0] = np.where(ok, px, 0.0)
    cand[1] = np.where(ok, py, 0.0)
    cand[2] = np.where(ok, pz, 0.0)
    return cand, np.where(ok, g, 0.0), ok.astype(np.int8)


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


def rpm_spheres(x, z, r, amp, nbr, nnbr, sigma_d, sigma_r, i0=0, n=None):
    """Whole 3-D RPM step: intersect, score, argmax (eq. 10-11).

    Parameters are those of :func:`intersect_spheres` plus ``sigma_r`` (m).

    Returns
    -------
    best, best_score, point
        As :func:`argmax_candidates`; ``point`` (3, n) is in each main
        antenna's frame (add ``x`` and ``z`` for absolute coordinates).
    """
    cand, w, valid = intersect_spheres(x, z, r, amp, nbr, nnbr, sigma_d, i0, n)
    return argmax_candidates(score_candidates(cand, w, valid, sigma_r), cand)


def _cluster_triplets(x, z, r, amp, lo, hi, i, sigma_d):
    """Every valid triplet (i, j, k), j < k, of the cluster ``lo .. hi``: the
    candidates (P, 3) in the main antenna's frame and their weights g (P,),
    pairs of two far sub RPs (see :data:`MS_PAIR_CUTOFF`) left out."""
    js, ks = np.triu_indices(hi - lo, 1)
    j, k = lo + js, lo + ks
    px, py, pz, ok, g, (nj2, nk2) = _triplet(x, z, r, amp, i, j, k, sigma_d)
    far2 = (MS_PAIR_CUTOFF * sigma_d) ** 2
    ok &= (nj2 <= far2) | (nk2 <= far2)
    return np.stack([px[ok], py[ok], pz[ok]], axis=1), g[ok]


def _triplet(x, z, r, amp, i, j, k, sigma_d):
    """The y > 0 intersection of the spheres of RPs i, j, k (index arrays
    that broadcast) in i's antenna frame, the maths of kernels/triplet.h
    (module notes of kernels/spheres.cl), and the weight g of eq. 11.

    Returns px, py, pz (m), ok (False where the antennas are collinear or
    coincident, or there is no real, non-tangent intersection; the
    coordinates there are meaningless), g, and (|a_j|^2, |a_k|^2) (m^2).
    """
    ajx, ajz, akx, akz = x[j] - x[i], z[j] - z[i], x[k] - x[i], z[k] - z[i]
    nj2, nk2 = ajx**2 + ajz**2, akx**2 + akz**2
    det = ajx * akz - ajz * akx
    ri = r[i]
    ok = np.abs(det) > EPS_DET * np.sqrt(nj2) * np.sqrt(nk2)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        bj = 0.5 * ((ri - r[j]) * (ri + r[j]) + nj2)
        bk = 0.5 * ((ri - r[k]) * (ri + r[k]) + nk2)
        px = (bj * akz - bk * ajz) / det
        pz = (ajx * bk - akx * bj) / det
        rho = np.sqrt(px**2 + pz**2)
        ok &= ri - rho > 0
        py = np.sqrt((ri - rho) * (ri + rho))
        inv = 1.0 / (2.0 * sigma_d**2)
        g = amp[j] * np.exp(-nj2 * inv) + amp[k] * np.exp(-nk2 * inv)
    return px, py, pz, ok, g, (nj2, nk2)


def _shift_sums(c, g, p, sigma_r):
    """Kernel sums at ``p`` over the candidates within MS_CUTOFF sigma_r:
    (s = sum w G, m1 = sum w G d, m2 = sum w G d d^T (3, 3), d = c - p, the
    MS_NEAR_K nearest candidates (k, 3), nearest first, ties in pair order)."""
    d = c - p
    d2 = np.sum(d * d, axis=1)
    inside = d2 <= (MS_CUTOFF * sigma_r) ** 2
    wg = np.where(inside, g * np.exp(-d2 / (2.0 * sigma_r**2)), 0.0)
    d = np.where(inside[:, None], d, 0.0)
    order = np.argsort(np.where(inside, d2, np.inf), kind="stable")[:MS_NEAR_K]
    return float(wg.sum()), wg @ d, (d * wg[:, None]).T @ d, c[order[inside[order]]]


def _newton_step(s, m1, m2, sigma_r):
    """The step of ``kernels/meanshift.cl``'s newton_step, written the same
    way (Cholesky with the MS_NEWTON_PIVOT test), from the sums at p."""
    b = m1 / s
    a = np.eye(3) - (m2 / s - np.outer(b, b)) / sigma_r**2
    if not a[0, 0] >= MS_NEWTON_PIVOT:
        return b
    l00 = np.sqrt(a[0, 0])
    l10, l20 = a[0, 1] / l00, a[0, 2] / l00
    p11 = a[1, 1] - l10 * l10
    if not p11 >= MS_NEWTON_PIVOT:
        return b
    l11 = np.sqrt(p11)
    l21 = (a[1, 2] - l20 * l10) / l11
    p22 = a[2, 2] - l20 * l20 - l21 * l21
    if not p22 >= MS_NEWTON_PIVOT:
        return b
    low = np.array([[l00, 0, 0], [l10, l11, 0], [l20, l21, np.sqrt(p22)]])
    return np.linalg.solve(low.T, np.linalg.solve(low, b))


def meanshift_spheres(x, z, r, amp, cstart, ccount, point, sigma_d, sigma_r, iters, i0=0, n=None):
    """Mean shift of each main RP's point to a mode of the exhaustive eq. 10 density.

    The density of a point p for main RP i is
    ``f(p) = sum_{j<k} g_jk exp(-|p - c_jk|^2 / (2 sigma_r^2))`` over every
    valid triplet (i, j, k) of i's cluster (:func:`intersect_spheres`' maths
    and validity, with every pair of the cluster instead of a list), c_jk the
    intersection and g_jk its eq. 11 weight; the exhaustive RPM picks the
    candidate with the largest f.  Starting from ``point``, each step moves p
    by Newton's step on log f where log f is concave enough there (see
    :data:`MS_NEWTON_PIVOT`), else by the mean-shift step ``sum g G (c - p) /
    sum g G`` (G the Gaussian); at most ``iters`` steps, fewer when a step is
    shorter than ``MS_TOL * sigma_r`` or no candidate is near.  Truncations: candidates farther than
    ``MS_CUTOFF * sigma_r`` from p, and pairs of two sub RPs farther than
    ``MS_PAIR_CUTOFF * sigma_d`` from the main antenna, are left out.

    Parameters
    ----------
    x, z, r, amp : ndarray, shape (N,)
        Antenna coordinates (m), ranges (m) and amplitudes (>= 0) of the RPs.
    cstart, ccount : ndarray of int, shape (N,)
        First index and size of each RP's cluster (clusters contiguous).
    point : ndarray, shape (3, n)
        Start points of main RPs ``i0 .. i0+n-1`` in each main antenna's
        frame, m (the argmax of :func:`rpm_spheres`).
    sigma_d, sigma_r : float
        sigma_D of eq. 11 and sigma_r of eq. 10, m.
    iters : int
        Most mean-shift steps, >= 0 (0: ``point`` returned unchanged).
    i0, n : int
        The main RPs are ``i0 .. i0+n-1`` (a chunk; default all RPs).

    Returns
    -------
    mode : ndarray, shape (3, n)
        The point after the last step, m, main antenna's frame.
    density : ndarray, shape (n,)
        f (truncated as above) at the last point evaluated, the start of the
        last step (within ``MS_TOL * sigma_r`` of the mode when the steps
        converged): no extra pass; 0 where no candidate is within the cutoff
        or ``iters`` is 0.
    nearest : ndarray, shape (3, MS_NEAR_K, n)
        The candidates within the cutoff nearest to that point, m, nearest
        first (equal distances in pair order, j then k); the point itself in
        the slots beyond ``count``.
    count : ndarray of int32, shape (n,)
        How many of the ``nearest`` slots hold candidates.
    """
    x, z, r, amp = (np.asarray(v, np.float64) for v in (x, z, r, amp))
    cstart = np.asarray(cstart, np.int64)
    ccount = np.asarray(ccount, np.int64)
    n = x.size - i0 if n is None else n
    mode = np.array(point, np.float64).reshape(3, n)
    density = np.zeros(n)
    nearest = np.repeat(mode[:, None, :], MS_NEAR_K, axis=1)
    count = np.zeros(n, np.int32)
    tol2 = (MS_TOL * sigma_r) ** 2
    for il in range(n):
        i = i0 + il
        c, g = _cluster_triplets(x, z, r, amp, cstart[i], cstart[i] + ccount[i], i, sigma_d)
        p = mode[:, il].copy()
        s, near = 0.0, np.zeros((0, 3))
        for _ in range(int(iters)):
            start = p.copy()
            s, m1, m2, near = _shift_sums(c, g, p, sigma_r)
            nearest[:, :, il] = start[:, None]
            if not s > 0:
                break
            step = _newton_step(s, m1, m2, sigma_r)
            p = p + step
            if np.sum(step**2) <= tol2:
                break
        mode[:, il], density[il] = p, s
        nearest[:, : len(near), il] = near.T
        count[il] = len(near)
    return mode, density, nearest, count


def density_spheres(
    x, z, r, amp, cstart, ccount, point, sigma_d, sigma_r, i0=0, n=None, reuse=False
):
    """The exhaustive density f of :func:`meanshift_spheres` at a few nearby
    points per main RP (the candidates nearest to its mode, the largest f of
    which is the exhaustive argmax).

    Truncations: those of :func:`meanshift_spheres`, with the candidates
    within ``MS_CUTOFF * sigma_r`` of each main RP's *first* point counting
    for all of its points.  The kernel sums exp(-|c - t_u|^2 / 2 sigma_r^2)
    as the first point's Gaussian times a series (``kernels/meanshift.cl``):
    it agrees with this to 5e-7 relative while the points lie within
    sigma_r / 10 of the first.

    Parameters
    ----------
    x, z, r, amp, cstart, ccount, sigma_d, sigma_r, i0, n
        As :func:`meanshift_spheres`.
    point : ndarray, shape (3, nt, n)
        1 <= nt <= MS_DENSITY_T points per main RP, each main antenna's frame, m.
    reuse : bool
        The device engine's hint that the last mean shift ran on the same
        chunk (its stored candidates are read); the same density either way.

    Returns
    -------
    density : ndarray, shape (nt, n)
        f at each point.
    """
    x, z, r, amp = (np.asarray(v, np.float64) for v in (x, z, r, amp))
    cstart = np.asarray(cstart, np.int64)
    ccount = np.asarray(ccount, np.int64)
    n = x.size - i0 if n is None else n
    point = np.asarray(point, np.float64).reshape(3, -1, n)
    out = np.zeros(point.shape[1:])
    for il in range(n):
        i = i0 + il
        c, g = _cluster_triplets(x, z, r, amp, cstart[i], cstart[i] + ccount[i], i, sigma_d)
        t = point[:, :, il].T  # (nt, 3)
        inside = np.sum((c - t[0]) ** 2, axis=1) <= (MS_CUTOFF * sigma_r) ** 2
        d2 = np.sum((c[inside, None, :] - t[None]) ** 2, axis=2)  # (candidates, nt)
        out[:, il] = g[inside] @ np.exp(-d2 / (2.0 * sigma_r**2))
    return out
