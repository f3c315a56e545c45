"""Imaging methods behind one interface, with a registry by name.

A method maps ``RadarData`` to an :class:`ImageResult` (RPs, image points,
stage timings).  ``--method`` and ``reproduce`` iterate over :data:`METHODS`.

- ``kspace-rpm``: k-space decomposition -> clustered RPs -> RPM per cluster
  (the paper's method, eq. 2-6).
- ``mf-rpm``: RPs of the plain matched filter (one cluster) -> RPM (the
  conventional RPM input, for comparison).
- ``capon-rpm``: RPs of the Capon range filter with frequency averaging
  (:mod:`rpm_cl.extract.capon`, the paper's comparator) -> RPM.
- ``phase-rpm``: the k-space decomposition's RPs with their ranges refined by
  each echo's carrier phase across the array (:mod:`rpm_cl.extract.phase`) -> RPM.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from .extract.hyperbola import check_medium
from .extract.kspace import KSpaceParams, decompose
from .extract.preprocess import check as check_preprocess
from .extract.preprocess import preprocess
from .extract.rangepoints import RangePoints, rps_from_decomposition, rps_from_profiles
from .io.data import InputError, RadarData
from .io.medium import Medium, seen_data
from .rpm.neighbours import neighbour_lists
from .rpm.reference import MS_DENSITY_T

#: The paper's sigma_r for 2-D (Section V-A2), m.
SIGMA_R_DEFAULT = 0.05
#: Linear arrays: sigma_x is at most this many times the range of the
#: strongest echo (the half-width a target at that range is seen over by an
#: antenna of +-63 deg beam, tan 63.4 deg = 2): a GPR line of metres must
#: not weigh antennas a scan length apart as neighbours.
SIGMA_X_PER_RANGE = 2.0
#: phase-rpm: a point seen from its main RP's antenna more than this far
#: from boresight (the array's normal), deg, lies beyond the antenna's reach
#: and is dropped.  Noise-free, the paper's scenes and the human body put
#: every point within 60 deg (the body's within 45); on the sparse scene at
#: 20 dB every point beyond 60 deg was more than 50 mm from the targets
#: (``python benchmarks/reach.py``).  Real antennas' beams are narrower.
REACH_DEG_DEFAULT = 70.0
#: k-space window period for planar arrays, rad/m: the measured best on the
#: paper's 3-D scene (0.8-1.2 k-space resolution cells of its 11 x 17 array;
#: see rpm_cl.simulate.scene._human_body).  Linear arrays: WINDOW_LINEAR_PER_KC.
WINDOW_PLANAR_DEFAULT = 60.0
#: k-space window period of linear arrays as a multiple of the carrier
#: wavenumber k_c (rad/m per rad/m): the paper's 417 rad/m is k_c at its 20
#: GHz (419 rad/m), a quarter of the visible wavenumbers |k| < 2 k_c.  A fixed
#: 417 rad/m held every echo of a 4 GHz scan (2 k_c = 168 rad/m) in one
#: cluster (gprMax fixture, 3.875-4.125 GHz: 9 % of the points within 50 mm;
#: at k_c, 70-94 % over windows of 60-84 rad/m; `python
#: benchmarks/gprmax_image.py`).
WINDOW_LINEAR_PER_KC = 1.0
#: RPs below this level relative to their cluster's maximum are dropped, dB.
RP_THRESHOLD_DB_DEFAULT = -10.0

__all__ = [
    "DEFAULT_METHOD",
    "METHODS",
    "Image",
    "ImageResult",
    "ImagingParams",
    "RPMParams",
    "default_params",
    "pair_windows",
    "rpm_image",
    "run_method",
    "save_result",
    "timed_run",
]


@dataclass(frozen=True)
class RPMParams:
    """Settings of the RPM step (eq. 6).

    Attributes
    ----------
    sigma_x : float
        sigma_x (sigma_D) of the antenna-distance weight, m.
    sigma_r : float
        sigma_r of the Gaussian kernel between intersection points, m.
    min_cluster_rps : int
        Clusters with fewer RPs are not imaged (an intersection needs 2).
    max_cluster_rps : int
        2-D: a main RP whose pair window (the RPs of its cluster within
        ``pair_cutoff_2d * sigma_x``) holds more RPs is refused with an
        error (the scoring work per main RP grows as the window's square).
        3-D clusters of any size are imaged: each main RP scores a bounded
        neighbour list.
    chunk_slots : int
        Main RPs are processed in chunks of at most this many candidate slots
        (main RPs x slots per main RP), which bounds device memory.
    pair_cutoff : float
        3-D: sub RPs farther than ``pair_cutoff * sigma_x`` from the main
        antenna are not paired (their weight in eq. 11 is below
        exp(-pair_cutoff^2 / 2)); inf pairs the whole cluster.
    max_neighbours : int
        3-D: at most this many sub RPs per main RP; the triplet candidates per
        main RP are their pairs, max_neighbours^2 / 2, and the scoring work per
        main RP grows as their square.  Clusters the mean shift refines that
        hold one RP per antenna take ``meanshift_neighbours`` instead (the
        human body's, by default: there this field does not enter).
    pair_cutoff_2d : float
        2-D: sub RPs farther than ``pair_cutoff_2d * sigma_x`` from the main
        antenna are not paired (their weight exp(-D^2 / 2 sigma_x^2) in eq. 6
        is below exp(-8) = 3.4e-4 at the default 4); the slots per main RP are
        then the RPs of its cluster within that distance, not the whole
        cluster.  The paper's 2-D scenes (sigma_x = the aperture) pair
        exhaustively either way.  inf pairs the whole cluster.
    near_neighbours : int or None
        3-D: how many of those are the nearest (within ``pair_cutoff *
        sigma_x``); the rest are spread evenly over the cluster by distance
        rank (long, well-conditioned baselines; see
        :mod:`rpm_cl.rpm.neighbours`).  None: all nearest.
    meanshift_iters : int
        3-D: after the argmax over the list's triplets, at most this many
        steps towards the mode of the *exhaustive* eq. 10 density (every pair
        of the cluster; :func:`rpm_cl.rpm.reference.meanshift_spheres`):
        Newton's on log f where it is concave enough, else mean shift's, each
        O(pairs) per main RP; 0 turns it off (the list's argmax is the point).
    meanshift_max_rps : int
        3-D: mean shift only in clusters of at most this many RPs.  A step
        costs about (near sub RPs) x (cluster RPs) pairs per main RP: the
        human body's clusters (187 RPs, one per antenna) take about 0.2 s
        in all (two passes and the density pass),
        a 32 x 32 array's (about 1000 RPs each) 5.3 s on top of the list's
        3.2 s (RPM <= 10 mm 99.0 % against 97.9 %), a 64 x 64 array's 60 s;
        so by default those keep the list's argmax.
    meanshift_neighbours : int or None
        3-D: the list length (``max_neighbours``) in the clusters the mean
        shift refines that hold one RP per antenna (the k-space
        decomposition's: one echo per antenna, one surface); there the
        list's argmax only picks where the steps start, so a shorter list
        gives the same points for less (see docs/model.md, "RPM, 3-D").  Clusters
        with several RPs at an antenna (the matched-filter and Capon
        baselines put the whole scene in one) have a mode per surface, and
        the longer list starts nearer the exhaustive argmax's.  Used as
        given, also when longer than ``max_neighbours``; None:
        ``max_neighbours``.
    meanshift_point : {"argmax", "sphere", "nearest", "mode"}
        3-D, with mean shift: the image point.  "argmax" (default): the
        exhaustive argmax sought among the candidates nearest to the mode,
        :data:`rpm_cl.rpm.reference.MS_DENSITY_T` of them scored with the
        exhaustive density (:func:`rpm_cl.rpm.reference.density_spheres`, one
        more pass).  On the human body (``python benchmarks/exhaustive_3d.py
        --snr 20 --steps 0 3``) 97.8 % of the points are the exhaustive
        eq. 10 image's own to 1 um, 98.9 % to 0.1 mm and 99.9 % to 1 mm
        with the default 3 steps (noise-free 96.7 / 98.6 / 99.9 %; the mode
        put back on the sphere, ``"sphere"``: 5.6 % to 0.1 mm, median 0.40
        mm).  The rest are float32 ties: eq. 10 evaluated
        in float64 at both points differs by at most 9.1e-7 (noise-free
        7.0e-7) of the density, and ours is the higher in 56 % (63 %).
        With float64 kernels (``--precision float64``) 99.8 % (noise-free
        99.5 %) are the float64 exhaustive image's own; the density of the
        other 4 (11) of 2057 is within 1.5e-6 (8.8e-8) of the maximum
        (noise-free, 10 of the 11 are the exhaustive point mirrored in x,
        main RPs on the symmetric scene's centre column).
        "sphere": the mode put back on the main RP's sphere (radially from
        its antenna); "nearest": the candidate nearest to the start of the
        last step; "mode": the mode itself.
    """

    sigma_x: float = 0.10
    sigma_r: float = SIGMA_R_DEFAULT
    min_cluster_rps: int = 2
    max_cluster_rps: int = 8192
    chunk_slots: int = 1 << 22
    pair_cutoff: float = 2.0
    max_neighbours: int = 24
    near_neighbours: int | None = 4
    pair_cutoff_2d: float = 4.0
    meanshift_iters: int = 3
    meanshift_max_rps: int = 512
    meanshift_neighbours: int | None = 12
    meanshift_point: Literal["argmax", "sphere", "nearest", "mode"] = "argmax"

    def __post_init__(self):
        for name in ("sigma_x", "sigma_r"):
            v = getattr(self, name)
            # 1 um .. 1 km keeps 1/(2 sigma^2) finite and non-zero in float32
            if not (np.isfinite(v) and 1e-6 <= v <= 1e3):
                raise InputError(f"{name} must be between 1e-6 and 1e3 m, got {v}")
        if self.min_cluster_rps < 2:
            raise InputError(f"min_cluster_rps must be >= 2, got {self.min_cluster_rps}")
        for name in ("pair_cutoff", "pair_cutoff_2d"):
            if not (getattr(self, name) > 0):
                raise InputError(f"{name} must be > 0 (inf allowed), got {getattr(self, name)}")
        if not (2 <= self.max_neighbours <= 4096):
            raise InputError(f"max_neighbours must be in 2..4096, got {self.max_neighbours}")
        if self.meanshift_neighbours is not None and not (2 <= self.meanshift_neighbours <= 4096):
            raise InputError(
                f"meanshift_neighbours must be in 2..4096, got {self.meanshift_neighbours}"
            )
        # a shorter meanshift_neighbours list takes min(near, its length) nearest
        if self.near_neighbours is not None and not (
            0 <= self.near_neighbours <= self.max_neighbours
        ):
            raise InputError(
                f"near_neighbours must be in 0..max_neighbours, got {self.near_neighbours}"
            )
        if not (0 <= self.meanshift_iters <= 1000):
            raise InputError(f"meanshift_iters must be in 0..1000, got {self.meanshift_iters}")
        if self.meanshift_max_rps < 0:
            raise InputError(f"meanshift_max_rps must be >= 0, got {self.meanshift_max_rps}")
        if self.meanshift_point not in ("argmax", "sphere", "nearest", "mode"):
            raise InputError(
                "meanshift_point must be 'argmax', 'sphere', 'nearest' or 'mode', got "
                f"{self.meanshift_point!r}"
            )
        if self.chunk_slots < 1:
            raise InputError(f"chunk_slots must be >= 1, got {self.chunk_slots}")
        if self.max_cluster_rps < self.min_cluster_rps:
            raise InputError(
                f"max_cluster_rps ({self.max_cluster_rps}) must be >= "
                f"min_cluster_rps ({self.min_cluster_rps})"
            )


@dataclass(frozen=True)
class ImagingParams:
    """All imaging settings: decomposition, RP extraction, RPM and the medium."""

    kspace: KSpaceParams = field(default_factory=KSpaceParams)
    rpm: RPMParams = field(default_factory=RPMParams)
    medium: Medium = field(default_factory=Medium)
    rp_threshold_db: float = RP_THRESHOLD_DB_DEFAULT
    multipath: Literal["drop", "flag"] = "drop"
    reach_deg: float = REACH_DEG_DEFAULT
    background: Literal["none", "mean", "median"] = "none"
    time_zero: float = 0.0
    gain_db_per_m: float = 0.0
    max_range: float | None = None

    def __post_init__(self):
        check_preprocess(self.background, self.time_zero, self.gain_db_per_m, self.max_range)
        if not (np.isfinite(self.rp_threshold_db) and self.rp_threshold_db < 0):
            raise InputError(f"rp_threshold_db must be < 0, got {self.rp_threshold_db}")
        if not (np.isfinite(self.reach_deg) and 0 < self.reach_deg <= 90):
            raise InputError(f"reach_deg must be in (0, 90] degrees, got {self.reach_deg}")
        if self.multipath not in ("drop", "flag"):
            raise InputError(f"multipath must be 'drop' or 'flag', got {self.multipath!r}")


def default_params(data: RadarData, **overrides) -> ImagingParams:
    """Parameters derived from the array when not given.

    - sigma_x (sigma_D): linear arrays, the aperture length (the paper's 2-D
      choice: 100 mm for its 100 mm aperture, 400 mm for the 400 mm sparse
      one), but no more than :data:`SIGMA_X_PER_RANGE` times the range of
      the strongest echo (:func:`_strongest_range`; a long scan's antennas
      far apart do not see one target) nor less than 2.5 spacings; planar arrays, 2.5 antenna spacings (the paper: "two or three
      times of sensor separations").
    - sigma_r: from the aperture and the range, as the paper says it "could
      be roughly estimated" (Section II): two circles from antennas a baseline
      b apart, each with a range error delta, cross at a point displaced by
      about delta * R / b across the range direction, so the intersection
      points of an RP spread over about ``delta * R / L`` for the aperture
      L (the largest extent of the array) and the range R of the strongest
      echo (the peak of the profile power summed over the antennas, echoes
      within half a range resolution of zero, antenna coupling, left out:
      :func:`_derived_sigma_r`), with delta = 10 mm (the paper's Err_range criterion of an accurate RP).
      At least the range-gate spacing.  This gives the paper's 2-D scene 45
      mm (the paper sets 50 mm), its sparse one 12 mm and the human body 85
      mm.  Measured against the presets' 50 mm (the paper's value; the presets
      keep it): the k-space RPM rows of ``reproduce paper-2d`` are equal or a
      point better, and the human body's points within 10 mm go from 94.7 %
      to 95.6 % (noise-free) and 94.2 % to 95.2 % (20 dB); the Capon and
      matched-filter comparators on the sparse scene lose 2-3 of about 20
      points within 50 mm.
    - window_x: linear arrays :data:`WINDOW_LINEAR_PER_KC` times the carrier
      wavenumber (417 rad/m, the paper's 2-D value, at its 20 GHz),
      :data:`WINDOW_PLANAR_DEFAULT` for planar ones; window_z = window_x.
    - in a medium (``eps_r``, ``antenna_height``): sigma_r and window_x of
      the scene the RP extraction sees (:func:`rpm_cl.io.medium.seen_data`:
      ranges divided by sqrt(eps_r), carrier wavenumber k_c sqrt(eps_r)).
    - everything else: the dataclass defaults.

    Parameters
    ----------
    data : RadarData
    overrides : keyword arguments
        Any field of :class:`RPMParams`, :class:`KSpaceParams`,
        :class:`rpm_cl.io.medium.Medium` or the plain fields of
        :class:`ImagingParams`, by name (each name is routed to the
        dataclass that has it, so a field added there is accepted here).
        None means "the default" (use :func:`dataclasses.replace` on the
        result to set a field to None).

    Raises
    ------
    InputError
        An unknown name, ``window_z`` for a linear array, or a value the
        dataclasses reject.
    """
    from dataclasses import fields

    arr = data.array
    ov = {k: v for k, v in overrides.items() if v is not None}
    top = {f.name for f in fields(ImagingParams)} - {"kspace", "rpm", "medium"}
    rpm_names = {f.name for f in fields(RPMParams)}
    ks_names = {f.name for f in fields(KSpaceParams)}
    medium_names = {f.name for f in fields(Medium)}
    unknown = sorted(set(ov) - top - rpm_names - ks_names - medium_names)
    if unknown:
        raise InputError(f"unknown imaging parameter {unknown[0]!r}")
    medium = Medium(**{k: v for k, v in ov.items() if k in medium_names})
    data = preprocess(data, **{k: v for k, v in ov.items() if k in _PREPROCESS})
    seen = seen_data(data, medium)  # what the decomposition and RPM see
    r_echo = _strongest_range(seen)
    if arr.planar:
        sigma_x = 2.5 * max(arr.dx, arr.dz)
    else:
        sigma_x = float(arr.x[-1] - arr.x[0])
        if r_echo is not None:  # no wider than the echo's reach
            sigma_x = min(sigma_x, max(SIGMA_X_PER_RANGE * r_echo, 2.5 * arr.dx))
    rpm_kw = {"sigma_x": sigma_x, "sigma_r": _derived_sigma_r(seen, r_echo)}
    derived = {k for k in ("sigma_x", "sigma_r") if k not in ov}
    rpm_kw.update({k: v for k, v in ov.items() if k in rpm_names})
    top_kw = {k: v for k, v in ov.items() if k in top}
    if derived:  # a value the array gave, not the user: say so
        try:
            RPMParams(**{k: rpm_kw[k] for k in derived})
        except InputError as exc:
            raise InputError(
                f"{exc} (derived from the array: {data.array.n} antennas over "
                f"{float(np.ptp(data.array.positions()[:, 0])):g} m in x; check the "
                f"units of x / z (m), or set sigma_x / sigma_r)"
            ) from None
    ks_kw = {k: v for k, v in ov.items() if k in ks_names}
    if "window_z" in ks_kw and not arr.planar:
        raise InputError("window_z applies to planar arrays only; this array is linear")
    if arr.planar:
        ks_kw.setdefault("window_x", WINDOW_PLANAR_DEFAULT)
        ks_kw.setdefault("window_z", ks_kw["window_x"])
    else:
        ks_kw.setdefault("window_x", WINDOW_LINEAR_PER_KC * seen.waveform.kc)
    return ImagingParams(KSpaceParams(**ks_kw), RPMParams(**rpm_kw), medium, **top_kw)


def _strongest_range(data: RadarData) -> float | None:
    """The range of the strongest echo, m (None where the data hold none).

    The largest local maximum of the profile power summed over the
    antennas, among those at least half a range resolution or the aperture
    L from zero, whichever is less.  Closer maxima are left out: an echo
    there overlaps R = 0 within its main lobe, where antenna coupling and
    feed-through leakage sit (an echo at 1 mm set sigma_r to the gate
    spacing), and a scatterer that close cannot be told from them.  Half a
    resolution, not one, keeps the paper's 2-D scene (targets at 0.37-0.46
    m, resolution 0.75 m); the aperture bounds it for narrow bands, whose
    half resolution can exceed the whole scene (a 0.25 GHz sweep at 4 GHz:
    0.59 m, with objects at 0.29-0.6 m).  Where no maximum lies beyond, the
    strongest gate beyond is taken.
    """
    pos = data.array.positions()
    aperture = float(np.max(np.ptp(pos, axis=0))) if len(pos) > 1 else 0.0
    mag = np.abs(data.signal.reshape(-1, data.range.size))
    top = float(mag.max()) if mag.size else 0.0
    # relative powers: the argmax is all that counts, and squares of the
    # data's own scale would leave float64's range beyond 1e154
    power = np.sum((mag / top) ** 2, axis=0) if top > 0 else np.zeros(data.range.size)
    far = np.abs(data.range) >= min(0.5 * data.waveform.range_resolution, aperture)
    if aperture <= 0 or not np.any(power[far] > 0):
        return None
    padded = np.concatenate([[-np.inf], power, [-np.inf]])
    peak = (power >= padded[:-2]) & (power >= padded[2:]) & far & (power > 0)
    pick = np.where(peak if np.any(peak) else far, power, -np.inf)
    return abs(float(data.range[int(np.argmax(pick))]))


def _derived_sigma_r(data: RadarData, r: float | None, range_error: float = 0.01) -> float:
    """sigma_r = range_error * R / L (see :func:`default_params`), m, for
    the range R of the strongest echo (:func:`_strongest_range`) and the
    aperture L; :data:`SIGMA_R_DEFAULT` where there is none.  For narrow
    bands L also bounds R's search (see there), where the estimate, delta
    R / L, would otherwise fall below the range error delta itself."""
    pos = data.array.positions()
    aperture = float(np.max(np.ptp(pos, axis=0))) if len(pos) > 1 else 0.0
    if r is None or aperture <= 0:
        return SIGMA_R_DEFAULT
    return float(np.clip(range_error * r / aperture, data.dr, 1.0))


@dataclass(frozen=True)
class Image:
    """RPM image: one scattering-centre estimate per imaged main RP.

    Attributes
    ----------
    points : ndarray, shape (M, dim)
        (x, y) or (x, y, z), m.
    cluster : ndarray of int, shape (M,)
    score : ndarray, shape (M,)
        The maximised kernel-density value (eq. 6).
    rp_index : ndarray of int, shape (M,)
        Index of the main RP in the RangePoints.
    multipath : ndarray of bool, shape (M,), or None
        Points of clusters that a double bounce between two other objects
        explains (:mod:`rpm_cl.rpm.multipath`), kept because
        ``ImagingParams.multipath`` is "flag"; None where not assessed or
        such points were dropped.
    """

    points: np.ndarray
    cluster: np.ndarray
    score: np.ndarray
    rp_index: np.ndarray
    multipath: np.ndarray | None = None

    def keep(self, mask: np.ndarray) -> Image:
        """The points where ``mask`` (bool, shape (M,)) holds, every column alike."""
        return Image(
            self.points[mask],
            self.cluster[mask],
            self.score[mask],
            self.rp_index[mask],
            None if self.multipath is None else self.multipath[mask],
        )


@dataclass(frozen=True)
class ImageResult:
    """What a method returns: its RPs, the image, and stage timings (s)."""

    method: str
    rps: RangePoints
    image: Image
    timings: dict
    dropped: dict = field(default_factory=dict)


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


def _chunks(total: int, maxc: int, chunk_slots: int):
    step = max(1, chunk_slots // max(1, maxc))
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
    :func:`_argmax_near`); the score becomes the exhaustive density there."""
    best = np.concatenate([p[0] for p in parts])
    score = np.concatenate([p[1] for p in parts]).astype(np.float64)
    local = np.concatenate([p[2] for p in parts], axis=1).astype(np.float64)
    # main RPs of clusters up to meanshift_max_rps (clusters are contiguous,
    # so these are runs of indices)
    small = np.flatnonzero(_refined(count, params))
    if small.size == 0:
        return [(best, score, local)]
    # the scratch holds 5 rows of the largest cluster per main RP
    width = 5 * int(count[small].max())
    runs = np.split(small, np.flatnonzero(np.diff(small) > 1) + 1)
    for i0, n in (
        (int(run[0]) + a, b)
        for run in runs
        for a, b in _chunks(run.size, width, params.chunk_slots)
    ):
        sl = slice(i0, i0 + n)
        mode, dens, near, cnt = engine.meanshift_spheres(
            x,
            z,
            r,
            amp,
            start,
            count,
            local[:, sl],
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
            new = mode * (r[sl] / np.where(norm > 0, norm, 1.0))
        else:
            new = near[:, 0] if params.meanshift_point == "nearest" else mode
        moved = (best[sl] >= 0) & (dens > 0) & np.all(np.isfinite(new), axis=0)
        local[:, sl] = np.where(moved, new, local[:, sl])
        score[sl] = np.where(moved, dens, score[sl])
    return [(best, score, local)]


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
            x, z, r, amp, start, count, targets, params.sigma_x, params.sigma_r, i0, n
        ),
        np.float64,
    )
    f = np.where(np.isfinite(d2[pick, cols]), f, -np.inf)
    b = np.argmax(f, axis=0)
    return np.where(cnt > 0, f[b, cols], 0.0), targets[:, b, cols]


def _kspace_rpm(data: RadarData, params: ImagingParams, engine) -> ImageResult:
    t0 = time.perf_counter()
    # the near-field search's pair scans run on the engine's device, if any
    dec = decompose(data, params.kspace, getattr(engine, "env", None))
    t1 = time.perf_counter()
    rps = rps_from_decomposition(data, dec, params.rp_threshold_db)
    t2 = time.perf_counter()
    image = _rpm(rps, params, engine)
    t3 = time.perf_counter()
    return ImageResult(
        "kspace-rpm",
        rps,
        image,
        {"decompose": t1 - t0, "range_points": t2 - t1, "rpm": t3 - t2, "total": t3 - t0},
    )


def _phase_rpm(data: RadarData, params: ImagingParams, engine) -> ImageResult:
    from .extract.phase import phase_ranges

    t0 = time.perf_counter()
    dec = decompose(data, params.kspace, getattr(engine, "env", None))
    t1 = time.perf_counter()
    rps = rps_from_decomposition(data, dec, params.rp_threshold_db)
    if not dec.near_field and dec.clusters:
        rps, _ = phase_ranges(data, rps, np.array([c.k for c in dec.clusters]))
    t2 = time.perf_counter()
    image = _rpm(rps, params, engine)
    t3 = time.perf_counter()
    n_rpm = len(image.points)
    image = _multipath(data, rps, image, params.multipath, params.medium)
    n_single = len(image.points)
    image = in_reach(data.array, rps, image, params.reach_deg)
    t4 = time.perf_counter()
    return ImageResult(
        "phase-rpm",
        rps,
        image,
        {
            "decompose": t1 - t0,
            "range_points": t2 - t1,
            "rpm": t3 - t2,
            "multipath": t4 - t3,
            "total": t4 - t0,
        },
        {"multipath": n_rpm - n_single, "reach": n_single - len(image.points)},
    )


def _rpm(rps: RangePoints, params: ImagingParams, engine) -> Image:
    """RPM of the method's RPs: :func:`rpm_image`, or above a half-space
    :func:`rpm_cl.rpm.halfspace.halfspace_rpm` of their air-equivalent ranges
    (the refracted equal-time curves)."""
    if params.medium.half_space:
        from .rpm.halfspace import halfspace_rpm, to_air

        return halfspace_rpm(to_air(rps, params.medium), params.rpm, engine, params.medium)
    return rpm_image(rps, params.rpm, engine)


def _multipath(
    data: RadarData, rps: RangePoints, image: Image, mode: str, medium: Medium | None = None
) -> Image:
    """The image without (``"drop"``) or with flags on (``"flag"``) the
    points of double-bounce clusters (:mod:`rpm_cl.rpm.multipath`); above a
    half-space the double bounces' paths refract (``medium``)."""
    from dataclasses import replace

    from .rpm.multipath import flag_multipath

    resolution = data.waveform.range_resolution
    if medium is not None and medium.half_space:  # rps of the paraxial scene: back to air
        from .rpm.halfspace import to_air

        rps, resolution = to_air(rps, medium), resolution * medium.n
    flags = flag_multipath(
        data.array.positions(),
        rps,
        image,
        resolution,
        medium if medium is not None and medium.half_space else None,
    )
    if mode == "flag":
        return replace(image, multipath=flags)
    return image.keep(~flags)


def reach_angles(array, rps: RangePoints, image: Image) -> np.ndarray:
    """Each point's angle from boresight (the array's normal, +y) seen from
    the antenna of its main RP, deg, shape (M,)."""
    pos = array.positions()[np.asarray(rps.antenna)[image.rp_index]]
    p = image.points
    lateral = (
        np.abs(p[:, 0] - pos[:, 0])
        if p.shape[1] == 2
        else np.hypot(p[:, 0] - pos[:, 0], p[:, 2] - pos[:, 2])
    )
    return np.degrees(np.arctan2(lateral, p[:, 1]))


def in_reach(array, rps: RangePoints, image: Image, reach_deg: float) -> Image:
    """The image without the points beyond ``reach_deg`` from their main
    antenna's boresight (:func:`reach_angles`; ``ImageResult.dropped``
    counts them)."""
    if reach_deg >= 90 or image.points.shape[0] == 0:
        return image
    keep = reach_angles(array, rps, image) <= reach_deg
    return image if keep.all() else image.keep(keep)


def _mf_rpm(data: RadarData, params: ImagingParams, engine) -> ImageResult:
    t0 = time.perf_counter()
    rps = rps_from_profiles(data, params.rp_threshold_db)
    t1 = time.perf_counter()
    image = _rpm(rps, params, engine)
    t2 = time.perf_counter()
    return ImageResult(
        "mf-rpm", rps, image, {"range_points": t1 - t0, "rpm": t2 - t1, "total": t2 - t0}
    )


def _capon_rpm(data: RadarData, params: ImagingParams, engine) -> ImageResult:
    from .extract.capon import CaponParams, rps_from_capon

    t0 = time.perf_counter()
    rps = rps_from_capon(data, CaponParams(), params.rp_threshold_db)
    t1 = time.perf_counter()
    image = _rpm(rps, params, engine)
    t2 = time.perf_counter()
    return ImageResult(
        "capon-rpm", rps, image, {"range_points": t1 - t0, "rpm": t2 - t1, "total": t2 - t0}
    )


#: Imaging methods by name.
METHODS = {
    "kspace-rpm": _kspace_rpm,
    "phase-rpm": _phase_rpm,
    "mf-rpm": _mf_rpm,
    "capon-rpm": _capon_rpm,
}


#: The method ``rpm-cl image`` and ``batch`` run unless told otherwise: the
#: most accurate on the robustness benchmark (``python
#: benchmarks/robustness.py``) at about the paper's method's cost.
DEFAULT_METHOD = "phase-rpm"


#: The ImagingParams fields of :mod:`rpm_cl.extract.preprocess`.
_PREPROCESS = ("background", "time_zero", "gain_db_per_m", "max_range")


def run_method(name: str, data: RadarData, params: ImagingParams, engine) -> ImageResult:
    """Run the method called ``name`` (a key of :data:`METHODS`).

    Warns
    -----
    DataWarning
        When the echoes' hyperbolas fit another permittivity than
        ``params.medium`` (:func:`rpm_cl.extract.hyperbola.check_medium`).
    DataWarning
        ``kspace-rpm`` and ``phase-rpm`` (the k-space decomposition's
        methods) on data whose range sidelobes
        (``data.range_sidelobe_db``, known for a compressed spectrum) reach
        above the k-space peak threshold: each strong echo's sidelobes would
        become clusters of spurious points.

    Notes
    -----
    ``params.medium``: in a homogeneous medium the method images the
    equivalent air scene (:func:`rpm_cl.io.medium.in_medium`); above a
    half-space it extracts RPs from the paraxial scene
    (:func:`rpm_cl.io.medium.paraxial_data`) and images them with
    :func:`rpm_cl.rpm.halfspace.halfspace_rpm`.  Either way the RPs come back
    with the data's own air-equivalent ranges (c tau / 2, as measured, and as
    a file's ``truth_rp_range`` gives them), the image points in true
    metres.
    """
    try:
        fn = METHODS[name]
    except KeyError:
        raise InputError(f"unknown method {name!r}; choose from {', '.join(METHODS)}") from None
    data = preprocess(data, **{k: getattr(params, k) for k in _PREPROCESS})
    if name in ("kspace-rpm", "phase-rpm"):
        _check_sidelobes(data, params.kspace.peak_threshold_db)
    medium = params.medium
    check_medium(data, medium)
    # in a medium the method runs on the scene of rpm_cl.io.medium.seen_data
    # (in air: ``data`` itself)
    result = fn(seen_data(data, medium), params, engine)
    if not medium.air:  # RPs as measured: air-equivalent ranges
        from dataclasses import replace

        from .rpm.halfspace import to_air

        result = replace(result, rps=to_air(result.rps, medium))
    return result


def _check_sidelobes(data: RadarData, threshold_db: float) -> None:
    """Warn when the range sidelobes reach above the k-space peak threshold.

    The fix named is a window with lower sidelobes: a threshold raised above
    them removes the clusters beside each echo, but not those of sidelobe
    tails at gates thresholded apart (the dechirped gates, kspace module
    notes, step 2), whose threshold follows their own maximum."""
    import warnings

    from .io.data import DataWarning

    sl = data.range_sidelobe_db
    if sl is not None and threshold_db < sl:
        warnings.warn(
            f"the range compression's sidelobes reach {sl:.1f} dB, above the k-space "
            f"peak threshold {threshold_db:g} dB: each strong echo's sidelobes become "
            f"clusters of spurious points; use a window with lower sidelobes "
            f"(range_window='hann', --range-window hann: -31.5 dB)",
            DataWarning,
            stacklevel=3,
        )


def timed_run(name: str, data: RadarData, params: ImagingParams, engine, repeats: int = 1):
    """Run a method after one warm-up call (first-call costs excluded).

    Returns
    -------
    result : ImageResult
        The last run's result.
    seconds : float
        Median wall time of ``repeats`` runs, s(X, R) to points.
    stages : dict
        Median time of each stage, s.
    """
    run_method(name, data, params, engine)
    times, stages = [], {}
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        result = run_method(name, data, params, engine)
        times.append(time.perf_counter() - t0)
        for k, v in result.timings.items():
            stages.setdefault(k, []).append(v)
    return result, float(np.median(times)), {k: float(np.median(v)) for k, v in stages.items()}


def save_result(path, result: ImageResult, meta: dict | None = None) -> None:
    """Write an image result as ``.npz`` (atomically).

    Keys: ``points`` (M, 2|3), ``cluster`` (M,), ``score`` (M,), ``rp_index``
    (M,), the RPs ``rp_x`` (and ``rp_z`` for planar arrays), ``rp_range``,
    ``rp_amp``, ``rp_cluster``, ``rp_antenna``, and ``meta`` (a JSON string:
    method, version, device, parameters, stage timings).
    """
    from .io.data import atomic_savez
    from .io.formats import result_arrays

    out = result_arrays(result, meta)
    atomic_savez(path, **out)
