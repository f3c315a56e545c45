"""Range-compressed radar data (:class:`RadarData`), validated at
construction: the signal's shape, dtype and amplitudes against the array and
the range axis, the range axis against the range resolution, the truth
against the array."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .checks import InputError, _finite_scalar, _uniform_axis, scale_hint
from .model import C0, Array, Truth, Waveform

#: Bounds of the largest signal amplitude accepted: a sum of all the samples
#: stays within float64 (at most SUM_MAX: the FFTs and the coherent sums add
#: up to every sample; powers are formed from amplitudes relative to the
#: largest), and the smallest peak keeps products with weights and windows
#: of 1e-8 normal numbers (float64's smallest normal is 2.2e-308).
SUM_MAX = 1e307
AMPLITUDE_MIN = 1e-300


#: A range resolution ``c / 2B`` more than BANDWIDTH_SPAN_WARN times the
#: range axis's span is warned about as a bandwidth in kHz numbers (the whole
#: axis within 1 % of one resolution cell), more than BANDWIDTH_SPAN_MAX
#: times refused as one in MHz or GHz numbers (as fc's are).  The searches
#: sized by the resolution are bounded by the axis, so such data cost what
#: the clean data do.  The frequency domain compares a given bandwidth with
#: its band by the same ratios.
BANDWIDTH_SPAN_WARN = 100.0
BANDWIDTH_SPAN_MAX = 1e4


def _bandwidth_line(bw: float, span: float, ratio: float) -> str:
    res = C0 / (2 * bw)
    return (
        f"bandwidth = {bw:g} Hz gives a range resolution c/2B = {res:g} m, over {ratio:g} "
        f"times the whole range axis ({span:g} m): it looks like "
        f"{scale_hint(bw, C0 / (2 * span))}; give fc and bandwidth in Hz"
    )


def profile_power(signal, nr: int) -> np.ndarray:
    """The profile power summed over the antennas, relative to the largest
    sample's: ``sum |s / max|s||^2`` per range gate, shape (nr,); zeros for a
    zero signal.  Relative, so that data at any scale (1e-300 .. 1e300) stay
    within float64's range when squared."""
    mag = np.abs(np.asarray(signal)).reshape(-1, nr)
    top = float(mag.max()) if mag.size else 0.0
    return np.sum((mag / top) ** 2, axis=0) if top > 0 else np.zeros(nr)


#: Range windows of :func:`rpm_cl.io.compress.range_compress` -> their names
#: in :func:`rpm_cl.io.windows.window` (SciPy's).
RANGE_WINDOWS = {
    "rect": "boxcar",
    "hann": "hann",
    "hamming": "hamming",
    "blackman": "blackman",
    "taylor": "taylor",
}


def window_key(name: str) -> str:
    """``name`` once it is a key of :data:`RANGE_WINDOWS`; else one line
    naming them."""
    if name not in RANGE_WINDOWS:
        raise InputError(f"unknown range window {name!r}; choose from {', '.join(RANGE_WINDOWS)}")
    return name


def mostly_common(v, share: float) -> bool:
    """Whether at least ``share`` of the power of the complex samples ``v``
    (one per antenna) is their mean's, ``|mean v|^2 / mean |v|^2``: an echo
    the antennas all see alike (False for none, all zero or not finite)."""
    v = np.asarray(v)
    top = float(np.abs(v).max()) if v.size else 0.0
    if not (np.isfinite(top) and top > 0):
        return False
    u = v.astype(np.complex128) / top  # any scale: no overflow in the powers
    return abs(complex(u.mean())) ** 2 >= share * float(np.mean(np.abs(u) ** 2))


@dataclass(frozen=True)
class Compression:
    """How a :class:`RadarData`'s profiles were compressed from frequency
    samples (:func:`rpm_cl.io.compress.range_compress`): the window over
    ``samples`` frequencies, inverse-transformed onto ``gates`` range gates
    (the periodic axis of the unambiguous range).  An echo's profile is the
    window's response about it, whatever was done since to the profiles
    but a gain (a background, a cut of the axis, a medium's scaling of the
    ranges): the k-space search bounds its range sidelobes by it
    (:func:`rpm_cl.extract.kspace_detect.sidelobe_envelope`)."""

    window: str
    samples: int
    gates: int

    def __post_init__(self):
        window_key(self.window)
        if not 2 <= int(self.samples) <= int(self.gates):
            raise InputError(
                f"a compression of {self.samples} samples onto {self.gates} gates: the "
                f"samples must be 2 or more and no more than the gates"
            )


