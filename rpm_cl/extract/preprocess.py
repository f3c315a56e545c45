"""What a GPR user does to the range profiles before imaging.

Four steps (five with the trace alignment), in this order, on the range-compressed data
(:class:`rpm_cl.io.data.RadarData`); each is off by default (the paper's
scenes need none) but for the background removal of a B-scan whose
strongest echo is the antennas' own coupling (``background="auto"``,
:func:`coupling_dominates`):

0. **trace alignment** (``align_traces``, off by default): each trace
   moved by a fraction of a gate so that its direct wave lines up with the
   scan's mean (:mod:`rpm_cl.extract.alignment`): an impulse GPR's trigger
   jitter otherwise leaves a residue of the direct wave after step 2;
1. **time zero** (``time_zero``, m): the range at which the antenna's own
   pulse leaves it (the direct coupling, or the surface echo of a ground-
   coupled antenna) becomes 0: ``R' = R - time_zero``, gates before it
   dropped;
2. **background removal** (``background``): the mean or median profile over
   the antennas, per range gate (complex), is subtracted: what every
   antenna sees alike (coupling, the surface of a flat ground, cable
   ringing) goes, a target's range walk across the scan stays; ``auto``
   (the default) removes the mean of a linear scan where
   :func:`coupling_dominates`, else nothing.  A planar scan's mean is not
   removed: a flat sample parallel to a near-field scan is as common to
   every antenna as the coupling.  ``auto`` takes out of a planar scan's
   frequency samples (and its profiles alike) only the coupling, a delay
   with an amplitude linear across the band fitted to their mean
   (:func:`planar_coupling`, :func:`without_echo`);
   a planar range-domain file has no samples, and phase-rpm drops the
   points of its coupling's RPs instead (:func:`coupling_rps`);
3. **gain** (``gain_db_per_m``): amplitudes times ``10^(g R' / 20)``, a
   linear-in-range gain in dB per metre, for echoes that a lossy medium
   weakens with depth (scaled so that no factor exceeds 1: only amplitude
   ratios matter to the imagers);
4. **region of interest** (``max_range``, m): gates beyond it dropped (a
   radar's feed and cable echoes far beyond the scene make clusters of
   their own).

The median is taken over the real and imaginary parts apart (a robust
background where a few antennas hold a strong target).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..io.data import DataWarning, InputError, RadarData
from ..io.model import C0
from ..io.radar import mostly_common
from .alignment import JITTER_WARN, SMOOTH, aligned, smoothness, trace_shifts

__all__ = [
    "BACKGROUNDS",
    "COUPLING_MIN_FREQUENCIES",
    "COUPLING_SAME",
    "COUPLING_SHARE",
    "COUPLING_TERMS",
    "JITTER_SHARE",
    "LATE_PULSE",
    "align",
    "common_echo",
    "coupling_dominates",
    "coupling_rps",
    "pick_time_zero",
    "planar_coupling",
    "preprocess",
    "shift_truth",
    "warn_jitter",
    "warn_late_pulse",
    "without_echo",
]

#: Background removals: the mean where the coupling dominates (see
#: :func:`coupling_dominates`), none, the mean profile, the median profile.
BACKGROUNDS = ("auto", "none", "mean", "median")
#: :func:`coupling_dominates`: the share of the antennas whose strongest
#: gate lies within a range resolution of the median antenna's ...
COUPLING_SAME = 0.9
#: ... and the share of that gate's power that is common to every antenna
#: (|mean s|^2 / mean |s|^2).  Measured on the gprMax fixtures as converted
#: without their background runs: 1.00 at range 0 (the coupling, and above
#: the half-space the surface with it); with the background subtracted, and
#: on the paper's 2-D scenes, 0.03-0.12 at the strongest echo.
COUPLING_SHARE = 0.9
#: ... or, where fewer than COUPLING_SAME have their strongest gate there,
#: the share whose strongest gate lies within a range resolution of the peak
#: of the antennas' coherent mean profile: a GSSI recorder's range gain
#: lifts deep reflectors above the direct wave at 27 % of the traces of
#: GPRPy's 400 MHz example line (FILE____032.DZT), whose direct wave is 97.5 %
#: common.
COUPLING_MOST = 0.5
#: A linear scan's common strongest echo this many range resolutions or
#: more past range 0, with time zero left at 0, is warned of as a pulse the
#: record starts before (a GSSI record's direct wave some 40 samples in
#: lies 0.6-0.8 resolutions in; a gprMax run's coupling, at its source's
#: start, at 0).
LATE_PULSE = 0.5
#: :func:`warn_jitter` measures the traces' offsets only where this share
#: of the power at the mean profile's strongest gate is common to the
#: antennas: a direct wave's with 60 ps of jitter at 2 GHz (0.75 rad of
#: phase) keeps 0.57 of it, the paper's scenes' strongest echo 0.03-0.12.
JITTER_SHARE = 0.3
#: Terms of a planar scan's coupling in its samples: one delay times a
#: polynomial across the band (:func:`planar_coupling`); 2: an amplitude
#: and phase that change linearly across it.  Measured on the physical-optics
#: scan of ``benchmarks/near_field_scan.py`` at 187 x 144 antennas, with a
#: coupling 3 times the sample's echo falling 6 dB across the band: 89.4 %
#: of the points within 15 mm with one term (what the fit left became a
#: cluster of its own), 100 % with two.
COUPLING_TERMS = 2
#: Fewest frequencies a planar scan's coupling is sought with: the fit's
#: Hann weights vanish at the band's two ends, and the two terms want
#: samples to spare; with fewer, a resolution near each end of the
#: unambiguous range (:func:`coupling_rps`) covers most of it.
COUPLING_MIN_FREQUENCIES = 8


def coupling_dominates(data: RadarData, time_zero: float = 0.0) -> bool:
    """Whether a B-scan's strongest echo is the antennas' own coupling: an
    echo within one range resolution of time zero, the same at the antennas
    (:func:`common_echo`; module notes, step 2).

    Parameters
    ----------
    data : RadarData
    time_zero : float
        Range of time zero, m (the axis is measured from it).

    Returns
    -------
    bool
        True where :func:`common_echo` finds the scan's strongest echo
        common to its antennas within ``data.waveform.range_resolution`` of
        time zero, before or after it.
    """
    rng = common_echo(data, time_zero)
    if rng is None:
        return False
    res = data.waveform.range_resolution
    # a coupling at time zero straddles it, and peaks before it as often as
    # after (round a periodic axis, or where time zero cuts a record's axis
    # within its lobe)
    return -res <= rng <= res


def common_echo(data: RadarData, time_zero: float = 0.0) -> float | None:
    """The range from ``time_zero`` of a B-scan's strongest echo common to
    its antennas, m; None where there is none.

    That echo is the median over the antennas of each one's strongest gate
    (round a periodic axis: ranges past half its period from time zero
    count as before it), where the strongest gates of :data:`COUPLING_SAME`
    of the antennas lie within a range resolution of it, else the peak of
    the antennas' coherent mean profile where those of :data:`COUPLING_MOST`
    do; and at least :data:`COUPLING_SHARE` of the gate's power must be the
    antennas' mean.  A
    linear array of 4 antennas or more; planar arrays: None (a flat
    surface parallel to the scan, a near-field sample's, is as common to
    every antenna as a coupling).
    """
    if data.array.planar or data.array.shape[0] < 4:
        return None
    periodic = data.range_period
    rng = data.range - time_zero
    if periodic:
        rng = np.where(rng > 0.5 * periodic, rng - periodic, rng)
    s = data.signal.reshape(-1, rng.size)
    strongest = np.abs(s).argmax(axis=1)
    g = int(strongest[np.argsort(rng[strongest], kind="stable")[strongest.size // 2]])
    res = data.waveform.range_resolution
    if np.mean(np.abs(rng[strongest] - rng[g]) <= res) < COUPLING_SAME:
        # a recorder's range gain may lift deep echoes above the direct wave
        # at some antennas: then the peak of the coherent mean profile, where
        # it is still the strongest echo at most of them
        g = int(np.argmax(np.abs(s.mean(axis=0))))
        if np.mean(np.abs(rng[strongest] - rng[g]) <= res) < COUPLING_MOST:
            return None
    if not _mostly_common(s[:, g]):
        return None
    return float(rng[g])


def warn_late_pulse(data: RadarData) -> None:
    """Warn (one line, with the fix) where a linear scan's strongest echo,
    the same at every antenna, lies more than :data:`LATE_PULSE` range
    resolutions past range 0 while time zero is left at 0: a GPR record
    that starts before the antennas' pulse, whose every depth is then too
    deep by its range.  Not above a half-space (an antenna height is set):
    the surface's echo lies there, common to every antenna too."""
    rng = common_echo(data)
    if rng is not None and rng > LATE_PULSE * data.waveform.range_resolution:
        import warnings

        warnings.warn(
            f"the strongest echo, the same at every antenna, lies at range {rng:.3g} m: "
            f"if it is the antennas' own pulse (a GPR's direct wave), every range is "
            f"measured from before it; --time-zero auto sets time zero there",
            DataWarning,
            stacklevel=4,
        )


