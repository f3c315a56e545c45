"""The medium the echoes' range walks imply: a hyperbola fit per cluster.

A point scatterer at true position ``(x0, d[, z0])`` in a homogeneous
medium of refractive index ``n`` seen from antennas on the line (plane)
``y = 0`` in the same medium has the air-equivalent range

    R(x, z) = n sqrt(d^2 + (x - x0)^2 + (z - z0)^2),

so that ``R^2 = a + b x + c z + eps_r (x^2 + z^2)``: a linear least-squares
fit of each track's squared ranges gives ``eps_r`` directly, with its
standard error from the residuals (the usual GPR hyperbola fit).

The tracks come from the data alone (:func:`tracks`): each antenna's range
profile peaks, linked across neighbouring antennas of a linear array.  The
imaging method's own RPs would not do: their extraction assumes the medium
under test, and with the wrong one the k-space windows cut a track's walk
into pieces that no longer follow it (a homogeneous eps_r = 6 scene imaged
as air: RPs 0.1-0.25 m off their tracks, fitting eps_r about 1).  Above a half-space (antennas ``h`` over the
surface) the track is Fermat's path (:func:`rpm_cl.io.medium.one_way`), and
``(x0, d[, z0], eps_r)`` are fitted by nonlinear least squares started from
the homogeneous fit.

Only tracks that pin the curvature take part: at least :data:`MIN_RPS` RPs,
a relative standard error of ``eps_r`` at most :data:`TRACK_REL_ERROR`, a
value the engine takes as a medium (at most ``EPS_R_MAX``: beyond it the
track is not one point's hyperbola but peaks of overlapping echoes linked
across antennas, which a dense array at a coarse range resolution lets the
tracker hop between); and
the estimate (their inverse-variance weighted median) is reported only
where the tracks' pooled error, ``1 / sqrt(sum 1 / se^2)``, is at most
:data:`MAX_REL_ERROR` of it.  :func:`check_medium` warns only where the
mismatch stands :data:`SURE` errors beyond :data:`MISMATCH`, the error
widened by the tracks' scatter about the estimate, ``sqrt(chi^2 / (n -
1))`` with ``chi^2 = sum (e - est)^2 / se^2``, where they disagree beyond
their errors: a mean-trace removal takes part of each walk's flat apex,
where another echo comes within a range resolution (points 0.30 and 0.38
m deep, 0.3 m apart along a 1-3 GHz line in air, fit 0.45 and 1.50, with
errors of 18 % and 4 %), while the tracks of a half-space's
rods imaged as air, which the homogeneous model reads as 2.1-3.2 by
depth, all stand beyond it.  A flat track (a plate, a planar surface) has
none and is left out.  An
extended convex scatterer (radius ``a`` at depth ``d``) flattens its track,
``eps_r`` about ``(1 - a / d)`` times the true one, and antennas ``h``
above the surface of a material taken as homogeneous fit ``(h + n d) / (h
+ d / n)`` (the apex's range over its curvature radius; 2.7 for a rod 0.1 m
down in eps_r 6 under 80 mm of air): a fit *below* the setting may be
either, so :func:`check_medium` names both and never warns that air data
fit less than air.

Where no track qualifies (rows of bars whose envelopes merge), the check
reads the focus at the echoes' apexes instead (:mod:`rpm_cl.extract.apex`).
"""

from __future__ import annotations

import hashlib
import warnings

import numpy as np

from ..io.data import DataWarning
from ..io.medium import EPS_R_MAX, Medium, one_way

__all__ = [
    "MAX_REL_ERROR",
    "MIN_RPS",
    "MISMATCH",
    "SURE",
    "TRACK_REL_ERROR",
    "TRACK_THRESHOLD_DB",
    "check_medium",
    "fit_eps_r",
    "read_eps_r",
    "track_eps_r",
    "tracks",
]

