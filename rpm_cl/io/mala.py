"""MALÅ (RAMAC, ProEx, GX) ``.rd3`` / ``.rd7`` + ``.rad`` (impulse GPR
B-scans) -> the engine's frequency-domain input.

Layout
------
The ``.rad`` header is text beside the data file (the same name): lines
``KEY:value``, of which these are read::

    SAMPLES              samples per trace
    FREQUENCY            the sampling frequency, MHz (dt = 1 / FREQUENCY)
    DISTANCE INTERVAL    the trace spacing, m (0: a time-triggered survey)
    LAST TRACE           traces (checked against the data's size)
    ANTENNAS             the antenna's name, its centre frequency first
                         ("500_shielded", "250 MHz Shielded", "1.6GHz")

The data file holds the traces one after another, the samples of each as
little-endian signed integers: 2 bytes in ``.rd3``, 4 in ``.rd7``; no
trace headers.  The trace count is the file's size over one trace's bytes.
The sample interval is ``1 / FREQUENCY``, as MALÅ's and ImpDAR's readers
take it; the header's ``TIMEWINDOW`` is not used (on a real RAMAC file,
ImpDAR's test line ``ten_col``, it is twice ``SAMPLES / FREQUENCY``).

Conversion
----------
As for GSSI files (:func:`rpm_cl.io.traces.line_arrays`); time zero is
the sample ``time_zero`` (default 0; ``rpm-cl image --time-zero auto`` puts
it on the direct wave), positions ``i`` times the spacing, the band given or
0.5-1.5 times the antenna's centre frequency.
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

__all__ = ["MalaHeader", "antenna_frequency", "convert", "read_rad", "read_traces"]

#: Largest ``.rad`` read, bytes (a header is under 2 kB).
RAD_MAX_BYTES = 1 << 16
#: Bytes per sample by the data file's extension.
SAMPLE_BYTES = {".rd3": 2, ".rd7": 4}


@dataclass(frozen=True)
class MalaHeader:
    """What :func:`read_rad` reads of a ``.rad`` (the module docstring).

    Attributes
    ----------
    samples : int
    dt : float
        Sample interval, s.
    step : float
        Trace spacing, m; 0 for a time-triggered survey.
    traces : int or None
        LAST TRACE.
    frequency : float or None
        The antenna's centre frequency, Hz.
    """

    samples: int
    dt: float
    step: float
    traces: int | None
    frequency: float | None


def antenna_frequency(name: str) -> float | None:
    """The centre frequency a MALÅ antenna name starts with, Hz: a number
    with an optional unit (MHz when none), as in "500_shielded", "250 MHz
    Shielded", "1.6GHz"; None where it starts with none (or a number
    outside 1 MHz .. 100 GHz)."""
    m = re.match(r"\s*(\d+(?:\.\d+)?)\s*(MHz|GHz)?", name or "", re.IGNORECASE)
    if not m:
        return None
    f = float(m.group(1)) * (1e9 if (m.group(2) or "").lower() == "ghz" else 1e6)
    return f if 1e6 <= f <= 1e11 else None


def read_rad(path) -> MalaHeader:
    """The ``.rad`` beside the data file at ``path`` (the module docstring).

    Raises
    ------
    InputError
        No header beside the file, a key missing or not a finite number,
        samples below 3, a sampling frequency that is not positive, a
        negative spacing.
    """
    path = os.fspath(path)
    rad = header_beside(path, ".rad")
    keys = header_keys(rad, _key_value)

    def number(key, required=True):
        return header_number(keys, key, rad, "{key}:{value}", required)

    value = number("SAMPLES")
    samples = trace_samples(value, rad, f"SAMPLES:{value:g}")
    mhz = number("FREQUENCY")
    if not mhz > 0:
        raise InputError(f"{rad}: FREQUENCY:{mhz:g} MHz: the sampling frequency must be > 0")
    step = number("DISTANCE INTERVAL", required=False) or 0.0
    if step < 0:
        raise InputError(f"{rad}: DISTANCE INTERVAL:{step:g} m: it must be >= 0")
    traces = number("LAST TRACE", required=False)
    plausible_dt(rad, 1e-6 / mhz, "FREQUENCY")
    return MalaHeader(
        samples,
        1e-6 / mhz,
        step,
        None if traces is None or not 0 <= traces <= 1 << 40 else int(traces),
        antenna_frequency(keys.get("ANTENNAS", "")),
    )


def _key_value(line: str):
    key, sep, value = line.partition(":")
    return (key, value) if sep else None


def read_traces(path) -> tuple:
    """The header and the traces of a ``.rd3`` / ``.rd7``, ``(header,
    traces (n, samples) float64)``; sizes checked before the samples are
    read.

    Warns
    -----
    DataWarning
        The file ends inside a trace (that trace is dropped), or holds
        another number of traces than LAST TRACE says.
    """
    path = os.fspath(path)
    ext = os.path.splitext(path)[1].lower()
    if ext not in SAMPLE_BYTES:
        raise InputError(f"{path}: a MALÅ data file is .rd3 (16-bit) or .rd7 (32-bit)")
    if not os.path.isfile(path):
        raise InputError(f"{path}: no such file")
    hdr = read_rad(path)
    per = SAMPLE_BYTES[ext]
    trace_bytes = per * hdr.samples
    size = os.path.getsize(path)
    n = trace_count(path, size, 0, trace_bytes, hdr.samples)
    buf = read_block(path, size, 0, trace_bytes, n, (hdr.traces, "LAST TRACE says"))
    tr = np.frombuffer(buf, "<i2" if per == 2 else "<i4").reshape(n, hdr.samples)
    return hdr, tr.astype(np.float64)


def convert(
    path, band=None, dx: float | None = None, time_zero: float = 0.0, subtract_mean: bool = False
) -> dict:
    """A MALÅ B-scan -> ``spectrum``, ``frequency``, ``x``,
    ``record_range`` (the module docstring; the same arrays as
    :func:`rpm_cl.io.dzt.convert`).

    Parameters
    ----------
    path : str or path-like
        The ``.rd3`` or ``.rd7`` file, its ``.rad`` beside it.
    band : (float, float), optional
        Hz; default 0.5-1.5 times the antenna's centre frequency.
    dx : float, optional
        Trace spacing, m; default the header's (required where it is 0).
    time_zero : float
        The sample of time zero, may be fractional.
    subtract_mean : bool
        Subtract the mean trace.
    """
    path = os.fspath(path)
    hdr, tr = read_traces(path)
    if band is None:
        if hdr.frequency is None:
            raise InputError(
                f"{path}: no band given and no frequency in the header's ANTENNAS: "
                f"give --band F0:F1 (Hz)"
            )
        band = (0.5 * hdr.frequency, 1.5 * hdr.frequency)

    def spacing():
        if not hdr.step > 0:
            raise InputError(
                f"{path}: a time-triggered survey (DISTANCE INTERVAL 0): give the trace "
                f"spacing (--dx M)"
            )
        return plausible_spacing(path, hdr.step, "the header's DISTANCE INTERVAL")

    return line_arrays(
        path, tr, hdr.dt, band, spacing if dx is None else dx, time_zero, subtract_mean
    )
