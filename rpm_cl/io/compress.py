"""Range compression of frequency-domain samples into the time-domain
contract (:func:`range_compress`: a windowed inverse FFT zero-padded to
:data:`RANGE_OVERSAMPLE` gates per resolution cell), the bandwidth and the
strongest range sidelobe a window gives (:func:`window_bandwidth`,
:func:`range_sidelobe_db`), and the checks of a spectrum on its way (its
frequency axis, its fc and bandwidth against the band, a conjugated
recording, an echo wrapped from beyond the unambiguous range).  The formula
and the defaults of fc and bandwidth: :mod:`rpm_cl.io.formats`."""

from __future__ import annotations

import numpy as np

from .checks import (
    FC_MAX,
    FC_MIN,
    DataWarning,
    InputError,
    _uniform_axis,
    carrier,
    scale_hint,
    unit_hint,
)
from .model import C0, Waveform
from .radar import (
    BANDWIDTH_SPAN_MAX,
    BANDWIDTH_SPAN_WARN,
    RANGE_WINDOWS,
    Compression,
    RadarData,
    Spectrum,
    mostly_common,
    profile_power,
    window_key,
)
from .windows import window

#: Zero-padding of the range FFT: at least this many range gates per
#: resolution cell ``c / (2 nf df)`` of the whole band.
RANGE_OVERSAMPLE = 16


def next_fast_len(n: int) -> int:
    """The smallest 11-smooth number >= ``n`` (``scipy.fft.next_fast_len(n)``
    for complex transforms: the lengths pocketfft transforms fastest).
    NumPy's FFT (pocketfft, as SciPy's) gives the complex transforms here
    bit for bit equal to SciPy's, without its import."""
    m = max(int(n), 1)
    while True:
        k = m
        for p in (2, 3, 5, 7, 11):
            while k % p == 0:
                k //= p
        if k == 1:
            return m
        m += 1


def _window_name(name) -> str:
    return RANGE_WINDOWS[window_key(name)]


def _window(name: str, n: int) -> np.ndarray:
    w = window(_window_name(name), n)
    if not np.any(w > 0):  # hann, blackman ... over 1 or 2 samples: zero at both ends
        raise InputError(
            f"the {name} range window over {n} frequency samples is all zero; "
            f"use range_window='rect' (--range-window rect) or more samples"
        )
    return w


def _frequency_axis(values) -> np.ndarray:
    f = _uniform_axis("frequency", values, min_len=2, unit="Hz")
    if f[0] <= 0:
        raise InputError(f"frequency must be > 0 Hz, starts at {f[0]:g} Hz")
    if f[-1] < FC_MIN:  # as Waveform refuses such an fc: the same words either way
        raise InputError(
            f"frequency reaches only {f[-1]:g} Hz, below {FC_MIN:g} Hz: it looks "
            f"like {unit_hint(f[-1])}; give it in Hz"
        )
    if f[0] > FC_MAX:  # as Waveform refuses such an fc
        raise InputError(
            f"frequency starts at {f[0]:g} Hz, above {FC_MAX:g} Hz (10 THz): not "
            f"a radar band; give it in Hz"
        )
    return f


#: A spectrum is taken for a conjugated one when at least this share of its
#: compressed power lies in the last quarter of the unambiguous range (and
#: so, mirrored, in the first quarter of the conjugate's): noise alone puts a
#: quarter there, a scene in the near part of the range almost none.
CONJUGATE_FAR_SHARE = 0.5
#: Where the conjugation check looks: beyond this fraction of the
#: unambiguous range (its last quarter).
CONJUGATE_FAR_FROM = 0.75
#: An echo (a local maximum of the compressed power summed over the
#: antennas, at least WRAP_LEVEL of the largest and WRAP_ABOVE_MEDIAN times
#: the median over the axis, so not noise) in the last WRAP_EDGE of the
#: unambiguous range is warned about as possibly wrapped from beyond.
WRAP_EDGE = 0.05
#: An echo at the end of the axis with this share of its power or more
#: common to all the antennas (four or more) ...
WRAP_COMMON_SHARE = 0.9
#: ... whose lobe runs on past the wrap (the first gate holds at least this
#: share of its peak's power) is the antennas' coupling at time zero
#: (:func:`_straddling_lobe`): no conjugated spectrum's, no wrapped target's.
WRAP_STRADDLE = 0.25
#: Data that hold nothing beyond such a coupling but rounding (their largest
#: sample of what the antennas do not share under this share of the largest
#: sample) are not judged at all.
WRAP_REST = 1e-6
WRAP_LEVEL = 0.01
WRAP_ABOVE_MEDIAN = 10.0


