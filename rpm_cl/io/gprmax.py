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
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field

import numpy as np

from .data import C0, InputError, _finite_scalar, _uniform_axis, refuse_overwrite
from .guard import h5_inside

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
#: Most time samples read from one file (traces x iterations): 1 GB as float64.
MAX_SAMPLES = 1 << 27
#: Most per-trace files of one scan, and most frequency samples.
MAX_FILES = 100_000
MAX_FREQUENCIES = 1 << 16
#: Largest sidecar JSON read, bytes.
MAX_SIDECAR = 16 << 20
#: Weakest waveform level accepted in the band, relative to its peak (-60 dB):
#: below, the deconvolution divides by numbers that carry no signal.
MIN_WAVEFORM_LEVEL = 1e-3
#: Positions given twice (file and sidecar, scan and background) agree within, m.
POSITION_TOL = 1e-6


# --------------------------------------------------------------------------
# the source waveform
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


# --------------------------------------------------------------------------
# HDF5: only objects stored in the file itself
def _h5py():
    import h5py

    return h5py


def _guarded(path: str, read):
    """``read()``; any failure but an InputError (a truncated dataset, a bad
    filter) becomes one InputError line naming ``path``."""
    from .formats import _guarded as guarded

    return guarded(path, read)


def _open_h5(path: str):
    if not os.path.isfile(path):
        raise InputError(f"{path}: no such file")
    h5py = _h5py()
    try:
        return h5py.File(path, "r")
    except OSError as exc:
        text = " ".join(str(exc).split())
        raise InputError(f"{path}: not a readable HDF5 file ({text})") from None


def _get(f, path: str, what: str):
    """The object at ``path``, reached through hard links only (an external
    link would open another file, a soft link may lead to one)."""
    h5py = _h5py()
    obj = f
    for name in path.strip("/").split("/"):
        if not isinstance(obj, h5py.Group) or name not in obj:
            raise InputError(f"{f.filename}: no {what} ({path!r} is missing)")
        link = obj.get(name, getlink=True)
        if isinstance(link, h5py.ExternalLink):
            raise InputError(
                f"{f.filename}: {path!r} is an external link (to "
                f"{link.filename}); only data stored in the file are read"
            )
        if not isinstance(link, h5py.HardLink):
            raise InputError(
                f"{f.filename}: {path!r} is a soft link; only data stored in the file are read"
            )
        obj = obj[name]
    return obj


def _dataset(f, path: str, what: str):
    """A real, numeric dataset stored in the file (no external raw storage,
    no virtual dataset mapping other files); its data are not read."""
    ds = _get(f, path, what)
    if not isinstance(ds, _h5py().Dataset):
        raise InputError(f"{f.filename}: {path!r} is not a dataset")
    h5_inside(f, ds, f"{f.filename}: {path!r}")
    if ds.dtype.kind not in "fiu":
        raise InputError(f"{f.filename}: {path!r} must hold real numbers, got dtype {ds.dtype}")
    return ds


def _attr(obj, name: str, shape: tuple, what: str) -> np.ndarray:
    """Attribute ``name`` of the given shape (checked before it is read), as float64."""
    if name not in obj.attrs:
        raise InputError(f"{obj.file.filename}: {obj.name} has no {name!r} attribute ({what})")
    got = obj.attrs.get_id(name).shape
    if tuple(got) != shape:
        raise InputError(
            f"{obj.file.filename}: attribute {obj.name}:{name} must have shape "
            f"{shape}, got {tuple(got)}"
        )
    v = np.asarray(obj.attrs[name])
    if v.dtype.kind not in "fiu" or not np.all(np.isfinite(v)):
        raise InputError(f"{obj.file.filename}: attribute {obj.name}:{name} must be finite numbers")
    return v.astype(np.float64)


def _text_attr(obj, name: str) -> str | None:
    if name not in obj.attrs or obj.attrs.get_id(name).shape not in ((), None):
        return None
    v = obj.attrs[name]
    return v.decode("utf-8", "replace") if isinstance(v, bytes) else str(v)


