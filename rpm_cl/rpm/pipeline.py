"""RPM of a set of range points: per cluster, the pair (2-D) or neighbour
(3-D) candidates, their kernel-density scores on the engine, and the 3-D
mean-shift refinement; :func:`rpm_image` runs it all and returns an
:class:`Image`.
"""

from __future__ import annotations

import numpy as np

from ..extract.rangepoints import RangePoints
from ..io.data import InputError
from ..result import Image
from .neighbours import neighbour_lists
from .params import RPMParams
from .reference import MS_DENSITY_T

#: Fewest main RPs of a cluster's sample (:func:`_moving`).
MS_SAMPLE_MIN = 8
#: A cluster whose sample's median move is below ``MS_SAMPLE_TOL * sigma_r``
#: keeps the list's argmax (:func:`_moving`).  Measured per-cluster medians
#: with every cluster stepped (``python benchmarks/meanshift_sample.py``):
#: the human body's 0.20-0.21 sigma_r, noise-free and at 20 dB; phase-rpm's
#: clusters of three spheres below 1e-4 sigma_r on 15 x 15 and up to 0.014
#: sigma_r (90th percentile over clusters) on 64 x 64 in tiles.  A twentieth
#: of the kernel width lies between them with a factor 3.5 to 4 either side.
MS_SAMPLE_TOL = 0.05

__all__ = ["Image", "pair_windows", "rpm_image"]


def _prepare(rps: RangePoints, params: RPMParams):
    """Kept RPs (clusters with enough RPs), re-indexed, amplitudes scaled to 1."""
    cstart, ccount = rps.cluster_bounds()
    idx = np.nonzero(ccount >= params.min_cluster_rps)[0]
    # amplitudes scaled to a maximum of 1: the argmax of eq. 6/10 is unchanged
    # and float32 kernels keep their range whatever the data's scale.
    amp = np.asarray(rps.amp, np.float64)[idx]
    scale = float(amp.max()) if amp.size and amp.max() > 0 else 1.0
    start, count = np.searchsorted(idx, cstart[idx]), ccount[idx]
    return idx, amp / scale, scale, start, count


def pair_windows(x, start, count, cutoff: float):
    """2-D: the sub RPs of each main RP, those of its cluster whose antenna
    lies within ``cutoff`` of its own (``RPMParams.pair_cutoff_2d``).

    Parameters
    ----------
    x : ndarray, shape (N,)
        Antenna x of each RP, m, non-decreasing within each cluster.
    start, count : ndarray, shape (N,)
        Each RP's cluster, as index range ``start .. start + count``.
    cutoff : float
        Largest antenna distance paired, m; inf pairs the whole cluster.

    Returns
    -------
    start, count : ndarray, shape (N,)
        Each RP's window of sub RPs (a sub-range of its cluster).
    """
    start = np.asarray(start, np.int64)
    count = np.asarray(count, np.int64)
    if not np.isfinite(cutoff) or start.size == 0:
        return start, count
    x = np.asarray(x, np.float64)
    # one sorted key over all clusters: cluster rank * span + x
    span = float(x.max() - x.min()) + 4.0 * cutoff + 1.0
    rank = np.cumsum(np.r_[0, np.diff(start) != 0])
    key = rank * span + (x - x.min())
    if np.any(np.diff(key) < 0):  # not sorted by antenna within a cluster: pair them all
        return start, count
    lo = np.maximum(np.searchsorted(key, key - cutoff, "left"), start)
    hi = np.minimum(np.searchsorted(key, key + cutoff, "right"), start + count)
    return lo, hi - lo