def pick_time_zero(data: RadarData, antenna_height: float | None = None) -> float:
    """``time_zero = "auto"``: the range of the antennas' own pulse, m.

    The echo :func:`common_echo` finds is taken for the ground's surface:
    time zero is its envelope peak in the scan's mean profile (a parabola
    through the gate and its two neighbours), less ``antenna_height`` above
    a half-space.  For a ground-coupled antenna (no height) the surface's
    echo is its direct wave, whose envelope peak marks the surface
    (docs/input-format.md, GSSI).  0 where no such echo is found, or where
    it straddles the start of a periodic axis (at time zero already), or
    lies nearer than the antenna height.

    Parameters
    ----------
    data : RadarData
    antenna_height : float, optional
        m (:class:`rpm_cl.io.medium.Medium`), None for none.
    """
    r0 = common_echo(data)
    if r0 is None or r0 < 0:
        return 0.0
    g = int(np.argmin(np.abs(data.range - r0)))
    mean = np.abs(data.signal.reshape(-1, data.range.size).mean(axis=0))
    if 0 < g < mean.size - 1:
        a, b, c = mean[g - 1], mean[g], mean[g + 1]
        den = a - 2.0 * b + c
        if den < 0:
            r0 = float(data.range[g] + 0.5 * (a - c) / den * data.dr)
    return max(float(r0) - (antenna_height or 0.0), 0.0)


