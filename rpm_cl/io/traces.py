"""What the impulse-GPR readers share (:mod:`rpm_cl.io.dzt`,
:mod:`rpm_cl.io.dt1`, :mod:`rpm_cl.io.mala`): a text header's numbers, the
block of traces read after its size is checked, and the real traces'
conversion to the engine's frequency-domain input (the conversion is
described in :mod:`rpm_cl.io.dzt`'s notes).
"""

from __future__ import annotations

import math
import os
import re
import warnings

import numpy as np

from .data import C0, DataWarning, InputError, _finite_scalar

__all__ = [
    "MAX_SAMPLES",
    "header_beside",
    "header_number",
    "line_arrays",
    "read_block",
    "traces_to_spectrum",
]

#: Most samples a reader reads (traces x channels x samples per trace).
MAX_SAMPLES = 1 << 27

_NUMBER = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?")


def header_beside(path: str, extension: str) -> str:
    """The header file beside ``path``: its name with ``extension`` (".HD",
    ".rad") in any case.

    Raises
    ------
    InputError
        None is there.
    """
    stem = os.path.splitext(path)[0]
    folder = os.path.dirname(stem) or "."
    want = (os.path.basename(stem) + extension).lower()
    found = sorted(n for n in os.listdir(folder) if n.lower() == want)
    for name in found:
        full = os.path.join(folder, name)
        if os.path.isfile(full):
            return full
    raise InputError(f"{path}: no header {os.path.basename(stem)}{extension} beside it")


def header_number(keys: dict, key: str, where: str, line: str, required: bool = True):
    """The number a text header's ``key`` starts with, float; None where
    the key is missing and not ``required``.

    Parameters
    ----------
    keys : dict
        The header's keys (upper case) and values (text).
    key : str
    where : str
        The header file, for the messages.
    line : str
        How the header writes a line, with ``{key}`` and ``{value}`` (for
        the messages: ``"{key} = {value}"``, ``"{key}:{value}"``).

    Raises
    ------
    InputError
        A required key missing, or a value that starts with no finite number.
    """
    v = keys.get(key)
    if v is None:
        if required:
            raise InputError(f"{where}: no '{key}' line")
        return None
    m = _NUMBER.match(v)
    if not m or not math.isfinite(float(m.group(0))):
        shown = line.format(key=key, value=repr(v))
        raise InputError(f"{where}: {shown} is no (finite) number")
    return float(m.group(0))


def read_block(path: str, size: int, offset: int, trace_bytes: int, samples: int, declared=None):
    """The whole traces of a file, as bytes, after their count is checked.

    Parameters
    ----------
    path : str
    size : int
        The file's bytes.
    offset : int
        Where the traces start, bytes.
    trace_bytes : int
        Bytes of one trace (its header included).
    samples : int
        Samples per trace (the bound :data:`MAX_SAMPLES`).
    declared : (int or None, str), optional
        The trace count a header gives and how to name it ("the HD says").

    Returns
    -------
    (int, bytes)
        The traces and their bytes.

    Raises
    ------
    InputError
        More than :data:`MAX_SAMPLES` samples, fewer than 2 traces, a file
        that changes while read.

    Warns
    -----
    DataWarning
        The file ends inside a trace (it is dropped), or holds another count
        than ``declared``.
    """
    n, rest = divmod(size - offset, trace_bytes)
    if n * samples > MAX_SAMPLES:
        raise InputError(f"{path}: {n} traces of {samples} samples, more than {MAX_SAMPLES}")
    if n < 2:
        raise InputError(f"{path}: {n} traces of {trace_bytes} bytes; a B-scan needs at least 2")
    if rest:
        warnings.warn(
            f"{path}: the data end {rest} bytes into trace {n + 1} (of {trace_bytes} bytes); "
            f"that part trace is dropped",
            DataWarning,
            stacklevel=3,
        )
    if declared is not None and declared[0] is not None and declared[0] != n:
        warnings.warn(
            f"{path}: {n} traces, where {declared[1]} {declared[0]}; the file's are read",
            DataWarning,
            stacklevel=3,
        )
    with open(path, "rb") as fh:
        fh.seek(offset)
        buf = fh.read(n * trace_bytes)
    if len(buf) != n * trace_bytes:
        raise InputError(f"{path}: the file changed while read")
    return n, buf


