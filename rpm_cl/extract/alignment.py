"""Per-trace time-zero alignment of a scan on its direct wave.

An impulse GPR's sampler is triggered anew for every trace, and its timing
wanders by picoseconds to tens of picoseconds from trace to trace (trigger
jitter, drift).  The whole trace moves with it: the direct wave (the
antennas' own coupling, or a ground-coupled antenna's surface echo) and
every echo behind it.  The direct wave is 20-40 dB above the targets, so a
mean-trace background removal (:mod:`rpm_cl.extract.preprocess`) leaves of
it ``2 k_c delta`` times its amplitude where a trace sits ``delta`` off the
mean, a residue with a random phase per trace that swamps the targets:
20 ps at 1.6 GHz (3 mm of range) leaves 0.2 of the direct wave.

:func:`trace_shifts` measures each trace's offset on the direct wave, and
:func:`aligned` moves every trace by it, the standard GPR step before the
background removal; :func:`rpm_cl.extract.preprocess.align` does both where
the strongest echo is a direct wave.  Trigger jitter is white from trace to trace, while the range
walk of a target's echo (the strongest echo of a scan without a direct
wave, or with it removed) follows the scan smoothly and is not common to
the antennas: offsets whose neighbours along the scan correlate by
:data:`SMOOTH` or more (:func:`smoothness`), measured on an echo that is not common to the
antennas (:func:`rpm_cl.io.radar.mostly_common`, the coupling test's
share), are a target's walk, and the traces are left as they are (a
warning says so).  A slow drift of the direct wave is smooth too, but its
echo stays common.

Measurement
-----------
The direct wave is the strongest gate ``g_0`` of the scan's mean profile.
Its leading flank, the gates from where the mean profile's magnitude last
rises above :data:`LEAD_FLOOR` of that peak up to ``g_0`` (round the axis's
end where it is the compression's whole period), holds the direct wave and
nothing later: every echo of the scene arrives after it.  Each trace's
gates there are taken back to the band (the inverse of the compression
there, ``q(f) = sum_g s(R_g) exp(-j 4 pi (f - f_c) R_g / c)``), and so are
the mean's (``q_ref``).  A trace whose echoes arrive ``delta`` late has
``q(f) = q_ref(f) exp(-j 4 pi f delta / c)``, the carrier included; its
offset is the maximum of ::

    J(delta) = Re sum_f q(f) conj(q_ref(f)) exp(+j 4 pi f delta / c)

within half the carrier's period of range either side (``c / (4 f_c)``:
the two-way phase turns by pi there, and ``J`` has no other maximum as
high within it), on a grid and then by Newton steps.
Holding the carrier's phase to the delay makes the estimate unbiased where
the flank is cut from a lobe; the envelope's cross-correlation alone is
pulled towards 0 by the fixed cut (measured: a fifth of the true offsets).
The cut is fixed while the traces move, which pulls this estimate, too,
towards 0 (by 3.5 % on a 1-3 GHz line); so the traces' flanks are formed
again from their samples moved by the offsets found, and what is left
measured against their new mean and added (:data:`PASSES` in all: the
pull shrinks as the traces come into line).  The offsets' mean is taken
off, so the scan's mean time zero stays where it was.  A dead trace (its
flank's energy under :data:`DEAD` of the median trace's) has no offset to
measure: it keeps 0 and is left out of the mean.

Moving a trace by ``delta`` multiplies its samples by
``exp(+j 4 pi f delta / c)``; its profiles are formed from them again as
the compression forms them (:func:`rpm_cl.io.compress.range_compress`), on
the data's range axis, where the data hold their frequency samples
(``RadarData.spectrum``: a spectrum input, a DZT or gprMax conversion).
Range profiles given alone are moved by interpolation,
``exp(+j 2 k_c delta) s(R + delta)``, and their flanks taken back to a
grid over the waveform's band.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..io.data import DataWarning, InputError, RadarData
from ..io.model import C0

__all__ = [
    "BAND_SAMPLES",
    "DEAD",
    "JITTER_WARN",
    "LEAD_FLOOR",
    "PASSES",
    "SMOOTH",
    "aligned",
    "profiles",
    "smoothness",
    "trace_shifts",
    "warn_ambiguous",
]

#: The leading flank of the direct wave starts where the mean profile's
#: magnitude last rises above this share of its peak (-20 dB).
LEAD_FLOOR = 0.1
#: Measurements of the offsets, each of what the one before left, on the
#: traces as it aligned them, against their mean.
PASSES = 3
#: Grid steps per quarter period of the highest frequency, before the
#: Newton steps.
GRID_PER_QUARTER = 8
#: Newton steps from the grid's best offset.
NEWTON_STEPS = 4
#: A trace whose flank holds less than this share of the median trace's
#: energy there is dead: no offset is measured on it.
DEAD = 1e-3
#: Offsets whose correlation between neighbours along the scan reaches
#: this follow it smoothly (a target's walk, or a drift), where jitter's
#: are white (about 0).
SMOOTH = 0.5
#: Traces moved at once where range profiles alone are interpolated (their
#: transform along the range is the memory that grows).
CHUNK = 1024
#: :func:`rpm_cl.extract.preprocess.warn_jitter` warns where the direct wave's residue that the
#: traces' timing leaves after a mean removal is at least this share of the
#: strongest echo left beyond the direct wave.
JITTER_WARN = 0.5


def profiles(values: np.ndarray, frequency: np.ndarray, window: str, fc: float, rng) -> np.ndarray:
    """Range profiles of frequency samples on the gates ``rng`` as
    :func:`rpm_cl.io.compress.range_compress` forms them:
    ``s(R) = sum_f w_f Y_f exp(+j 4 pi (f - fc) R / c) / sum_f w_f``.

    Parameters
    ----------
    values : ndarray, complex, shape (..., nf)
    frequency : ndarray, shape (nf,)
        Hz.
    window : str
        A key of :data:`rpm_cl.io.compress.RANGE_WINDOWS`.
    fc : float
        Hz.
    rng : ndarray, shape (ng,)
        m.

    Returns
    -------
    ndarray, complex128, shape (..., ng)
    """
    from ..io.compress import _window

    w = _window(window, frequency.size)
    ramp = np.exp(4j * np.pi * np.outer(frequency - fc, rng) / C0)
    return (values * w) @ ramp / w.sum()


def _lead_gates(mean: np.ndarray, periodic: bool) -> np.ndarray:
    """The gates of the leading flank of the strongest peak of ``|mean|``,
    in order, ending at the peak (module notes); round the axis's start to
    its end where ``periodic``.  At least the gate before the peak."""
    a = np.abs(mean)
    n = a.size
    g0 = int(a.argmax())
    floor = LEAD_FLOOR * a[g0]
    gates = [g0]
    g = g0
    while len(gates) < n:
        prev = g - 1
        if prev < 0:
            if not periodic:
                break
            prev += n
        if not (floor < a[prev] <= a[g]):
            break
        gates.append(prev)
        g = prev
    if len(gates) == 1:  # a peak at the axis's start: its flank is cut off
        return np.array([g0, g0 + 1] if g0 + 1 < n else [g0 - 1, g0])
    return np.array(gates[::-1])


def _best_offset(x: np.ndarray, f: np.ndarray, span: float) -> np.ndarray:
    """For each row of the cross-spectra ``x`` (n, nf), the ``delta`` within
    ``+-span`` (m) that maximises ``Re sum_f x exp(+j 4 pi f delta / c)``."""
    k = 4.0 * np.pi * f / C0
    step = C0 / (8.0 * f[-1] * GRID_PER_QUARTER)
    grid = np.linspace(-span, span, 2 * int(np.ceil(span / step)) + 1)
    d = grid[np.argmax((x @ np.exp(1j * np.outer(k, grid))).real, axis=1)]
    for _ in range(NEWTON_STEPS):
        e = x * np.exp(1j * np.outer(d, k))
        slope = -(e @ k).imag  # d J / d delta
        curve = -(e @ (k * k)).real  # d2 J / d delta2, < 0 at a maximum
        safe = np.where(curve < 0, curve, -np.inf)
        d = np.clip(d - slope / safe, -span, span)
    return d


#: Frequencies over the band that range profiles without their samples are
#: taken back to (:func:`trace_shifts`).
BAND_SAMPLES = 64


def _moved(data: RadarData, shifts: np.ndarray, gates=None) -> np.ndarray:
    """The traces' profiles (n, gates) moved by ``-shifts`` (n,), m: from
    the samples times ``exp(+j 4 pi f delta / c)`` where the data keep
    them, else ``exp(+j 2 k_c delta) s(R + delta)``, the profile
    interpolated by its Fourier transform along the range (zero-padded to
    twice the axis, unless the axis is the compression's whole period)."""
    n = shifts.size
    rng = data.range if gates is None else data.range[gates]
    fc = data.waveform.fc
    sp = data.spectrum
    if sp is not None:
        f = sp.frequency
        values = sp.values.reshape(n, f.size) * np.exp(4j * np.pi * np.outer(shifts, f) / C0)
        return profiles(values, f, sp.window, fc, rng)
    from ..io.compress import next_fast_len
    from ..transforms import fft, ifft

    p = data.signal.reshape(n, -1)
    size = p.shape[1] if data.range_period else next_fast_len(2 * p.shape[1])
    nu = np.fft.fftfreq(size, data.dr)  # cycles per m of range
    keep = slice(None) if gates is None else gates
    out = np.empty((n, rng.size), np.complex128)
    for i in range(0, n, CHUNK):
        d = shifts[i : i + CHUNK]
        spec = fft(p[i : i + CHUNK], n=size, axis=1) * np.exp(2j * np.pi * np.outer(d, nu))
        moved = ifft(spec, axis=1)[:, : p.shape[1]][:, keep]
        out[i : i + CHUNK] = moved * np.exp(4j * np.pi * fc * d / C0)[:, None]
    return out


def trace_shifts(data: RadarData, quiet: bool = False) -> np.ndarray:
    """Each trace's offset on the direct wave from the scan's mean, m of
    range (module notes): trace ``i``'s echoes lie at ``R + delta_i``.

    Parameters
    ----------
    data : RadarData
        With its frequency samples (``data.spectrum``), or profiles alone:
        then the flank is taken back to :data:`BAND_SAMPLES` frequencies
        over the waveform's band, and moved as :func:`_moved` says.

    quiet : bool
        No warning of offsets at the search's edge.

    Returns
    -------
    ndarray, float64, shape data.array.shape
        Mean 0 over the live traces; 0 at the dead ones (module notes).

    Raises
    ------
    InputError
        Fewer than 2 traces.
    """
    n = int(np.prod(data.array.shape))
    if n < 2:
        raise InputError("trace alignment needs 2 traces or more")
    fc = data.waveform.fc
    if data.spectrum is not None:
        f = data.spectrum.frequency
    else:
        f = fc + data.waveform.bandwidth * np.linspace(-0.5, 0.5, BAND_SAMPLES)
    p = data.signal.reshape(n, -1)
    gates = _lead_gates(p.mean(axis=0), bool(data.range_period))
    back = np.exp(-4j * np.pi * np.outer(data.range[gates], f - fc) / C0)
    span = C0 / (4.0 * fc)
    shifts = np.zeros(n)
    flank = np.abs(p[:, gates]).astype(np.float64)
    top = float(flank.max())
    if not (np.isfinite(top) and top > 0):
        return shifts.reshape(data.array.shape)
    energy = np.sum((flank / top) ** 2, axis=1)  # any scale: no overflow
    live = energy > DEAD * np.median(energy)
    if live.sum() < 2:
        return shifts.reshape(data.array.shape)
    for _ in range(PASSES):
        q = _moved(data, shifts, gates) @ back
        q /= np.abs(q).max()
        step = _best_offset(q * q[live].mean(axis=0).conj(), f, span)
        shifts = np.where(live, shifts + step - step[live].mean(), 0.0)
    shifts = shifts.reshape(data.array.shape)
    if not quiet:
        warn_ambiguous(data, shifts)
    return shifts


def warn_ambiguous(data: RadarData, shifts: np.ndarray) -> None:
    """Warn (one line) where offsets reach the search's edge, half the
    carrier's period of range either side, where they are ambiguous."""
    span = C0 / (4.0 * data.waveform.fc)
    edge = np.abs(shifts) > 0.95 * span
    if edge.any():
        import warnings

        warnings.warn(
            f"trace alignment: {int(edge.sum())} of {edge.size} traces are {span * 1e3:.3g} mm "
            f"or more off the mean on the direct wave, half the carrier's period, where the "
            f"measurement is ambiguous: their timing is not to be trusted",
            DataWarning,
            stacklevel=4,
        )


def aligned(data: RadarData, shifts: np.ndarray) -> RadarData:
    """``data`` with trace ``i`` moved by ``-shifts[i]`` (m of range): its
    samples times ``exp(+j 4 pi f delta_i / c)`` and its profiles formed
    from them again on the data's range axis (:func:`profiles`), or, for
    profiles alone, the profiles moved (:func:`_moved`).

    Parameters
    ----------
    data : RadarData
    shifts : ndarray, shape data.array.shape
        m (:func:`trace_shifts`).
    """
    from ..io.radar import Spectrum

    d = np.asarray(shifts, dtype=np.float64).ravel()
    sp = data.spectrum
    if sp is None:
        signal = _moved(data, d)
        signal = signal.reshape(data.signal.shape).astype(data.signal.dtype, copy=False)
        return replace(data, signal=signal)
    f = sp.frequency
    values = sp.values * np.exp(4j * np.pi * d.reshape(data.array.shape + (1,)) * f / C0)
    signal = profiles(values, f, sp.window, data.waveform.fc, data.range)
    return replace(
        data,
        signal=signal.astype(data.signal.dtype, copy=False),
        spectrum=Spectrum(values.astype(sp.values.dtype, copy=False), f, sp.window),
    )


def smoothness(shifts: np.ndarray) -> float:
    """Correlation of the offsets ``shifts`` (array shape) between
    neighbours along the scan's first axis (0 where they do not vary)."""
    d = np.asarray(shifts, np.float64)
    d = d - d.mean()
    den = float(np.sum(d * d))
    if d.shape[0] < 3 or not den > 0:
        return 0.0
    return float(np.sum(d[1:] * d[:-1]) / den)