def _mostly_common(v) -> bool:
    """Whether at least :data:`COUPLING_SHARE` of the power of the complex
    samples ``v`` is their mean's (:func:`rpm_cl.io.radar.mostly_common`)."""
    return mostly_common(v, COUPLING_SHARE)


def planar_coupling(data: RadarData, time_zero: float = 0.0) -> np.ndarray | None:
    """A planar scan's own coupling in its frequency samples, the same at
    every antenna, or None where the scan has no samples or no coupling
    (module notes, step 2).

    The coupling is what every antenna sees alike within one range
    resolution of time zero: the array's mean profile has its strongest
    local peak there with at least :data:`COUPLING_SHARE` of that gate's
    power common to every antenna, above twice the range window's side
    lobe level under the mean profile's strongest peak (a flat sample's side
    lobes are as common).  Its range ``R_c`` is that of the mean spectrum's
    Hann-weighted coherent sum's peak within half a resolution of that gate,
    and its samples ``exp(-j 4 pi f R_c / c) (a_0 + a_1 u)``, ``u`` the
    frequency's offset from the band's centre over the band
    (:data:`COUPLING_TERMS` terms), are fitted to the mean spectrum by
    Hann-weighted least squares: an antenna's mismatch is seldom one clean
    echo (its amplitude may fall across the band), and the mean profile
    there holds the coupling's main lobe and only the far side lobes of
    echoes a resolution or more away.  A planar scan's mean profile cannot
    be removed whole (a flat sample parallel to the scan is as common to
    every antenna as the coupling), nor cut at a range: with 11 frequencies
    over 22.2-26.2 GHz (a resolution of 68 mm, Hann) a coupling 12 mm from
    the antennas and a sample at 0.105 m overlap in range.

    Returns
    -------
    ndarray, complex128, shape (nf,)
        The coupling's samples (:func:`without_echo` takes them out).
    """
    sp = data.spectrum
    if not data.array.planar or sp is None or sp.frequency.size < COUPLING_MIN_FREQUENCIES:
        return None
    rng = data.range - time_zero
    res = data.waveform.range_resolution
    first = np.flatnonzero((rng >= 0) & (rng <= res))
    if first.size == 0:
        return None
    s = data.signal.reshape(-1, rng.size)[:, first]
    top = float(np.abs(s).max())
    if not (np.isfinite(top) and top > 0):
        return None
    v = s.astype(np.complex128) / top  # any scale: no overflow in the powers
    mean = np.abs(v.mean(axis=0))
    # the strongest local maximum (a sample's main lobe may reach in and
    # rise to the last gate)
    peak = np.r_[True, mean[1:] >= mean[:-1]] & np.r_[mean[:-1] >= mean[1:], False]
    if not peak.any():
        return None
    g = int(np.flatnonzero(peak)[np.argmax(mean[peak])])
    if not _mostly_common(s[:, g]):
        return None
    # not a side lobe of a common echo beyond (a flat sample's): twice the
    # window's side lobe level under the mean profile's strongest peak
    if data.range_sidelobe_db is not None:
        whole = np.abs(data.signal.reshape(-1, rng.size).mean(axis=0)).max() / top
        if mean[g] < 2.0 * 10.0 ** (data.range_sidelobe_db / 20.0) * whole:
            return None
    from ..io.windows import window

    f = sp.frequency
    y = sp.values.reshape(-1, f.size).astype(np.complex128).mean(axis=0)
    w = window("hann", f.size)
    k = 4.0 * np.pi * f / C0
    r0 = float(data.range[first[g]])
    step = res / 512
    grid = r0 + step * np.arange(-256, 257)
    val = np.abs(np.exp(1j * np.outer(grid, k)) @ (w * y))
    j = int(np.clip(np.argmax(val), 1, grid.size - 2))
    den = val[j - 1] - 2 * val[j] + val[j + 1]
    rc = float(grid[j] + (0.5 * step * (val[j - 1] - val[j + 1]) / den if den < 0 else 0.0))
    delay = np.exp(-1j * k * rc)
    u = (f - 0.5 * (f[0] + f[-1])) / (f[-1] - f[0])
    basis = delay[:, None] * u[:, None] ** np.arange(COUPLING_TERMS)[None, :]
    sw = np.sqrt(w)[:, None]
    coef = np.linalg.lstsq(sw * basis, sw[:, 0] * y, rcond=None)[0]
    return basis @ coef