def _straddling_lobe(signal, power) -> bool:
    """Whether the data hold an echo the antennas all see alike whose main
    lobe runs round the periodic axis's wrap: a coupling at time zero (a
    GPR trace cut at its direct wave's peak).  Its peak lies in the last
    :data:`WRAP_EDGE` of the axis with at least :data:`WRAP_COMMON_SHARE`
    of its power common to the antennas (four or more), and the first gate
    holds :data:`WRAP_STRADDLE` of its power (``power``: per gate, summed
    over the antennas)."""
    n = power.size
    flat = np.asarray(signal).reshape(-1, n)
    if flat.shape[0] < 4 or n < 4:
        return False
    e0 = int((1.0 - WRAP_EDGE) * n)
    g = e0 + int(np.argmax(power[e0:]))
    if not (power[g] > 0 and power[0] >= WRAP_STRADDLE * power[g]):
        return False
    return mostly_common(flat[:, g], WRAP_COMMON_SHARE)


def _check_conjugated(signal, rng, record: float | None = None) -> None:
    """Warn when the compressed power sits in the far quarter of the
    unambiguous range ``[0, c / 2 df)``: a spectrum recorded as ``exp(+j 4 pi
    f R / c)`` puts each echo at ``R_u - R`` (its compression is the mirror
    image of the conjugate's, which then holds that power in the first
    quarter); and when a strong echo lies at the axis's end, where one from
    beyond it wraps, unless the record (``record``, m: a file's
    ``record_range``) ends well short of it: a record padded before its
    transform holds nothing from beyond it."""
    import warnings

    power = profile_power(signal, rng.size)
    if not power.max() > 0:
        return
    # the antennas' own coupling at time zero, its lobe round the wrap, is
    # neither a conjugated echo nor one from beyond the range: judged without
    # what every antenna sees alike (the coupling and its side lobes)
    if _straddling_lobe(signal, power):
        flat = np.asarray(signal).reshape(-1, rng.size)
        top = np.abs(flat).max()
        rest = flat - flat.mean(axis=0)
        if not np.abs(rest).max() > WRAP_REST * top:  # the common echo alone
            return
        power = profile_power(rest, rng.size)
    r_u = float(rng[-1] + (rng[1] - rng[0]))
    share = float(power[rng >= CONJUGATE_FAR_FROM * r_u].sum() / power.sum())
    if share >= CONJUGATE_FAR_SHARE:
        warnings.warn(
            f"the spectrum looks conjugated: {share:.0%} of the compressed power "
            f"lies beyond {CONJUGATE_FAR_FROM * r_u:.3g} m, in the last quarter of the unambiguous "
            f"range {r_u:.3g} m (an echo recorded as exp(+j 4 pi f R / c) lands at "
            f"{r_u:.3g} m - R); if so, load it with conjugate=True (--conjugate)",
            DataWarning,
            stacklevel=2,
        )
        return
    # an echo near the end of the axis may be one from beyond it, wrapped
    if record is not None and record < (1.0 - WRAP_EDGE) * r_u:
        return
    edge = rng >= (1.0 - WRAP_EDGE) * r_u
    inner = power[1:-1]
    peak = np.zeros(rng.size, bool)
    peak[1:-1] = (inner >= power[:-2]) & (inner >= power[2:])
    strong = (
        peak
        & edge
        & (power >= WRAP_LEVEL * power.max())
        & (power >= WRAP_ABOVE_MEDIAN * np.median(power))
    )
    if strong.any():
        r = float(rng[np.flatnonzero(strong)[0]])
        warnings.warn(
            f"an echo at {r:.3g} m lies within {WRAP_EDGE:.0%} of the unambiguous "
            f"range c/(2 df) = {r_u:.3g} m: it may be a target beyond it, wrapped "
            f"(at {r:.3g} + {r_u:.3g} m); a finer frequency step widens the range",
            DataWarning,
            stacklevel=2,
        )