# --------------------------------------------------------------------------
# reading a scan
@dataclass(frozen=True)
class BScan:
    """Time-domain traces of one monostatic scan.

    Attributes
    ----------
    traces : ndarray, float64, shape (nt, nx)
        Ez, V/m; column i is antenna i.
    dt : float
        Time step, s.
    t0 : float
        Time of sample 0, s (0 for gprMax's E).
    x : ndarray, shape (nx,) or None
        Antenna x (transmitter/receiver midpoint), m, as recorded; None when
        the file holds no positions.
    y : float or None
        The scan line's y in gprMax's frame, m.
    source : str
        The file(s) read, for messages.
    waveform : SourceWaveform or None
        The waveform the file records (gprMax 4 one-file-per-trace output).
    """

    traces: np.ndarray
    dt: float
    t0: float
    x: np.ndarray | None
    y: float | None
    source: str
    waveform: SourceWaveform | None = field(default=None)

    def __post_init__(self):
        tr = np.asarray(self.traces, np.float64)
        if tr.ndim != 2 or tr.shape[0] < 2 or tr.shape[1] < 2:
            raise InputError(
                f"{self.source}: a B-scan needs >= 2 time samples and >= 2 traces, "
                f"got shape {tr.shape}"
            )
        if not np.all(np.isfinite(tr)):
            raise InputError(f"{self.source}: Ez contains NaN or Inf")
        object.__setattr__(self, "traces", tr)
        object.__setattr__(self, "dt", _finite_scalar("dt", self.dt))
        object.__setattr__(self, "t0", _finite_scalar("time offset", self.t0, positive=False))
        if self.x is not None:
            x = np.asarray(self.x, np.float64)
            if x.shape != (tr.shape[1],) or not np.all(np.isfinite(x)):
                raise InputError(
                    f"{self.source}: {tr.shape[1]} traces but positions of shape {x.shape}"
                )
            object.__setattr__(self, "x", x)

    @property
    def duration(self) -> float:
        """Record length ``nt dt``, s."""
        return self.traces.shape[0] * self.dt


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


def _position(obj):
    if obj is None or "Position" not in obj.attrs:
        return None
    return _attr(obj, "Position", (3,), "a position")


def _file_waveform(f) -> SourceWaveform | None:
    """The waveform a gprMax 4 trace file records for its one source, if any;
    refuses what the converter cannot model."""
    if "srcs" not in f:
        return None
    src = _get(f, "srcs/src1", "source 1")
    kind = _text_attr(src, "Type")
    if kind is not None and kind != "HertzianDipole":
        raise InputError(
            f"{f.filename}: source 1 is a {kind}; the converter takes a Hertzian "
            f"dipole (line current)"
        )
    if "excitation" not in src:
        return None
    ex = _get(f, "srcs/src1/excitation", "the source excitation")
    start = float(_attr(ex, "SourceStartTime", (), "")) if "SourceStartTime" in ex.attrs else 0.0
    if start != 0:
        raise InputError(
            f"{f.filename}: the source starts at {start:g} s; the converter takes "
            f"sources that start at 0"
        )
    wtype = _text_attr(ex, "WaveformType")
    if wtype is None or "WaveformFrequency" not in ex.attrs:
        return None
    if wtype not in WAVEFORMS:
        raise InputError(
            f"{f.filename}: waveform {wtype!r} cannot be deconvolved; use one of "
            f"{', '.join(WAVEFORMS)}"
        )
    amp = float(_attr(ex, "WaveformAmplitude", (), "")) if "WaveformAmplitude" in ex.attrs else 1.0
    return SourceWaveform(wtype, float(_attr(ex, "WaveformFrequency", (), "")), amp)


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
    pos_rx = None if any(p is None for p in rxs) else np.stack(rxs)
    pos_tx = None if any(p is None for p in txs) else np.stack(txs)
    x, y = _midpoints(paths[0], pos_rx, pos_tx)
    src = f"{paths[0]} (+{len(paths) - 1} files)"
    return BScan(np.stack(cols, axis=1), ref[1], ref[2], x, y, src, wave)