def without_echo(data: RadarData, echo: np.ndarray) -> RadarData:
    """``data`` less the frequency samples ``echo`` (nf,) at every antenna:
    in its samples, and in its profiles as its compression
    (``data.spectrum.window``) forms them, on the data's range axis."""
    from ..io.radar import Spectrum
    from .alignment import profiles

    sp = data.spectrum
    f = sp.frequency
    profile = profiles(echo, f, sp.window, data.waveform.fc, data.range)
    signal = (data.signal - profile).astype(data.signal.dtype, copy=False)
    values = (sp.values - echo).astype(sp.values.dtype, copy=False)
    return replace(data, signal=signal, spectrum=Spectrum(values, f, sp.window))


def coupling_rps(data: RadarData, rps) -> np.ndarray:
    """Which RPs of a planar scan are its antennas' own coupling: those
    within one range resolution of time zero (the axis's 0), where they
    hold :data:`COUPLING_SAME` of the antennas or more and at least
    :data:`COUPLING_SHARE` of their power is common to every antenna (the
    mean of their complex samples, :func:`coupling_dominates`'s test).

    The RPs near 0 and those near the end of the unambiguous range (below)
    are tested apart, each set as a whole: a real echo among them makes the
    set fail (its points stay), and a weak one in a set that passes goes
    with the coupling.

    A planar scan keeps its background (:func:`preprocess`): a flat sample
    parallel to it is as common to every antenna as the coupling, and the
    mean over the antennas would take it too.  So the coupling's echo
    reaches the imaging, and its RPs become a "surface" a few mm before the
    antennas; this test finds them instead.  A surface within one
    resolution of the antennas is taken for the coupling (0.068 m for 11
    frequencies over 22.2-26.2 GHz, Hann).  Where the profiles were
    compressed from frequency samples the range axis is periodic over the
    unambiguous range ``c / 2 df``, and RPs within one resolution of its end
    are near time zero too: what :func:`planar_coupling`'s fit leaves of a
    coupling (of two echoes, say) lies partly before 0, which wraps there.

    Parameters
    ----------
    data : RadarData
        After :func:`preprocess` (ranges measured from time zero).
    rps : RangePoints
        With ``sample`` (else the profiles' value at each RP's gate).

    Returns
    -------
    ndarray of bool, shape (K,)
        All False for linear arrays (:func:`coupling_dominates` removes
        theirs before the imaging).
    """
    k = len(rps)
    out = np.zeros(k, bool)
    if not data.array.planar or k == 0:
        return out
    rng = np.asarray(rps.range, np.float64)
    res = data.waveform.range_resolution
    zones = [(rng >= 0) & (rng <= res)]
    sp = data.spectrum
    if sp is not None and sp.frequency.size >= COUPLING_MIN_FREQUENCIES:
        # the compression is periodic over the unambiguous range: what the
        # fit leaves of the coupling's main lobe before 0 lies at its end
        df = float(sp.frequency[1] - sp.frequency[0])
        zones.append((rng >= C0 / (2.0 * df) - res) & ~zones[0])
    for near in zones:
        out |= _common(data, rps, near)
    return out


