"""gprMax (2-D TM FDTD) B-scans -> the engine's frequency-domain input.

Reads gprMax output (HDF5, ``.out`` or ``.h5``; numpy and h5py only, gprMax
itself is not needed) and writes the input schema's frequency-domain form:
``spectrum`` (nx, nf), ``frequency`` (nf,), ``x`` (nx,).

Inputs
------
- one merged B-scan (gprMax's ``outputfiles_merge``: ``rxs/rx1/Ez`` of shape
  (Iterations, traces)), or one file per trace (``rxs/rx1/Ez`` of shape
  (Iterations,)), of a 2-D TM model (``nx_ny_nz[2] == 1``; the Ez of a
  z-directed Hertzian dipole, which is a line current in 2-D);
- the same scan without targets (the *background*: the direct coupling and
  everything else the targets do not cause), subtracted trace by trace;
- the source waveform (gprMax's type and centre frequency): given, or read
  from a sidecar JSON (see :func:`read_sidecar`).  A merged file does not keep
  it; a one-file-per-trace gprMax 4 output does, and must then agree.

Antenna positions: per trace from the file (gprMax 4: the receivers' and
sources' ``Position``; merged: ``trace_metadata``), else from the sidecar's
``scan.x`` (gprMax 3 merged files keep none).  ``x`` is the midpoint of
transmitter and receiver (the receiver alone when the file has no source
position), in metres *as recorded* in gprMax's frame (not centred), sorted
increasing.  The engine's range ``y`` of a point ``(X, Y)`` of gprMax's
plane is ``|Y - y_scan|``, ``y_scan`` the scan line.

Time zero and sign
------------------
Time zero is the start of the FDTD run, where gprMax's waveform has its own
time origin (a Ricker of centre ``f0`` peaks at ``t = sqrt(2)/f0``).  Ez
sample ``n`` lies at ``t_n = n dt`` (plus the dataset's ``TimeSampleOffset``
where the file has one, 0 for E); a Hertzian dipole injects the current
``w((m + 1/2) dt)`` in the update from ``m dt`` to ``(m + 1) dt`` (the
half-step values gprMax 3 and 4 keep for it).  The Fourier transform is ``X(f) = sum_n x_n exp(-j 2 pi f t_n) dt``
(NumPy's FFT sign), so a delay ``tau`` multiplies by ``exp(-j 2 pi f tau)``.

With ``E(f)`` the background-subtracted trace and ``I(f)`` the injected
current (the DTFT of the samples above), the converter returns

    Y(f) = E(f) / (I(f) L(f)),   L(f) = -(w mu0 / 4) sqrt(2 / (pi k)) exp(+j pi/4)

``L`` is the far field of a unit line current in the ``exp(+j w t)``
convention, ``E = -(w mu0 / 4) I H0^(2)(k rho)`` with
``H0^(2)(k rho) ~ sqrt(2 / (pi k rho)) exp(-j (k rho - pi/4))``, without its
``rho^(-1/2)``.  An echo of range ``R`` then becomes ``a exp(-j 4 pi f R / c)``,
the input schema's form: the waveform's spectrum, the line source's
``sqrt(f)`` rise and its constant ``pi/4`` are gone.  ``a`` is real and
constant over frequency for a specular echo of a smooth convex surface in the
geometric-optics limit, and *negative*: Ez reverses on a PEC (reflection
coefficient -1).  A finite flat plate's echo lies between a constant (a
plate much wider than its Fresnel zone) and a ``sqrt(f)`` rise with a
``pi/4`` (a much narrower one), a small cylinder's (k a ~ 1) has a slowly
varying phase: those belong to the targets.

Where the code lives: :mod:`.gprmax_waveform` (the source waveform),
:mod:`.gprmax_h5` (HDF5 access), :mod:`.gprmax_scan` (:class:`BScan`),
:mod:`.gprmax_sidecar` (the sidecar JSON), :mod:`.gprmax_spectrum` (the
conversion to the frequency domain and its file), :mod:`.gprmax_truth` (the
truth from the geometry); their names are importable from here too.  This
module reads the scans (:func:`read_bscan`, with the size limits
:data:`MAX_SAMPLES` and :data:`MAX_FILES`) and converts them
(:func:`convert`).
"""