def line_arrays(path, tr, dt: float, band, dx, time_zero, subtract_mean: bool) -> dict:
    """The schema's arrays of a line of real traces: ``spectrum``,
    ``frequency``, ``x`` (trace ``i`` at ``i dx``), ``record_range``.

    Parameters
    ----------
    path : str
    tr : ndarray, float64, shape (traces, N)
    dt : float
        Sample interval, s.
    band : (float, float)
        Hz, the caller's default already in.
    dx : float or callable
        Trace spacing, m, or a function of no arguments that gives it (or
        raises), called after the band is checked.
    time_zero, subtract_mean
        :func:`traces_to_spectrum`'s.

    Raises
    ------
    InputError
        A band beyond the Nyquist frequency, a spacing that is no finite
        positive length, and :func:`traces_to_spectrum`'s.
    """
    f0, f1 = (float(v) for v in band)
    nyq = 0.5 / dt
    if not (math.isfinite(f0) and math.isfinite(f1) and 0 < f0 < f1 <= nyq):
        raise InputError(
            f"{path}: band must satisfy 0 < f0 < f1 <= {nyq:g} Hz (the Nyquist "
            f"frequency of {dt * 1e12:g} ps samples), got {f0:g} .. {f1:g} Hz"
        )
    dx = _finite_scalar("dx", dx() if callable(dx) else dx)
    out = traces_to_spectrum(path, tr, dt, time_zero, (f0, f1), subtract_mean)
    return {
        "spectrum": out["spectrum"],
        "frequency": out["frequency"],
        "x": np.arange(tr.shape[0]) * dx,
        "record_range": out["record_range"],
    }


def traces_to_spectrum(path, tr, dt: float, time_zero, band, subtract_mean: bool) -> dict:
    """Real traces -> ``spectrum``, ``frequency``, ``record_range``
    (:mod:`rpm_cl.io.dzt`'s notes, "Conversion").

    Parameters
    ----------
    path : str
        The file, for the messages.
    tr : ndarray, float64, shape (traces, N)
    dt : float
        Sample interval, s.
    time_zero : float
        The sample of time zero, 0 .. N - 2, may be fractional.
    band : (float, float)
        Hz, within the Nyquist frequency.
    subtract_mean : bool
        Subtract the mean trace.
    """
    n = tr.shape[1]
    f0, f1 = band
    n0 = _finite_scalar("time zero", time_zero, positive=False)
    if not 0 <= n0 <= n - 2:
        raise InputError(f"{path}: time zero at sample {n0:g}, outside the trace's 0 .. {n - 2}")
    tr = tr - tr.mean(axis=1, keepdims=True)
    if subtract_mean:
        tr -= tr.mean(axis=0, keepdims=True)
    tr[:, : math.ceil(n0)] = 0.0
    df = 1.0 / (2 * n * dt)
    k = np.arange(math.ceil(f0 / df - 1e-9), math.floor(f1 / df + 1e-9) + 1)
    if k.size < 2:
        raise InputError(
            f"{path}: the band {f0:g} .. {f1:g} Hz holds {k.size} frequency "
            f"samples at {df:g} Hz; widen it"
        )
    freq = k * df
    spec = np.fft.rfft(tr, n=2 * n, axis=1)[:, k] * dt
    spec *= np.exp(2j * np.pi * freq * n0 * dt)  # t_n = (n - n0) dt
    return {
        "spectrum": spec,
        "frequency": freq,
        # the record after time zero: the padded half's gates hold nothing
        "record_range": (n - n0) * dt * C0 / 2.0,
    }