def _common(data: RadarData, rps, near: np.ndarray) -> np.ndarray:
    """``near`` where those RPs hold :data:`COUPLING_SAME` of the antennas
    and :data:`COUPLING_SHARE` of their power is common, else all False."""
    ant = np.asarray(rps.antenna)[near]
    if np.unique(ant).size < COUPLING_SAME * data.array.n:
        return np.zeros(near.shape, bool)
    if rps.sample is not None:
        v = np.asarray(rps.sample)[near]
    else:
        rng = np.asarray(rps.range, np.float64)[near]
        g = np.clip(np.round((rng - data.range[0]) / data.dr), 0, data.range.size - 1)
        v = data.signal.reshape(-1, data.range.size)[ant, g.astype(np.int64)]
    return near.copy() if _mostly_common(v) else np.zeros(near.shape, bool)


def check(background: str, time_zero: float, gain_db_per_m: float, max_range: float | None) -> None:
    """Refuse settings that no data could take (one line each)."""
    if background not in BACKGROUNDS:
        raise InputError(f"background must be one of {', '.join(BACKGROUNDS)}, got {background!r}")
    zero = _real(time_zero)
    if zero is None or not (np.isfinite(zero) and zero >= 0):
        raise InputError(
            f'time_zero must be a range >= 0 m ("auto" is resolved by '
            f"rpm_cl.rpm.params.default_params), got {time_zero!r}"
        )
    gain = _real(gain_db_per_m)
    if gain is None or not (np.isfinite(gain) and abs(gain) <= 1000):
        raise InputError(f"gain_db_per_m must be within +-1000 dB/m, got {gain_db_per_m!r}")
    if max_range is not None:
        top = _real(max_range)
        if top is None or not (np.isfinite(top) and top > 0):
            raise InputError(
                f"max_range must be a range > 0 m (after time_zero), got {max_range!r}"
            )


