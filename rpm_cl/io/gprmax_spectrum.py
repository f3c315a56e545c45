"""A gprMax scan in the frequency domain (:func:`to_spectrum`,
:class:`GprSpectrum`): the background subtracted, the band sampled, the
source's current and the line source's far field divided out; and the file
the converted arrays are written to (:func:`save_spectrum`)."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from .atomic import refuse_overwrite
from .checks import InputError, _finite_scalar, _uniform_axis
from .gprmax_scan import POSITION_TOL, BScan
from .gprmax_waveform import SourceWaveform, _dtft, line_source_factor

#: Most frequency samples.
MAX_FREQUENCIES = 1 << 16


#: Weakest waveform level accepted in the band, relative to its peak (-60 dB):
#: below, the deconvolution divides by numbers that carry no signal.
MIN_WAVEFORM_LEVEL = 1e-3


@dataclass(frozen=True)
class GprSpectrum:
    """The engine's frequency-domain input made from a gprMax scan.

    Attributes
    ----------
    spectrum : ndarray, complex128, shape (nx, nf)
        ``Y(f)``: an echo of range R is ``a exp(-j 4 pi f R / c)``
        (:mod:`rpm_cl.io.gprmax`), m^(-1/2).
    frequency : ndarray, shape (nf,)
        Uniform, Hz.
    x : ndarray, shape (nx,)
        Increasing antenna x, m, as recorded.
    y_scan : float or None
        The scan line's y in gprMax's frame, m.
    """

    spectrum: np.ndarray
    frequency: np.ndarray
    x: np.ndarray
    y_scan: float | None


def _band(band, scan: BScan, df) -> np.ndarray:
    try:
        f0, f1 = (float(v) for v in band)
    except (TypeError, ValueError):
        raise InputError(f"band must be two frequencies (f0, f1) in Hz, got {band!r}") from None
    nyq = 0.5 / scan.dt
    if not (math.isfinite(f0) and math.isfinite(f1) and 0 < f0 < f1 <= nyq):
        raise InputError(
            f"band must satisfy 0 < f0 < f1 <= {nyq:g} Hz (the Nyquist "
            f"frequency of dt), got {f0:g} .. {f1:g} Hz"
        )
    t = scan.duration
    if df is None:
        nf = max(65, math.ceil((f1 - f0) * 2 * t) + 1)
        df = (f1 - f0) / (nf - 1)
    else:
        df = _finite_scalar("df", df)
        if df > 1 / t:
            raise InputError(
                f"df {df:g} Hz is coarser than 1/T = {1 / t:g} Hz of the "
                f"{t * 1e9:g} ns record: later echoes would alias in range"
            )
        nf = math.floor((f1 - f0) / df * (1 + 1e-12)) + 1
        if nf < 2:
            raise InputError(f"df {df:g} Hz leaves fewer than 2 samples in the band")
    if nf > MAX_FREQUENCIES:
        raise InputError(f"{nf} frequency samples; at most {MAX_FREQUENCIES} (a coarser df)")
    return f0 + df * np.arange(nf)


def _in_scan_order(scan: BScan, bg: BScan) -> BScan:
    """``bg`` with its traces in the order of ``scan``'s positions, where both
    hold the same positions in another order (a background scanned the
    other way); else ``bg`` as it is (:func:`_matching` judges it)."""
    from dataclasses import replace

    if scan.x is None or bg.x is None or scan.x.shape != bg.x.shape:
        return bg
    a, b = np.argsort(scan.x, kind="stable"), np.argsort(bg.x, kind="stable")
    if np.max(np.abs(scan.x[a] - bg.x[b])) > POSITION_TOL or np.array_equal(a, b):
        return bg
    order = np.empty_like(a)
    order[a] = b  # scan trace a[i] <- background trace b[i]
    return replace(bg, traces=bg.traces[:, order], x=bg.x[order])


def _matching(scan: BScan, bg: BScan) -> None:
    why = None
    if scan.traces.shape != bg.traces.shape:
        why = f"shape {bg.traces.shape} (time samples, traces) against {scan.traces.shape}"
    elif not math.isclose(scan.dt, bg.dt, rel_tol=1e-9):
        why = f"dt {bg.dt:g} s against {scan.dt:g} s"
    elif abs(scan.t0 - bg.t0) > 1e-6 * scan.dt:
        why = f"time offset {bg.t0:g} s against {scan.t0:g} s"
    elif scan.x is not None and bg.x is not None and np.max(np.abs(scan.x - bg.x)) > POSITION_TOL:
        why = "other antenna positions"
    elif scan.y is not None and bg.y is not None and abs(scan.y - bg.y) > POSITION_TOL:
        why = f"scan line y {bg.y:g} m against {scan.y:g} m"
    if why:
        raise InputError(f"background {bg.source} does not match the scan {scan.source}: {why}")


def to_spectrum(
    scan: BScan,
    background: BScan | None,
    band,
    waveform: SourceWaveform,
    df: float | None = None,
    scan_x=None,
    scan_y=None,
) -> GprSpectrum:
    """Background-subtract, transform, select the band, deconvolve.

    Parameters
    ----------
    scan : BScan
        The scan with the targets.
    background : BScan or None
        The same scan without targets (None: no subtraction, the direct
        coupling then dominates).
    band : (float, float)
        ``f0 < f1``, Hz, within the Nyquist frequency ``1 / (2 dt)``.
    waveform : SourceWaveform
        The source's waveform.
    df : float, optional
        Frequency step, Hz, at most ``1 / T`` (``T`` the record length);
        default ``(f1 - f0) / (nf - 1)`` with ``nf = max(65, 2 T (f1 - f0) + 1)``
        (the DTFT of the record, sampled at least twice as finely as its own
        resolution ``1 / T``).
    scan_x : ndarray, shape (nx,), optional
        Antenna x per trace, m (from a sidecar): required when the files hold
        no positions, checked against them when they do.
    scan_y : float, optional
        The scan line, m (checked likewise).

    Returns
    -------
    GprSpectrum
        Traces sorted by increasing x.

    Raises
    ------
    InputError
        Mismatched background, bad band or df, no positions, the waveform
        below -60 dB of its peak somewhere in the band.
    """
    if background is not None:
        background = _in_scan_order(scan, background)
        _matching(scan, background)
    x, y = scan.x, scan.y
    if scan_x is not None:
        sx = np.asarray(scan_x, np.float64)
        if sx.shape != (scan.traces.shape[1],):
            raise InputError(
                f"the sidecar gives {sx.size} positions for {scan.traces.shape[1]} traces"
            )
        if x is not None and np.max(np.abs(sx - x)) > POSITION_TOL:
            raise InputError(f"the sidecar's scan positions differ from those of {scan.source}")
        x = sx
    if scan_y is not None:
        if y is not None and abs(scan_y - y) > POSITION_TOL:
            raise InputError(
                f"the sidecar's scan line y {scan_y:g} m differs from {scan.source}'s {y:g} m"
            )
        y = float(scan_y)
    if x is None:
        raise InputError(
            f"{scan.source} holds no antenna positions (a gprMax 3 merged file "
            f'keeps none): give them in a sidecar ({{"scan": {{"x": [...]}}}})'
        )
    order = np.argsort(x, kind="stable")
    _uniform_axis("antenna x", x[order], 2)
    freq = _band(band, scan, df)
    nt = scan.traces.shape[0]
    level = np.abs(waveform.spectrum(np.linspace(0, 0.5 / scan.dt, 513), scan.dt, nt))
    src = waveform.spectrum(freq, scan.dt, nt)
    weak = np.abs(src) < MIN_WAVEFORM_LEVEL * level.max()
    if np.any(weak):
        fw = freq[np.argmax(weak)]
        raise InputError(
            f"the {waveform.kind} waveform of {waveform.frequency:g} Hz is below "
            f"-60 dB of its peak at {fw:g} Hz: choose a band where it has energy"
        )
    traces = scan.traces if background is None else scan.traces - background.traces
    t = scan.t0 + scan.dt * np.arange(nt)
    e = _dtft(traces, t, freq) * scan.dt
    y_f = e / (src * line_source_factor(freq))
    return GprSpectrum(y_f[order], freq, x[order], y)


def save_spectrum(path, arrays: dict, inputs=()) -> None:
    """Write :func:`rpm_cl.io.gprmax.convert`'s arrays as ``.npz`` or HDF5 (the input schema's
    names), through a temporary file renamed over ``path``.

    Parameters
    ----------
    path : str or path-like
        ``.npz``, ``.h5`` or ``.hdf5``.
    arrays : dict
        Names -> arrays.
    inputs : iterable of paths
        Files that ``path`` must not be (the converted files, the background,
        the sidecar).

    Raises
    ------
    InputError
        Unknown extension, missing folder, ``path`` is one of ``inputs``, or
        the file cannot be written.
    """
    from .data import _atomic_file, atomic_savez
    from .formats import DATA_EXTENSIONS, _h5_write_arrays, check_output

    path = os.fspath(path)
    ext = check_output(path, DATA_EXTENSIONS, "data output")
    refuse_overwrite(path, inputs)
    if ext == ".npz":
        atomic_savez(path, **arrays)
    else:
        _atomic_file(path, lambda tmp: _h5_write_arrays(tmp, arrays))