from __future__ import annotations

import math
import os

import numpy as np

from .atomic import refuse_overwrite
from .checks import InputError
from .gprmax_h5 import (
    _attr,
    _dataset,
    _file_waveform,
    _get,
    _guarded,
    _open_h5,
    _position,
)
from .gprmax_scan import POSITION_TOL, BScan, _midpoints
from .gprmax_sidecar import MAX_SIDECAR, Sidecar, read_sidecar  # noqa: F401 - importable from here
from .gprmax_spectrum import (  # noqa: F401 - importable from here
    MAX_FREQUENCIES,
    MIN_WAVEFORM_LEVEL,
    GprSpectrum,
    save_spectrum,
    to_spectrum,
)
from .gprmax_truth import REFRACTED_STEP, truth_arrays  # noqa: F401 - importable from here
from .gprmax_waveform import (
    MU0,
    WAVEFORMS,
    SourceWaveform,
    _same_waveform,
    line_source_factor,
)

__all__ = [
    "MU0",
    "WAVEFORMS",
    "BScan",
    "GprSpectrum",
    "Sidecar",
    "SourceWaveform",
    "convert",
    "line_source_factor",
    "read_bscan",
    "read_sidecar",
    "refuse_overwrite",
    "save_spectrum",
    "to_spectrum",
    "truth_arrays",
]

#: Most time samples read from one file (traces x iterations): 1 GB as float64.
MAX_SAMPLES = 1 << 27
#: Most per-trace files of one scan.
MAX_FILES = 100_000


def _grid_checks(f, rx: int):
    """Root attributes of a 2-D TM output; returns (iterations, dt, Ez dataset)."""
    its = _attr(f, "Iterations", (), "the number of time steps")
    dt = float(_attr(f, "dt", (), "the time step"))
    if its != int(its) or its < 2:
        raise InputError(f"{f.filename}: Iterations must be an integer >= 2, got {its:g}")
    if not dt > 0:
        raise InputError(f"{f.filename}: dt must be > 0, got {dt:g}")
    if "nsrc" in f.attrs and _attr(f, "nsrc", (), "the number of sources") != 1:
        raise InputError(
            f"{f.filename}: {int(_attr(f, 'nsrc', (), ''))} sources; the converter "
            f"takes one Hertzian dipole"
        )
    if "nx_ny_nz" in f.attrs:
        n = _attr(f, "nx_ny_nz", (3,), "the grid size")
        if n[2] != 1:
            raise InputError(
                f"{f.filename}: a 3-D model (nx_ny_nz {n.astype(int).tolist()}); "
                f"the converter takes 2-D TM models (one cell in z, Ez)"
            )
    ds = _dataset(f, f"rxs/rx{rx}/Ez", f"Ez of receiver {rx} (a 2-D TM model records Ez)")
    if ds.shape[:1] != (int(its),) or ds.ndim not in (1, 2):
        raise InputError(
            f"{f.filename}: rxs/rx{rx}/Ez has shape {ds.shape}; Iterations is "
            f"{int(its)}: expected ({int(its)},) or ({int(its)}, traces)"
        )
    if ds.size > MAX_SAMPLES:
        raise InputError(
            f"{f.filename}: rxs/rx{rx}/Ez holds {ds.size} samples, more than {MAX_SAMPLES}"
        )
    if "SampleInterval" in ds.attrs:
        si = float(_attr(ds, "SampleInterval", (), "the sample interval"))
        if not math.isclose(si, dt, rel_tol=1e-9):
            raise InputError(f"{f.filename}: Ez's SampleInterval {si:g} s differs from dt {dt:g} s")
    t0 = float(_attr(ds, "TimeSampleOffset", (), "")) if "TimeSampleOffset" in ds.attrs else 0.0
    return int(its), dt, t0, ds