#: Fewest RPs of a cluster whose track is fitted: seven degrees of freedom
#: or more beside the fit's three (offset, slope, eps_r), so that the
#: standard error from the residuals is itself within about a quarter of
#: the true one (Student's t at 95 %: 2.36 against the normal's 1.96).
#: Shorter tracks are pieces of walks that hop between crossing echoes as
#: often as hyperbolas: on 20 random gprMax scenes in air at four bands,
#: three tracks of 6-7 RPs over 40-48 mm fitted 11.8, 19.2 and 27.6 with
#: errors of 5-15 % and drew the one warning of the 80 runs
#: (docs/benchmarks.md, "Full-wave scenes nobody laid out").
MIN_RPS = 10
#: Largest relative standard error of the estimate (the tracks' pooled
#: inverse-variance error) that is reported.
MAX_REL_ERROR = 0.05
#: Largest relative standard error of one track's eps_r that takes part.
#: Shallow bars under a scan give short tracks: in a full-wave scene of bars
#: 70-90 mm deep in eps_r 8 (13-19 antennas per track) each fits 5.9-7.8
#: with an error of 6-16 %, none under 5 %; pooled, four name 5.9.
TRACK_REL_ERROR = 0.2
#: Ratio between fitted and set eps_r beyond which :func:`check_medium` warns.
MISMATCH = 1.5
#: ... where the fit stands this many of its errors beyond that ratio, the
#: error widened by the tracks' scatter about the estimate (module notes).
SURE = 2.0
#: Profile peaks below this level (dB from the strongest) start no track.
TRACK_THRESHOLD_DB = -20.0
#: Largest distance, in range resolutions, between a peak and the range its
#: track predicts for its antenna (the track's last range, moved on by its
#: last step): farther, the peak is another echo.
TRACK_STEP = 0.25
#: Most clusters fitted (the ones with most RPs): enough for a median,
#: bounded time on a 3-D scene of thousands of clusters.
MAX_TRACKS = 16


def tracks(data, threshold_db: float = TRACK_THRESHOLD_DB):
    """Echo tracks of a linear array's data: profile peaks linked across
    antennas.

    Each antenna's range-profile peaks above ``threshold_db`` (relative to
    the strongest) join the track whose last peak, on the previous antenna,
    lies nearest in range and within :data:`TRACK_STEP` range resolutions
    (greedy, strongest peak first); the others start tracks.

    Parameters
    ----------
    data : RadarData
        Range-compressed data of a linear array.
    threshold_db : float
        dB, < 0.

    Returns
    -------
    RangePoints
        One cluster per track, sorted by cluster; no samples.
    """
    from .rangepoints import RangePoints, rps_from_profiles

    peaks = rps_from_profiles(data, threshold_db)
    step = TRACK_STEP * data.waveform.range_resolution
    label = np.full(peaks.range.size, -1)
    # track -> (predicted range on the next antenna, its last range, antenna)
    last: dict[int, tuple[float, float, int]] = {}
    n_tracks = 0
    order = np.lexsort((-peaks.amp, peaks.antenna))
    for a in np.unique(peaks.antenna):
        idx = order[peaks.antenna[order] == a]
        open_ = {t: pr for t, (pr, _, ant) in last.items() if ant == a - 1}
        for i in idx:
            r = float(peaks.range[i])
            best = min(open_, key=lambda t: abs(open_[t] - r), default=None)
            if best is not None and abs(open_[best] - r) <= step:
                label[i] = best
                del open_[best]
                prev = last[best][1]
                last[best] = (2 * r - prev, r, int(a))
            else:
                label[i], n_tracks = n_tracks, n_tracks + 1
                last[int(label[i])] = (r, r, int(a))
    o = np.argsort(label, kind="stable")
    return RangePoints(peaks.antenna[o], peaks.x[o], None, peaks.range[o], peaks.amp[o], label[o])


