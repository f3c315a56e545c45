"""The gprMax source waveform (:class:`SourceWaveform`: each kind as gprMax
defines it, and the spectrum of the current a Hertzian dipole injects), the
far field of a unit line current (:func:`line_source_factor`), and the DTFT
of sampled traces.  Conventions (time zero, Fourier sign):
:mod:`rpm_cl.io.gprmax`."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .checks import InputError, _finite_scalar
from .model import C0

#: Vacuum permeability, H/m.
MU0 = 1.25663706212e-6
#: gprMax waveforms whose spectrum is wide enough to deconvolve (``sine``,
#: ``contsine``, ``impulse`` and ``user`` are not taken).
WAVEFORMS = (
    "gaussian",
    "gaussiandot",
    "gaussiandotnorm",
    "gaussiandotdot",
    "gaussiandotdotnorm",
    "gaussianprime",
    "gaussiandoubleprime",
    "ricker",
    "gauspulse",
)


@dataclass(frozen=True)
class SourceWaveform:
    """A gprMax excitation waveform (``#waveform: kind amplitude frequency ID``).

    Attributes
    ----------
    kind : str
        One of :data:`WAVEFORMS`.
    frequency : float
        gprMax's frequency parameter of the waveform, Hz (the centre frequency
        of a ``ricker``).
    amplitude : float
        Amplitude scaling (A for a Hertzian dipole).
    """

    kind: str
    frequency: float
    amplitude: float = 1.0

    def __post_init__(self):
        if self.kind not in WAVEFORMS:
            raise InputError(f"waveform {self.kind!r} is not one of {', '.join(WAVEFORMS)}")
        object.__setattr__(self, "frequency", _finite_scalar("waveform frequency", self.frequency))
        amp = _finite_scalar("waveform amplitude", self.amplitude, positive=False)
        if amp == 0:
            raise InputError("waveform amplitude must not be 0")
        object.__setattr__(self, "amplitude", amp)

    @classmethod
    def parse(cls, text: str) -> SourceWaveform:
        """``KIND:FREQ`` or ``KIND:FREQ:AMP`` (Hz), e.g. ``ricker:3e9``."""
        parts = str(text).split(":")
        if len(parts) not in (2, 3):
            raise InputError(f"waveform must be KIND:FREQ[:AMP] (e.g. ricker:3e9), got {text!r}")
        try:
            nums = [float(p) for p in parts[1:]]
        except ValueError:
            raise InputError(
                f"waveform must be KIND:FREQ[:AMP] with numbers in Hz, got {text!r}"
            ) from None
        return cls(parts[0].strip().lower(), *nums)

    def values(self, t) -> np.ndarray:
        """The waveform at times ``t`` (s), as gprMax defines it
        (``gprMax/waveforms.py``, ``Waveform.calculate_value``)."""
        t = np.asarray(t, np.float64)
        f = self.frequency
        if self.kind in ("gaussiandotdot", "gaussiandotdotnorm", "ricker"):
            chi, zeta = math.sqrt(2) / f, math.pi**2 * f**2
        elif self.kind == "gauspulse":
            zeta = -((math.pi * f * 0.5) ** 2) / (4 * math.log(10 ** (-6 / 20)))
            chi = math.sqrt(-math.log(10 ** (-60 / 20)) / zeta)
        else:
            chi, zeta = 1 / f, 2 * math.pi**2 * f**2
        d = t - chi
        g = np.exp(-zeta * d * d)
        k = self.kind
        if k == "gaussian":
            v = g
        elif k in ("gaussiandot", "gaussianprime"):
            v = -2 * zeta * d * g
        elif k == "gaussiandotnorm":
            v = -2 * zeta * d * g * math.sqrt(math.e / (2 * zeta))
        elif k in ("gaussiandotdot", "gaussiandoubleprime"):
            v = 2 * zeta * (2 * zeta * d * d - 1) * g
        elif k == "gaussiandotdotnorm":
            v = (2 * zeta * d * d - 1) * g
        elif k == "ricker":
            v = -(2 * zeta * d * d - 1) * g
        else:  # gauspulse
            v = g * np.cos(2 * math.pi * f * d)
        return self.amplitude * v

    def spectrum(self, frequency, dt: float, n: int) -> np.ndarray:
        """DTFT of the current a Hertzian dipole injects over ``n`` steps.

        ``I(f) = sum_m w((m + 1/2) dt) exp(-j 2 pi f (m + 1/2) dt) dt``,
        m = 0 .. n-1: the samples gprMax uses, at the times it uses them.

        Parameters
        ----------
        frequency : ndarray, shape (nf,)
            Hz.
        dt : float
            Time step, s.
        n : int
            Iterations.

        Returns
        -------
        ndarray, complex, shape (nf,)
            A s.
        """
        t = (np.arange(n) + 0.5) * dt
        return _dtft(self.values(t)[:, None], t, np.asarray(frequency, np.float64))[0] * dt


def _same_waveform(a: SourceWaveform | None, b: SourceWaveform | None) -> bool:
    if a is None or b is None:
        return a is b
    return (
        a.kind == b.kind
        and math.isclose(a.frequency, b.frequency, rel_tol=1e-9)
        and math.isclose(a.amplitude, b.amplitude, rel_tol=1e-9)
    )


def line_source_factor(frequency) -> np.ndarray:
    """``L(f) = -(w mu0 / 4) sqrt(2 / (pi k)) exp(+j pi/4)``: the far field of a
    unit line current at unit distance (``exp(+j w t)``), V/m per A, shape as
    ``frequency`` (Hz)."""
    f = np.asarray(frequency, np.float64)
    w = 2 * np.pi * f
    k = w / C0
    return -(w * MU0 / 4) * np.sqrt(2 / (np.pi * k)) * np.exp(0.25j * np.pi)


def _dtft(traces, t, frequency) -> np.ndarray:
    """``sum_n traces[n, i] exp(-j 2 pi f t_n)``: (nt, nx) -> (nx, nf), in
    frequency chunks of a few MB."""
    nt, nx = traces.shape
    out = np.empty((nx, frequency.size), np.complex128)
    step = max(1, (1 << 19) // max(nt, 1))
    for i in range(0, frequency.size, step):
        ph = np.exp(-2j * np.pi * np.outer(frequency[i : i + step], t))  # (chunk, nt)
        out[:, i : i + step] = (ph @ traces).T
    return out