def _chunks(total: int, maxc: int, chunk_slots: int, most: int | None = None):
    """(i0, n) runs of ``total`` main RPs of ``maxc`` slots each, at most
    ``chunk_slots`` slots (and ``most`` main RPs) a run."""
    step = max(1, chunk_slots // max(1, maxc))
    if most is not None:
        step = max(1, min(step, most))
    return [(i0, min(step, total - i0)) for i0 in range(0, total, step)]


def rpm_image(rps: RangePoints, params: RPMParams, engine) -> Image:
    """RPM over every cluster of ``rps``: eq. 6 (2-D) or eq. 10-11 (3-D).

    Main RPs run in chunks of at most ``params.chunk_slots`` candidate slots,
    so one large cluster cannot exhaust device memory.

    Parameters
    ----------
    rps : RangePoints
        RPs sorted by cluster; 2-D (linear array) or 3-D (planar array).
    params : RPMParams
    engine : object
        :mod:`rpm_cl.rpm.reference` (float64 NumPy) or a
        :class:`rpm_cl.rpm.DeviceRPM`; anything with ``rpm_circles`` and
        ``rpm_spheres``.

    Returns
    -------
    Image
        Points (M, 2) or (M, 3), m.
    """
    dim = rps.dim
    idx, amp, scale, start, count = _prepare(rps, params)
    if idx.size == 0:
        return Image(np.zeros((0, dim)), np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int64))
    x, r = np.asarray(rps.x, np.float64)[idx], np.asarray(rps.range, np.float64)[idx]
    parts = []
    if dim == 2:
        start, count = pair_windows(x, start, count, params.pair_cutoff_2d * params.sigma_x)
        maxc = int(count.max())
        if maxc > params.max_cluster_rps:
            raise InputError(
                f"a main RP pairs with {maxc} RPs (its cluster's RPs within "
                f"pair_cutoff_2d x sigma_x = {params.pair_cutoff_2d * params.sigma_x:g}"
                f" m), more than max_cluster_rps={params.max_cluster_rps}; lower "
                f"sigma_x or pair_cutoff_2d, or raise the RP or peak thresholds"
            )
        for i0, n in _chunks(idx.size, maxc, params.chunk_slots):
            parts.append(
                engine.rpm_circles(
                    x, r, amp, start, count, maxc, params.sigma_x, params.sigma_r, i0, n
                )
            )
    else:
        z = np.asarray(rps.z, np.float64)[idx]
        ant = np.asarray(rps.antenna)[idx]
        short = _refined(count, params) & _one_per_antenna(ant, start)
        kmax = np.where(
            short, params.meanshift_neighbours or params.max_neighbours, params.max_neighbours
        )
        nbr, nnbr = neighbour_lists(
            x,
            z,
            ant,
            start,
            count,
            params.pair_cutoff * params.sigma_x,
            kmax,
            params.near_neighbours,
        )
        # runs of main RPs with one list length, each scored with its own width
        cuts = np.flatnonzero(np.diff(kmax)) + 1
        narrowed = {}  # width -> the lists cut to it (at most two widths)
        for a, b in zip(np.r_[0, cuts], np.r_[cuts, idx.size]):
            width = int(nnbr[a:b].max())
            if width < 2:  # no pair to intersect: no point
                parts.append((np.full(b - a, -1, np.int32), np.zeros(b - a), np.zeros((3, b - a))))
                continue
            if width not in narrowed:
                narrowed[width] = (np.ascontiguousarray(nbr[:, :width]), np.minimum(nnbr, width))
            sub, nsub = narrowed[width]
            maxc = width * (width - 1) // 2
            for i0, n in _chunks(int(b - a), maxc, params.chunk_slots):
                parts.append(
                    engine.rpm_spheres(
                        x, z, r, amp, sub, nsub, params.sigma_x, params.sigma_r, int(a) + i0, n
                    )
                )
        if parts and params.meanshift_iters > 0:
            parts = _meanshift(parts, x, z, r, amp, start, count, params, engine)
    if not parts:
        return Image(np.zeros((0, dim)), np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int64))
    best = np.concatenate([p[0] for p in parts])
    score = np.concatenate([p[1] for p in parts]).astype(np.float64) * scale
    local = np.concatenate([p[2] for p in parts], axis=1).astype(np.float64)
    ok = best >= 0
    pts = local[:, ok].T.copy()
    pts[:, 0] += x[ok]
    if dim == 3:
        pts[:, 2] += z[ok]
    return Image(pts, np.asarray(rps.cluster)[idx][ok], score[ok], idx[ok])