def track_eps_r(x, z, r) -> tuple[float, float]:
    """``eps_r`` and its standard error from one homogeneous track.

    Parameters
    ----------
    x, z : ndarray, shape (K,)
        Antenna positions, m (``z`` None for a linear array).
    r : ndarray, shape (K,)
        Air-equivalent ranges, m.

    Returns
    -------
    (float, float)
        The fitted ``eps_r`` (the coefficient of ``x^2 + z^2`` in ``R^2``)
        and its standard error; ``(nan, inf)`` when the fit is singular or
        has no degree of freedom left.
    """
    x = np.asarray(x, np.float64)
    r = np.asarray(r, np.float64)
    # centred and scaled columns: the normal equations stay well conditioned
    # at any scale and offset of the array
    sx = float(np.ptp(x))
    if not sx > 0:  # one antenna position: no curvature to fit
        return float("nan"), float("inf")
    x0 = x.mean()
    u = (x - x0) / sx
    cols = [np.ones_like(u), u]
    quad = u * u
    if z is not None:
        z = np.asarray(z, np.float64)
        w = (z - z.mean()) / sx
        cols.append(w)
        quad = quad + w * w
    cols.append(quad)
    a = np.stack(cols, axis=1)
    y = r * r / (sx * sx)
    dof = len(y) - a.shape[1]
    if dof < 1:
        return float("nan"), float("inf")
    coef, _, rank, _ = np.linalg.lstsq(a, y, rcond=None)
    if rank < a.shape[1]:
        return float("nan"), float("inf")
    resid = y - a @ coef
    s2 = float(resid @ resid) / dof
    cov = s2 * np.linalg.pinv(a.T @ a)
    return float(coef[-1]), float(np.sqrt(max(cov[-1, -1], 0.0)))


def _halfspace_track(pos, r, h: float, eps0: float) -> tuple[float, float]:
    """``eps_r`` and its standard error of one track above a half-space."""
    from scipy.optimize import least_squares

    planar = np.ptp(pos[:, 2]) > 0
    j = int(np.argmin(r))
    n0 = np.sqrt(min(max(eps0, 1.0), EPS_R_MAX))
    d0 = max((r[j] - h) / n0, 1e-3)

    def model(p):
        n2 = p[-1]
        m = Medium(float(np.clip(n2, 1.0, EPS_R_MAX)), h)
        pt = np.array([p[0], h + p[1], p[2] if planar else 0.0])
        return one_way(m, pos, pt[None, :]) - r

    p0 = [pos[j, 0], d0] + ([pos[j, 2]] if planar else [0.0]) + [max(eps0, 1.0)]
    lo = [-np.inf, 1e-6, -np.inf, 1.0]
    hi = [np.inf, np.inf, np.inf, EPS_R_MAX]
    if not planar:  # z0 fixed at 0
        lo[2], hi[2] = -1e-12, 1e-12
    fit = least_squares(model, p0, bounds=(lo, hi), x_scale="jac")
    dof = len(r) - (4 if planar else 3)
    if not fit.success or dof < 1:
        return float("nan"), float("inf")
    jac = fit.jac[:, [0, 1, 2, 3] if planar else [0, 1, 3]]
    s2 = float(fit.fun @ fit.fun) / dof
    try:
        cov = s2 * np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        return float("nan"), float("inf")
    return float(fit.x[-1]), float(np.sqrt(max(cov[-1, -1], 0.0)))


def fit_eps_r(positions, rps, medium: Medium | None = None) -> tuple[float, int]:
    """The relative permittivity the clusters' range walks imply.

    Parameters
    ----------
    positions : ndarray, shape (A, 3)
        Antenna positions, m (``Array.positions()``).
    rps : RangePoints
        RPs with air-equivalent ranges (as measured) and cluster labels.
    medium : Medium, optional
        Above a half-space the tracks are fitted with its antenna height;
        otherwise (air or homogeneous) the homogeneous model.

    Returns
    -------
    (float, int)
        The inverse-variance weighted median of the qualifying tracks'
        ``eps_r`` (module notes), and how many tracks qualified; ``(nan, 0)``
        when none did or their pooled error exceeds :data:`MAX_REL_ERROR`.
    """
    height = medium.antenna_height if medium is not None and medium.half_space else None
    value, n, _ = _fit(positions, rps, height)
    return value, n


