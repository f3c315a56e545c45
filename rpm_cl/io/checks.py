"""The error and the warning of malformed input (:class:`InputError`,
:class:`DataWarning`) and the checks of single values: a finite real scalar,
a uniform, strictly increasing axis, a carrier frequency within
:data:`FC_MIN` .. :data:`FC_MAX`, and the unit a mistyped frequency looks
like (:func:`unit_hint`, :func:`scale_hint`)."""

from __future__ import annotations

import decimal
import numbers

import numpy as np


class InputError(ValueError):
    """Malformed input; the message names the field and the problem."""


class DataWarning(UserWarning):
    """Input that loads but looks wrong (a unit, a sign convention or a
    setting); the message says what to change.  The command line prints it
    as one line ``rpm-cl: warning: ...`` on stderr."""


#: Lowest centre frequency accepted, Hz.  Below it the numbers are taken for
#: GHz or MHz values given without their factor and refused (every radar the
#: engine models, HF included, lies above).
FC_MIN = 1e6
#: Highest centre frequency accepted, Hz (10 THz: above the terahertz
#: imagers, below the infrared).  A larger number is no radar carrier but a
#: corrupt or mistyped value, and would size the k-space searches beyond any
#: memory (1e30 Hz: 1e22 directions).
FC_MAX = 1e13


def unit_hint(value_hz: float) -> str:
    """For a frequency below :data:`FC_MIN`: the unit its number looks like
    (``"GHz numbers (x 1e9)"`` below 1e3, else ``"MHz numbers (x 1e6)"``)."""
    return "GHz numbers (x 1e9)" if abs(value_hz) < 1e3 else "MHz numbers (x 1e6)"


#: The factors a frequency given in kHz, MHz or GHz numbers lacks.
_UNIT_FACTORS = (
    (1e3, "kHz numbers (x 1e3)"),
    (1e6, "MHz numbers (x 1e6)"),
    (1e9, "GHz numbers (x 1e9)"),
)


def scale_hint(value_hz: float, at_least_hz: float) -> str:
    """For a frequency (a bandwidth) that should be at least ``at_least_hz``:
    the unit its number looks like, the smallest factor that lifts it there
    (``"MHz numbers (x 1e6)"``), or ``"a unit other than Hz"``."""
    for k, name in _UNIT_FACTORS:
        if value_hz * k >= at_least_hz:
            return name
    return "a unit other than Hz"


def _real_kind(a) -> bool:
    """True for real numbers: integer or floating dtypes, not bool, complex,
    strings, dates or time spans (``np.timedelta64`` counts as an integer
    to ``np.issubdtype``)."""
    return np.asarray(a).dtype.kind in "iuf"


def _finite_scalar(name: str, value, positive: bool = True) -> float:
    if isinstance(value, (numbers.Real, decimal.Decimal)) and not isinstance(
        value, (bool, np.bool_)
    ):
        arr = np.asarray(float(value))  # int, float, numpy scalars, Fraction, Decimal
    else:
        arr = np.asarray(value)
        if not _real_kind(arr):
            raise InputError(f"{name} must be a real number, got dtype {arr.dtype}")
    try:
        v = float(arr.reshape(()))
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a real scalar, got {value!r}") from None
    if not np.isfinite(v):
        raise InputError(f"{name} must be finite, got {v}")
    if positive and v <= 0:
        raise InputError(f"{name} must be > 0, got {v}")
    return v


def uniform_steps(a: np.ndarray, eps: float) -> bool:
    """Whether the steps of ``a`` (float64, >= 2 values) agree to what the
    schema takes as uniform: 1e-6 of the mean step plus the rounding of the
    stored values (``eps``, the stored type's, times 8 the largest value)."""
    step = np.diff(a)
    tol = 1e-6 * abs(step.mean()) + 8 * eps * float(np.max(np.abs(a))) + 1e-12
    return bool(np.max(np.abs(step - step.mean())) <= tol)


def _uniform_axis(name: str, values, min_len: int = 1, unit: str = "m") -> np.ndarray:
    a = np.asarray(values)
    if a.ndim != 1:
        raise InputError(f"{name} must be 1-D, got shape {a.shape}")
    if a.size < min_len:
        raise InputError(f"{name} must have at least {min_len} values, got {a.size}")
    if not _real_kind(a):
        raise InputError(f"{name} must be real numbers, got dtype {a.dtype}")
    # tolerance of the uniformity test: 1e-6 of the step, plus the rounding of
    # the stored values (float32 axes of measured data are common)
    eps = np.finfo(a.dtype).eps if np.issubdtype(a.dtype, np.floating) else 0.0
    a = a.astype(np.float64)
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name} contains NaN or Inf")
    if a.size >= 2:
        step = np.diff(a)
        if np.all(step < 0):
            raise InputError(
                f"{name} must be strictly increasing, and it decreases: reverse it with "
                f"the data's axis (rpm-cl convert IN --map ... does)"
            )
        if np.any(step <= 0):
            raise InputError(f"{name} must be strictly increasing")
        if not uniform_steps(a, eps):
            raise InputError(
                f"{name} must be uniformly spaced (steps vary from "
                f"{step.min():.6g} to {step.max():.6g} {unit})"
            )
        if eps > np.finfo(np.float64).eps:
            # stored in a coarser type (float32): the uniform axis its values
            # round, in float64, so that a check of the float64 axis passes
            a = a[0] + (a[-1] - a[0]) / (a.size - 1) * np.arange(a.size)
    a.setflags(write=False)
    return a


def carrier(fc) -> float:
    """``fc`` as a float, Hz, once it is finite and within :data:`FC_MIN` ..
    :data:`FC_MAX`; else :class:`InputError` naming the unit it looks like."""
    fc = _finite_scalar("fc", fc)
    if fc < FC_MIN:
        raise InputError(
            f"fc = {fc:g} Hz is below {FC_MIN:g} Hz: it looks like "
            f"{unit_hint(fc)}; give fc and bandwidth in Hz"
        )
    if fc > FC_MAX:
        raise InputError(
            f"fc = {fc:g} Hz is above {FC_MAX:g} Hz (10 THz): not a radar carrier; give fc in Hz"
        )
    return fc
