"""Warnings for radar data whose units look wrong (:func:`check_plausible`):
the array pitch against the wavelength, the range resolution against the
range axis, and the echoes' width in range (:func:`echo_width`)."""

from __future__ import annotations

import numpy as np

from .checks import DataWarning
from .radar import BANDWIDTH_SPAN_WARN, RadarData, _bandwidth_line

#: The array pitch is taken for a unit mistake beyond these multiples of the
#: wavelength: above PITCH_MAX_WAVELENGTHS, x (z) in mm or cm read as m (a
#: 5 mm pitch is 333 wavelengths at 20 GHz in mm numbers, 33 in cm numbers;
#: the paper's sparse array has 1.3, a GPR line of 2 cm traces at 1.5 GHz
#: 0.1; an array with pitches of 20 wavelengths has grating lobes every 3
#: degrees, which no imager here can tell apart);
#: below 1 / PITCH_MIN_PER_WAVELENGTH, frequencies in kHz numbers (a 20 GHz
#: radar read as 20 MHz has a 15 m wavelength, 3000 of its 5 mm pitches).
PITCH_MAX_WAVELENGTHS = 20.0
PITCH_MIN_PER_WAVELENGTH = 300.0
#: A pitch below 1 / PITCH_MIN_PER_WAVELENGTH of the wavelength is blamed on
#: the positions (um, or a scale applied twice) where the carrier is at
#: least this (GPR antennas start near 100 MHz): a carrier read in kHz
#: numbers would lie below it.
PITCH_CARRIER_TRUSTED = 1e8
#: An echo's range profile is as wide as the range resolution c / 2B: its
#: autocorrelation falls to half within about 0.6 of it (less for a rect
#: window).  Profiles correlated over more than ECHO_WIDTH_MAX resolutions
#: say the range axis is in cm numbers (mm numbers leave its gates coarser
#: than the resolution and are refused).
ECHO_WIDTH_MAX = 10.0


def check_plausible(data: RadarData) -> None:
    """Warn (:class:`DataWarning`) where the data's units look wrong.

    The array pitch against the wavelength ``c / fc``: more than
    :data:`PITCH_MAX_WAVELENGTHS` wavelengths suggests x (z) in mm or cm read as m;
    less than 1 / :data:`PITCH_MIN_PER_WAVELENGTH` of one suggests
    frequencies in kHz numbers; a range resolution over
    :data:`BANDWIDTH_SPAN_WARN` times the range axis's span, a bandwidth in
    kHz numbers.  (GHz and MHz numbers are refused by
    :class:`~rpm_cl.io.model.Waveform`; a range axis in mm by :class:`RadarData`.)
    """
    import warnings

    arr = data.array
    span = float(data.range[-1] - data.range[0])
    pitch = max(abs(arr.dx), abs(arr.dz or 0.0))
    lam = data.waveform.wavelength
    where = "x / z" if arr.planar else "x"
    if pitch > PITCH_MAX_WAVELENGTHS * lam:
        warnings.warn(
            f"the antenna pitch {pitch:g} m is {pitch / lam:.0f} wavelengths "
            f"({lam:.3g} m at fc = {data.waveform.fc:g} Hz): is {where} in mm or cm? "
            f"give {where} in m",
            DataWarning,
            stacklevel=3,
        )
    elif pitch < lam / PITCH_MIN_PER_WAVELENGTH:
        # a carrier in the radar bands is more likely right than the pitch
        cause = (
            f"is {where} in um, or scaled to m twice? give {where} in m"
            if data.waveform.fc >= PITCH_CARRIER_TRUSTED
            else "are the frequencies in kHz numbers? give them in Hz (x 1e3)"
        )
        warnings.warn(
            f"the antenna pitch {pitch:g} m is 1/{lam / pitch:.0f} of the wavelength "
            f"({lam:.3g} m at fc = {data.waveform.fc:g} Hz): {cause}",
            DataWarning,
            stacklevel=3,
        )
    elif data.waveform.range_resolution > BANDWIDTH_SPAN_WARN * span:
        warnings.warn(
            _bandwidth_line(data.waveform.bandwidth, span, BANDWIDTH_SPAN_WARN),
            DataWarning,
            stacklevel=3,
        )
    width = echo_width(data)
    if width > ECHO_WIDTH_MAX * data.waveform.range_resolution:
        warnings.warn(
            f"the echoes are {width:.3g} m wide in range, "
            f"{width / data.waveform.range_resolution:.0f} times the range "
            f"resolution c/2B = {data.waveform.range_resolution:.3g} m: is range in cm "
            f"numbers? give it in m",
            DataWarning,
            stacklevel=3,
        )


def echo_width(data: RadarData) -> float:
    """The lag, m, at which the range profiles' autocorrelation (summed over
    the antennas) first falls to half its peak: about 0.6 range resolutions
    for echoes, a gate or so for white noise; 0 for all-zero data."""
    s = data.signal.reshape(-1, data.range.size)
    top = float(np.max(np.abs(s))) if s.size else 0.0
    if not top > 0:
        return 0.0
    n = data.range.size
    spec = np.fft.fft(s / top, 2 * n, axis=-1)  # relative: squares stay in range
    acf = np.abs(np.fft.ifft(np.sum(np.abs(spec) ** 2, axis=0))[:n])
    if not acf[0] > 0:
        return 0.0
    below = np.flatnonzero(acf < 0.5 * acf[0])
    return float((below[0] if below.size else n) * data.dr)