@dataclass(frozen=True)
class Spectrum:
    """The frequency samples a :class:`RadarData`'s signal was compressed
    from (:func:`rpm_cl.io.compress.range_compress`): any range's profile
    can be formed from them exactly, with any window.

    Attributes
    ----------
    values : ndarray, complex, shape (nx[, nz], nf)
        ``Y(f_n)``; an echo of range ``R`` and amplitude ``a`` is
        ``a exp(-j 4 pi f_n R / c)``.
    frequency : ndarray, shape (nf,)
        Uniform, strictly increasing, > 0, Hz.
    window : str
        The range window the signal was compressed with (a key of
        :data:`rpm_cl.io.compress.RANGE_WINDOWS`): what changes the samples
        changes the profiles alike (:func:`rpm_cl.extract.preprocess.preprocess`
        takes a planar scan's coupling out of both).
    """

    values: np.ndarray
    frequency: np.ndarray
    window: str = "hann"

    def __post_init__(self):
        y = np.asarray(self.values)
        if not np.iscomplexobj(y):
            raise InputError(f"spectrum must be complex, got dtype {y.dtype}")
        f = _uniform_axis("frequency", self.frequency, 2)
        if f[0] <= 0:
            raise InputError(f"frequency must be > 0, starts at {f[0]:g} Hz")
        if y.ndim < 2 or y.shape[-1] != f.size:
            raise InputError(
                f"spectrum's last axis ({y.shape[-1] if y.ndim else 0}) must match "
                f"frequency ({f.size})"
            )
        # C order: the coherent sums read rows of it per track; complex64 or
        # complex128 (long double is not an array type of numpy.linalg)
        y = y.astype(np.complex64 if y.dtype == np.complex64 else np.complex128, copy=False)
        object.__setattr__(self, "values", np.ascontiguousarray(y))
        object.__setattr__(self, "frequency", f)
        window_key(self.window)

    def scaled(self, factor: float) -> Spectrum:
        """The same samples at ``factor`` times the frequencies: the scene
        seen with ranges divided by ``factor`` (a medium of index
        ``factor``, :func:`rpm_cl.io.medium.in_medium`)."""
        return Spectrum(self.values, self.frequency * factor, self.window)


