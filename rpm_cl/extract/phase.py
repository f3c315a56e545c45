"""Phase-aided range points: each echo's carrier phase refines its range.

Why
---
Range-only RPM places a scattering centre where the range circles (spheres)
of neighbouring antennas cross, and the crossing moves along the circle by
about ``delta * R / b`` for a range error ``delta`` over a baseline ``b``.
With a narrow band (0.2 GHz: a range resolution of 0.75 m) ``delta`` is a
few cm at 20-30 dB and the points slide tens of mm along their circles.  But
each decomposed echo also carries its carrier phase ``-2 k_c R_t(X)`` (the
range-compressed signal of an echo at ``R_t`` is ``a exp(-j 2 k_c R_t)``
times a real envelope, :mod:`rpm_cl.simulate`), which measures the *change*
of the range from antenna to antenna to a small fraction of a wavelength:
at 20 dB a phase error of 0.1 rad is 0.04 mm of range at 20 GHz.

What is done
------------
Per cluster of a k-space decomposition (one echo per antenna and direction,
:mod:`rpm_cl.extract.kspace`):

1. *Tracks.*  The cluster's RPs are joined into tracks: RPs at neighbouring
   antennas (along x, and along z for planar arrays) whose envelope ranges
   differ by less than :data:`TRACK_GAP` range resolutions from what the
   cluster's direction predicts.  Each connected set of RPs is one track (one
   echo followed across the array).
2. *Unwrapping.*  Along each track the phase is unwrapped from the strongest
   RP outwards over a maximum spanning tree of the amplitudes (quality-guided
   unwrapping: a weak, noisy RP is reached last and cannot break the path to
   the others).  Each step adds the wrapped difference of the phases after
   the cluster's wavefront is taken out (:func:`_wavefront`: the spherical
   wave of the point at the cluster's range in its direction ``k``), which
   keeps every step well inside +-pi: the window of the decomposition holds
   wavenumbers within half its period of the centre, and the curvature of a
   near target's wavefront, which a plane wave ``exp(j k . X)`` would leave
   in, turns by 4 rad per antenna at the ends of 21 antennas at 20 mm for a
   point 0.8 m away (whole cycles slipped: RPs 7 and 15 mm off).
3. *Relative ranges.*  ``r_phase(X) = -phi(X) / (2 k_c)``, the wavefront
   added back: the range walk across the track, exact up to one constant.
   Where the array is coarser than a quarter wavelength the cluster's k is
   ambiguous by ``2 pi / d`` per axis.  The walk starts from the alias the
   decomposition's range-walk alignment chose (``-2 k_c u``, where it ran;
   else the window's centre), and every alias that is a physical direction
   is tried (up to :data:`ALIASES_AXIS` per axis): on 20 mm at 20 GHz a
   point at 35-65 degrees lies two or three aliases from the principal
   one.  The alias whose range walk best fits the envelope ranges
   (weighted least squares) is taken, but on an array of half a wavelength
   or finer (where the starting alias spans +-30 degrees or more) in place
   of the starting alias only where it leaves at most :data:`ALIAS_GAIN` of
   the starting one's misfit: the other echoes of a resolution cell bend the envelopes
   too, and where the aliases' walks differ by a fraction of a resolution
   the two misfits come out alike (on the plane-wave path, 32 antennas at
   half a wavelength, 6 cm at 77 GHz, with three points in one 0.25 GHz
   cell: the alias of the 15-degree point fits at 0.73 of the starting
   one's misfit, and drawn there it lies at -48 degrees).  On a coarser
   array the starting alias is one narrow band of directions among several,
   and the least misfit decides.  A lone steep target's envelope fits its
   alias exactly.  Where another alias wins, the track is unwrapped again
   after that alias's own wavefront (its curvature differs).
4. *Absolute range.*  A first constant is the amplitude-weighted mean of
   ``r_envelope - r_phase`` over the track (whatever the scatterer's own
   reflection phase is, it cancels).  Then the data's own range profiles
   are summed coherently along the track's walk and the constant moved to
   the peak of that sum (:func:`_coherent_level`): the envelope ranges of a
   decomposed echo are biased by the other echoes in its resolution cell
   that the k-space window lets through, while the coherent sum along this
   echo's phase history cancels them (gprMax fixture, 0.25 GHz at 4 GHz:
   70 % -> 96 % of the points within 50 mm, median 27.5 -> 7.6 mm; at 20 dB
   in-band the two constants are equally noisy, docs/robustness.md).

The refined ranges then go through the same RPM (eq. 6/10) as the envelope
ranges: the circles of neighbouring antennas now cross where the echo's
wavefront says, and the Gaussian kernel density picks the consistent
crossings.  RPs that no track of at least :data:`MIN_TRACK` RPs holds keep
their envelope range.

Clusters of the near-field decomposition (:mod:`rpm_cl.extract.nearfield`)
carry the phase of their fitted spherical wave, not a measured one: there is
nothing to unwrap, but the fit itself is the phase information.  Its centre
``p`` (polished by least squares over every antenna and gate, the phase
curvature pinning it) gives the range walk ``|X - p|`` exactly where a
point or a circle about ``p`` echoes, and the envelope ranges give the one
constant (their amplitude-weighted mean offset from the walk: a circle's
radius, 0 for a point; RPs more than :data:`TRACK_GAP` resolutions from the
weighted median offset, stray peaks of the cluster's gates, keep their own
range and take no part).  :func:`spherical_ranges` puts each cluster's RPs
on that walk.  Where the array is coarser than a quarter wavelength the
search's centre ``(u, r)`` has aliases at ``v = u + n lambda / (2 d)`` and
the range ``r (1 - v^2) / (1 - u^2)`` that keeps the wave's curvature, and
where the array is short against the range their spherical waves agree on
every antenna (48 antennas at half a wavelength, a point 2.9 m away at -29.6
degrees and its alias at +30.4: to 1e-3), so the fit cannot tell them
apart; their range walks run opposite ways.  Among the aliases whose waves
correlate with the search's by at least :data:`ALIAS_CORRELATION` over the
array, the one whose walk fits the envelope ranges best replaces the
search's where it leaves less than :data:`ALIAS_GAIN` of its misfit, on
any pitch (the plane-wave path, step 3, asks that only of arrays of half a
wavelength or finer; :func:`_spherical_alias`, each RP's misfit at most a
track's gap squared).  Where the curvature differs more, the fit tells
them apart, and the envelope, bent by the other echoes of its resolution
cell, is not asked (on the paper's sparse scene at 20 dB a cluster's
envelope preferred an alias whose wave correlated 0.59 with the search's,
and asked, it took the cluster onto another target).  The envelope ranges
of the sparse array's clusters wander a few mm from antenna to antenna already at 40 dB (the envelope polynomial
follows noise), enough to tilt the range walk and slide the points tens of
mm along their circles: on twenty random layouts of the paper's sparse
array the mean share of points within 50 mm is 0.975 against 0.673 at
30 dB, 0.731 against 0.183 at 20 dB (``python benchmarks/sparse_phase.py``).
The coherent level of step 4 is not taken: over an array of half a
wavelength or coarser the other targets' aliases add into the coherent sum
(8-16 mm off on the paper's sparse scene noise-free), while the joint fit
has already taken them out of each cluster's envelope (docs/decisions.md).
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, replace

import numpy as np

from ..io.data import RadarData
from .rangepoints import RangePoints

__all__ = ["MIN_TRACK", "TRACK_GAP", "PhaseParams", "phase_ranges", "spherical_ranges", "tracks"]

#: Two RPs at neighbouring antennas belong to one track when their envelope
#: ranges differ from the cluster direction's prediction by less than this
#: many range resolutions (c / 2B).  An echo's envelope moves by at most a
#: pitch between neighbours, far less than a resolution in the narrow-band
#: case; two echoes of one cluster (a direction) are separated in range by
#: more than a resolution, else the envelope would not show two peaks.
TRACK_GAP = 0.5
#: On an array of half a wavelength or finer, another alias of a cluster's k
#: replaces the starting one only where the envelope ranges' misfit to its
#: walk is at most this fraction of their misfit to the starting walk
#: (module notes, step 3).
ALIAS_GAIN = 0.25
#: A near-field cluster's alias is weighed against the search's direction
#: only where their spherical waves correlate at least this much over the
#: array (|a^H b| / N; module notes, the near-field clusters).
ALIAS_CORRELATION = 0.9
#: Most aliases of a cluster's k tried along an array axis (module notes,
#: step 3): every physical one up to a pitch of 8 wavelengths.
ALIASES_AXIS = 33
#: Fewest RPs in a track whose ranges the phase refines (a range walk needs
#: two, a check of it three).
MIN_TRACK = 3


@dataclass(frozen=True)
class PhaseParams:
    """Settings of the phase refinement (module notes).

    Attributes
    ----------
    track_gap : float
        :data:`TRACK_GAP`, range resolutions (> 0).
    min_track : int
        :data:`MIN_TRACK`, RPs (>= 2).
    coherent_level : bool
        Take each track's constant from the coherent sum of the range
        profiles along its walk (module notes, step 4) rather than from the
        mean of its envelope ranges.
    """

    track_gap: float = TRACK_GAP
    min_track: int = MIN_TRACK
    coherent_level: bool = True

    def __post_init__(self):
        from ..io.data import InputError

        if not (np.isfinite(self.track_gap) and self.track_gap > 0):
            raise InputError(f"track_gap must be > 0, got {self.track_gap}")
        if int(self.min_track) != self.min_track or self.min_track < 2:
            raise InputError(f"min_track must be an integer >= 2, got {self.min_track}")


def _grid_index(data: RadarData, antenna: np.ndarray) -> np.ndarray:
    """(ix, iz) of flat antenna indices, shape (K, 2) (iz = 0 for linear arrays)."""
    arr = data.array
    if arr.planar:
        ix, iz = np.unravel_index(antenna, arr.shape)
        return np.stack([ix, iz], axis=1)
    return np.stack([antenna, np.zeros_like(antenna)], axis=1)


def tracks(grid: np.ndarray, r_env: np.ndarray, slope: np.ndarray, steps, gap: float) -> np.ndarray:
    """Connected tracks of one cluster's RPs (module notes, step 1).

    Parameters
    ----------
    grid : ndarray of int, shape (K, 2)
        Antenna grid index (ix, iz) of each RP.
    r_env : ndarray, shape (K,)
        Envelope ranges, m.
    slope : ndarray, shape (2,)
        The cluster's range slopes dR/dX, dR/dZ (0 for an absent axis).
    steps : (float, float)
        Array pitch along x and z, m.
    gap : float
        Largest misfit of a link, m.

    Returns
    -------
    ndarray of int, shape (K,)
        Track label of each RP, 0 .. n_tracks - 1.
    """
    return _components(len(r_env), _links(grid, r_env, slope, steps, gap))


def _components(k: int, links: np.ndarray) -> np.ndarray:
    """Connected components of ``k`` nodes joined by ``links`` (P, 2),
    labelled 0 .. n - 1 in the order of their smallest node: each node
    takes the least label among its neighbours', then its label's label,
    until nothing changes."""
    label = np.arange(k)
    if len(links) == 0:
        return label.astype(np.int64)
    a, b = links[:, 0], links[:, 1]
    while True:
        new = label.copy()
        np.minimum.at(new, a, label[b])
        np.minimum.at(new, b, label[a])
        new = new[new]
        if np.array_equal(new, label):
            break
        label = new
    return np.unique(label, return_inverse=True)[1].astype(np.int64)


def _links(grid, r_env, slope, steps, gap) -> np.ndarray:
    """Pairs (i, j), shape (P, 2), of RPs at neighbouring antennas (one step
    along x or z, j the farther) whose envelope ranges fit the cluster's
    slope within ``gap``."""
    grid = np.asarray(grid, np.int64)
    k = len(grid)
    if k == 0:
        return np.zeros((0, 2), np.int64)
    width = int(grid[:, 1].max()) + 2  # a key per (ix, iz), iz + 1 included
    key = grid[:, 0] * width + grid[:, 1]
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    out = []
    for a, (dx, dz) in enumerate(((1, 0), (0, 1))):
        target = (grid[:, 0] + dx) * width + grid[:, 1] + dz
        lo = np.searchsorted(sorted_key, target, "left")
        cnt = np.searchsorted(sorted_key, target, "right") - lo
        i = np.repeat(np.arange(k), cnt)
        j = order[np.repeat(lo - np.cumsum(cnt) + cnt, cnt) + np.arange(int(cnt.sum()))]
        walk = slope[a] * steps[a]
        keep = np.abs(r_env[j] - r_env[i] - walk) < gap
        out.append(np.stack([i[keep], j[keep]], axis=1))
    return np.concatenate(out)


def _unwrap(phase, amp, links, model) -> np.ndarray:
    """Phase unwrapped over the links, strongest RP first (module notes, step
    2): returns the residual phase after the cluster's wavefront ``model``
    (:func:`_wavefront`), rad.

    The walk is a Python heap over Python floats (a cluster's few hundred
    RPs: NumPy scalars would cost several times more per step, with the
    same IEEE arithmetic)."""
    k = len(phase)
    nbr = [[] for _ in range(k)]
    for i, j in np.asarray(links, np.int64).reshape(-1, 2).tolist():
        nbr[i].append(j)
        nbr[j].append(i)
    resid = (phase - model).tolist()
    w = np.asarray(amp, np.float64).tolist()
    out = [None] * k
    start = int(np.argmax(amp))
    out[start] = resid[start]
    heap = [(-min(w[start], w[j]), start, j) for j in nbr[start]]
    heapq.heapify(heap)
    two_pi = 2 * math.pi
    while heap:
        _, i, j = heapq.heappop(heap)
        if out[j] is not None:
            continue
        out[j] = out[i] + (resid[j] - resid[i] + math.pi) % two_pi - math.pi
        wj = w[j]
        for n in nbr[j]:
            if out[n] is None:
                heapq.heappush(heap, (-min(wj, w[n]), j, n))
    return np.array([np.nan if v is None else v for v in out], np.float64)


def phase_ranges(
    data: RadarData,
    rps: RangePoints,
    cluster_k: np.ndarray,
    params: PhaseParams = PhaseParams(),
    cluster_r: np.ndarray | None = None,
) -> tuple[RangePoints, np.ndarray]:
    """Refine the ranges of a decomposition's RPs by their carrier phase.

    Parameters
    ----------
    data : RadarData
        The data the RPs came from (array, carrier, range resolution).
    rps : RangePoints
        RPs of :func:`rpm_cl.extract.rangepoints.rps_from_decomposition` (with
        ``sample``).
    cluster_k : ndarray, shape (n_clusters, n_k_axes)
        Each cluster's wavenumber(s), rad/m: the alias the walk starts from
        (module notes, step 3), e.g. ``Cluster.k``, or ``-2 k_c u`` of an
        aligned cluster's range slopes ``Cluster.direction``.
    params : PhaseParams
    cluster_r : ndarray, shape (n_clusters,), optional
        Each cluster's range (``Cluster.r_centre``), m: the phase is unwrapped
        after the spherical wave of that range (:func:`_wavefront`); None:
        after the plane wave.

    Returns
    -------
    rps : RangePoints
        The same RPs, ranges refined where a track of at least
        ``params.min_track`` RPs holds them.
    refined : ndarray of bool, shape (K,)
        Which ranges the phase refined.
    """
    k_all = len(rps)
    refined = np.zeros(k_all, bool)
    if rps.sample is None or k_all == 0:
        return rps, refined
    arr = data.array
    kc = data.waveform.kc
    steps = (arr.dx, arr.dz if arr.planar else 1.0)
    periods = np.array([2 * np.pi / steps[0], 2 * np.pi / steps[1]])
    gap = params.track_gap * data.waveform.range_resolution
    grid_all = _grid_index(data, np.asarray(rps.antenna))
    r_new = np.array(rps.range, np.float64, copy=True)
    phase_all = np.angle(rps.sample)
    amp_all = np.asarray(rps.amp, np.float64)
    cl = np.asarray(rps.cluster)
    # the array's centre in the grid's positions (index times pitch)
    centre = 0.5 * (np.asarray(arr.shape + (1,))[:2] - 1) * np.asarray(steps)
    for m in np.unique(cl):
        sel = np.nonzero(cl == m)[0]
        if sel.size < params.min_track:
            continue
        kvec = np.zeros(2)
        kvec[: cluster_k.shape[1]] = cluster_k[m]
        slope = -kvec / (2 * kc)
        grid, r_env, amp = grid_all[sel], r_new[sel], amp_all[sel]
        links = _links(grid, r_env, slope, steps, gap)
        label = _components(len(r_env), links)
        place = np.zeros(len(r_env), np.int64)  # an RP's index within its track
        for t in range(int(label.max()) + 1):
            mem = np.nonzero(label == t)[0]
            if mem.size < params.min_track:
                continue
            g, re_, a = grid[mem], r_env[mem], amp[mem]
            place[mem] = np.arange(mem.size)
            own = place[links[label[links[:, 0]] == t]].tolist()  # a link joins one track
            ph = phase_all[sel][mem]
            pos = g * np.asarray(steps)[None, :]
            r_m = None if cluster_r is None else float(cluster_r[m])
            model = _wavefront(pos - centre, kvec, r_m, kc)
            psi = _unwrap(ph, a, own, model)
            ok = np.isfinite(psi)
            if np.count_nonzero(ok) < params.min_track:
                continue
            kv = _alias(pos[ok], psi[ok] + model[ok], re_[ok], a[ok], kvec, periods, kc)
            if kv is None:  # no alias is a physical direction: keep the envelope
                continue
            if np.any(kv != kvec):
                # another alias: unwrapped again after its own wavefront (a
                # sphere's curvature differs; a plane wave's differs by whole
                # cycles per step)
                model = _wavefront(pos - centre, kv, r_m, kc)
                psi = _unwrap(ph, a, own, model)
                ok = np.isfinite(psi)
            r_fit = _absolute(psi[ok] + model[ok], re_[ok], a[ok], kc)
            idx = sel[mem[ok]]
            if params.coherent_level:
                r_fit = r_fit + _coherent_level(data, np.asarray(rps.antenna)[idx], g[ok], r_fit)
            r_new[idx] = r_fit
            refined[idx] = True
    out = replace(rps, range=r_new)
    return out, refined


def spherical_ranges(
    data: RadarData, rps: RangePoints, clusters, params: PhaseParams = PhaseParams()
) -> tuple[RangePoints, np.ndarray]:
    """Put a near-field decomposition's RPs on their clusters' fitted
    spherical waves (module notes).

    Parameters
    ----------
    data : RadarData
        The linear array's data the decomposition ran on.
    rps : RangePoints
        RPs of :func:`rpm_cl.extract.rangepoints.rps_from_decomposition`;
        ``cluster`` indexes ``clusters``.
    clusters : sequence of Cluster
        The near-field clusters: ``k`` = ``2 k_c sin(theta)`` of the centre
        (not wrapped), ``r_centre`` its range from the array's middle, m.
    params : PhaseParams
        ``track_gap``: RPs farther than it (range resolutions) from the walk
        and the cluster's weighted median offset keep their envelope range
        and take no part in the constant; ``min_track``: clusters with fewer
        RPs on the walk keep their envelope ranges.

    Returns
    -------
    rps : RangePoints
        The same RPs with ranges ``|X - p| + c`` per cluster, m.
    refined : ndarray of bool, shape (K,)
        Which ranges were replaced.
    """
    k_all = len(rps)
    refined = np.zeros(k_all, bool)
    if k_all == 0:
        return rps, refined
    x = np.asarray(data.array.x, np.float64)
    # the search's frame: positions from the array's middle
    xr = np.asarray(rps.x, np.float64) - 0.5 * (x[0] + x[-1])
    kc = data.waveform.kc
    gap = params.track_gap * data.waveform.range_resolution
    r_new = np.array(rps.range, np.float64, copy=True)
    amp_all = np.asarray(rps.amp, np.float64)
    cl = np.asarray(rps.cluster)
    # the aliases' spacing in sin(theta): the k period 2 pi / d over 2 k_c
    pitch = float(data.array.dx) if x.size > 1 else 0.0
    xa = x - 0.5 * (x[0] + x[-1])
    period = np.pi / (kc * pitch) if pitch > 0 else np.inf
    for m in np.unique(cl):
        sel = np.nonzero(cl == m)[0]
        if sel.size < params.min_track:
            continue
        c = clusters[int(m)]
        amp = amp_all[sel]
        w = (amp / amp.max()) ** 2 if amp.max() > 0 else np.ones(sel.size)
        u = float(np.clip(c.k[0] / (2 * kc), -1.0, 1.0))
        u, r_c = _spherical_alias(xr[sel], r_new[sel], w, u, c.r_centre, period, gap, xa, kc)
        walk = _spherical_walk(xr[sel], u, r_c)
        off = r_new[sel] - walk
        # the RPs of the walk: within the tracks' gap of the weighted median
        # offset (a stray peak of the cluster's gates keeps its own range and
        # does not pull the others' constant)
        med = _weighted_median(off, w)
        on = np.abs(off - med) <= gap
        if np.count_nonzero(on) < params.min_track:
            continue
        keep = sel[on]
        r_new[keep] = walk[on] + float(np.sum(w[on] * off[on]) / np.sum(w[on]))
        refined[keep] = True
    return replace(rps, range=r_new), refined


def _weighted_median(values, w) -> float:
    """The ``w``-weighted median of ``values`` (the first value whose
    cumulative weight, in ascending order, reaches half the total)."""
    o = np.argsort(values)
    cw = np.cumsum(w[o])
    return values[o][np.searchsorted(cw, 0.5 * cw[-1])]


def _alias_steps(start: float, period: float, bound: float) -> np.ndarray:
    """The steps ``n`` (0 among them) that keep ``start + n period`` within
    ``+-bound``; beyond :data:`ALIASES_AXIS` of them (a pitch over 8
    wavelengths; x in mm read as m gives a million) -1, 0 and 1 only."""
    lo = int(np.ceil((-bound - start) / period))
    hi = int(np.floor((bound - start) / period))
    return np.arange(lo, hi + 1) if hi - lo + 1 <= ALIASES_AXIS else np.arange(-1, 2)


def _spherical_walk(xr, u: float, r: float) -> np.ndarray:
    """Ranges from antennas at ``xr`` (m, the array's middle at 0) to the
    point at range ``r`` (m) in direction ``u = sin(theta)``."""
    return np.hypot(xr - r * u, r * np.sqrt(1.0 - u * u))


def _spherical_alias(
    xr, r_env, w, u: float, r: float, period: float, gap: float, xa, kc: float
) -> tuple[float, float]:
    """The centre of a near-field cluster whose range walk fits its RPs'
    envelope ranges (module notes, the near-field clusters): ``(u, r)``
    itself (the search's choice), or an alias ``(v, r (1 - v^2) / (1 - u^2))``,
    ``v = u + n period`` (|v| < 1, up to :data:`ALIASES_AXIS` of them), where
    that one leaves less than :data:`ALIAS_GAIN` of the search's misfit.  An
    alias keeps the wave's linear phase across the array modulo ``2 pi`` per
    antenna and, at that range, its curvature ``(1 - u^2) / r``: the wave the
    fit sees, to the cubic term.

    ``xr``, ``r_env``, ``w``: the cluster's RPs' positions from the array's
    middle (m), envelope ranges (m) and weights; ``r``: the cluster's range,
    m; ``period``: the aliases' spacing in ``sin(theta)``, ``pi / (k_c d)``;
    ``gap``: the misfit of one RP is its squared offset from the walk's
    weighted median offset, at most ``gap**2`` (a stray peak of the
    cluster's gates counts no more than a track's gap)."""
    ns = _alias_steps(u, period, 1.0) if np.isfinite(period) else np.zeros(1, int)
    bend = 1.0 - u * u
    if not bend > 0:  # a direction along the array has no curvature to keep
        return u, r
    cands = [
        (v, r * (1.0 - v * v) / bend)
        for v in (u + n * period for n in ns if n != 0)
        if abs(v) < 1.0
    ]
    # only the aliases whose waves the fit could not tell from the search's
    wave = np.exp(-2j * kc * _spherical_walk(xa, u, r))
    cands = [
        (v, q)
        for v, q in cands
        if abs(np.vdot(wave, np.exp(-2j * kc * _spherical_walk(xa, v, q)))) / xa.size
        >= ALIAS_CORRELATION
    ]
    if not cands:
        return u, r
    ws = float(np.sum(w))

    def misfit(v, q):
        off = r_env - _spherical_walk(xr, v, q)
        med = _weighted_median(off, w)
        return float(np.sum(w * np.minimum((off - med) ** 2, gap * gap))) / ws

    costs = [misfit(v, q) for v, q in cands]
    best = int(np.argmin(costs))
    return cands[best] if costs[best] < ALIAS_GAIN * misfit(u, r) else (u, r)


#: The coherent level search spans this many range resolutions either side
#: of the envelope's constant (coarse steps of LEVEL_FIT / 4 resolutions,
#: then a quarter range gate around the coarse peak).
LEVEL_SPAN = 0.5
#: Half-width of the parabola fitted to the coherent sum's peak, range
#: resolutions.
LEVEL_FIT = 0.05


def _grid(start: float, stop: float, step: float, lo: float, hi: float) -> np.ndarray:
    """The values of ``np.arange(start, stop, step)`` within ``[lo, hi]``,
    the same numbers, without forming the rest."""
    n = max(0, int(np.ceil((stop - start) / step)))
    k0 = min(n, max(0, int(np.floor((lo - start) / step))))
    k1 = min(n, max(k0, int(np.ceil((hi - start) / step)) + 1))
    delta = (start + step) - start  # as np.arange fills: start + i * delta
    g = start + np.arange(k0, k1) * delta
    return g[(g >= lo) & (g <= hi)]


def _coherent_level(
    data: RadarData, antenna: np.ndarray, grid: np.ndarray, r_fit: np.ndarray
) -> float:
    """The shift of a track's ranges that maximises the coherent sum of the
    data's range profiles along them (module notes, step 4), m.

    ``p(c) = sum_i w_i s(X_i, r_i + c) exp(j 2 k_c r_i)``: the phase walk
    ``r_i`` lines the track's echo up across the array, so the sum gains
    ``N`` in signal power over one antenna, while other echoes in the same
    range cell, whose phase histories differ, cancel (a Hann taper ``w``
    over the track's extent along each array axis keeps their leakage to its
    -31 dB sidelobes).  The profiles' phase is constant near an echo (a
    real envelope about the carrier), so ``c`` moves along the envelope only.
    """
    sig = data.signal.reshape(-1, data.range.size)
    kc = data.waveform.kc
    w = np.ones(len(r_fit))
    for a in range(grid.shape[1]):
        lo, hi = grid[:, a].min(), grid[:, a].max()
        if hi > lo:
            w = w * np.sin(np.pi * (grid[:, a] - lo + 1) / (hi - lo + 2)) ** 2
    res = data.waveform.range_resolution
    weights = w * np.exp(2j * kc * r_fit)

    def profile(c):
        pos = (r_fit[:, None] + c[None, :] - data.range[0]) / data.dr  # fractional gates
        g0 = np.clip(np.floor(pos).astype(np.int64), 0, data.range.size - 2)
        f = np.clip(pos - g0, 0.0, 1.0)
        inside = (pos >= 0) & (pos <= data.range.size - 1)
        rows = antenna[:, None]
        v = ((1 - f) * sig[rows, g0] + f * sig[rows, g0 + 1]) * inside
        return np.abs(np.sum(weights[:, None] * v, axis=0))  # no BLAS: its threads spin

    if data.spectrum is not None:
        profile = _spectral_profile(data, antenna, r_fit, weights)

    # coarse over the span, then fine (a quarter gate) around the coarse peak;
    # only shifts that keep some of the track on the range axis (elsewhere
    # the sum is 0), so that a resolution far beyond the axis costs no more
    lo_c = data.range[0] - r_fit.max() - data.dr
    hi_c = data.range[-1] - r_fit.min() + data.dr
    half = LEVEL_FIT * res
    coarse = _grid(-LEVEL_SPAN * res, LEVEL_SPAN * res + half / 8, half / 4, lo_c, hi_c)
    if coarse.size == 0:
        return 0.0
    top = coarse[int(np.argmax(profile(coarse)))]
    step = min(0.25 * data.dr, half / 8)
    c = top + _grid(-2 * half, 2 * half + step / 2, step, lo_c - top, hi_c - top)
    if c.size == 0:
        return 0.0
    prof = profile(c)
    j = int(np.argmax(prof))
    if not prof[j] > 0:
        return 0.0
    # a parabola through the top LEVEL_FIT resolutions either side: the
    # envelope's top is flat over a resolution, and ripples of what leaks
    # through the taper would move a three-sample peak
    h = max(1, round(half / step))
    sl = slice(max(0, j - h), min(len(c), j + h + 1))
    if sl.stop - sl.start >= 3:
        a2, a1, _ = np.polyfit(c[sl] - c[j], prof[sl] / prof[j], 2)
        if a2 < 0 and abs(a1 / (2 * a2)) <= h * step:
            return float(c[j] - a1 / (2 * a2))
    return float(c[j])


#: The window of the coherent sums formed from the frequency samples
#: (:func:`_spectral_profile`).  For the same noise the peak of a sum
#: weighted ``w_n`` wanders ``sqrt(sum w^2 u^2) / sum w u^2`` (``u`` the
#: frequency offset) times as far as with the flat window, the least: 1.09
#: for Taylor (30 dB, nbar 4), 1.57 for the Hann window of the profiles;
#: Taylor's sidelobes stay at -30 dB where the flat window's reach -13 dB
#: (docs/decisions.md, "The coherent level is formed from the frequency
#: samples").
LEVEL_WINDOW = "taylor"


def _spectral_profile(data: RadarData, antenna: np.ndarray, r_fit: np.ndarray, weights):
    """``profile(c)`` of :func:`_coherent_level` formed from the frequency
    samples (``data.spectrum``) with :data:`LEVEL_WINDOW`: each antenna's
    profile at ``r_i + c`` is ``sum_n v_n Y_n exp(j kappa_n (r_i + c)) /
    sum_n v_n``, ``kappa_n = 4 pi (f_n - f_c) / c`` (the compression's own
    form, :func:`rpm_cl.io.compress.range_compress`, evaluated at any range
    without interpolation), so the sum over the track is one small DFT of
    ``Z_n = sum_i weights_i Y_in exp(j kappa_n r_i)`` per shift."""
    from ..io.model import C0
    from ..io.windows import window

    spec = data.spectrum
    y = spec.values.reshape(-1, spec.frequency.size)[antenna]
    kappa = 4.0 * np.pi * (spec.frequency - data.waveform.fc) / C0
    v = window(LEVEL_WINDOW, kappa.size)
    z = np.einsum("i,in,in->n", weights, y, np.exp(1j * np.outer(r_fit, kappa)))
    z *= v / v.sum()

    def profile(c):  # no BLAS: its threads spin
        return np.abs(np.sum(np.exp(1j * np.outer(c, kappa)) * z, axis=1))

    return profile


def _wavefront(d, kvec, r, kc) -> np.ndarray:
    """The phase a cluster's wave puts on antennas at ``d`` (K, 2) from the
    array's centre (module notes, step 2), rad: the spherical wave of the
    point at range ``r`` whose range slopes at the centre are ``u = -kvec /
    (2 k_c)``, ``-2 k_c (|X - p| - r)``; the plane wave ``kvec . d`` where
    ``r`` is None.  A near target's wavefront curves: on a sparse array its
    steps from antenna to antenna reach 4 rad at the ends (21 antennas at
    20 mm, a point 0.8 m away), which a plane wave leaves in the residual."""
    if r is None:
        return d @ kvec
    u = -kvec / (2 * kc)
    q = r * r + 2 * r * (d @ u) + np.sum(d * d, axis=1)
    return -2 * kc * (np.sqrt(np.maximum(q, 0.0)) - r)


def _weights(amp) -> np.ndarray:
    """A track's amplitude-squared weights, summing to 1 (relative to the
    largest: the data's own scale may square beyond float64)."""
    w = (amp / amp.max()) ** 2
    return w / w.sum()


def _alias(pos, phi, r_env, amp, kvec, periods, kc) -> np.ndarray:
    """The alias of ``kvec`` whose range walk fits one unwrapped track's
    envelope ranges best (module notes, step 3): ``kvec + n 2 pi / d`` per
    axis, over every ``n`` that is a physical direction (|u| < 1), or None
    where none is.

    ``pos`` (K, 2) are the antennas' positions, m; ``phi`` is the track's
    unwrapped phase (the starting wavefront included); an alias adds
    ``n 2 pi / d`` to its slope.  The weighted misfit of every alias comes
    from the track's moments at once: with
    ``e`` the envelope ranges less the starting walk and ``q = X . dk /
    (2 k_c)``, ``Var(e + q) = Var(e) + 2 Cov(e, q) + Var(q)``."""
    w = _weights(amp)
    # per axis the track extends over, the n that keep |u| < 1
    span = []
    for a in range(2):
        if np.ptp(pos[:, a]) == 0:
            span.append(np.zeros(1, int))
            continue
        span.append(_alias_steps(kvec[a], periods[a], 2 * kc))
    n = np.stack(np.meshgrid(*span, indexing="ij"), axis=-1).reshape(-1, 2)
    kv = kvec[None, :] + n * periods[None, :]
    phys = np.hypot(kv[:, 0], kv[:, 1]) < 2 * kc
    if not phys.any():
        return None
    n, kv = n[phys], kv[phys]
    e = r_env + phi / (2 * kc)  # the envelope less the starting walk
    em = float(np.sum(w * e))
    pm = w @ pos
    dp = pos - pm
    cov_pp = (w[:, None] * dp).T @ dp  # (2, 2)
    cov_pe = (w * (e - em)) @ dp  # (2,)
    dq = (kv - kvec[None, :]) / (2 * kc)  # per alias, the walk's extra slope
    cost = (
        float(np.sum(w * (e - em) ** 2))
        + 2 * dq @ cov_pe
        + np.einsum("ia,ab,ib->i", dq, cov_pp, dq)
    )
    start = np.flatnonzero(np.all(n == 0, axis=1))
    others = np.flatnonzero(np.any(n != 0, axis=1))
    best = others[int(np.argmin(cost[others]))] if others.size else None
    # another alias in place of the starting one only where it explains most
    # of the starting one's misfit, where the starting alias spans +-30
    # degrees or more (a pitch of half a wavelength or finer); on a coarser
    # array it is one narrow band of directions among several, and the least
    # misfit decides
    moved = [a for a in range(2) if span[a].size > 1]
    wide = bool(moved) and all(periods[a] >= 2 * kc * (1 - 1e-9) for a in moved)
    if start.size:
        s0 = int(start[0])
        if best is None or (wide and cost[best] > ALIAS_GAIN * cost[s0]) or cost[s0] <= cost[best]:
            return kv[s0]
    return kv[best]


def _absolute(phi, r_env, amp, kc) -> np.ndarray:
    """Ranges of one unwrapped track (module notes, steps 3-4): the walk of
    its unwrapped phase ``phi`` (its wavefront included) and the constant
    that fits the envelope ranges ``r_env`` (amplitude-weighted), m."""
    rel = -phi / (2 * kc)
    return rel + float(np.sum(_weights(amp) * (r_env - rel)))