def _read_merged(path: str, rx: int) -> BScan:
    with _open_h5(path) as f:
        _, dt, t0, ds = _grid_checks(f, rx)
        if ds.ndim != 2:
            raise InputError(
                f"{path}: one trace; give every trace file of the scan, or a merged B-scan"
            )
        n = ds.shape[1]
        pos_rx = pos_tx = None
        if "trace_metadata" in f:
            if f"trace_metadata/rxs/rx{rx}/Position" in f:
                p = _dataset(f, f"trace_metadata/rxs/rx{rx}/Position", "receiver positions")
                if p.shape != (n, 3):
                    raise InputError(
                        f"{path}: receiver positions of shape {p.shape} for {n} traces"
                    )
                pos_rx = np.asarray(p[()], np.float64)
            if "trace_metadata/srcs/src1/Position" in f:
                p = _dataset(f, "trace_metadata/srcs/src1/Position", "source positions")
                if p.shape != (n, 3):
                    raise InputError(f"{path}: source positions of shape {p.shape} for {n} traces")
                pos_tx = np.asarray(p[()], np.float64)
        traces = np.asarray(ds[()], np.float64)
    x, y = _midpoints(path, pos_rx, pos_tx)
    return BScan(traces, dt, t0, x, y, path)


def _trace_file(path: str, rx: int, n_files: int):
    """One per-trace file: ((Iterations, dt, t0), waveform, rx position,
    tx position, trace)."""
    with _open_h5(path) as f:
        its, dt, t0, ds = _grid_checks(f, rx)
        if ds.ndim != 1:
            raise InputError("a merged B-scan; give it alone, not with other files")
        if its * n_files > MAX_SAMPLES:
            raise InputError(f"{n_files} traces of {its} samples, more than {MAX_SAMPLES} in all")
        wave = _file_waveform(f)
        rx_pos = _position(_get(f, f"rxs/rx{rx}", f"receiver {rx}"))
        has_src = "srcs" in f and "src1" in _get(f, "srcs", "sources")
        tx_pos = _position(_get(f, "srcs/src1", "source 1")) if has_src else None
        return (its, dt, t0), wave, rx_pos, tx_pos, np.asarray(ds[()], np.float64)


def _read_traces(paths: list, rx: int) -> BScan:
    cols, rxs, txs = [], [], []
    ref = wave = None
    for i, path in enumerate(paths):
        grid, w, rx_pos, tx_pos, col = _guarded(path, lambda p=path: _trace_file(p, rx, len(paths)))
        if i == 0:
            ref, wave = grid, w
        elif grid != ref:
            raise InputError(
                f"{path}: Iterations/dt/time offset {grid} differ from {paths[0]}'s {ref}"
            )
        elif not _same_waveform(w, wave):
            raise InputError(f"{path}: its waveform differs from {paths[0]}'s")
        rxs.append(rx_pos)
        txs.append(tx_pos)
        cols.append(col)
    missing = [p for p, pos in zip(paths, rxs) if pos is None]
    if missing and len(missing) < len(paths):
        having = next(p for p, pos in zip(paths, rxs) if pos is not None)
        raise InputError(
            f"{missing[0]} holds no receiver position while {having} does: a file of another run?"
        )
    pos_rx = None if missing else np.stack(rxs)
    pos_tx = None if any(p is None for p in txs) else np.stack(txs)
    x, y = _midpoints(paths[0], pos_rx, pos_tx)
    if x is not None and len(x) > 1:
        o = np.argsort(x, kind="stable")
        same = np.flatnonzero(np.diff(x[o]) <= POSITION_TOL)
        if same.size:
            a, b = sorted((int(o[same[0]]), int(o[same[0] + 1])))
            raise InputError(
                f"{paths[a]} and {paths[b]} hold traces at the same antenna position "
                f"(x = {x[a]:g} m): a file given twice?"
            )
    src = f"{paths[0]} (+{len(paths) - 1} files)"
    return BScan(np.stack(cols, axis=1), ref[1], ref[2], x, y, src, wave)


