"""Imaging methods behind one interface, with a registry by name.

A method maps ``RadarData`` to an :class:`ImageResult` (RPs, image points,
stage timings).  ``--method`` and ``reproduce`` iterate over :data:`METHODS`.

- ``kspace-rpm``: k-space decomposition -> clustered RPs -> RPM per cluster
  (the paper's method, eq. 2-6).
- ``mf-rpm``: RPs of the plain matched filter (one cluster) -> RPM (the
  conventional RPM input, for comparison).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from .data import InputError, RadarData
from .kspace import KSpaceParams, decompose
from .rangepoints import RangePoints, rps_from_decomposition, rps_from_profiles

#: The paper's sigma_r for 2-D (Section V-A2), m.
SIGMA_R_DEFAULT = 0.05
#: RPs below this level relative to their cluster's maximum are dropped, dB.
RP_THRESHOLD_DB_DEFAULT = -10.0

__all__ = ["RPMParams", "ImagingParams", "Image", "ImageResult", "rpm_image", "METHODS", "save_result", "timed_run",
           "run_method", "default_params"]


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
        Larger clusters are refused with an error (the scoring work grows as
        the cube of a cluster's size).
    chunk_slots : int
        Main RPs are processed in chunks of at most this many candidate slots
        (main RPs x largest cluster), which bounds device memory.
    """

    sigma_x: float = 0.10
    sigma_r: float = SIGMA_R_DEFAULT
    min_cluster_rps: int = 2
    max_cluster_rps: int = 8192
    chunk_slots: int = 1 << 22

    def __post_init__(self):
        for name in ("sigma_x", "sigma_r"):
            v = getattr(self, name)
            # 1 um .. 1 km keeps 1/(2 sigma^2) finite and non-zero in float32
            if not (np.isfinite(v) and 1e-6 <= v <= 1e3):
                raise InputError(f"{name} must be between 1e-6 and 1e3 m, got {v}")
        if self.min_cluster_rps < 2:
            raise InputError(f"min_cluster_rps must be >= 2, got {self.min_cluster_rps}")
        if self.chunk_slots < 1 or self.max_cluster_rps < self.min_cluster_rps:
            raise InputError("chunk_slots must be >= 1 and max_cluster_rps >= min_cluster_rps")


@dataclass(frozen=True)
class ImagingParams:
    """All imaging settings: decomposition, RP extraction and RPM."""

    kspace: KSpaceParams = field(default_factory=KSpaceParams)
    rpm: RPMParams = field(default_factory=RPMParams)
    rp_threshold_db: float = RP_THRESHOLD_DB_DEFAULT

    def __post_init__(self):
        if not (np.isfinite(self.rp_threshold_db) and self.rp_threshold_db < 0):
            raise InputError(f"rp_threshold_db must be < 0, got {self.rp_threshold_db}")


