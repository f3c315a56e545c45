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
    "MAX_TRACE_SAMPLES",
    "header_beside",
    "header_keys",
    "header_number",
    "line_arrays",
    "plausible_dt",
    "plausible_spacing",
    "read_block",
    "trace_count",
    "trace_samples",
]

#: Most samples a reader reads (traces x channels x samples per trace).
MAX_SAMPLES = 1 << 27
#: Most bytes a reader reads (samples and trace headers).
MAX_BYTES = 1 << 30
#: Most samples of one trace a text header may declare.
MAX_TRACE_SAMPLES = 1 << 20
#: Largest text header read, bytes (a GPR header is under 2 kB).
HEADER_MAX_BYTES = 1 << 16
#: Sample intervals a header may give, s: a 10 GHz antenna's record is
#: sampled at tens of ps, a 10 MHz one's at nanoseconds.
DT_MIN, DT_MAX = 1e-13, 1e-7
#: Trace spacings a header may give, m (as GSSI's scans per metre allow):
#: outside them it is no survey's and ``--dx`` is asked for.
SPACING_MIN, SPACING_MAX = 1e-5, 100.0

# a number, then at most a unit word (letters) and blanks: "1200.000",
# "50 ns"; "50,5" is refused rather than read as 50
_NUMBER = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*[A-Za-z]*\s*$")


def header_beside(path: str, extension: str) -> str:
    """The header file beside ``path``: its name with ``extension`` (".HD",
    ".rad") in any case, a regular file.

    Raises
    ------
    InputError
        None is there, or it is no regular file.
    """
    from .guard import regular_file

    stem = os.path.splitext(path)[0]
    folder = os.path.dirname(stem) or "."
    want = (os.path.basename(stem) + extension).lower()
    try:
        found = sorted(n for n in os.listdir(folder) if n.lower() == want)
    except OSError as exc:
        raise InputError(f"{path}: cannot list its folder ({exc.strerror or exc})") from None
    if not found:
        raise InputError(f"{path}: no header {os.path.basename(stem)}{extension} beside it")
    return regular_file(os.path.join(folder, found[0]), "header")


def header_keys(path: str, split) -> dict:
    """The ``KEY value`` pairs of a text header, read to at most
    :data:`HEADER_MAX_BYTES`: keys upper case with single blanks, the first
    of each kept; ``split(line)`` gives ``(key, value)`` or None.

    Raises
    ------
    InputError
        A longer file, or one that cannot be read.
    """
    try:
        with open(path, "rb") as fh:
            raw = fh.read(HEADER_MAX_BYTES + 1)
    except OSError as exc:
        raise InputError(f"{path}: cannot read the header ({exc.strerror or exc})") from None
    if len(raw) > HEADER_MAX_BYTES:
        raise InputError(f"{path}: over {HEADER_MAX_BYTES} bytes, no GPR header")
    keys = {}
    for line in raw.decode("latin-1").splitlines():
        kv = split(line)
        if kv is not None:
            keys.setdefault(" ".join(kv[0].split()).upper(), kv[1].strip())
    return keys


def header_number(keys: dict, key: str, where: str, line: str, required: bool = True):
    """The number a text header gives for ``key`` (a unit word may follow
    it), float; None where the key is missing and not ``required``.

    Parameters
    ----------
    keys : dict
        :func:`header_keys`.
    key : str
    where : str
        The header file, for the messages.
    line : str
        How the header writes a line, with ``{key}`` and ``{value}`` (for
        the messages: ``"{key} = {value}"``, ``"{key}:{value}"``).

    Raises
    ------
    InputError
        A required key missing, or a value that is no finite number.
    """
    v = keys.get(key)
    if v is None:
        if required:
            raise InputError(f"{where}: no '{key}' line")
        return None
    m = _NUMBER.match(v)
    if not m or not math.isfinite(float(m.group(1))):
        shown = line.format(key=key, value=repr(v))
        raise InputError(f"{where}: {shown} is no (finite) number")
    return float(m.group(1))


def trace_samples(value: float, where: str, shown: str) -> int:
    """A header's samples per trace, a whole number 3 .. :data:`MAX_TRACE_SAMPLES`."""
    if value != int(value) or not 3 <= value <= MAX_TRACE_SAMPLES:
        raise InputError(
            f"{where}: {shown}: samples per trace must be a whole number, 3 .. {MAX_TRACE_SAMPLES}"
        )
    return int(value)