def window_bandwidth(frequency, window: str = "hann") -> float:
    """The ``bandwidth`` a spectrum gets when the file gives none, Hz.

    The full width at half amplitude of the window over the band: ``nf df``
    times the fraction of the (finely sampled, continuous) window at or above
    half its peak.  rect: ``nf df``; hann: ``nf df / 2``; hamming: 0.53;
    blackman: 0.41; taylor (scipy's defaults, nbar 4, 30 dB): 0.64 (x ``nf df``).

    Parameters
    ----------
    frequency : ndarray, shape (nf,)
        Uniform frequency axis, Hz.
    window : str
        A key of :data:`RANGE_WINDOWS`.
    """
    f = np.asarray(frequency, np.float64)
    span = f.size * float(f[1] - f[0])
    w = _window(window, 4001)
    return span * float(np.mean(w >= 0.5 * w.max()))


def range_sidelobe_db(frequency, window: str, bandwidth: float) -> float | None:
    """The strongest range sidelobe of :func:`range_compress` that a peak
    search can take for an echo, dB relative to the main lobe.

    The compressed response of a lone echo, ``|sum_n w_n exp(j 4 pi n df R /
    c)| / sum_n w_n``, on the gates of :func:`range_compress`; its local
    maxima farther than half a range resolution ``c / (4 bandwidth)`` from
    the main lobe's peak (the k-space search's neighbourhood along R, so a
    sidelobe within it is never a centre) and the largest of them.  rect:
    -13.3 dB, hann -31.5, hamming -42.6 (of scipy's windows over 81 samples
    with the default bandwidth).

    Parameters
    ----------
    frequency : ndarray, shape (nf,)
        Uniform frequency axis, Hz.
    window : str
        A key of :data:`RANGE_WINDOWS`.
    bandwidth : float
        The engine's bandwidth B, Hz (its range resolution ``c / 2B``).

    Returns
    -------
    float or None
        dB (< 0); None where no sidelobe lies beyond that distance.
    """
    f = np.asarray(frequency, np.float64)
    nf = f.size
    df = float(f[1] - f[0])
    n = next_fast_len(RANGE_OVERSAMPLE * nf)
    w = _window(window, nf)
    resp = np.abs(np.fft.ifft(w, n=n)) * n / w.sum()
    dr = C0 / (2.0 * df * n)
    half = int(np.ceil(0.5 * C0 / (2.0 * bandwidth) / dr))
    lag = np.minimum(np.arange(n), n - np.arange(n))  # circular distance to the peak, gates
    peak = (resp >= np.roll(resp, 1)) & (resp >= np.roll(resp, -1)) & (lag > half)
    if not np.any(peak):
        return None
    top = float(resp[peak].max())
    return float(20.0 * np.log10(top)) if top > 0 else None


def range_compress(spectrum, frequency, fc: float, window: str = "hann"):
    """Range profiles of frequency-domain samples (the time-domain contract).

    ``s(R) = sum_n w_n Y_n exp(+j 4 pi (f_n - fc) R / c) / sum_n w_n`` on the
    gates ``R_m = m c / (2 df N)``, ``N = next_fast_len(RANGE_OVERSAMPLE nf)``,
    ``m = 0 .. N-1``: an inverse FFT along the last axis.

    Parameters
    ----------
    spectrum : ndarray, complex, shape (..., nf)
        Samples ``Y(f_n)``; an echo of range ``R`` and amplitude ``a`` is
        ``a exp(-j 4 pi f_n R / c)``.
    frequency : ndarray, shape (nf,)
        Uniform, strictly increasing, > 0, Hz.
    fc : float
        Centre frequency the baseband phase refers to, Hz.
    window : str
        A key of :data:`RANGE_WINDOWS` (``w_n``, symmetric over the band).

    Returns
    -------
    signal : ndarray, complex, shape (..., N)
        complex64 for complex64 input, else complex128; a lone echo peaks at
        ``|s| = a`` with phase ``exp(-j 2 k_c R)``.
    range_axis : ndarray, shape (N,)
        m, from 0 to just below the unambiguous range ``c / (2 df)``.
    """
    y = np.asarray(spectrum)
    f = _frequency_axis(frequency)
    nf = f.size
    if y.shape[-1] != nf:
        raise InputError(f"spectrum's last axis ({y.shape[-1]}) must match frequency ({nf})")
    df = float(f[1] - f[0])
    n = next_fast_len(RANGE_OVERSAMPLE * nf)
    w = _window(window, nf)
    rng = np.arange(n) * (C0 / (2.0 * df * n))
    out_dtype = np.complex64 if y.dtype == np.complex64 else np.complex128
    # sum_n (w_n Y_n) exp(+j 2 pi n m / N) = N ifft(w Y)[m]; the band's offset
    # from fc is one phase ramp in R
    s = np.fft.ifft(y * (w / w.sum()), n=n, axis=-1) * n
    s *= np.exp(4j * np.pi * (f[0] - fc) * rng / C0)
    return s.astype(out_dtype, copy=False), rng