def _one_per_antenna(antenna, start):
    """Per RP: does its cluster (first RP ``start``) hold at most one RP per
    antenna?"""
    order = np.lexsort((antenna, start))
    a, s = antenna[order], start[order]
    dup = np.zeros(a.size, bool)
    dup[1:] = (a[1:] == a[:-1]) & (s[1:] == s[:-1])
    clash = np.zeros(a.size, bool)
    clash[np.unique(s[dup])] = True  # clusters are indexed by their first RP
    return ~clash[start]


def _refined(count, params: RPMParams):
    """Which main RPs the mean shift refines (their cluster sizes ``count``)."""
    return (np.asarray(count) <= params.meanshift_max_rps) & (params.meanshift_iters > 0)


def _meanshift(parts, x, z, r, amp, start, count, params: RPMParams, engine):
    """3-D: move each chunk's argmax points towards the exhaustive density's
    mode (``RPMParams.meanshift_iters`` steps), all clusters in one launch per
    chunk, and put the point where ``meanshift_point`` says (by default the
    exhaustive argmax among the candidates nearest the mode, see
    :func:`_argmax_near`); the score becomes the exhaustive density there.
    Clusters whose sample does not move (:func:`_moving`) keep the list's
    argmax and its score (the list's eq. 10, not the exhaustive density)."""
    best = np.concatenate([p[0] for p in parts])
    score = np.concatenate([p[1] for p in parts]).astype(np.float64)
    local = np.concatenate([p[2] for p in parts], axis=1).astype(np.float64)
    # main RPs of clusters up to meanshift_max_rps (clusters are contiguous,
    # so these are runs of indices)
    small = np.flatnonzero(_refined(count, params))
    if small.size and params.meanshift_sample > 0:
        small = _moving(small, best, local, x, z, r, amp, start, count, params, engine)
    if small.size == 0:
        return [(best, score, local)]
    for i0, n in _step_chunks(small, count, params, engine):
        sl = slice(i0, i0 + n)
        moved, dens, new = _steps(
            x, z, r, amp, start, count, best[sl], local[:, sl], params, engine, i0, n
        )
        local[:, sl] = np.where(moved, new, local[:, sl])
        score[sl] = np.where(moved, dens, score[sl])
    return [(best, score, local)]


def _step_chunks(mains, count, params: RPMParams, engine):
    """(i0, n) chunks of the main RPs ``mains`` (sorted indices) for the
    steps: runs of consecutive indices, each cut so that the scratch (5 rows
    of the largest cluster per main RP) fits ``chunk_slots`` and the
    engine's candidate store (``meanshift_chunk``)."""
    largest = int(count[mains].max())
    limit = getattr(engine, "meanshift_chunk", None)
    most = None if limit is None else limit(largest)
    runs = np.split(mains, np.flatnonzero(np.diff(mains) > 1) + 1)
    return [
        (int(run[0]) + a, b)
        for run in runs
        for a, b in _chunks(run.size, 5 * largest, params.chunk_slots, most)
    ]


def _steps(x, z, r, amp, start, count, best, local, params: RPMParams, engine, i0, n):
    """The steps of main RPs ``i0 .. i0+n-1`` from their list argmax
    ``local`` (3, n): which of them moved (a valid start, a candidate near
    the mode, a finite point), the exhaustive density there and the new
    point (3, n), main antenna's frame."""
    mode, dens, near, cnt = engine.meanshift_spheres(
        x,
        z,
        r,
        amp,
        start,
        count,
        local,
        params.sigma_x,
        params.sigma_r,
        params.meanshift_iters,
        i0,
        n,
    )
    mode, dens, near = (np.asarray(v, np.float64) for v in (mode, dens, near))
    if params.meanshift_point == "argmax":
        dens, new = _argmax_near(
            mode, near, np.asarray(cnt), engine, x, z, r, amp, start, count, params, i0, n
        )
    elif params.meanshift_point == "sphere":
        norm = np.linalg.norm(mode, axis=0)
        new = mode * (r[i0 : i0 + n] / np.where(norm > 0, norm, 1.0))
    else:
        new = near[:, 0] if params.meanshift_point == "nearest" else mode
    moved = (best >= 0) & (dens > 0) & np.all(np.isfinite(new), axis=0)
    return moved, dens, new