@dataclass(frozen=True)
class RadarData:
    """Range-compressed radar data, validated at construction.

    Attributes
    ----------
    signal : ndarray, complex, shape (nx, nr) or (nx, nz, nr)
        Baseband range profiles s(X[, Z], R); phase ``exp(-2j k_c R_t)`` at a
        target of range ``R_t``.
    array : Array
    range : ndarray, shape (nr,)
        Uniform range axis, m.
    waveform : Waveform
    truth : Truth, optional
    range_sidelobe_db : float, optional
        The strongest range sidelobe of the range compression that a k-space
        peak search can take for an echo (one beyond half a range
        resolution from its main lobe), dB relative to the main lobe, < 0;
        known for a spectrum compressed by :func:`rpm_cl.io.formats.range_compress`,
        None otherwise.  Imaging warns when a peak threshold lies below it.
    spectrum : Spectrum, optional
        The frequency samples ``signal`` was compressed from, where the
        input was a spectrum (:func:`rpm_cl.io.load.load_data`) and nothing
        since has changed the profiles but a cut of the range axis; None
        otherwise.  phase-rpm forms its coherent sums from them
        (:mod:`rpm_cl.extract.phase`).  Whatever makes new profiles from
        the data (``dataclasses.replace(data, signal=...)``) must pass
        ``spectrum=None`` with them, or the sums describe the old ones.
    compression : Compression, optional
        The window and transform the profiles were compressed with, where
        the input was a spectrum; kept through what leaves each echo's
        profile the window's response (a background, a cut of the range
        axis), None after a gain or a resampling of the profiles.
    """

    signal: np.ndarray
    array: Array
    range: np.ndarray
    waveform: Waveform
    truth: Truth | None = field(default=None)
    range_sidelobe_db: float | None = field(default=None)
    spectrum: Spectrum | None = field(default=None)
    compression: Compression | None = field(default=None)

    def __post_init__(self):
        s = np.asarray(self.signal)
        if not np.iscomplexobj(s):
            raise InputError(
                f"signal must be complex baseband (complex64/complex128), got dtype {s.dtype}"
            )
        rng = _uniform_axis("range", self.range, 2)
        want = self.array.shape + (rng.size,)
        if s.shape != want:
            raise InputError(
                f"signal must have shape {want} (array {self.array.shape} x "
                f"range {rng.size}), got {s.shape}"
            )
        if not np.all(np.isfinite(s)):
            raise InputError("signal contains NaN or Inf")
        if rng[0] < 0:
            raise InputError(f"range must be >= 0, starts at {rng[0]:g} m")
        res = self.waveform.range_resolution
        dr = float(rng[1] - rng[0])
        if dr > res:
            raise InputError(
                f"range spacing {dr:g} m is coarser than the range resolution "
                f"c/2B = {res:g} m: range peaks cannot be located (range is "
                f"in m: millimetre numbers are 1000 times too large)"
            )
        span = float(rng[-1] - rng[0])
        if res > BANDWIDTH_SPAN_MAX * span:
            raise InputError(_bandwidth_line(self.waveform.bandwidth, span, BANDWIDTH_SPAN_MAX))
        if dr < 1e-9 * res:
            raise InputError(
                f"range spacing {dr:g} m is below 1e-9 of the range resolution {res:g} m"
            )
        t = self.truth
        if t is not None:
            if t.boundary.shape[1] != self.array.dim or len(t.boundary) == 0:
                raise InputError(
                    f"truth_boundary must have shape (P>0, {self.array.dim}) for "
                    f"this array, got {t.boundary.shape}"
                )
            if (
                t.has_rps
                and t.rp_antenna.size
                and (t.rp_antenna.min() < 0 or t.rp_antenna.max() >= self.array.n)
            ):
                raise InputError(f"truth_rp_antenna must index the {self.array.n} antennas")
        peak = float(np.max(np.abs(s))) if s.size else 0.0
        top = SUM_MAX / max(s.size, 1)
        if peak > 0 and not AMPLITUDE_MIN <= peak <= top:
            raise InputError(
                f"signal amplitudes up to {peak:.3g} are outside {AMPLITUDE_MIN:g} .. "
                f"{top:.3g} (for {s.size} samples: a sum of them all stays within "
                f"float64's range); scale the data"
            )
        # complex64 stays complex64 unless |s|^2 would leave float32's range
        # (1.2e-38 .. 3.4e38) on the way: then complex128, exactly
        keep64 = s.dtype == np.complex64 and (peak == 0 or 1e-15 <= peak <= 1e15)
        s = s.astype(np.complex64 if keep64 else np.complex128, copy=False)
        object.__setattr__(self, "signal", s)
        object.__setattr__(self, "range", rng)
        sl = self.range_sidelobe_db
        if sl is not None:
            sl = _finite_scalar("range_sidelobe_db", sl, positive=False)
            if sl >= 0:
                raise InputError(f"range_sidelobe_db must be < 0 dB, got {sl:g}")
            object.__setattr__(self, "range_sidelobe_db", sl)
        sp = self.spectrum
        if sp is not None:
            if not isinstance(sp, Spectrum):
                raise InputError(f"spectrum must be a Spectrum, got {type(sp).__name__}")
            if sp.values.shape[:-1] != self.array.shape:
                raise InputError(
                    f"spectrum must have shape {self.array.shape} x frequency, got "
                    f"{sp.values.shape}"
                )

    @property
    def dr(self) -> float:
        """Range sample spacing, m."""
        return float(self.range[1] - self.range[0])

    @property
    def range_period(self) -> float:
        """The period of the range axis, m, where it is a compressed
        spectrum's whole unambiguous range (``compression``): an echo whose
        main lobe straddles the axis's start wraps to its end.  0 where the
        axis is no such period."""
        comp = self.compression
        if comp is None or self.range.size != comp.gates:
            return 0.0
        return comp.gates * self.dr