def _fit(positions, rps, height: float | None = None) -> tuple[float, int, float]:
    """:func:`fit_eps_r`, and the estimate's error widened by the tracks'
    scatter (module notes; ``inf`` for ``(nan, 0)``)."""
    cl = np.asarray(rps.cluster)
    if cl.size == 0:
        return float("nan"), 0, float("inf")
    _, start, count = np.unique(cl, return_index=True, return_counts=True)
    order = np.argsort(count)[::-1]
    order = order[count[order] >= MIN_RPS][:MAX_TRACKS]
    pos_all = np.asarray(positions, np.float64)[np.asarray(rps.antenna)]
    if pos_all.shape[1] == 2:  # a linear array's (x, y): z = 0
        pos_all = np.column_stack([pos_all, np.zeros(len(pos_all))])
    half = bool(height)  # antennas this far above a half-space
    est, err = [], []
    for i in order:
        sl = slice(start[i], start[i] + count[i])
        r = np.asarray(rps.range[sl], np.float64)
        z = None if rps.z is None else np.asarray(rps.z[sl])
        e, se = track_eps_r(rps.x[sl], z, r)
        if half and np.isfinite(e) and se <= 2 * TRACK_REL_ERROR * e:
            e, se = _halfspace_track(pos_all[sl], r, height, e)
        # a fit beyond the media the engine takes (EPS_R_MAX) is not the
        # hyperbola of a point: a track that hops between the peaks of
        # overlapping echoes bends sharply and fits hundreds
        if np.isfinite(e) and 0 < e <= EPS_R_MAX and se <= TRACK_REL_ERROR * e:
            est.append(e)
            err.append(se)
    if not est:
        return float("nan"), 0, float("inf")
    est, w = np.asarray(est), 1.0 / np.square(np.maximum(err, 1e-12))
    o = np.argsort(est)
    cw = np.cumsum(w[o])
    value = float(est[o][np.searchsorted(cw, 0.5 * cw[-1])])
    if 1.0 / np.sqrt(cw[-1]) > MAX_REL_ERROR * value:
        return float("nan"), 0, float("inf")
    chi2 = float(np.sum(w * (est - value) ** 2)) / (len(est) - 1) if len(est) > 1 else 1.0
    return value, len(est), float(np.sqrt(max(chi2, 1.0) / cw[-1]))


#: Readings of :func:`_estimate` kept, by the content they were read from:
#: with ``--eps-r auto`` the parameters read the medium from the prepared
#: data and the run's check (:func:`check_medium`) meets the same data again
#: (0.45 s a reading on a 421-trace GSSI line, most of it the apexes' focus).
READINGS_KEPT = 4

_readings: dict[bytes, tuple[float, int, float, str]] = {}


def _content_key(data, height: float | None) -> bytes:
    """A digest of everything :func:`_estimate` reads: the profiles, the
    range axis, the antennas' positions, the waveform and ``height``."""
    h = hashlib.blake2b(digest_size=20)
    for a in (data.signal, data.range, data.array.positions()):
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(a.reshape(-1).view(np.uint8))
    h.update(repr((data.waveform.fc, data.waveform.bandwidth, height)).encode())
    return h.digest()


def _estimate(data, height: float | None) -> tuple[float, int, float, str]:
    """The tracks' fit (:func:`_fit`; Fermat's paths with antennas
    ``height`` above a half-space), or where no track qualifies (and there
    is no half-space) the apexes' (:func:`rpm_cl.extract.apex.apex_eps_r`):
    (eps_r, how many took part, its error, what they were, in words).  The
    last :data:`READINGS_KEPT` readings are kept by their data's content."""
    key = _content_key(data, height)
    if key not in _readings:
        while len(_readings) >= READINGS_KEPT:
            _readings.pop(next(iter(_readings)))
        _readings[key] = _read(data, height)
    return _readings[key]