#: A spectrum's bandwidth may exceed the band its samples span (n_f df) by
#: this factor at most (rounding of a nominal width): beyond, it promises a
#: range resolution the samples do not hold, and the derived widths follow it.
BANDWIDTH_OVER_SAMPLED = 1.01


def _compress_checked(values, freq, fc, bw, window, array):
    y = np.asarray(values)
    want = array.shape + (freq.size,)
    if y.shape != want:
        raise InputError(
            f"spectrum must have shape {want} (array {array.shape} x frequency "
            f"{freq.size}), got {y.shape}"
        )
    if not np.all(np.isfinite(y)):
        raise InputError("spectrum contains NaN or Inf")
    fc = float((freq[0] + freq[-1]) / 2) if fc is None else carrier(fc)
    if not freq[0] <= fc <= freq[-1]:  # before Waveform: its messages would miss the unit
        ratio = fc / freq[-1] if fc > freq[-1] else freq[0] / fc
        hint = (
            f": one of them looks like {scale_hint(1.0, ratio)}; give both in Hz"
            if ratio >= 100
            else ""
        )
        raise InputError(
            f"fc ({fc:g} Hz) must lie within the frequency band "
            f"({freq[0]:g} .. {freq[-1]:g} Hz){hint}"
        )
    bw = window_bandwidth(freq, window) if bw is None else bw
    waveform = Waveform(fc, bw)
    import warnings

    band = float(freq[-1] - freq[0])
    sampled = band + float(freq[1] - freq[0])  # nf df: what the samples span
    if waveform.bandwidth > BANDWIDTH_OVER_SAMPLED * sampled:
        raise InputError(
            f"bandwidth = {waveform.bandwidth:g} Hz is wider than the {sampled:g} Hz the "
            f"frequency samples span: the range resolution cannot beat theirs; give the "
            f"bandwidth of the band sampled (or leave it out: the window's, by default)"
        )
    for ratio in (BANDWIDTH_SPAN_MAX, BANDWIDTH_SPAN_WARN):  # as RadarData's span test
        if waveform.bandwidth * ratio < band:
            line = (
                f"bandwidth = {waveform.bandwidth:g} Hz is below 1/{ratio:g} of the "
                f"frequency band ({band:g} Hz): it looks like "
                f"{scale_hint(waveform.bandwidth, band / BANDWIDTH_SPAN_WARN)}; give fc "
                f"and bandwidth in Hz"
            )
            if ratio == BANDWIDTH_SPAN_MAX:
                raise InputError(line)
            warnings.warn(line, DataWarning, stacklevel=2)
            break
    signal, rng = range_compress(y, freq, waveform.fc, window)
    return signal, rng, waveform


def spectrum_data(values, freq, array, fc=None, bw=None, window="hann", truth=None) -> RadarData:
    """The :class:`RadarData` of frequency samples, as
    :func:`rpm_cl.io.load.load_data` makes it of a spectrum file: the
    checked compression over the whole unambiguous range
    (:func:`_compress_checked`; ``fc`` and ``bw`` None: the band's centre
    and the window's bandwidth), the window's sidelobe level and the samples
    themselves (``RadarData.spectrum``).

    Parameters
    ----------
    values : ndarray, complex, shape array.shape + (nf,)
    freq : ndarray, shape (nf,)
        Uniform, increasing, Hz (:func:`_frequency_axis`).
    array : Array
    fc, bw : float or None
        Hz.
    window : str
        A key of :data:`RANGE_WINDOWS`.
    truth : Truth, optional
    """
    signal, rng, waveform = _compress_checked(values, freq, fc, bw, window, array)
    return RadarData(
        signal,
        array,
        rng,
        waveform,
        truth,
        range_sidelobe_db(freq, window, waveform.bandwidth),
        Spectrum(values, freq, window),
        Compression(window, freq.size, rng.size),
    )
