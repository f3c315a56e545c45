"""Sensors & Software pulseEKKO ``.DT1`` + ``.HD`` (impulse GPR B-scans) ->
the engine's frequency-domain input.

Layout
------
The ``.HD`` header is text beside the ``.DT1`` (the same name, extension
``.HD`` or ``.hd``): lines ``KEY = value``, of which these are read::

    NUMBER OF TRACES     traces (checked against the .DT1's size)
    NUMBER OF PTS/TRC    samples per trace
    TOTAL TIME WINDOW    the trace's window, ns
    TIMEZERO AT POINT    the recorder's time zero, sample (kept in the header
                         object, not applied: ``--time-zero`` sets it)
    STEP SIZE USED       the trace spacing, in POSITION UNITS
    POSITION UNITS       m, cm, mm, ft or in (or spelt out), read only where
                         the step is used
    NOMINAL FREQUENCY    the antenna's centre frequency, MHz

The ``.DT1`` holds the traces one after another, each a 128-byte header of
32 little-endian float32 words (word 0 the trace number, 1 its position in
POSITION UNITS, 2 its samples, 5 the bytes per sample) and then its samples,
little-endian signed integers of 2 bytes (or 4 where word 5 says so).  The
trace count is the file's size over one trace's bytes; every trace's own
word 2 must give the HD's samples (a file of another layout is refused, not
misread).  The HD's window is used, not the trace headers' word 6: on a
pulseEKKO PRO line (GPRPy's example ``XLINE00``) that word says 800 ns where
the HD's 1200 ns matches the recorded depths.

Conversion
----------
As for GSSI files (:func:`rpm_cl.io.traces.line_arrays`: each trace
less its mean, samples before time zero set to 0, the record zero-padded to
twice its length and transformed with NumPy's sign, the band kept).  Time
zero is the sample ``time_zero`` (default 0, the window's first sample;
``rpm-cl image --time-zero auto`` then puts it on the direct wave, as for a
DZT).  Positions: trace ``i`` at ``i`` times the HD's step (or ``dx``), in
metres.  Band: given, else 0.5-1.5 times the nominal frequency.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass

import numpy as np

from .data import InputError
from .traces import (
    header_beside,
    header_keys,
    header_number,
    line_arrays,
    plausible_dt,
    plausible_spacing,
    read_block,
    trace_count,
    trace_samples,
)

__all__ = ["TRACE_HEADER", "UNITS", "Dt1Header", "convert", "read_hd", "read_traces"]

#: Bytes of each trace's header in a DT1.
TRACE_HEADER = 128
#: Metres per POSITION UNITS (also spelt out, singular or plural).
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "ft": 0.3048, "in": 0.0254}
_SPELT = {
    "metre": "m",
    "meter": "m",
    "centimetre": "cm",
    "centimeter": "cm",
    "millimetre": "mm",
    "millimeter": "mm",
    "foot": "ft",
    "feet": "ft",
    "inch": "in",
    "inches": "in",
}


@dataclass(frozen=True)
class Dt1Header:
    """What :func:`read_hd` reads of an ``.HD`` (the module docstring).

    Attributes
    ----------
    traces : int or None
        NUMBER OF TRACES.
    samples : int
        Samples per trace.
    window : float
        s.
    time_zero : float or None
        The recorder's time zero, sample.
    step : float or None
        STEP SIZE USED, in ``units``.
    units : str
        POSITION UNITS as written (:func:`metres` reads them).
    frequency : float or None
        The antenna's nominal frequency, Hz.
    """

    traces: int | None
    samples: int
    window: float
    time_zero: float | None
    step: float | None
    units: str
    frequency: float | None

    @property
    def dt(self) -> float:
        """Sample interval, s."""
        return self.window / self.samples


def read_hd(path) -> Dt1Header:
    """The ``.HD`` beside the ``.DT1`` at ``path`` (the module docstring).

    Raises
    ------
    InputError
        No HD beside the file, a key missing or not a number, samples below
        3, a window that is not positive, unknown position units.
    """
    path = os.fspath(path)
    hd = header_beside(path, ".HD")
    keys = header_keys(hd, _key_value)

    def number(key, required=True):
        return header_number(keys, key, hd, "{key} = {value}", required)

    pts = number("NUMBER OF PTS/TRC")
    samples = trace_samples(pts, hd, f"NUMBER OF PTS/TRC = {pts:g}")
    window = number("TOTAL TIME WINDOW")
    if not window > 0:
        raise InputError(f"{hd}: TOTAL TIME WINDOW = {window:g} ns: it must be > 0")
    traces = number("NUMBER OF TRACES", required=False)
    mhz = number("NOMINAL FREQUENCY", required=False)
    plausible_dt(hd, window * 1e-9 / samples, "TOTAL TIME WINDOW and NUMBER OF PTS/TRC")
    return Dt1Header(
        None if traces is None or not 0 <= traces <= 1 << 40 else int(traces),
        samples,
        window * 1e-9,
        number("TIMEZERO AT POINT", required=False),
        number("STEP SIZE USED", required=False),
        keys.get("POSITION UNITS", "m"),
        None if mhz is None or not mhz > 0 else mhz * 1e6,
    )


def _key_value(line: str):
    m = re.match(r"\s*([A-Za-z][A-Za-z0-9 /()#_.-]*?)\s*=\s*(.*?)\s*$", line)
    return None if m is None else (m.group(1), m.group(2))


def metres(hdr: Dt1Header, hd: str) -> float:
    """The HD's STEP SIZE USED in metres.

    Raises
    ------
    InputError
        No step, or unknown POSITION UNITS.
    """
    unit = hdr.units.strip().lower()
    unit = _SPELT.get(unit.rstrip("s") if unit.rstrip("s") in _SPELT else unit, unit)
    if unit not in UNITS:
        raise InputError(
            f"{hd}: POSITION UNITS {hdr.units!r}; known: {', '.join(UNITS)}: or give the trace "
            f"spacing (--dx M)"
        )
    if hdr.step is None:
        raise InputError(f"{hd}: no STEP SIZE USED: give the trace spacing (--dx M)")
    return hdr.step * UNITS[unit]


def read_traces(path) -> tuple:
    """The HD and the traces of a ``.DT1``, ``(header, traces (n, samples)
    float64)``; sizes checked from the headers before the samples are read.

    Warns
    -----
    DataWarning
        The file ends inside a trace (that trace is dropped), or holds
        another number of traces than the HD says.
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise InputError(f"{path}: no such file")
    hdr = read_hd(path)
    size = os.path.getsize(path)
    with open(path, "rb") as fh:
        first = fh.read(TRACE_HEADER)
    if len(first) < TRACE_HEADER:
        raise InputError(f"{path}: {size} bytes, shorter than a trace header ({TRACE_HEADER})")
    words = np.frombuffer(first, "<f4")
    per = 4 if words[5] == 4 else 2
    if words[2] != hdr.samples:
        raise InputError(
            f"{path}: its first trace says {words[2]:g} samples, the HD {hdr.samples}: "
            f"not a DT1 of this header"
        )
    trace_bytes = TRACE_HEADER + per * hdr.samples
    n = trace_count(path, size, 0, trace_bytes, hdr.samples)
    # every trace's own sample count, read in place before the samples are
    # (a file of another layout is refused, not read whole)
    mm = np.memmap(path, np.uint8, "r", shape=(n * trace_bytes,))
    counts = np.ndarray((n,), "<f4", buffer=mm, offset=8, strides=(trace_bytes,))
    bad = np.flatnonzero(counts != hdr.samples)
    if bad.size:
        raise InputError(
            f"{path}: trace {bad[0] + 1} says {counts[bad[0]]:g} samples, the HD {hdr.samples}: "
            f"not a DT1 of this header"
        )
    del counts, mm
    buf = read_block(path, size, 0, trace_bytes, n, (hdr.traces, "the HD says"))
    raw = np.frombuffer(buf, np.uint8).reshape(n, trace_bytes)
    tr = raw[:, TRACE_HEADER:].copy().view("<i2" if per == 2 else "<i4").astype(np.float64)
    return hdr, tr


