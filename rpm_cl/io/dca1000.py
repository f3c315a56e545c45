"""TI mmWave (xWR1443/1642/1843/6843) + DCA1000 raw ADC captures -> the
engine's frequency-domain input.

Layouts
-------
The ``.bin`` file of a DCA1000 capture (mmWave Studio, or the DCA1000 CLI
in raw mode) is a stream of little-endian int16 ADC values, chirp after
chirp (each frame's chirps in order), laid out as TI's application report
SWRA581 ("Mmwave Radar Device ADC Raw Data Capture") describes for each
device family:

``complex-2lane`` (xWR16xx, xWR18xx, xWR68xx: two LVDS lanes, non-interleaved)
    Each chirp holds the receivers one after another (lowest first), each
    ``samples`` complex values; the values come in groups of four int16
    ``I(n) I(n+1) Q(n) Q(n+1)`` (lane 1 carries the I, lane 2 the Q of two
    successive samples).  Only 1, 2 or 4 receivers.
``complex-4lane`` (xWR12xx, xWR14xx: four LVDS lanes, interleaved)
    One lane per receiver, always four lanes (unused ones hold zeros): each
    sample time is eight int16, ``I`` of lanes 0..3 then ``Q`` of lanes
    0..3; the receivers are lanes ``0 .. receivers-1``.
``real`` (real-only ADC output of xWR16xx/18xx/68xx, and one-lane captures)
    Each chirp holds the receivers one after another, each ``samples`` int16.

Frequency and sign
------------------
A chirp of slope ``S`` starts at ``f0`` (TI's ``startFreq``); ADC sample
``n`` is taken at ``t_n = t_adc + n / fs`` after the ramp's start (TI's
``adcStartTime`` and sample rate), when the transmitted frequency is
``f_n = f0 + S t_n``.  TI's receivers mix the echo with the transmitted
chirp so that a target's IF is a *positive* frequency ``S tau`` (TI's
range FFT puts range 0 .. max at bins 0 .. N-1 of the complex samples, with
no negative half): the IF is ``TX conj(RX)``::

    IF(t_n) = a exp(+j 2 pi (f0 tau + S tau t_n - S tau^2 / 2))
            = a exp(+j 2 pi f_n tau) exp(-j pi S tau^2)

so sample ``n`` is the spectrum at ``f_n`` *conjugated*: the reader takes
its conjugate, ``a exp(-j 4 pi f_n R / c)`` with ``R = c tau / 2``, the
schema's echo.  The residual video phase ``pi S tau^2`` is left in (2e-3 rad
at 1 m for 30 MHz/us; it grows as ``R^2``).  Real samples
``a cos(2 pi f_n tau + ...)`` become their analytic signal along each chirp
(``scipy.signal.hilbert``: the positive-frequency half, ``a exp(+j ...)``),
then the same conjugate.

Positions
---------
One of:

``dx`` (synthetic aperture: the radar moved by ``dx`` between frames)
    One position per frame, ``x = i dx`` from 0; the frame's chirps are
    averaged (the radar stands still during a frame; ``chirps=1`` gives one
    position per chirp); one receiver (``receiver``, default 0).
``rx_spacing`` (the receivers as an array; one transmitter)
    Receiver ``k`` at ``x = k d / 2``: the engine is monostatic, and a
    transmitter-receiver pair acts as one antenna at their midpoint (right
    within ``b^2 / (8 R)`` for a pair ``b`` apart; the midpoints of receivers
    ``d`` apart are ``d / 2`` apart).  Several frames make a stack.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from .checks import FC_MIN, unit_hint
from .data import C0, InputError, _finite_scalar

__all__ = [
    "LAYOUTS",
    "MAX_VALUES",
    "Chirp",
    "convert",
    "decode",
    "read_capture",
]

#: Layouts (module docstring) and the device families that write them.
LAYOUTS = {
    "complex-2lane": "xWR16xx/18xx/68xx, complex",
    "complex-4lane": "xWR12xx/14xx, complex",
    "real": "xWR16xx/18xx/68xx real-only, or one lane",
}
#: Most int16 values read from a capture (256 MB).
MAX_VALUES = 1 << 27


def _count(name: str, value, lo: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < lo:
        raise InputError(f"{name} must be an integer >= {lo}, got {value!r}")
    return int(value)


@dataclass(frozen=True)
class Chirp:
    """The chirp and capture parameters (mmWave Studio's profile and frame).

    Attributes
    ----------
    slope : float
        Frequency slope ``S``, Hz/s, > 0 (TI's MHz/us times 1e12).
    adc_rate : float
        ADC sample rate ``fs``, samples/s.
    samples : int
        ADC samples per chirp, >= 2.
    start_freq : float
        Start frequency ``f0`` of the ramp, Hz.
    adc_start_time : float
        Time of the first ADC sample after the ramp's start, s, >= 0.
    chirps : int
        Chirps per frame.
    receivers : int
        Receivers enabled (1 .. 4).
    layout : str
        A key of :data:`LAYOUTS`.
    """

    slope: float
    adc_rate: float
    samples: int
    start_freq: float
    adc_start_time: float = 0.0
    chirps: int = 1
    receivers: int = 4
    layout: str = "complex-2lane"

    def __post_init__(self):
        object.__setattr__(self, "slope", _finite_scalar("slope", self.slope))
        object.__setattr__(self, "adc_rate", _finite_scalar("ADC rate", self.adc_rate))
        object.__setattr__(self, "start_freq", _finite_scalar("start frequency", self.start_freq))
        if self.start_freq < FC_MIN:
            raise InputError(
                f"start frequency {self.start_freq:g} Hz is below {FC_MIN:g} Hz: it looks "
                f"like {unit_hint(self.start_freq)}; give it in Hz"
            )
        t0 = _finite_scalar("ADC start time", self.adc_start_time, positive=False)
        if t0 < 0:
            raise InputError(f"ADC start time must be >= 0 s, got {t0:g}")
        object.__setattr__(self, "adc_start_time", t0)
        object.__setattr__(self, "samples", _count("samples", self.samples, 2))
        band = self.slope * self.samples / self.adc_rate
        if band < FC_MIN:
            raise InputError(
                f"the ramp sweeps {band:.3g} Hz over {self.samples} samples at "
                f"{self.adc_rate:g} samples/s (a range resolution of {C0 / (2 * band):.3g} m): "
                f"is the slope {self.slope:g} in MHz/us x 1e6? give it in Hz/s (MHz/us x 1e12)"
            )
        object.__setattr__(self, "chirps", _count("chirps", self.chirps))
        rx = _count("receivers", self.receivers)
        if rx > 4:
            raise InputError(f"receivers must be 1 .. 4, got {rx}")
        object.__setattr__(self, "receivers", rx)
        if self.layout not in LAYOUTS:
            raise InputError(f"layout {self.layout!r} is not one of {', '.join(LAYOUTS)}")
        if self.layout == "complex-2lane":
            if rx == 3:
                raise InputError(
                    "complex-2lane captures (xWR16xx/18xx/68xx) hold 1, 2 or 4 receivers, not 3"
                )
            if self.samples * rx % 2:
                raise InputError(
                    f"complex-2lane: {self.samples} samples x {rx} receivers must "
                    f"be even (two samples per lane word)"
                )

    @property
    def values_per_chirp(self) -> int:
        """int16 values of one chirp in the file."""
        if self.layout == "complex-4lane":
            return 8 * self.samples
        return self.samples * self.receivers * (1 if self.layout == "real" else 2)

    @property
    def frequency(self) -> np.ndarray:
        """``f_n = f0 + S (t_adc + n / fs)``, Hz, shape (samples,)."""
        t = self.adc_start_time + np.arange(self.samples) / self.adc_rate
        return self.start_freq + self.slope * t


def decode(values: np.ndarray, chirp: Chirp) -> np.ndarray:
    """int16 values of whole chirps -> samples per chirp and receiver.

    Parameters
    ----------
    values : ndarray, int16, shape (n_chirps * chirp.values_per_chirp,)
    chirp : Chirp

    Returns
    -------
    ndarray, shape (n_chirps, receivers, samples)
        complex128 (``I + jQ``) for the complex layouts, float64 for ``real``.
    """
    v = np.asarray(values, np.int16).astype(np.float64)
    rx, ns = chirp.receivers, chirp.samples
    if chirp.layout == "real":
        return v.reshape(-1, rx, ns)
    if chirp.layout == "complex-2lane":
        g = v.reshape(-1, 4)  # I(n) I(n+1) Q(n) Q(n+1)
        z = np.empty((g.shape[0], 2), np.complex128)
        z[:, 0] = g[:, 0] + 1j * g[:, 2]
        z[:, 1] = g[:, 1] + 1j * g[:, 3]
        return z.reshape(-1, rx, ns)
    g = v.reshape(-1, ns, 8)  # per sample: I lanes 0..3, Q 0..3
    z = g[:, :, :4] + 1j * g[:, :, 4:]
    return np.ascontiguousarray(z[:, :, :rx].transpose(0, 2, 1))


def read_capture(paths, chirp: Chirp) -> np.ndarray:
    """Read a capture (files concatenated in order, as mmWave Studio splits
    one at 1 GB) and decode it.

    Returns
    -------
    ndarray, shape (frames, chirps, receivers, samples)
        As :func:`decode`.

    Raises
    ------
    InputError
        A file missing, more than :data:`MAX_VALUES` values, a size that is
        not a whole number of frames (naming the counts: check ``samples``,
        ``receivers``, ``chirps`` and ``layout``), no frame.
    """
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    paths = [os.fspath(p) for p in paths]
    if not paths:
        raise InputError("no capture given")
    sizes = []
    for p in paths:
        if not os.path.isfile(p):
            raise InputError(f"{p}: no such file")
        sizes.append(os.path.getsize(p))
    total = sum(sizes)
    name = paths[0] if len(paths) == 1 else f"{paths[0]} (+{len(paths) - 1} files)"
    if total // 2 > MAX_VALUES:
        raise InputError(f"{name}: {total} bytes, more than {2 * MAX_VALUES}")
    per_frame = chirp.values_per_chirp * chirp.chirps * 2
    frames, rest = divmod(total, per_frame)
    if rest or frames == 0:
        raise InputError(
            f"{name}: {total} bytes is not a whole number of frames of {per_frame} "
            f"bytes ({chirp.chirps} chirps x {chirp.values_per_chirp} int16, "
            f"{chirp.layout}, {chirp.receivers} receivers x {chirp.samples} "
            f"samples): check --samples, --rx, --chirps and --layout"
        )
    buf = bytearray()
    for p, n in zip(paths, sizes):
        with open(p, "rb") as fh:
            part = fh.read(n)
        if len(part) != n:
            raise InputError(f"{p}: the file changed while read")
        buf += part
    values = np.frombuffer(bytes(buf), "<i2")
    z = decode(values, chirp)
    return z.reshape(frames, chirp.chirps, chirp.receivers, chirp.samples)


def _to_spectrum(z: np.ndarray, real: bool) -> np.ndarray:
    """IF samples (..., samples) -> ``a exp(-j 4 pi f_n R / c)`` (conjugate;
    real samples through their analytic signal first)."""
    if real:
        from scipy.signal import hilbert

        z = hilbert(z, axis=-1)
    return np.conj(z)


def convert(
    paths, chirp: Chirp, dx: float | None = None, rx_spacing: float | None = None, receiver: int = 0
) -> dict:
    """A DCA1000 capture -> ``spectrum``, ``frequency``, ``x``.

    Parameters
    ----------
    paths : path or list of paths
        The ``.bin`` file(s), in order.
    chirp : Chirp
        Chirp and capture parameters.
    dx : float, optional
        Scan step between frames, m: one position per frame (synthetic
        aperture), receiver ``receiver``.
    rx_spacing : float, optional
        Receiver spacing ``d``, m: the receivers at ``k d / 2`` (midpoints
        with the transmitter); a stack when the capture holds several frames.
    receiver : int
        With ``dx``: the receiver used, 0 .. receivers-1.

    Returns
    -------
    dict
        ``spectrum`` complex128: ``(frames, nf)`` with ``dx``;
        ``(receivers, nf)``, or ``(frames, receivers, nf)`` for several
        frames, with ``rx_spacing``.  ``frequency`` ``(nf,)`` Hz (``f_n``),
        ``x`` m.

    Raises
    ------
    InputError
        Neither or both of ``dx`` and ``rx_spacing``, a receiver out of
        range, one frame with ``dx``, one receiver with ``rx_spacing``, and
        :func:`read_capture`'s errors.
    """
    if (dx is None) == (rx_spacing is None):
        raise InputError(
            "give the positions: --dx (the radar moved between frames) or "
            "--rx-spacing (the receivers as the array), one of them"
        )
    if dx is None and receiver != 0:
        raise InputError("--receiver picks the receiver of a --dx scan")
    freq = chirp.frequency
    if freq[0] <= 0:
        raise InputError(
            f"the chirp's first sample lies at {freq[0]:g} Hz; frequencies must be > 0"
        )
    z = read_capture(paths, chirp).mean(axis=1)  # (frames, receivers, samples)
    frames = z.shape[0]
    if dx is not None:
        dx = _finite_scalar("dx", dx)
        r = _count("receiver", receiver, 0)
        if r >= chirp.receivers:
            raise InputError(
                f"receiver {r}: the capture holds {chirp.receivers} (0 .. {chirp.receivers - 1})"
            )
        if frames < 2:
            raise InputError(
                "one frame: a --dx scan needs a frame per position (>= 2); "
                "use --rx-spacing for one frame"
            )
        spec = _to_spectrum(z[:, r], chirp.layout == "real")
        return {"spectrum": spec, "frequency": freq, "x": np.arange(frames) * dx}
    d = _finite_scalar("rx spacing", rx_spacing)
    if chirp.receivers < 2:
        raise InputError("one receiver: --rx-spacing needs at least 2 (or use --dx)")
    spec = _to_spectrum(z, chirp.layout == "real")
    if frames == 1:
        spec = spec[0]
    return {"spectrum": spec, "frequency": freq, "x": np.arange(chirp.receivers) * (d / 2)}