def _real(value) -> float | None:
    """``value`` as a float where it is a real number (not a bool), else None."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.number)):
        return None
    if isinstance(value, (complex, np.complexfloating)):
        return None
    return float(value)


def preprocess(
    data: RadarData,
    background: str = "auto",
    time_zero: float = 0.0,
    gain_db_per_m: float = 0.0,
    max_range: float | None = None,
    *,
    align_traces: bool = False,
    coupling_zero: float | None = None,
    warn: bool = True,
    late_pulse: bool = False,
) -> RadarData:
    """``data`` after the module's steps; ``data`` itself when all are off.

    Parameters
    ----------
    data : RadarData
    background : {'auto', 'none', 'mean', 'median'}
        ``auto``: a linear scan's ``mean`` where :func:`coupling_dominates`,
        else ``none``; a planar scan's coupling alone where
        :func:`planar_coupling` finds one (module notes, step 2).
    time_zero : float
        m, >= 0.
    gain_db_per_m : float
        dB per metre of range after time zero.
    max_range : float, optional
        m (after time zero); None keeps every gate.
    align_traces : bool
        Step 0: each trace moved onto the scan's mean on the direct wave
        (:mod:`rpm_cl.extract.alignment`).
    coupling_zero : float, optional
        The time zero ``auto``'s coupling tests measure from, m (None:
        ``time_zero``): :func:`rpm_cl.imaging.prepared` removes the
        background on the whole axis before it cuts it at ``time_zero``.
    warn : bool
        Warn where a background removal without the alignment leaves the
        direct wave's timing jitter as strong as the echoes
        (:func:`warn_jitter`), and of an alignment refused; the derivation
        of the defaults, which preprocesses the data once more, does not.
    late_pulse : bool
        With ``warn``: warn, after the alignment, where the record starts
        before the antennas' pulse (:func:`warn_late_pulse`);
        :func:`rpm_cl.imaging.prepared` asks it where time zero is 0 and no
        antenna height is set.

    Returns
    -------
    RadarData
        The same antennas; the range axis shifted by ``-time_zero`` and
        cut to ``[0, max_range]``; the truth's RP ranges shifted alike; the
        frequency samples (``spectrum``) kept where nothing but
        ``max_range``, a trace alignment and a planar scan's coupling
        removal apply (the alignment and the coupling's removal made in
        them too).

    Raises
    ------
    InputError
        A setting out of range, or no range gate left.
    """
    check(background, time_zero, gain_db_per_m, max_range)
    if align_traces:
        data = align(data, warn)
    if warn and late_pulse:
        warn_late_pulse(data)  # on the aligned traces: jitter blurs the pulse
    zero = time_zero if coupling_zero is None else coupling_zero
    if warn and background != "none" and not align_traces:
        warn_jitter(data, zero)  # before auto decides: jitter can hide a coupling from it
    if background == "auto" and data.array.planar:
        echo = planar_coupling(data, zero)
        if echo is not None:
            data = without_echo(data, echo)
        background = "none"
    elif background == "auto":
        background = "mean" if coupling_dominates(data, zero) else "none"
    if background == "none" and time_zero == 0 and gain_db_per_m == 0 and max_range is None:
        return data
    rng = data.range - time_zero
    keep = rng >= 0
    if max_range is not None:
        keep &= rng <= max_range
    if keep.sum() < 2:
        raise InputError(
            f"time_zero {time_zero:g} m and max_range {max_range} m leave fewer "
            f"than 2 range gates of {data.range[0]:g} .. {data.range[-1]:g} m"
        )
    s = np.array(data.signal[..., keep], copy=True)
    rng = rng[keep]
    flat = s.reshape(-1, rng.size)
    if background == "mean":
        flat -= flat.mean(axis=0)
    elif background == "median":
        flat -= np.median(flat.real, axis=0) + 1j * np.median(flat.imag, axis=0)
    if gain_db_per_m:
        # relative to the gate it raises most, so no factor exceeds 1 (the
        # imagers normalise amplitudes; a large gain cannot overflow)
        ref = rng[-1] if gain_db_per_m > 0 else rng[0]
        s *= (10.0 ** (gain_db_per_m * (rng - ref) / 20.0)).astype(s.real.dtype)
    # the frequency samples still describe the profiles where only gates were
    # dropped; a shifted axis, a background or a gain is not in them
    keep_spectrum = background == "none" and time_zero == 0 and gain_db_per_m == 0
    return replace(
        data,
        signal=s,
        range=rng,
        truth=shift_truth(data.truth, time_zero),
        spectrum=data.spectrum if keep_spectrum else None,
        # a background or a cut leaves each echo the window's response; a
        # gain reshapes it along the range
        compression=None if gain_db_per_m else data.compression,
    )


def shift_truth(truth, time_zero: float):
    """``truth`` (:class:`rpm_cl.io.data.Truth` or None) with its RP ranges
    measured from ``time_zero``, m, as :func:`preprocess` measures ranges."""
    if truth is None or not truth.has_rps or not time_zero:
        return truth
    return replace(truth, rp_range=truth.rp_range - time_zero)


def _common_peak(data: RadarData, share: float = COUPLING_SHARE) -> bool:
    """Whether at least ``share`` of the power at the strongest gate of the
    scan's mean profile is common to its antennas
    (:func:`rpm_cl.io.radar.mostly_common`)."""
    p = data.signal.reshape(-1, data.range.size)
    return mostly_common(p[:, int(np.abs(p.mean(axis=0)).argmax())], share)


def _walks(data: RadarData, shifts: np.ndarray) -> bool:
    """Whether ``shifts`` are a target's range walk, not a direct wave's
    jitter (:mod:`rpm_cl.extract.alignment` notes): smooth along the scan
    (:data:`rpm_cl.extract.alignment.SMOOTH`), measured on an echo that is
    not common to the antennas (:func:`_common_peak`)."""
    return smoothness(shifts) >= SMOOTH and not _common_peak(data)


def align(data: RadarData, warn: bool = True) -> RadarData:
    """``data`` with its traces aligned on the direct wave
    (:func:`rpm_cl.extract.alignment.trace_shifts`, ``aligned``), where the
    strongest echo is one: ``data`` itself, with a warning, where the
    offsets are a target's range walk (:func:`_walks`), or where the
    aligned traces' strongest echo is still not common to them (no direct
    wave: the strongest echo is a scene's, whose phase across the antennas
    no shift within half a carrier period makes one).

    Parameters
    ----------
    data : RadarData
    warn : bool
        Warn (a refusal; offsets at the search's edge).
    """
    from .alignment import warn_ambiguous

    shifts = trace_shifts(data, quiet=True)
    why = None
    if _walks(data, shifts):
        why = (
            f"its offsets follow the scan (correlation {smoothness(shifts):.2f} between "
            f"neighbours): a target's range walk"
        )
    else:
        out = aligned(data, shifts)
        if not _common_peak(out):
            why = "aligned, it is still not the same at every antenna"
    if why is not None:
        if warn:
            import warnings

            warnings.warn(
                f"--align-traces: the strongest echo is no direct wave ({why}); the traces "
                f"are left as they are",
                DataWarning,
                stacklevel=3,
            )
        return data
    if warn:
        warn_ambiguous(data, shifts)
    return out


def warn_jitter(data: RadarData, time_zero: float = 0.0) -> None:
    """Warn (one line, with the fix) where a background removal of ``data``
    without alignment leaves a residue of the direct wave that its traces'
    timing makes as strong as the echoes.

    The traces' offsets on the strongest echo are measured
    (:func:`rpm_cl.extract.alignment.trace_shifts`); where they are a
    target's walk (:func:`_walks`), or the echo, once they are taken out,
    is no coupling at ``time_zero`` (:func:`coupling_dominates` of the
    aligned data: jitter large enough makes a coupling fail that test
    unaligned), nothing is said.  The residue a trace ``delta`` off the mean keeps is
    ``2 k_c |delta|`` times the direct wave's peak in the mean profile; its
    rms over the traces is compared with the strongest echo the removal
    leaves beyond two range resolutions of the direct wave, and the warning
    given from :data:`rpm_cl.extract.alignment.JITTER_WARN` of it.

    Parameters
    ----------
    data : RadarData
        Before the removal (the direct wave in), a linear scan of 4 traces
        or more.
    time_zero : float
        m.
    """
    n = int(np.prod(data.array.shape))
    if data.array.planar or n < 4:
        return
    # first, cheaply: the strongest gate of the mean holds a direct wave,
    # jittered or not (JITTER_SHARE of its power common), where a scene's
    # echo walks in phase across the antennas (0.03-0.12 on the paper's)
    if not _common_peak(data, JITTER_SHARE):
        return
    shifts = trace_shifts(data, quiet=True)
    if not np.any(shifts) or _walks(data, shifts):
        return
    if not coupling_dominates(aligned(data, shifts), time_zero):
        return
    shifts = shifts.ravel()
    p = data.signal.reshape(n, -1)
    mean = p.mean(axis=0)
    g0 = int(np.abs(mean).argmax())
    far = np.abs(data.range - data.range[g0]) > 2.0 * data.waveform.range_resolution
    if not far.any():
        return
    left = float(np.abs(p[:, far] - mean[far]).max())
    kc = 4.0 * np.pi * data.waveform.fc / C0
    rms = float(np.sqrt(np.mean(shifts**2)))
    residue = kc * rms * float(np.abs(mean[g0]))
    if residue >= JITTER_WARN * left:
        import warnings

        warnings.warn(
            f"the direct wave's timing wanders by {2e12 * rms / C0:.3g} ps rms from trace to "
            f"trace ({rms * 1e3:.3g} mm of range): the background removal leaves "
            f"{residue / left:.2g} times the strongest echo of it: try --align-traces true",
            DataWarning,
            stacklevel=4,
        )