def default_params(data: RadarData, **overrides) -> ImagingParams:
    """Parameters derived from the array when not given.

    sigma_x defaults to the aperture length (the paper's 2-D choice: 100 mm
    for its 100 mm aperture, 400 mm for the 400 mm sparse one); sigma_r to
    50 mm (the paper's 2-D value); window_x to 417 rad/m (the paper's).

    Parameters
    ----------
    overrides : keyword arguments
        ``sigma_x``, ``sigma_r``, ``window_x``, ``window_z`` and any other
        :class:`KSpaceParams` field, ``rp_threshold_db``.
    """
    arr = data.array
    aperture = float(arr.x[-1] - arr.x[0])
    sigma_x = overrides.pop("sigma_x", None)
    sigma_r = overrides.pop("sigma_r", None)
    rpm_kw = {"sigma_x": aperture if sigma_x is None else sigma_x,
              "sigma_r": SIGMA_R_DEFAULT if sigma_r is None else sigma_r}
    rp_thr = overrides.pop("rp_threshold_db", None)
    ks = {k: v for k, v in overrides.items() if v is not None}
    if "window_z" in ks and not arr.planar:
        raise InputError("window_z applies to planar arrays only; this array is linear")
    params = ImagingParams(KSpaceParams(**ks), RPMParams(**rpm_kw))
    return replace(params, rp_threshold_db=rp_thr) if rp_thr is not None else params


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
    """

    points: np.ndarray
    cluster: np.ndarray
    score: np.ndarray
    rp_index: np.ndarray


@dataclass(frozen=True)
class ImageResult:
    """What a method returns: its RPs, the image, and stage timings (s)."""

    method: str
    rps: RangePoints
    image: Image
    timings: dict


def rpm_image(rps: RangePoints, params: RPMParams, engine) -> Image:
    """RPM (eq. 6) over every cluster of ``rps``.

    Parameters
    ----------
    rps : RangePoints
        2-D RPs (linear array), sorted by cluster.
    params : RPMParams
    engine : object
        :mod:`rpm_cl.rpm.reference` (float64 NumPy) or a
        :class:`rpm_cl.rpm.DeviceRPM`; anything with ``rpm_circles``.

    Returns
    -------
    Image
    """
    if rps.dim != 2:
        raise InputError("rpm_image handles 2-D RPs (linear arrays)")
    cstart, ccount = rps.cluster_bounds()
    keep = ccount >= params.min_cluster_rps
    idx = np.nonzero(keep)[0]
    empty = Image(np.zeros((0, 2)), np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int64))
    if idx.size == 0:
        return empty
    too_big = int(ccount[idx].max())
    if too_big > params.max_cluster_rps:
        raise InputError(f"a cluster holds {too_big} RPs, more than max_cluster_rps="
                         f"{params.max_cluster_rps}; raise the RP or peak thresholds")
    # re-index the kept RPs (clusters stay contiguous)
    x, r = np.asarray(rps.x)[idx], np.asarray(rps.range)[idx]
    # amplitudes scaled to a maximum of 1: the argmax of eq. 6 is unchanged and
    # float32 kernels keep their range whatever the data's scale.
    amp = np.asarray(rps.amp, np.float64)[idx]
    scale = float(amp.max()) if amp.size and amp.max() > 0 else 1.0
    amp = amp / scale
    start, count = np.searchsorted(idx, cstart[idx]), ccount[idx]
    maxc = int(count.max())
    step = max(1, params.chunk_slots // maxc)
    best, score, px, py = [], [], [], []
    for i0 in range(0, idx.size, step):
        b, s_, p = engine.rpm_circles(x, r, amp, start, count, maxc, params.sigma_x,
                                      params.sigma_r, i0, min(step, idx.size - i0))
        best.append(b), score.append(s_), px.append(p[0]), py.append(p[1])
    best, score = np.concatenate(best), np.concatenate(score).astype(np.float64) * scale
    px, py = np.concatenate(px), np.concatenate(py)
    ok = best >= 0
    pts = np.stack([x[ok] + px[ok], py[ok]], axis=1).astype(np.float64)
    return Image(pts, np.asarray(rps.cluster)[idx][ok], score[ok], idx[ok])


def _kspace_rpm(data: RadarData, params: ImagingParams, engine) -> ImageResult:
    t0 = time.perf_counter()
    dec = decompose(data, params.kspace)
    t1 = time.perf_counter()
    rps = rps_from_decomposition(data, dec, params.rp_threshold_db)
    t2 = time.perf_counter()
    image = rpm_image(rps, params.rpm, engine)
    t3 = time.perf_counter()
    return ImageResult("kspace-rpm", rps, image,
                       {"decompose": t1 - t0, "range_points": t2 - t1, "rpm": t3 - t2,
                        "total": t3 - t0})


def _mf_rpm(data: RadarData, params: ImagingParams, engine) -> ImageResult:
    t0 = time.perf_counter()
    rps = rps_from_profiles(data, params.rp_threshold_db)
    t1 = time.perf_counter()
    image = rpm_image(rps, params.rpm, engine)
    t2 = time.perf_counter()
    return ImageResult("mf-rpm", rps, image,
                       {"range_points": t1 - t0, "rpm": t2 - t1, "total": t2 - t0})


#: Imaging methods by name.
METHODS = {"kspace-rpm": _kspace_rpm, "mf-rpm": _mf_rpm}


def run_method(name: str, data: RadarData, params: ImagingParams, engine) -> ImageResult:
    """Run the method called ``name`` (a key of :data:`METHODS`)."""
    try:
        fn = METHODS[name]
    except KeyError:
        raise InputError(f"unknown method {name!r}; choose from {', '.join(METHODS)}") from None
    return fn(data, params, engine)


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
    import json

    from .data import atomic_savez

    rps, img = result.rps, result.image
    out = {"points": img.points, "cluster": img.cluster, "score": img.score,
           "rp_index": img.rp_index, "rp_x": rps.x, "rp_range": rps.range, "rp_amp": rps.amp,
           "rp_cluster": rps.cluster, "rp_antenna": rps.antenna}
    if rps.z is not None:
        out["rp_z"] = rps.z
    info = {"method": result.method, "timings": result.timings, **(meta or {})}
    out["meta"] = np.array(json.dumps(info, default=str))
    atomic_savez(path, **out)