def plausible_dt(where: str, dt: float, shown: str) -> float:
    """A header's sample interval, s, within :data:`DT_MIN` .. :data:`DT_MAX`;
    else InputError naming the fields ``shown`` that gave it."""
    if not DT_MIN <= dt <= DT_MAX:
        raise InputError(
            f"{where}: a sample interval of {dt:.3g} s (from {shown}) is no GPR's "
            f"({DT_MIN:g} .. {DT_MAX:g} s)"
        )
    return dt


def plausible_spacing(path: str, dx: float, source: str) -> float:
    """A trace spacing from a header, m, within :data:`SPACING_MIN` ..
    :data:`SPACING_MAX`; else InputError asking for ``--dx``."""
    if not SPACING_MIN <= dx <= SPACING_MAX:
        raise InputError(
            f"{path}: {source} gives a {dx:.3g} m trace spacing, no survey's: give the "
            f"trace spacing (--dx M)"
        )
    return dx


def trace_count(path: str, size: int, offset: int, trace_bytes: int, samples: int) -> int:
    """The whole traces of ``trace_bytes`` after ``offset`` in a file of
    ``size`` bytes, checked: at least 2, at most :data:`MAX_SAMPLES` samples
    and :data:`MAX_BYTES` bytes."""
    n = (size - offset) // trace_bytes
    if n * samples > MAX_SAMPLES or n * trace_bytes > MAX_BYTES:
        raise InputError(
            f"{path}: {n} traces of {samples} samples ({trace_bytes} bytes each), more than "
            f"{MAX_SAMPLES} samples or {MAX_BYTES} bytes"
        )
    if n < 2:
        raise InputError(f"{path}: {n} traces of {trace_bytes} bytes; a B-scan needs at least 2")
    return n


def read_block(path: str, size: int, offset: int, trace_bytes: int, n: int, declared=None):
    """The bytes of the ``n`` whole traces (:func:`trace_count`) after
    ``offset``, with the warnings of a part trace at the end and of another
    count than a header's.

    Parameters
    ----------
    declared : (int or None, str), optional
        The trace count a header gives and how to name it ("the HD says").

    Warns
    -----
    DataWarning
        The file ends inside a trace (it is dropped), or holds another count
        than ``declared``.
    """
    rest = size - offset - n * trace_bytes
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
    return buf


def line_arrays(path, tr, dt: float, band, dx, time_zero, subtract_mean: bool) -> dict:
    """Real traces -> the schema's arrays: ``spectrum``, ``frequency``,
    ``x`` (trace ``i`` at ``i dx``), ``record_range`` (:mod:`rpm_cl.io.dzt`'s
    notes, "Conversion").

    Parameters
    ----------
    path : str
        The file, for the messages.
    tr : ndarray, float64, shape (traces, N)
    dt : float
        Sample interval, s.
    band : (float, float)
        Hz, the caller's default already in.
    dx : float or callable
        Trace spacing, m, or a function of no arguments that gives it (or
        raises), called after the band is checked.
    time_zero : float
        The sample of time zero, 0 .. N - 2, may be fractional.
    subtract_mean : bool
        Subtract the mean trace.

    Raises
    ------
    InputError
        A band beyond the Nyquist frequency or holding fewer than 2
        samples, a spacing that is no finite positive length, a time zero
        outside the trace.
    """
    f0, f1 = (float(v) for v in band)
    nyq = 0.5 / dt
    if not (math.isfinite(f0) and math.isfinite(f1) and 0 < f0 < f1 <= nyq):
        raise InputError(
            f"{path}: band must satisfy 0 < f0 < f1 <= {nyq:g} Hz (the Nyquist "
            f"frequency of {dt * 1e12:g} ps samples), got {f0:g} .. {f1:g} Hz"
        )
    dx = _finite_scalar("dx", dx() if callable(dx) else dx)
    n = tr.shape[1]
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
        "x": np.arange(tr.shape[0]) * dx,
        # the record after time zero: the padded half's gates hold nothing
        "record_range": (n - n0) * dt * C0 / 2.0,
    }