def _read(data, height: float | None) -> tuple[float, int, float, str]:
    """:func:`_estimate`, read."""
    eps, n, err = _fit(data.array.positions(), tracks(data), height)
    if n or height:
        return eps, n, err, f"{n} hyperbola{'s' if n != 1 else ''}"
    # no track is long enough (dense, shallow bars): the apexes' focus
    from .apex import apex_eps_r

    eps, n, err = apex_eps_r(data)
    return eps, n, err, f"focused at {n} apexes"


def read_eps_r(data, antenna_height: float | None = None) -> float:
    """``eps_r`` read from the data (``--eps-r auto``): the value
    :func:`check_medium` would compare the setting with, clipped to
    [1, ``EPS_R_MAX``]; 1 (air), with a warning, where nothing pins it or
    the reading lies below 1.

    Parameters
    ----------
    data : RadarData
        As the method images it (after the steps before imaging).
    antenna_height : float or None
        m: above a half-space the tracks are Fermat's paths (no apex reading
        there).

    Returns
    -------
    float

    Warns
    -----
    DataWarning
        Planar arrays, and scans whose tracks and apexes pin no value: one
        line saying that air is imaged and that ``--eps-r`` sets the medium;
        a reading below 1: one line naming it and its causes.
    """
    import logging

    if data.array.planar:
        eps, n, what = float("nan"), 0, ""
    else:
        eps, n, _, what = _estimate(data, antenna_height or None)
    if n == 0:
        warnings.warn(
            "eps_r auto: no echo track or apex of this scan pins the medium"
            + (" (planar arrays are not read)" if data.array.planar else "")
            + "; imaging as air: set --eps-r",
            DataWarning,
            stacklevel=3,
        )
        return 1.0
    if eps < 1.0:
        warnings.warn(
            f"eps_r auto: the echoes' range walks read eps_r = {eps:.2f} ({what}), below "
            f"air (extended targets, or an air gap: --antenna-height); imaging as air",
            DataWarning,
            stacklevel=3,
        )
    value = float(np.clip(eps, 1.0, EPS_R_MAX))
    logging.getLogger("rpm_cl").info("eps_r auto: %.3g (%s)", value, what)
    return value


def check_medium(data, medium: Medium) -> float | None:
    """Warn when the fitted ``eps_r`` of the data's tracks
    (:func:`tracks`, :func:`fit_eps_r`) and the medium's differ by more than
    :data:`MISMATCH` times.

    Parameters
    ----------
    data : RadarData
        As the method images it (after :mod:`rpm_cl.extract.preprocess`: a
        background removed leaves the targets' tracks, not the flat coupling
        and surface echoes); planar arrays are not checked.
    medium : Medium

    Returns
    -------
    float or None
        The fitted value when a track qualified; where none did (and the
        medium is no half-space), the apexes' reading
        (:func:`rpm_cl.extract.apex.apex_eps_r`) when enough focused; else
        None.

    Warns
    -----
    DataWarning
        One line naming the fitted value and the option that sets it; never
        for a fit below 1 on air data (extended targets, module notes).
    """
    if data.array.planar:
        return None
    eps, n, err, what = _estimate(data, medium.antenna_height if medium.half_space else None)
    if n == 0:
        return None
    # the mismatch must stand beyond the tracks' own disagreement
    if (eps - SURE * err) / medium.eps_r > MISMATCH:
        warnings.warn(
            f"the echoes' range walks fit eps_r = {eps:.2f} ({what}), but the "
            f"medium is set to eps_r = {medium.eps_r:g}: image with --eps-r {eps:.2f} "
            f"(or check the antenna height)",
            DataWarning,
            stacklevel=3,
        )
    elif (eps + SURE * err) / medium.eps_r < 1.0 / MISMATCH and not medium.air:
        warnings.warn(
            f"the echoes' range walks fit eps_r = {eps:.2f} ({what}), but the "
            f"medium is set to eps_r = {medium.eps_r:g}: try --eps-r {max(eps, 1.0):.2f}, or "
            f"--antenna-height where the antennas are above the surface (an air gap, like "
            f"extended targets, makes the walks fit low)",
            DataWarning,
            stacklevel=3,
        )
    return eps
