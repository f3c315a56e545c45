"""The RPM family's methods: range points by one of the extractions
(:mod:`rpm_cl.extract`), RPM of them (:mod:`rpm_cl.rpm.pipeline`, or
:mod:`rpm_cl.rpm.halfspace` above a half-space), and the point filters
(double bounces, the antennas' reach).  Each takes the data as its
extraction sees them (:func:`rpm_cl.io.medium.seen_data`) and returns an
:class:`rpm_cl.result.ImageResult`; :mod:`rpm_cl.imaging` registers them.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from ..extract.kspace import decompose
from ..extract.rangepoints import RangePoints, rps_from_decomposition, rps_from_profiles
from ..extract.segments import joined_rps, kept_rps, segment_data, segment_plan
from ..io.data import RadarData
from ..io.medium import Medium
from ..result import Image, ImageResult
from .params import ImagingParams, _strongest_range
from .pipeline import rpm_image

__all__ = [
    "capon_rpm",
    "in_reach",
    "kspace_rpm",
    "mf_rpm",
    "phase_plan",
    "phase_rpm",
    "reach_angles",
]


def kspace_rpm(data: RadarData, params: ImagingParams, engine) -> ImageResult:
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


def phase_plan(data: RadarData, params: ImagingParams) -> list | None:
    """The segments or tiles phase-rpm decomposes ``data`` in
    (:func:`rpm_cl.extract.segments.segment_plan`; planar tiles resolve the
    narrower window), or None where it decomposes them whole (also with
    ``params.segments`` off); ``data`` as the method sees them."""
    if not params.segments:
        return None
    ks = params.kspace
    return segment_plan(data, _strongest_range, min(ks.window_x, ks.window_z or ks.window_x))


def phase_rpm(data: RadarData, params: ImagingParams, engine) -> ImageResult:
    from ..extract.phase import phase_ranges, spherical_ranges

    t0 = time.perf_counter()
    ks = params.kspace
    if ks.close_centres is None:  # targets closer in direction than a window
        ks = replace(ks, close_centres=True)
    if ks.coherent_centres is None:  # weak echoes on strong ones' flanks
        ks = replace(ks, coherent_centres=True)
    plan = phase_plan(data, params)
    parts, spent = [], 0.0
    for antennas, kept in plan or [(None, None)]:
        part = data if plan is None else segment_data(data, antennas)
        ta = time.perf_counter()
        dec = decompose(part, ks, getattr(engine, "env", None))
        spent += time.perf_counter() - ta
        rps = rps_from_decomposition(part, dec, params.rp_threshold_db)
        if dec.near_field and dec.clusters:
            rps, _ = spherical_ranges(part, rps, dec.clusters)
        elif dec.clusters:
            r_c = np.array([c.r_centre for c in dec.clusters])
            rps, _ = phase_ranges(part, rps, _phase_k(part, dec.clusters), cluster_r=r_c)
        parts.append(rps if plan is None else kept_rps(rps, antennas, kept, data.array.shape))
    rps = parts[0] if plan is None else joined_rps(parts)
    # the part (segment or tile) each RP was found in, for the double-bounce test
    part_of = None if plan is None else np.repeat(np.arange(len(parts)), [len(p) for p in parts])
    t1 = t0 + spent
    t2 = time.perf_counter()
    image = _rpm(rps, params, engine)
    t3 = time.perf_counter()
    n_rpm = len(image.points)
    # points no antenna could have made go first, then those beside coherent
    # peaks (where they bridge the gap between two objects, the double-bounce
    # test takes the two for one); the double-bounce test, whose cost grows
    # with the clusters, sees what is left
    image = in_reach(data.array, rps, image, params.reach_deg)
    n_reach = len(image.points)
    image = without_coupling(data, rps, image)
    n_coupling = len(image.points)
    image = coherent(data, rps, image, params, engine)
    n_coherent = len(image.points)
    image = _multipath(data, rps, image, params.multipath, params.medium, part_of)
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
        {
            "reach": n_rpm - n_reach,
            "coupling": n_reach - n_coupling,
            "coherence": n_coupling - n_coherent,
            "multipath": n_coherent - len(image.points),
        },
    )


def _phase_k(data: RadarData, clusters) -> np.ndarray:
    """Each cluster's wavenumber for the phase refinement, rad/m, shape
    (n_clusters, n_k_axes): where the range-walk alignment ran, the alias it
    chose (``-2 k_c u`` of its range slopes ``u``), else the window's centre
    (the principal alias)."""
    kc = data.waveform.kc
    return np.array(
        [
            -2.0 * kc * np.asarray(c.direction, np.float64) if np.any(c.direction) else c.k
            for c in clusters
        ]
    )


def coherent(
    data: RadarData, rps: RangePoints, image: Image, params: ImagingParams, engine=None
) -> Image:
    """The image without the points beside a scatterer rather than on it
    (:mod:`rpm_cl.rpm.coherence`): linear arrays whose band is wide enough,
    with ``params.coherence`` on; ``data`` as the method saw them
    (:func:`rpm_cl.io.medium.seen_data`).  ``ImageResult.dropped``
    counts them.  The coherent sums run on ``engine``'s OpenCL device in
    float64 where it has one that takes doubles (:func:`device_sums`),
    else in NumPy."""
    from .coherence import MIN_FRACTIONAL_BANDWIDTH, coherent_keep

    if (
        not params.coherence
        or data.waveform.bandwidth < MIN_FRACTIONAL_BANDWIDTH * data.waveform.fc
        or data.array.planar
        or image.points.shape[0] == 0
    ):
        return image
    medium = params.medium
    if medium.half_space:  # the sums follow the refracted paths of the data as recorded
        from ..io.medium import recorded_data

        data = recorded_data(data, medium)
    # the antennas that saw each point: those of its cluster's RPs (sorted
    # by cluster)
    ids, first = np.unique(np.asarray(rps.cluster), return_index=True)
    x = np.asarray(rps.x, np.float64)
    at = np.searchsorted(ids, np.asarray(image.cluster))
    seen = np.column_stack([np.minimum.reduceat(x, first)[at], np.maximum.reduceat(x, first)[at]])
    keep = coherent_keep(
        data,
        image.points,
        params.coherence_db,
        params.reach_deg,
        medium,
        seen,
        device_sums(engine),
    )
    return image if keep.all() else image.keep(keep)


def device_sums(engine):
    """The coherent sums at points on ``engine``'s device, in float64
    (:meth:`rpm_cl.extract.backprojection_cl.PointSums.at_points`: its sums
    agree with the host's :func:`rpm_cl.extract.backprojection.at_points`
    to about 1e-13 of the largest, so the test keeps the same points), or
    None where the engine has no OpenCL device or it takes no doubles."""
    from ..extract.backprojection_cl import sums_on

    return sums_on(getattr(engine, "env", None))


def _rpm(rps: RangePoints, params: ImagingParams, engine) -> Image:
    """RPM of the method's RPs: :func:`rpm_image`, or above a half-space
    :func:`rpm_cl.rpm.halfspace.halfspace_rpm` of their air-equivalent ranges
    (the refracted equal-time curves)."""
    if params.medium.half_space:
        from .halfspace import halfspace_rpm, to_air

        return halfspace_rpm(to_air(rps, params.medium), params.rpm, engine, params.medium)
    return rpm_image(rps, params.rpm, engine)


def _multipath(
    data: RadarData,
    rps: RangePoints,
    image: Image,
    mode: str,
    medium: Medium | None = None,
    parts=None,
) -> Image:
    """The image without (``"drop"``) or with flags on (``"flag"``) the
    points of double-bounce clusters (:mod:`rpm_cl.rpm.multipath`); above a
    half-space the double bounces' paths refract (``medium``); ``parts``:
    per RP, the segment or tile it was found in (None: one decomposition)."""
    from .multipath import flag_multipath

    resolution = data.waveform.range_resolution
    wavelength = 2 * np.pi / data.waveform.kc
    if medium is not None and medium.half_space:  # rps of the paraxial scene: back to air
        from .halfspace import to_air

        rps, resolution = to_air(rps, medium), resolution * medium.n
        wavelength = wavelength * medium.n
    flags = flag_multipath(
        data.array.positions(),
        rps,
        image,
        resolution,
        medium if medium is not None and medium.half_space else None,
        parts,
        wavelength,
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


def without_coupling(data: RadarData, rps: RangePoints, image: Image) -> Image:
    """The image without the points whose main RP is a planar scan's own
    coupling (:func:`rpm_cl.extract.preprocess.coupling_rps`;
    ``ImageResult.dropped`` counts them)."""
    from ..extract.preprocess import coupling_rps

    if image.points.shape[0] == 0:
        return image
    own = coupling_rps(data, rps)
    if not own.any():
        return image
    return image.keep(~own[image.rp_index])


def mf_rpm(data: RadarData, params: ImagingParams, engine) -> ImageResult:
    t0 = time.perf_counter()
    rps = rps_from_profiles(data, params.rp_threshold_db)
    t1 = time.perf_counter()
    image = _rpm(rps, params, engine)
    t2 = time.perf_counter()
    return ImageResult(
        "mf-rpm", rps, image, {"range_points": t1 - t0, "rpm": t2 - t1, "total": t2 - t0}
    )


def capon_rpm(data: RadarData, params: ImagingParams, engine) -> ImageResult:
    from ..extract.capon import CaponParams, rps_from_capon

    t0 = time.perf_counter()
    rps = rps_from_capon(data, CaponParams(), params.rp_threshold_db)
    t1 = time.perf_counter()
    image = _rpm(rps, params, engine)
    t2 = time.perf_counter()
    return ImageResult(
        "capon-rpm", rps, image, {"range_points": t1 - t0, "rpm": t2 - t1, "total": t2 - t0}
    )