def _midpoints(path, pos_rx, pos_tx):
    """(x, y) of the transmitter/receiver midpoints; (None, None) without
    receiver positions."""
    if pos_rx is None:
        return None, None
    mid = pos_rx if pos_tx is None else (pos_rx + pos_tx) / 2
    if np.ptp(mid[:, 1]) > POSITION_TOL or np.ptp(mid[:, 2]) > POSITION_TOL:
        raise InputError(
            f"{path}: the scan must run along x (y and z fixed); y spans "
            f"{mid[:, 1].min():g} .. {mid[:, 1].max():g} m"
        )
    return mid[:, 0], float(mid[0, 1])


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


# --------------------------------------------------------------------------
# the sidecar
@dataclass(frozen=True)
class Sidecar:
    """What a sidecar JSON tells about a scan (all optional).

    Attributes
    ----------
    waveform : SourceWaveform or None
        ``{"waveform": {"type": "ricker", "frequency": 3e9, "amplitude": 1}}``.
    scan_x : ndarray, shape (nx,) or None
        ``{"scan": {"x": [...]}}``: antenna x per trace, m, in trace order.
    scan_y : float or None
        ``{"scan": {"y": ...}}``: the scan line, m.
    cylinders : tuple of (cx, cy, r)
        ``{"cylinders": [{"centre": [cx, cy], "radius": r}, ...]}``, m.
    polygons : tuple of ndarray (k, 2)
        ``{"plates": [{"corners": [[x, y], ...]}, ...]}``: convex outlines, m.
    eps_r : float or None
        ``{"medium": {"eps_r": 6.0, ...}}``: the relative permittivity of
        the material the objects lie in; None: free space.
    surface_y : float or None
        ``{"medium": {"surface_y": y}}``: gprMax's y of the flat surface of
        a half-space of that material (the antennas on the other side of it,
        in air), m; None with ``eps_r``: a homogeneous medium.
    """

    waveform: SourceWaveform | None = None
    scan_x: np.ndarray | None = None
    scan_y: float | None = None
    cylinders: tuple = ()
    polygons: tuple = ()
    eps_r: float | None = None
    surface_y: float | None = None

    def medium(self, y_scan: float | None = None):
        """The :class:`rpm_cl.io.medium.Medium` of the sidecar in the engine's
        frame (the antenna height ``|surface_y - y_scan|``), None in free
        space."""
        from .medium import Medium

        if self.eps_r is None:
            return None
        y = self.scan_y if y_scan is None else y_scan
        if self.surface_y is None or y is None:
            return Medium(self.eps_r)
        return Medium(self.eps_r, abs(self.surface_y - y))