def convert(
    path, band=None, dx: float | None = None, time_zero: float = 0.0, subtract_mean: bool = False
) -> dict:
    """A pulseEKKO B-scan -> ``spectrum``, ``frequency``, ``x``,
    ``record_range`` (the module docstring; the same arrays as
    :func:`rpm_cl.io.dzt.convert`).

    Parameters
    ----------
    path : str or path-like
        The ``.DT1`` file, its ``.HD`` beside it.
    band : (float, float), optional
        Hz; default 0.5-1.5 times the HD's nominal frequency.
    dx : float, optional
        Trace spacing, m; default the HD's step.
    time_zero : float
        The sample of time zero, may be fractional.
    subtract_mean : bool
        Subtract the mean trace.

    Raises
    ------
    InputError
        The headers' (:func:`read_hd`, :func:`read_traces`), no band given nor
        a nominal frequency, a band beyond the Nyquist frequency, no spacing.
    """
    path = os.fspath(path)
    hdr, tr = read_traces(path)
    if band is None:
        if hdr.frequency is None:
            raise InputError(
                f"{path}: no band given and no NOMINAL FREQUENCY: give --band F0:F1 (Hz)"
            )
        band = (0.5 * hdr.frequency, 1.5 * hdr.frequency)

    def spacing():
        return plausible_spacing(path, metres(hdr, path), "the HD's STEP SIZE USED")

    return line_arrays(
        path, tr, hdr.dt, band, spacing if dx is None else dx, time_zero, subtract_mean
    )