def read_bscan(paths, rx: int = 1) -> BScan:
    """Read one gprMax scan: a merged B-scan, or one file per trace.

    Parameters
    ----------
    paths : str, path-like or list of them
        One merged file, or the per-trace files in scan order (at most
        :data:`MAX_FILES`).
    rx : int
        Receiver number (``rxs/rx{rx}``), >= 1.

    Returns
    -------
    BScan
        Traces in file order (not yet sorted by x).

    Raises
    ------
    InputError
        Not HDF5, no Ez of that receiver, a 3-D model, more than one source or
        one that is not a Hertzian dipole, inconsistent trace files, external
        links or storage, sizes beyond :data:`MAX_SAMPLES`.  Sizes and links
        are checked from the headers before any data are read.
    """
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    paths = [os.fspath(p) for p in paths]
    if not paths:
        raise InputError("no gprMax output given")
    if len(paths) > MAX_FILES:
        raise InputError(f"{len(paths)} files; at most {MAX_FILES} traces")
    if isinstance(rx, bool) or not isinstance(rx, (int, np.integer)) or rx < 1:
        raise InputError(f"receiver number must be an integer >= 1, got {rx!r}")
    if len(paths) == 1:
        return _guarded(paths[0], lambda: _read_merged(paths[0], int(rx)))
    return _read_traces(paths, int(rx))


def convert(
    inputs,
    background=None,
    band=(2e9, 4e9),
    waveform: SourceWaveform | None = None,
    sidecar=None,
    df: float | None = None,
    rx: int = 1,
) -> dict:
    """gprMax files -> the arrays of the frequency-domain input schema.

    Parameters
    ----------
    inputs : path or list of paths
        One merged B-scan or the per-trace files (:func:`read_bscan`).
    background : path or list of paths, optional
        The same scan without targets.
    band : (float, float)
        Hz.
    waveform : SourceWaveform, optional
        Else the sidecar's, else the one the trace files record; where two
        of these are known they must agree.
    sidecar : path, optional
        JSON (:func:`read_sidecar`): waveform, scan positions, and geometry,
        which becomes the truth (:func:`truth_arrays`).
    df : float, optional
        Frequency step, Hz (:func:`to_spectrum`).
    rx : int
        Receiver number.

    Returns
    -------
    dict
        ``spectrum`` (nx, nf) complex128, ``frequency`` (nf,), ``x`` (nx,)
        and, with a sidecar's geometry and a known scan line, ``truth_*``.
    """
    side = read_sidecar(sidecar) if sidecar is not None else Sidecar()
    scan = read_bscan(inputs, rx)
    bg = read_bscan(background, rx) if background is not None else None
    known = [
        (w, what)
        for w, what in (
            (waveform, "the given waveform"),
            (side.waveform, f"the sidecar {sidecar}"),
            (scan.waveform, scan.source),
        )
        if w is not None
    ]
    if not known:
        raise InputError(
            'no waveform: give one (--waveform KIND:FREQ) or a sidecar with "waveform"'
        )
    for w, what in known[1:]:
        if not _same_waveform(w, known[0][0]):
            raise InputError(
                f"{what} records waveform {w.kind} {w.frequency:g} Hz "
                f"x{w.amplitude:g}; {known[0][1]} says {known[0][0].kind} "
                f"{known[0][0].frequency:g} Hz x{known[0][0].amplitude:g}"
            )
    out = to_spectrum(scan, bg, band, known[0][0], df, side.scan_x, side.scan_y)
    arrays = {"spectrum": out.spectrum, "frequency": out.frequency, "x": out.x}
    if out.y_scan is not None and (side.cylinders or side.polygons):
        arrays.update(truth_arrays(side, out.x, out.y_scan))
    return arrays