def _numbers(value, shape_ok, what: str, path: str) -> np.ndarray:
    try:
        a = np.asarray(value, np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{path}: {what} must be numbers") from None
    if not shape_ok(a.shape) or not np.all(np.isfinite(a)):
        raise InputError(
            f"{path}: {what} must be finite numbers of the right shape, got shape {a.shape}"
        )
    return a


def read_sidecar(path) -> Sidecar:
    """Read a sidecar JSON (the fixture's ``scene.json`` is one).

    Raises
    ------
    InputError
        Unreadable, larger than :data:`MAX_SIDECAR`, not a JSON object, or a
        known key of the wrong form (unknown keys are ignored).
    """
    path = os.fspath(path)
    try:
        size = os.path.getsize(path)
        if size > MAX_SIDECAR:
            raise InputError(f"{path}: {size} bytes; a sidecar is at most {MAX_SIDECAR}")
        with open(path, encoding="utf-8") as fh:
            doc = json.load(fh)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        text = " ".join(str(exc).split())
        raise InputError(f"{path}: not a readable JSON file ({text})") from None
    if not isinstance(doc, dict):
        raise InputError(f"{path}: must be a JSON object")
    wave = None
    if "waveform" in doc:
        w = doc["waveform"]
        if not isinstance(w, dict) or "type" not in w or "frequency" not in w:
            raise InputError(f'{path}: waveform must be {{"type": ..., "frequency": Hz}}')
        try:
            wave = SourceWaveform(str(w["type"]), w["frequency"], w.get("amplitude", 1.0))
        except InputError as exc:
            raise InputError(f"{path}: {exc}") from None
    scan = doc.get("scan", {})
    if not isinstance(scan, dict):
        raise InputError(f"{path}: scan must be an object")
    sx = (
        _numbers(scan["x"], lambda s: len(s) == 1 and s[0] >= 2, "scan.x", path)
        if "x" in scan
        else None
    )
    sy = float(_numbers(scan["y"], lambda s: s == (), "scan.y", path)) if "y" in scan else None
    cyl = []
    for c in _list(doc, "cylinders", path):
        if not isinstance(c, dict) or "centre" not in c or "radius" not in c:
            raise InputError(f'{path}: a cylinder must be {{"centre": [x, y], "radius": r}}')
        cx, cy = _numbers(c["centre"], lambda s: s == (2,), "a cylinder centre", path)
        r = float(_numbers(c["radius"], lambda s: s == (), "a cylinder radius", path))
        if r <= 0:
            raise InputError(f"{path}: a cylinder radius must be > 0, got {r:g}")
        cyl.append((float(cx), float(cy), r))
    polys = []
    for p in _list(doc, "plates", path):
        if not isinstance(p, dict) or "corners" not in p:
            raise InputError(f'{path}: a plate must be {{"corners": [[x, y], ...]}}')
        polys.append(
            _numbers(
                p["corners"],
                lambda s: len(s) == 2 and 3 <= s[0] <= 1000 and s[1] == 2,
                "plate corners",
                path,
            )
        )
    eps_r = surface = None
    if "medium" in doc:
        med = doc["medium"]
        if not isinstance(med, dict) or "eps_r" not in med:
            raise InputError(f'{path}: medium must be {{"eps_r": ..., "surface_y": m}}')
        eps_r = float(_numbers(med["eps_r"], lambda s: s == (), "medium.eps_r", path))
        if "surface_y" in med:
            surface = float(_numbers(med["surface_y"], lambda s: s == (), "medium.surface_y", path))
        from .medium import Medium

        try:
            Medium(eps_r)
        except InputError as exc:
            raise InputError(f"{path}: medium: {exc}") from None
    return Sidecar(wave, sx, sy, tuple(cyl), tuple(polys), eps_r, surface)


def _list(doc, key, path):
    v = doc.get(key, [])
    if not isinstance(v, list) or len(v) > 10_000:
        raise InputError(f"{path}: {key} must be a list (of at most 10000)")
    return v


# --------------------------------------------------------------------------
# conversion
@dataclass(frozen=True)
class GprSpectrum:
    """The engine's frequency-domain input made from a gprMax scan.

    Attributes
    ----------
    spectrum : ndarray, complex128, shape (nx, nf)
        ``Y(f)``: an echo of range R is ``a exp(-j 4 pi f R / c)`` (module
        docstring), m^(-1/2).
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


def truth_arrays(sidecar: Sidecar, x, y_scan: float, step: float = 1e-3) -> dict:
    """The input schema's truth from a sidecar's geometry, in the engine's frame.

    A point ``(X, Y)`` of gprMax's plane is ``(X, |Y - y_scan|)``.  The true
    RPs are, for every antenna and object, the distance to the object's
    nearest surface point (a specular point, or a plate's edge where no
    specular point exists).  With a medium (``sidecar.eps_r``) the distance is
    the air-equivalent range (optical path, :func:`rpm_cl.io.medium.one_way`):
    ``sqrt(eps_r)`` times the distance in a homogeneous medium, Fermat's
    refracted path to the nearest boundary sample above a half-space (the
    ranges :func:`rpm_cl.imaging.run_method` returns its RPs in there).

    Parameters
    ----------
    sidecar : Sidecar
        With cylinders and/or plates.
    x : ndarray, shape (nx,)
        Antenna x, m.
    y_scan : float
        The scan line's y in gprMax's frame, m.
    step : float
        Spacing of the boundary samples, m.

    Returns
    -------
    dict
        ``truth_rp_antenna`` (K,) int64, ``truth_rp_range`` (K,),
        ``truth_boundary`` (P, 2); empty when the sidecar has no geometry.
    """
    x = np.asarray(x, np.float64)
    ant = np.stack([x, np.full_like(x, y_scan)], axis=1)
    medium = sidecar.medium(y_scan)
    bounds, dists = [], []
    for cx, cy, r in sidecar.cylinders:
        n = max(16, math.ceil(2 * math.pi * r / step))
        a = 2 * math.pi * np.arange(n) / n
        bounds.append(np.stack([cx + r * np.cos(a), cy + r * np.sin(a)], axis=1))
        dists.append(np.abs(np.hypot(ant[:, 0] - cx, ant[:, 1] - cy) - r))
    for poly in sidecar.polygons:
        d = np.full(len(ant), np.inf)
        for p, q in zip(poly, np.roll(poly, -1, axis=0)):
            seg = q - p
            n = max(2, math.ceil(np.hypot(*seg) / step) + 1)
            bounds.append(p + np.linspace(0, 1, n)[:, None] * seg)
            u = np.clip(((ant - p) @ seg) / max(seg @ seg, 1e-300), 0, 1)
            d = np.minimum(d, np.linalg.norm(ant - (p + u[:, None] * seg), axis=1))
        dists.append(d)
    if not bounds:
        return {}
    if medium is not None and medium.half_space:
        # refracted: the nearest of boundary samples 0.1 mm apart in optical
        # path (the path is stationary there: off by about (0.1 mm)^2 / r)
        dists = [
            _refracted_min(medium, x, y_scan, b) for b in _dense_boundaries(sidecar, REFRACTED_STEP)
        ]
    elif medium is not None:
        dists = [medium.n * d for d in dists]
    b = np.concatenate(bounds)
    b[:, 1] = np.abs(b[:, 1] - y_scan)
    dist = np.stack(dists, axis=1)  # (nx, objects)
    ant_idx = np.repeat(np.arange(len(x), dtype=np.int64), dist.shape[1])
    return {"truth_rp_antenna": ant_idx, "truth_rp_range": dist.ravel(), "truth_boundary": b}


#: Spacing of the boundary samples of the refracted true ranges, m.
REFRACTED_STEP = 1e-4


def _dense_boundaries(sidecar: Sidecar, step: float) -> list:
    """Boundary samples (k, 2) of each object, cylinders first, in gprMax's
    frame, ``step`` apart."""
    out = []
    for cx, cy, r in sidecar.cylinders:
        n = max(16, math.ceil(2 * math.pi * r / step))
        a = 2 * math.pi * np.arange(n) / n
        out.append(np.stack([cx + r * np.cos(a), cy + r * np.sin(a)], axis=1))
    for poly in sidecar.polygons:
        edges = [
            p
            + np.linspace(0, 1, max(2, math.ceil(np.hypot(*(q - p)) / step) + 1))[:, None] * (q - p)
            for p, q in zip(poly, np.roll(poly, -1, axis=0))
        ]
        out.append(np.concatenate(edges))
    return out


def _refracted_min(medium, x, y_scan: float, boundary: np.ndarray) -> np.ndarray:
    """Least optical path (nx,) from each antenna to a boundary's samples
    (gprMax's frame), in antenna chunks of a few MB, m."""
    from .medium import one_way

    p3 = np.stack(
        [boundary[:, 0], np.abs(boundary[:, 1] - y_scan), np.zeros(len(boundary))], axis=1
    )
    ant = np.stack([x, np.zeros_like(x), np.zeros_like(x)], axis=1)
    step = max(1, (1 << 17) // max(1, len(p3)))
    return np.concatenate(
        [
            one_way(medium, ant[i : i + step, None], p3[None]).min(axis=1)
            for i in range(0, len(ant), step)
        ]
    )


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


def save_spectrum(path, arrays: dict, inputs=()) -> None:
    """Write :func:`convert`'s arrays as ``.npz`` or HDF5 (the input schema's
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
