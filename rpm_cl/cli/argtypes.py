"""Value types of the ``rpm-cl`` options (argparse ``type=`` callables).

Each converts one option's text or raises
:class:`argparse.ArgumentTypeError` with one line naming what was expected
(the parser prints it as ``rpm-cl: error: ...``).  They import nothing heavy:
the parser is built before any input is read.
"""

from __future__ import annotations

import argparse
import math


def _snr(text):
    if text.lower() in ("inf", "none"):
        return None
    try:
        v = float(text)
    except ValueError:
        v = float("nan")
    if v == float("inf"):
        return None
    if not (math.isfinite(v) and abs(v) <= 300):
        raise argparse.ArgumentTypeError(
            f"S/N must be a number of dB in [-300, 300] or 'inf', got {text!r}"
        )
    return v


def _int_at_least(lo: int, what: str):
    """argparse type: an integer >= lo, else one line ``{what}must be an
    integer >= lo, got ...``."""

    def parse(text):
        try:
            v = int(text)
        except ValueError:
            v = lo - 1
        if v < lo:
            raise argparse.ArgumentTypeError(f"{what}must be an integer >= {lo}, got {text!r}")
        return v

    return parse


_seed = _int_at_least(0, "seed ")


def _bounded_float(lo: float, hi: float, what: str):
    """argparse type: a finite float in [lo, hi], else one line naming ``what``."""

    def parse(text):
        try:
            v = float(text)
        except ValueError:
            v = float("nan")
        if not (math.isfinite(v) and lo <= v <= hi):
            raise argparse.ArgumentTypeError(f"{what}, got {text!r}")
        return v

    return parse


_dynamic_range = _bounded_float(1e-3, 400, "dynamic range must be between 0.001 and 400 dB")
_iso_db = _bounded_float(
    -400, -1e-6, "iso-surface level must be below the maximum, in [-400, 0) dB"
)
_budget_gb = _bounded_float(1e-3, 1e6, "memory budget must be between 0.001 and 1e6 GB")
_metres = _bounded_float(-1e4, 1e4, "must be a length in m within +-1e4")


_frame = _int_at_least(0, "frame ")


def _picture_size(text):
    """argparse type: 'WxH' pixels, each 100..10000."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        w = h = 0
    if not (100 <= w <= 10000 and 100 <= h <= 10000):
        raise argparse.ArgumentTypeError(f"size must be WxH pixels, each 100-10000, got {text!r}")
    return w, h


_positive_int = _int_at_least(1, "")


def _positive_quantity(parse, what: str, examples: str, none_ok: bool):
    """argparse type: ``parse(text)`` as a float > 0, or with ``none_ok``
    ``none`` (inf); else one line naming ``what`` and ``examples``."""

    def convert(text):
        from ..io.data import InputError

        if none_ok and text.strip().lower() == "none":
            return float("inf")
        try:
            v = float(parse(text.strip()))
        except (ValueError, KeyError, TypeError, InputError):
            v = float("nan")
        if not (math.isfinite(v) and v > 0):
            raise argparse.ArgumentTypeError(
                f"{what} > 0 (e.g. {examples}){' or none' if none_ok else ''}, got {text!r}"
            )
        return v

    return convert


def _dask_time(text):
    from dask.utils import parse_timedelta

    return parse_timedelta(text, default="seconds")


def _bytes(text):
    from ..io.guard import parse_bytes

    return parse_bytes(text)


_frame_timeout = _positive_quantity(
    _dask_time, "frame timeout must be a time", "90, 90s, 10m, 1h", True
)
_frame_memory = _positive_quantity(_bytes, "frame memory must be a size", "2G, 500MB, 1.5GiB", True)
_memory_size = _positive_quantity(
    _bytes, "a memory size must be a number of bytes", "8G, 512MB, 1.5GiB", False
)


def _band(text):
    """argparse type: 'F0:F1' in Hz, 0 < F0 < F1."""
    try:
        f0, f1 = (float(v) for v in text.split(":"))
    except ValueError:
        f0 = f1 = float("nan")
    if not (math.isfinite(f0) and math.isfinite(f1) and 0 < f0 < f1):
        raise argparse.ArgumentTypeError(
            f"band must be F0:F1 in Hz with 0 < F0 < F1 (e.g. 2e9:4e9), got {text!r}"
        )
    from ..io.checks import FC_MIN, unit_hint

    if f1 < FC_MIN:
        raise argparse.ArgumentTypeError(
            f"band {text} reaches only {f1:g} Hz, below {FC_MIN:g} Hz: it looks like "
            f"{unit_hint(f1)}; give it in Hz (e.g. 2e9:4e9)"
        )
    return f0, f1
