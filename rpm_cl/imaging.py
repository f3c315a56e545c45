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

import numpy as np

from .extract.hyperbola import check_medium
from .extract.kspace import decompose
from .extract.preprocess import preprocess
from .extract.rangepoints import RangePoints, rps_from_decomposition, rps_from_profiles
from .io.data import InputError, RadarData
from .io.medium import Medium, seen_data
from .result import ImageResult
from .rpm.params import PREPROCESS_FIELDS, ImagingParams
from .rpm.pipeline import Image, rpm_image

__all__ = ["DEFAULT_METHOD", "METHODS", "run_method", "timed_run"]


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
    data = preprocess(data, **{k: getattr(params, k) for k in PREPROCESS_FIELDS})
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
