"""Every imaging method behind one call, registered by name.

An :class:`Imager` maps ``RadarData`` to an :class:`rpm_cl.result.ImageResult`
(image points, the RPs they came from, stage timings); :func:`run_method`
runs one by name after the steps every method shares (preprocessing, the
data checks).  ``rpm-cl image --method`` and ``batch --method`` take any of
:data:`METHODS`; ``bench``, ``reproduce`` and the robustness benchmark
iterate over the RPM family (:data:`RPM_METHODS`) and add DAS and RMA rows
on grids of their own.

- ``kspace-rpm``: k-space decomposition -> clustered RPs -> RPM per cluster
  (the paper's method, eq. 2-6).
- ``mf-rpm``: RPs of the plain matched filter (one cluster) -> RPM (the
  conventional RPM input, for comparison).
- ``capon-rpm``: RPs of the Capon range filter with frequency averaging
  (:mod:`rpm_cl.extract.capon`, the paper's comparator) -> RPM.
- ``phase-rpm``: the k-space decomposition's RPs with their ranges refined by
  each echo's carrier phase across the array (:mod:`rpm_cl.extract.phase`) -> RPM.
- ``das``, ``rma``: the coherent baselines (:mod:`rpm_cl.baselines.imagers`):
  an image on a grid taken from the data, its peaks as the points.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .baselines.imagers import das_method, rma_method
from .extract.hyperbola import check_medium
from .extract.preprocess import preprocess
from .io.data import InputError, RadarData
from .io.medium import seen_data
from .result import ImageResult
from .rpm.methods import capon_rpm, kspace_rpm, mf_rpm, phase_rpm
from .rpm.params import PREPROCESS_FIELDS, ImagingParams

__all__ = [
    "DEFAULT_METHOD",
    "METHODS",
    "RPM_METHODS",
    "Imager",
    "prepared",
    "run_method",
    "timed_run",
]


@dataclass(frozen=True)
class Imager:
    """One imaging method, as the registry holds it.

    Attributes
    ----------
    name : str
        What ``--method`` calls it.
    family : {"rpm", "coherent"}
        "rpm": range points, then RPM (it runs on the scene its extraction
        sees in a medium, :func:`rpm_cl.io.medium.seen_data`, and its RPs come
        back with air-equivalent ranges); "coherent": an image on a grid
        and its peaks, no range points (it handles the medium itself).
    run : callable
        ``run(data, params, engine) -> ImageResult``.
    summary : str
        One line for ``rpm-cl image --help``.
    """

    name: str
    family: str
    run: Callable[..., ImageResult]
    summary: str


#: Every imaging method by name, the paper's first.
METHODS = {
    m.name: m
    for m in (
        Imager(
            "kspace-rpm",
            "rpm",
            kspace_rpm,
            "k-space decomposition -> RPs per cluster -> RPM (the paper's method)",
        ),
        Imager(
            "phase-rpm",
            "rpm",
            phase_rpm,
            "kspace-rpm with each RP's range refined by its echo's phase",
        ),
        Imager("mf-rpm", "rpm", mf_rpm, "matched-filter RPs (one cluster) -> RPM"),
        Imager("capon-rpm", "rpm", capon_rpm, "Capon range-filter RPs -> RPM"),
        Imager(
            "das",
            "coherent",
            das_method,
            "delay-and-sum image on a grid from the data, its peaks as points",
        ),
        Imager(
            "rma",
            "coherent",
            rma_method,
            "range-migration (f-k) image of a linear array, its peaks as points",
        ),
    )
}
#: The RPM family's names (range points, then RPM).
RPM_METHODS = tuple(n for n, m in METHODS.items() if m.family == "rpm")


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
        above the k-space peak threshold: the decomposition drops the
        sidelobes' centres, and with them any weaker echo at their direction.

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
        imager = METHODS[name]
    except KeyError:
        raise InputError(f"unknown method {name!r}; choose from {', '.join(METHODS)}") from None
    data, params = prepared(data, params)
    if name in ("kspace-rpm", "phase-rpm"):
        _check_sidelobes(data, params.kspace.peak_threshold_db)
    medium = params.medium
    check_medium(data, medium)
    if imager.family == "coherent":
        return imager.run(data, params, engine)
    # in a medium the method runs on the scene of rpm_cl.io.medium.seen_data
    # (in air: ``data`` itself)
    result = imager.run(seen_data(data, medium), params, engine)
    if np.size(result.rps.range) == 0:
        _warn_empty(data, params)
    if not medium.air:  # RPs as measured: air-equivalent ranges
        from dataclasses import replace

        from .rpm.halfspace import to_air

        result = replace(result, rps=to_air(result.rps, medium))
    return result


def prepared(data: RadarData, params: ImagingParams) -> tuple[RadarData, ImagingParams]:
    """The data after the preprocessing steps of ``params``
    (:func:`rpm_cl.extract.preprocess.preprocess`), and the parameters the
    methods run with.

    Where the steps cut the range axis (``time_zero``, ``max_range``) and no
    ``kspace.noise_power`` is given, the noise power is measured on the
    whole axis first (after the background removal, as the imaged gates
    are) and passed on as ``kspace.noise_power``: the gates a region of
    interest keeps are those that hold the scene, too few or too full of
    echoes for the decomposition's own estimate
    (:func:`rpm_cl.extract.kspace.measured_noise_power`).  Not with a gain,
    whose noise power changes along the range.
    """
    from dataclasses import replace

    steps = {k: getattr(params, k) for k in PREPROCESS_FIELDS}
    # a record that starts before the pulse, warned of where time zero is 0
    late = params.time_zero == 0 and params.medium.antenna_height is None
    cuts = params.time_zero > 0 or params.max_range is not None
    if not cuts or params.kspace.noise_power is not None or params.gain_db_per_m != 0:
        return preprocess(data, **steps, late_pulse=late), params
    # the background goes first, on every gate (it is per gate, so cutting
    # before or after it gives the same profiles); then the cut
    whole = preprocess(
        data,
        background=params.background,
        align_traces=params.align_traces,
        coupling_zero=params.time_zero,
        late_pulse=late,
    )
    out = preprocess(whole, **{**steps, "background": "none", "align_traces": False})
    if out.range.size < whole.range.size:
        from .extract.kspace import measured_noise_power

        power = measured_noise_power(whole)
        if power is not None:
            params = replace(params, kspace=replace(params.kspace, noise_power=power))
    return out, params


def _warn_empty(data: RadarData, params: ImagingParams) -> None:
    """One line where the RPM family found no range point in data that hold
    echoes: where the strongest echo is, and what to try."""
    import warnings

    from .io.data import DataWarning

    s = np.abs(data.signal.reshape(-1, data.range.size))
    if not s.max() > 0:
        return
    g = int(np.median(s.argmax(axis=1)))
    warnings.warn(
        f"no range point passed the thresholds; the strongest echo lies at range "
        f"{data.range[g]:.3g} m at most antennas (background {params.background!r}): "
        f"if that is the antennas' coupling or a surface, try --background mean or "
        f"--time-zero past it, else a lower --peak-threshold-db",
        DataWarning,
        stacklevel=3,
    )


#: Windows the sidelobe warning names, lowest sidelobes last, with their
#: levels over 81 samples (dB; :func:`rpm_cl.io.compress.range_sidelobe_db`),
#: used where the data keep no frequency samples to measure them on.
SIDELOBE_WINDOWS = (("hann", -31.5), ("hamming", -42.6), ("blackman", -58.2))


#: Range profiles (no samples) whose echoes' symmetric sidelobes are
#: measured: the strongest antennas' (at least half the strongest peak), at
#: most this many.
SIDELOBE_ANTENNAS = 64
#: ... over this many range resolutions either side of each peak.
SIDELOBE_REACH = 6.0
#: ... where they stand this many times above the profile's median (its
#: noise, where echoes fill few of its gates).
SIDELOBE_OVER_NOISE = 4.0
#: The main lobe of an echo's profile ends where it first falls under this
#: share of its peak (-26 dB).
SIDELOBE_LOBE_EDGE = 0.05


def profile_sidelobe_db(data: RadarData) -> float | None:
    """The range sidelobe level of range profiles given without their
    samples, measured on the data, dB (None where no echo stands clear).

    About the peak of each of the strongest antennas' profiles, the level
    at each offset is the lesser of the two sides (a window's sidelobes lie
    on both sides of an echo, another echo on one); the median over the
    antennas, beyond the main lobe's edge (:data:`SIDELOBE_LOBE_EDGE`) and within
    :data:`SIDELOBE_REACH` resolutions, gives the level; offsets at which
    a profile stands less than :data:`SIDELOBE_OVER_NOISE` times above its
    median (the noise, symmetric too) count as no sidelobe.  Two other echoes
    equally far before and behind a stronger one at most antennas would
    read as a sidelobe.
    """
    mag = np.abs(data.signal.reshape(-1, data.range.size))
    peak = mag.max(axis=1)
    if not np.any(peak > 0):
        return None
    strong = np.flatnonzero(peak >= 0.5 * peak.max())
    strong = strong[np.argsort(-peak[strong], kind="stable")][:SIDELOBE_ANTENNAS]
    reach = int(np.ceil(SIDELOBE_REACH * data.waveform.range_resolution / data.dr))
    m = np.arange(1, reach + 1)
    rows = []
    for a in strong:
        p = int(np.argmax(mag[a]))
        if p - reach < 0 or p + reach >= data.range.size:
            continue
        side = np.minimum(mag[a, p - m], mag[a, p + m])
        # the noise is symmetric about an echo too: only what stands
        # SIDELOBE_OVER_NOISE above the profile's median counts
        side = np.where(side > SIDELOBE_OVER_NOISE * np.median(mag[a]), side, 0.0)
        rows.append(side / mag[a, p])
    if not rows:
        return None
    sym = np.median(np.asarray(rows), axis=0)
    # the main lobe ends at the first null after it falls under
    # SIDELOBE_LOBE_EDGE of the peak (noise ripples the slope above that, so
    # the first local minimum will not do)
    below = np.flatnonzero(sym < SIDELOBE_LOBE_EDGE)
    if not below.size:
        return None
    j = int(below[0])
    while j + 1 < sym.size and sym[j + 1] <= sym[j]:  # on down to the null
        j += 1
    side = sym[j:].max()
    return float(20 * np.log10(side)) if side > 0 else None


def _check_sidelobes(data: RadarData, threshold_db: float) -> None:
    """Warn when the range sidelobes reach above the k-space peak threshold.

    The decomposition drops centres that the stronger echoes' sidelobes at
    their k explain (:func:`rpm_cl.extract.kspace_detect.above_leakage`),
    and with them any weaker echo there: the fix named is a window with
    lower sidelobes, below the threshold (measured on the data's own
    frequency samples where it has them).  Where no window's lie below it,
    the threshold is what to change."""
    import warnings

    from .io.data import DataWarning

    sl = data.range_sidelobe_db
    if sl is None and data.spectrum is None:
        sl = profile_sidelobe_db(data)
        if sl is not None and threshold_db < sl:
            warnings.warn(
                f"the range profiles' sidelobes reach {sl:.1f} dB about their echoes, above "
                f"the k-space peak threshold {threshold_db:g} dB (profiles compressed "
                f"without a window?): each strong echo's sidelobes may become clusters of "
                f"spurious points; compress them with a window (hann: -31.5 dB), or give "
                f"the frequency samples (spectrum, frequency) and --range-window",
                DataWarning,
                stacklevel=3,
            )
        return
    if sl is None or threshold_db >= sl:
        return
    levels = dict(SIDELOBE_WINDOWS)
    if data.spectrum is not None:
        from .io.compress import range_sidelobe_db, window_bandwidth

        f = data.spectrum.frequency
        # a window with no sidelobe beyond half a resolution (a handful of
        # samples) has none to name a level for
        levels = {w: range_sidelobe_db(f, w, window_bandwidth(f, w)) for w in levels}
    fits = [
        f"{w} ({lv:.1f} dB)" if lv is not None else w
        for w, lv in levels.items()
        if lv is None or lv < threshold_db
    ]
    if fits:
        names = " or ".join(f"--range-window {name}" for name in fits[:2])
        fix = f"use a window with lower sidelobes: {names}"
    else:  # every level is a number here: a window without one fits
        fix = (
            f"no window's sidelobes lie below it (blackman {levels['blackman']:.1f} dB): "
            f"raise --peak-threshold-db above {sl:.1f}"
        )
    cost = (
        "echoes weaker than a stronger one's sidelobes at their direction are dropped "
        "with those sidelobes"
        if data.compression is not None
        else "each strong echo's sidelobes may become clusters of spurious points"
    )
    warnings.warn(
        f"the range compression's sidelobes reach {sl:.1f} dB, above the k-space "
        f"peak threshold {threshold_db:g} dB: {cost}; {fix}",
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
