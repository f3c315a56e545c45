"""Imaging parameters: RPM's own (:class:`RPMParams`), the whole run's
(:class:`ImagingParams`: decomposition, RPM, medium, preprocessing, point
filters), and the defaults derived from the data (:func:`default_params`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from ..extract.kspace import KSpaceParams
from ..extract.preprocess import align, pick_time_zero, preprocess
from ..extract.preprocess import check as check_preprocess
from ..io.data import InputError, RadarData
from ..io.medium import Medium, seen_data
from ..io.radar import profile_power

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
#: phase-rpm on linear arrays: a point whose coherent (DAS) magnitude lies
#: more than this far below the largest within about one cross-range
#: resolution of it sits beside a scatterer, not on it, and is dropped
#: (:mod:`rpm_cl.rpm.coherence`), dB.
COHERENCE_DB_DEFAULT = -6.0
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
#: sigma_x of planar arrays in antenna spacings (the paper: "two or three
#: times of sensor separations"), and the least sigma_x of a linear one.
SIGMA_X_SPACINGS = 2.5
#: Range error of an accurate RP behind the derived sigma_r, m: the paper's
#: Err_range criterion (10 mm).
SIGMA_R_RANGE_ERROR = 0.01
#: RPs below this level relative to their cluster's maximum are dropped, dB.
RP_THRESHOLD_DB_DEFAULT = -10.0

#: The ImagingParams fields of :mod:`rpm_cl.extract.preprocess`.
PREPROCESS_FIELDS = ("align_traces", "background", "time_zero", "gain_db_per_m", "max_range")

__all__ = [
    "COHERENCE_DB_DEFAULT",
    "PREPROCESS_FIELDS",
    "REACH_DEG_DEFAULT",
    "RP_THRESHOLD_DB_DEFAULT",
    "SIGMA_R_DEFAULT",
    "SIGMA_R_RANGE_ERROR",
    "SIGMA_X_PER_RANGE",
    "SIGMA_X_SPACINGS",
    "WINDOW_LINEAR_PER_KC",
    "WINDOW_PLANAR_DEFAULT",
    "ImagingParams",
    "RPMParams",
    "default_params",
    "is_auto",
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
    meanshift_sample : int
        3-D, with mean shift: each cluster's steps first run on every
        ``meanshift_sample``-th of its main RPs (at least 8); where the
        median distance they move the point is below a twentieth of
        ``sigma_r`` (:data:`rpm_cl.rpm.pipeline.MS_SAMPLE_TOL`), the list's
        argmax already sits at the exhaustive mode and the cluster keeps it
        without the steps (:func:`rpm_cl.rpm.pipeline._moving`).  On the
        human body every cluster's points move (median 0.2 sigma_r) and
        every cluster takes the steps; on phase-rpm's clusters of spheres
        they move 0.014 sigma_r or less (nine clusters of ten), and the
        steps are skipped.  A
        skipped cluster's scores are the list's eq. 10 ones, as those of
        clusters over ``meanshift_max_rps``; a stepped cluster's are the
        exhaustive density.  Clusters of fewer than 32 main RPs are not
        sampled; 0: every cluster takes the steps.
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
    meanshift_sample: int = 16

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
        if not (0 <= self.meanshift_sample <= 1 << 20):
            raise InputError(
                f"meanshift_sample must be in 0..{1 << 20}, got {self.meanshift_sample}"
            )
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
    coherence: bool = True
    coherence_db: float = COHERENCE_DB_DEFAULT
    segments: bool = True
    align_traces: bool = False
    background: Literal["auto", "none", "mean", "median"] = "auto"
    # None ("auto") is resolved from the data by default_params
    # (rpm_cl.extract.preprocess.pick_time_zero); a parameter set holds a range
    time_zero: float | None = 0.0
    gain_db_per_m: float = 0.0
    max_range: float | None = None

    def __post_init__(self):
        check_preprocess(self.background, self.time_zero, self.gain_db_per_m, self.max_range)
        if not (np.isfinite(self.rp_threshold_db) and self.rp_threshold_db < 0):
            raise InputError(f"rp_threshold_db must be < 0, got {self.rp_threshold_db}")
        if not (np.isfinite(self.reach_deg) and 0 < self.reach_deg <= 90):
            raise InputError(f"reach_deg must be in (0, 90] degrees, got {self.reach_deg}")
        if not (-60.0 <= self.coherence_db < 0):
            raise InputError(f"coherence_db must be in [-60, 0) dB, got {self.coherence_db}")
        if self.multipath not in ("drop", "flag"):
            raise InputError(f"multipath must be 'drop' or 'flag', got {self.multipath!r}")


def is_auto(value) -> bool:
    """Whether ``value`` is the word "auto" (any case, spaces around): a
    setting read from the data (``eps_r``)."""
    return isinstance(value, str) and value.strip().lower() == "auto"


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
        result to set a field to None), but ``time_zero`` None or "auto"
        picks time zero from the data
        (:func:`rpm_cl.extract.preprocess.pick_time_zero`, on the aligned
        traces with ``align_traces``), and ``eps_r`` "auto" reads the
        medium from the echoes' hyperbolas after the steps before imaging
        (:func:`rpm_cl.extract.hyperbola.read_eps_r`; air, with a warning,
        where none pins it).

    Raises
    ------
    InputError
        An unknown name, ``window_z`` for a linear array, or a value the
        dataclasses reject.
    """
    from dataclasses import fields

    arr = data.array
    if overrides.get("align_traces"):
        # once, as preprocess would first: the pick and the derivations below
        # see the aligned traces (jitter blurs the pulse)
        data = align(data, warn=False)
    if "time_zero" in overrides and (
        overrides["time_zero"] is None or overrides["time_zero"] == "auto"
    ):
        zero = pick_time_zero(data, overrides.get("antenna_height"))
        overrides = {**overrides, "time_zero": zero}
    ov = {k: v for k, v in overrides.items() if v is not None}
    top = {f.name for f in fields(ImagingParams)} - {"kspace", "rpm", "medium"}
    rpm_names = {f.name for f in fields(RPMParams)}
    ks_names = {f.name for f in fields(KSpaceParams)}
    medium_names = {f.name for f in fields(Medium)}
    unknown = sorted(set(ov) - top - rpm_names - ks_names - medium_names)
    if unknown:
        raise InputError(f"unknown imaging parameter {unknown[0]!r}")
    # the pipeline preprocesses again (rpm_cl.imaging.prepared), and warns there
    steps = {k: v for k, v in ov.items() if k in PREPROCESS_FIELDS and k != "align_traces"}
    data = preprocess(data, **steps, warn=False)  # aligned above
    if is_auto(ov.get("eps_r")):
        from ..extract.hyperbola import read_eps_r

        ov["eps_r"] = read_eps_r(data, ov.get("antenna_height"))
    medium = Medium(**{k: v for k, v in ov.items() if k in medium_names})
    seen = seen_data(data, medium)  # what the decomposition and RPM see
    r_echo = _strongest_range(seen)
    if arr.planar:
        sigma_x = SIGMA_X_SPACINGS * max(arr.dx, arr.dz)
    else:
        sigma_x = float(arr.x[-1] - arr.x[0])
        if r_echo is not None:  # no wider than the echo's reach
            sigma_x = min(sigma_x, max(SIGMA_X_PER_RANGE * r_echo, SIGMA_X_SPACINGS * arr.dx))
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
    power = profile_power(data.signal, data.range.size)
    far = np.abs(data.range) >= min(0.5 * data.waveform.range_resolution, aperture)
    if aperture <= 0 or not np.any(power[far] > 0):
        return None
    padded = np.concatenate([[-np.inf], power, [-np.inf]])
    peak = (power >= padded[:-2]) & (power >= padded[2:]) & far & (power > 0)
    pick = np.where(peak if np.any(peak) else far, power, -np.inf)
    return abs(float(data.range[int(np.argmax(pick))]))


def _derived_sigma_r(
    data: RadarData, r: float | None, range_error: float = SIGMA_R_RANGE_ERROR
) -> float:
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