def _moving(mains, best, local, x, z, r, amp, start, count, params: RPMParams, engine):
    """The main RPs of ``mains`` whose clusters the steps move: each
    cluster's steps run first on every ``meanshift_sample``-th of its main
    RPs (at least :data:`MS_SAMPLE_MIN`, evenly spread); where the median
    distance those moved is below ``MS_SAMPLE_TOL * sigma_r``, the list's
    argmax already sits at the exhaustive density's mode and the cluster
    keeps it.  Clusters of fewer than ``4 * MS_SAMPLE_MIN`` main RPs are
    not sampled (the sample would be a quarter of them or more): they take
    the steps.  The sample runs on copies of its main RPs appended after
    the others (a main RP's own sphere is left out of its triplets by its
    position, not its index), so the steps of the clusters that move are
    the ones :func:`_meanshift` runs without a sample."""
    firsts, sizes = np.unique(start[mains], return_counts=True)
    every = int(params.meanshift_sample)
    big = sizes >= 4 * MS_SAMPLE_MIN
    if not big.any():
        return mains
    picks = []
    for f, m in zip(firsts[big], sizes[big]):
        k = max(MS_SAMPLE_MIN, int(np.ceil(m / every)))
        picks.append(int(f) + np.unique(np.round(np.linspace(0, m - 1, k)).astype(np.int64)))
    sample = np.concatenate(picks)
    total = x.size
    ext = [np.concatenate([a, a[sample]]) for a in (x, z, r, amp, start, count)]
    ext_best, ext_local = best[sample], local[:, sample]
    move = np.full(sample.size, np.nan)
    for i0, n in _step_chunks(total + np.arange(sample.size), ext[5], params, engine):
        j = slice(i0 - total, i0 - total + n)
        moved, _, new = _steps(*ext, ext_best[j], ext_local[:, j], params, engine, i0, n)
        move[j] = np.where(moved, np.linalg.norm(new - ext_local[:, j], axis=0), np.nan)
    # per sampled cluster (by its first RP), the median move of its sample
    owner = np.repeat(firsts[big], [p.size for p in picks])
    ok = np.isfinite(move)
    still = [
        f
        for f in firsts[big]
        if np.any(ok & (owner == f))
        and np.median(move[ok & (owner == f)]) < MS_SAMPLE_TOL * params.sigma_r
    ]
    return mains[~np.isin(start[mains], still)] if still else mains


def _argmax_near(mode, near, cnt, engine, x, z, r, amp, start, count, params, i0, n):
    """The exhaustive argmax among the candidates nearest to the mode
    (``meanshift_point="argmax"``): of the ``cnt`` candidates the mean shift
    returned per main RP (nearest to the start of its last step), the MS_DENSITY_T
    nearest to the mode are scored with the exhaustive density and the best
    is taken.  Returns its density (n,) (0 where there is no candidate) and
    the point (3, n)."""
    slot = np.arange(near.shape[1])[:, None]
    d2 = np.where(slot < cnt, np.sum((near - mode[:, None]) ** 2, axis=0), np.inf)
    pick = np.argsort(d2, axis=0, kind="stable")[:MS_DENSITY_T]  # (T, n)
    cols = np.arange(n)
    targets = near[:, pick, cols]  # (3, T, n)
    f = np.asarray(
        engine.density_spheres(
            x, z, r, amp, start, count, targets, params.sigma_x, params.sigma_r, i0, n, reuse=True
        ),
        np.float64,
    )
    f = np.where(np.isfinite(d2[pick, cols]), f, -np.inf)
    b = np.argmax(f, axis=0)
    return np.where(cnt > 0, f[b, cols], 0.0), targets[:, b, cols]
