"""File formats in and out: ``.npz`` and HDF5 inputs, results by extension.

Inputs (:func:`load_data`, :func:`frame_count`)
-----------------------------------------------
One schema, two containers: the names of the ``.npz`` input contract
(:mod:`rpm_cl.io.data`) are members of an ``.npz`` or datasets at the root of an
HDF5 file (``.h5`` / ``.hdf5``; scalars as 0-d datasets, ``truth_scene`` as a
string dataset).  Either

- **time domain**: ``signal`` (nx[, nz], nr) complex with its ``range`` (nr,)
  axis, ``fc`` and ``bandwidth``; or
- **frequency domain** (stepped-frequency or dechirped FMCW samples):
  ``spectrum`` (nx[, nz], nf) complex with its ``frequency`` (nf,) axis, Hz
  (uniform, strictly increasing, > 0); ``fc`` and ``bandwidth`` optional.
  :func:`range_compress` turns it into the time-domain form.

``signal`` / ``spectrum`` may carry one leading frame axis (a *stack*,
``(n_frames, nx[, nz], n)``); ``frame=i`` reads frame ``i`` only (an HDF5
hyperslab; for an ``.npz`` the frame's bytes of the member).

Range compression of a spectrum
-------------------------------
With ``f_n = f_0 + n df`` (n = 0 .. nf-1), a window ``w_n`` and ``fc``::

    s(R) = sum_n w_n Y(f_n) exp(+j 4 pi (f_n - fc) R / c) / sum_n w_n

so a lone echo ``Y(f) = a exp(-j 4 pi f R_t / c)`` peaks at ``|s(R_t)| = a``
with phase ``exp(-j 2 k_c R_t)``, ``k_c = 2 pi fc / c``: the time-domain
contract.  It is evaluated by an inverse FFT zero-padded to
``N = next_fast_len(RANGE_OVERSAMPLE * nf)`` points: range gates of
``dr = c / (2 df N)`` (at most 1/:data:`RANGE_OVERSAMPLE` of the resolution
``c / (2 nf df)`` of the whole band) over the unambiguous range
``[0, c / (2 df))``; echoes beyond it alias.

When omitted, ``fc = (f_0 + f_last) / 2`` (the band centre) and ``bandwidth``
= the full width at half amplitude of the window over the band,
``nf df`` times the fraction of the window above half its peak (rect:
``nf df``; hann: ``nf df / 2``): the engine's ``bandwidth`` is that width (the
simulator's ``P(f) = cos^2(pi f / 2B)``, a Hann window over ``2B``, has it).

Outputs by extension (:func:`save_result`, :func:`save_data`, :func:`write_volume`)
-----------------------------------------------------------------------------------
Image results: ``.npz``, ``.h5`` (same arrays; ``meta`` a JSON string
dataset), ``.ply`` and ``.vtp`` point clouds with per-point ``cluster`` and
``score``.  Radar data (``rpm-cl simulate``): ``.npz``, ``.h5``.  DAS images:
``.npz``, ``.h5`` (chunked), ``.vti`` (VTK ImageData).  Every file is written
to a temporary file beside the target and renamed.
"""

from __future__ import annotations

import errno
import io
import json
import os
import tempfile
import zipfile

import numpy as np

from .data import (
    BANDWIDTH_SPAN_MAX,
    BANDWIDTH_SPAN_WARN,
    C0,
    FC_MAX,
    FC_MIN,
    Array,
    DataWarning,
    InputError,
    RadarData,
    Truth,
    Waveform,
    _atomic_file,
    _uniform_axis,
    atomic_savez,
    carrier,
    check_plausible,
    data_arrays,
    drop_spikes,
    output_path,
    scale_hint,
    temp_prefix,
    unit_hint,
)
from .guard import (
    check_budget,
    check_declared,
    fmt_bytes,
    h5_chunks_bounded,
    h5_dataset,
    h5_has,
    h5_stored,
    memory_limit,
    regular_file,
    run_bytes,
)

__all__ = [
    "DATA_EXTENSIONS",
    "RANGE_OVERSAMPLE",
    "RANGE_WINDOWS",
    "RESULT_EXTENSIONS",
    "VOLUME_EXTENSIONS",
    "check_members",
    "check_output",
    "frame_count",
    "load_data",
    "range_compress",
    "range_sidelobe_db",
    "result_arrays",
    "save_data",
    "save_result",
    "window_bandwidth",
    "write_volume",
]

#: Input / radar-data extensions.
DATA_EXTENSIONS = (".npz", ".h5", ".hdf5")
#: Image-result extensions of :func:`save_result`.
RESULT_EXTENSIONS = (".npz", ".h5", ".hdf5", ".ply", ".vtp")
#: DAS image extensions of :func:`write_volume`.
VOLUME_EXTENSIONS = (".npz", ".h5", ".hdf5", ".vti")
#: Range windows of :func:`range_compress` -> scipy.signal.windows names.
RANGE_WINDOWS = {
    "rect": "boxcar",
    "hann": "hann",
    "hamming": "hamming",
    "blackman": "blackman",
    "taylor": "taylor",
}
#: Zero-padding of the range FFT: at least this many range gates per
#: resolution cell ``c / (2 nf df)`` of the whole band.
RANGE_OVERSAMPLE = 16

_H5_EXT = (".h5", ".hdf5")
#: Longest ``.npy`` header read, bytes (NumPy's own limit is 10 000; a v2
#: header may declare up to 4 GB, which NumPy reads before checking).
NPY_HEADER_MAX = 1 << 16
#: ``truth_scene`` (a JSON description) is read only up to this size, bytes.
TEXT_MAX_BYTES = 1 << 20
TEXT_MAX_ITEMS = 1


def _ext(path: str) -> str:
    return os.path.splitext(path)[1].lower()


def _need_ext(path: str, allowed: tuple, what: str) -> str:
    ext = _ext(path)
    if ext not in allowed:
        raise InputError(
            f"{path}: unknown {what} extension {ext or '(none)'!r}; supported: {', '.join(allowed)}"
        )
    return ext


def check_output(path, extensions: tuple, what: str = "output") -> str:
    """Check an output path before anything is computed: a known extension
    (one of ``extensions``) and an existing folder.

    Returns
    -------
    str
        The extension, lower case.

    Raises
    ------
    InputError
        Unknown extension (the message lists ``extensions``), missing folder,
        or ``path`` is a folder.
    """
    path, _ = output_path(path)  # a missing folder or a folder first: the plainer message
    return _need_ext(path, tuple(extensions), what)


def _h5py():
    try:
        import h5py
    except ImportError:  # a core dependency; only a broken install lands here
        raise InputError("HDF5 files need h5py: pip install h5py") from None
    return h5py


# --------------------------------------------------------------------------
# sources: one interface over .npz members and HDF5 root datasets
class _NpzSource:
    """Members of an ``.npz``, read through their ``.npy`` headers, so that a
    frame of a stack is read without the rest, and nothing is inflated
    before its header and its member's sizes agree."""

    def __init__(self, path: str):
        self.path = path
        self.zf = zipfile.ZipFile(path)
        # as numpy.load names them: ``k.npy`` is ``k``, and a member named
        # ``k`` itself wins (np.load reads that one, e.g. in `rpm-cl view`)
        names = self.zf.namelist()
        self.names = {n[:-4]: n for n in names if n.endswith(".npy")}
        self.names.update({n: n for n in names if not n.endswith(".npy")})

    def keys(self):
        return set(self.names)

    def __contains__(self, key):
        return key in self.names

    def _header(self, fh):
        """The ``.npy`` header of ``fh`` (shape, fortran, dtype), its length
        checked before NumPy reads it (a v2 header may declare 4 GB)."""
        magic = fh.read(8)
        if len(magic) < 8 or magic[:6] != b"\x93NUMPY":
            raise ValueError("not a .npy member (no NumPy magic)")
        size = fh.read(2 if magic[6] == 1 else 4)
        n = int.from_bytes(size, "little") if len(size) in (2, 4) else -1
        if not 0 < n <= NPY_HEADER_MAX:
            raise ValueError(f"header length {n} bytes, beyond {NPY_HEADER_MAX}")
        fh.seek(0)
        version = np.lib.format.read_magic(fh)
        if version == (1, 0):
            return np.lib.format.read_array_header_1_0(fh)
        return np.lib.format.read_array_header_2_0(fh)

    def _checked_header(self, key, fh):
        """The member's (shape, fortran, dtype) once its sizes agree: the
        header's array fits the member's declared size, which fits what the
        archive stores for it (:func:`rpm_cl.io.guard.check_declared`)."""
        try:
            shape, fortran, dtype = self._header(fh)
        except Exception as exc:  # noqa: BLE001 - ValueError, TokenError, SyntaxError ...
            raise InputError(f"{key}: corrupt .npy header ({' '.join(str(exc).split())})") from None
        if dtype.hasobject:
            raise InputError(
                f"{key} holds Python objects (dtype {dtype}); only numeric arrays are read"
            )
        info = self.zf.getinfo(self.names[key])
        nbytes = int(np.prod(shape, dtype=object)) * dtype.itemsize
        if nbytes > info.file_size - fh.tell():
            raise InputError(
                f"{key} is truncated or its header is corrupt: the header "
                f"declares {fmt_bytes(nbytes)}, the member holds "
                f"{fmt_bytes(max(info.file_size - fh.tell(), 0))}"
            )
        check_declared(key, info.file_size, info.compress_size)
        return tuple(shape), fortran, dtype

    def shape_dtype(self, key):
        with self.zf.open(self.names[key]) as fh:
            shape, _, dtype = self._checked_header(key, fh)
        return shape, np.dtype(dtype)

    def read(self, key):
        with self.zf.open(self.names[key]) as fh:
            self._checked_header(key, fh)
            fh.seek(0)
            return np.lib.format.read_array(fh, allow_pickle=False)

    def read_frame(self, key, i):
        with self.zf.open(self.names[key]) as fh:
            shape, fortran, dtype = self._checked_header(key, fh)
            if fortran:  # a frame is no contiguous run of bytes: the whole stack
                raise InputError(
                    f"{key} is a Fortran-ordered stack; its frames cannot be "
                    f"read one at a time: save it C-ordered "
                    f"(np.ascontiguousarray)"
                )
            n = int(np.prod(shape[1:])) * dtype.itemsize
            fh.seek(fh.tell() + i * n)
            buf = fh.read(n)
        if len(buf) != n:
            raise InputError(f"{self.path}: {key} is truncated")
        return np.frombuffer(buf, dtype).reshape(shape[1:]).copy()

    def text(self, key):
        shape, dtype = self.shape_dtype(key)
        if int(np.prod(shape, dtype=object)) * dtype.itemsize > TEXT_MAX_BYTES:
            raise InputError(f"{key} must be a short string, got {shape} of dtype {dtype}")
        return str(self.read(key))

    def close(self):
        self.zf.close()


class _H5Source:
    """Datasets at the root of an HDF5 file; a frame is one hyperslab.  Only
    data inside the file is read (:func:`rpm_cl.io.guard.h5_dataset`)."""

    def __init__(self, path: str):
        self.path = path
        self.f = _h5py().File(path, "r")
        self._bounded = set()

    def keys(self):
        return set(self.f.keys())

    def __contains__(self, key):
        return h5_has(self.f, key)

    def _ds(self, key):
        return h5_dataset(self.f, key)

    def shape_dtype(self, key):
        ds = self._ds(key)
        shape, dtype = tuple(ds.shape), ds.dtype
        if dtype.kind in "biufc":
            check_declared(key, int(np.prod(shape, dtype=object)) * dtype.itemsize, h5_stored(ds))
            if key not in self._bounded:  # each dataset's chunks inflated once
                h5_chunks_bounded(ds, key)
                self._bounded.add(key)
        return shape, dtype

    def read(self, key):
        self.shape_dtype(key)
        return np.asarray(self._ds(key)[()])

    def read_frame(self, key, i):
        self.shape_dtype(key)
        return np.asarray(self._ds(key)[i])

    def text(self, key):
        ds = self._ds(key)
        if ds.size > TEXT_MAX_ITEMS or ds.dtype.itemsize * ds.size > TEXT_MAX_BYTES:
            raise InputError(
                f"{key} must be a short string, got {ds.size} items of {ds.dtype.itemsize} bytes"
            )
        v = ds[()]
        if isinstance(v, bytes):
            return v.decode("utf-8")
        if isinstance(v, np.ndarray) and v.dtype.kind in "OSU" and v.ndim == 0:
            v = v.item()
            return v.decode("utf-8") if isinstance(v, bytes) else str(v)
        return str(v)

    def close(self):
        self.f.close()


def _open(path) -> tuple[str, object]:
    path = os.fspath(path)
    ext = _need_ext(path, DATA_EXTENSIONS, "input")
    regular_file(path)
    try:
        src = _H5Source(path) if ext in _H5_EXT else _NpzSource(path)
    except InputError:
        raise
    except Exception as exc:  # noqa: BLE001 - OSError (not HDF5, truncated), BadZipFile ...
        kind = "HDF5" if ext in _H5_EXT else ".npz"
        raise InputError(f"{path}: not a readable {kind} file ({_oneline(exc)})") from None
    return path, src


def check_members(path, keys=None, *, budget: bool = True, max_memory=None) -> dict:
    """Check the members ``keys`` of an ``.npz`` or HDF5 file from their
    headers, before a reader of that file reads them.

    Each present member's header must fit what the file stores for it (no
    truncation, no compression bomb, for HDF5 no data outside the file:
    :mod:`rpm_cl.io.guard`); with ``budget`` their bytes together must fit
    ``max_memory`` (:func:`rpm_cl.io.guard.memory_limit`).

    Parameters
    ----------
    path : str or path-like
        A regular ``.npz`` / ``.h5`` / ``.hdf5`` file (any other extension is
        read as an ``.npz``).
    keys : iterable of str, optional
        The members the reader uses; absent ones are skipped.  None: every
        member.

    Returns
    -------
    dict
        ``{key: (shape, dtype)}`` of the members present.

    Raises
    ------
    InputError
        One line naming the file and the member.
    """
    path = regular_file(path)
    h5 = _ext(path) in _H5_EXT
    try:
        src = _H5Source(path) if h5 else _NpzSource(path)
    except Exception as exc:  # noqa: BLE001 - not HDF5 / not a zip: the reader says so
        raise InputError(
            f"{path}: not a readable {'HDF5' if h5 else '.npz'} file ({_oneline(exc)})"
        ) from None
    try:
        found = _guarded(
            path,
            lambda: {
                k: src.shape_dtype(k) for k in (src.keys() if keys is None else keys) if k in src
            },
        )
    finally:
        src.close()
    if budget:
        total = sum(_nbytes(*sd) for sd in found.values())
        _guarded(
            path, lambda: check_budget(run_bytes(0, total), memory_limit(max_memory), "reading it")
        )
    return found


def _oneline(exc: BaseException) -> str:
    text = getattr(exc, "strerror", None) or " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _guarded(path: str, fn):
    """Run ``fn()``; every failure becomes one InputError line naming ``path``."""
    try:
        return fn()
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith(path) else f"{path}: {msg}") from None
    except (MemoryError, Warning):  # a warning turned into an error stays itself
        raise
    except Exception as exc:  # noqa: BLE001 - truncated member or dataset, bad header ...
        raise InputError(f"{path}: cannot read ({_oneline(exc)})") from None


def _frames(src, key: str, n_axes: int) -> int | None:
    """Frames in ``key``: None for a single frame, else the stack's length."""
    shape, dtype = src.shape_dtype(key)
    if not np.issubdtype(dtype, np.complexfloating):
        raise InputError(f"{key} must be complex (complex64/complex128), got dtype {dtype}")
    if len(shape) == n_axes:
        return None
    if len(shape) == n_axes + 1:
        if shape[0] == 0:
            raise InputError(f"{key} holds no frames (a stack of length 0, shape {shape})")
        return int(shape[0])
    raise InputError(
        f"{key} must have {n_axes} axes (or {n_axes + 1} for a stack of frames), got shape {shape}"
    )


def _data_key(src) -> str:
    if "signal" in src and "spectrum" in src:
        raise InputError("holds both signal and spectrum; keep one")
    if "signal" in src:
        return "signal"
    if "spectrum" in src:
        return "spectrum"
    raise InputError("missing key 'signal' (time domain) or 'spectrum' (frequency domain)")


def _n_axes(src) -> int:
    return 3 if "z" in src else 2


def _need(src, key):
    if key not in src:
        raise InputError(f"missing key {key!r}")
    return src.read(key)


def frame_count(path) -> int:
    """Frames in an input file: the stack's length, 1 for a single frame.

    Parameters
    ----------
    path : str or path-like
        An ``.npz`` or HDF5 input (see :func:`load_data`).

    Raises
    ------
    InputError
        The file is unreadable, or has no complex ``signal``/``spectrum`` of a
        valid number of axes, or a stack of no frames.
    """
    path, src = _open(path)
    try:
        n = _guarded(path, lambda: _frames(src, _data_key(src), _n_axes(src)))
    finally:
        src.close()
    return 1 if n is None else n


def _select(src, key: str, n_axes: int, frame):
    n = _frames(src, key, n_axes)
    if frame is not None and (isinstance(frame, bool) or not isinstance(frame, (int, np.integer))):
        raise InputError(f"frame must be an integer, got {frame!r}")
    if n is None:
        if frame not in (None, 0):
            raise InputError(f"frame {frame} out of range: the file holds a single frame")
        return src.read(key)
    if frame is None:
        raise InputError(
            f"{key} is a stack of {n} frames; choose one with frame= (--frame N, 0..{n - 1})"
        )
    if not 0 <= frame < n:
        raise InputError(f"frame {frame} out of range: the stack holds {n} frames (0..{n - 1})")
    return src.read_frame(key, int(frame))


#: The arrays beside the data and the shapes they must have, from the data
#: header's core shape (nx[, nz], n): a callable of (core, n_axes).
_BESIDE = {
    "x": lambda key, core, n_axes: (core[0],),
    "z": lambda key, core, n_axes: (core[1],) if n_axes == 3 else None,
    "range": lambda key, core, n_axes: (core[-1],) if key == "signal" else None,
    "frequency": lambda key, core, n_axes: (core[-1],) if key == "spectrum" else None,
    "fc": lambda key, core, n_axes: (),
    "bandwidth": lambda key, core, n_axes: (),
}
_TRUTH = ("truth_boundary", "truth_rp_antenna", "truth_rp_range")
#: An array beside the data larger than the data's header allows is refused
#: from its header when it holds more than this, bytes; a smaller one is
#: read and its mismatch reported by the validators in their own words.
BESIDE_READ_BYTES = 1 << 20


def _nbytes(shape, dtype) -> int:
    return int(np.prod(shape, dtype=object)) * np.dtype(dtype).itemsize


def _preflight(src, key: str, n_axes: int, with_truth: bool, max_memory) -> None:
    """Every array the run reads, checked from its header before any data is
    read: numeric, no larger than the data's header allows (``x`` its first
    axis, ``range`` / ``frequency`` its last, ``fc`` one number; see
    :data:`BESIDE_READ_BYTES`), and the whole run within ``max_memory``
    (:func:`rpm_cl.io.guard.run_bytes`)."""
    shape, _ = src.shape_dtype(key)
    core = shape[-n_axes:]
    other = 0
    for name, want in _BESIDE.items():
        if name not in src:
            continue
        got, dtype = src.shape_dtype(name)
        need = want(key, core, n_axes)
        if dtype.kind not in "biuf":
            what = "a real number" if need == () else "real numbers"
            raise InputError(f"{name} must be {what}, got dtype {dtype}")
        size, nbytes = int(np.prod(got, dtype=object)), _nbytes(got, dtype)
        if (
            need is not None
            and size > int(np.prod(need, dtype=object))
            and nbytes > BESIDE_READ_BYTES
        ):
            what = "one number" if need == () else f"{need[0]} values ({key} has shape {shape})"
            raise InputError(f"{name} must hold {what}, its header declares shape {got}")
        other += nbytes
    if with_truth:
        for name in _TRUTH:
            if name in src:
                got, dtype = src.shape_dtype(name)
                other += _nbytes(got, dtype)
    samples = int(np.prod(core[:-1], dtype=object))
    if key == "spectrum":  # range-compressed onto next_fast_len(16 nf) gates, ~16 nf
        samples *= RANGE_OVERSAMPLE * max(int(core[-1]), 1)
    else:
        samples *= int(core[-1])
    check_budget(run_bytes(samples, other, n_axes - 1), memory_limit(max_memory), f"{key} {shape}")


def _truth(src):
    if "truth_boundary" not in src:
        return None
    scene = src.text("truth_scene") if "truth_scene" in src else "{}"
    # the true RPs are optional (a surveyed boundary alone scores Err_RPM)
    rp = [src.read(k) if k in src else None for k in ("truth_rp_antenna", "truth_rp_range")]
    return Truth(rp[0], rp[1], src.read("truth_boundary"), scene)


def _build(
    src, frame, range_window: str, conjugate: bool, with_truth: bool = True, max_memory=None
) -> RadarData:
    key = _data_key(src)
    n_axes = _n_axes(src)
    _frames(src, key, n_axes)
    _preflight(src, key, n_axes, with_truth, max_memory)
    z = src.read("z") if "z" in src else None
    array = Array(_need(src, "x"), z)
    values = drop_spikes(_select(src, key, n_axes, frame), key)
    truth = _truth(src) if with_truth else None
    if key == "signal":
        if "frequency" in src:
            raise InputError("'frequency' goes with 'spectrum', not with 'signal'")
        if conjugate:
            raise InputError(
                "conjugate applies to a spectrum (frequency-domain input), not to 'signal'"
            )
        waveform = Waveform(_need(src, "fc"), _need(src, "bandwidth"))
        data = RadarData(values, array, _need(src, "range"), waveform, truth)
        check_plausible(data)
        return data
    if "range" in src:
        raise InputError(
            "'range' goes with 'signal'; a spectrum's range axis comes from 'frequency'"
        )
    freq = _frequency_axis(_need(src, "frequency"))
    fc = src.read("fc") if "fc" in src else None
    bw = src.read("bandwidth") if "bandwidth" in src else None
    if conjugate:
        values = np.conj(values)
    signal, rng, waveform = _compress_checked(values, freq, fc, bw, range_window, array)
    if not conjugate:
        _check_conjugated(signal, rng)
    data = RadarData(
        signal,
        array,
        rng,
        waveform,
        truth,
        range_sidelobe_db(freq, range_window, waveform.bandwidth),
    )
    check_plausible(data)
    return data


def load_data(
    path,
    *,
    frame: int | None = None,
    range_window: str = "hann",
    conjugate: bool = False,
    with_truth: bool = True,
    max_memory=None,
) -> RadarData:
    """Read and validate radar data from an ``.npz`` or HDF5 file.

    Parameters
    ----------
    path : str or path-like
        ``.npz``, ``.h5`` or ``.hdf5`` following the input schema (docs/input-format.md,
        "Input schema"): time domain (``signal``, ``range``) or frequency
        domain (``spectrum``, ``frequency``).
    frame : int, optional
        Frame of a stack (``signal``/``spectrum`` with a leading frame axis);
        required for a stack, 0 or None for a single-frame file.
    range_window : str
        Window of the range compression of a ``spectrum``, one of
        :data:`RANGE_WINDOWS` (ignored for time-domain data).
    conjugate : bool
        Conjugate a ``spectrum`` before compressing it: for samples recorded
        as ``a exp(+j 4 pi f R / c)`` (whose echoes otherwise land at the
        unambiguous range minus their range; a warning says when the data
        look so).  Refused for time-domain data.
    with_truth : bool
        Read the ``truth_*`` members (scoring); False leaves them unread.
    max_memory : int or str, optional
        Bytes a run on the data may take (:func:`rpm_cl.io.guard.memory_limit`:
        default ``RPM_CL_MAX_MEMORY`` or half the machine's memory); checked
        from the headers before any data is read.

    Warns
    -----
    DataWarning
        One line with its fix: a spectrum that looks conjugated, units that
        look wrong (:func:`rpm_cl.io.data.check_plausible`).

    Returns
    -------
    RadarData
        Validated; a spectrum comes back range-compressed (see
        :func:`range_compress`).

    Raises
    ------
    InputError
        One line naming the file and the problem: unknown extension, not a
        regular file, unreadable or truncated file, a header declaring more
        than the file holds or the run more memory than ``max_memory``,
        data outside the file (HDF5 external links or storage, virtual
        datasets), missing key, wrong shape or dtype,
        non-uniform axis, NaN/Inf, a stack of no frames, a stack without
        ``frame``, ``frame`` out of range, an unknown window.
    """
    _window_name(range_window)
    path, src = _open(path)
    try:
        return _guarded(
            path,
            lambda: _build(src, frame, range_window, bool(conjugate), bool(with_truth), max_memory),
        )
    finally:
        src.close()


# --------------------------------------------------------------------------
# frequency domain -> range profiles
def _window_name(name) -> str:
    if name not in RANGE_WINDOWS:
        raise InputError(f"unknown range window {name!r}; choose from {', '.join(RANGE_WINDOWS)}")
    return RANGE_WINDOWS[name]


def _window(name: str, n: int) -> np.ndarray:
    from scipy.signal import windows

    w = np.asarray(windows.get_window(_window_name(name), n, fftbins=False), np.float64)
    if not np.any(w > 0):  # hann, blackman ... over 1 or 2 samples: zero at both ends
        raise InputError(
            f"the {name} range window over {n} frequency samples is all zero; "
            f"use range_window='rect' (--range-window rect) or more samples"
        )
    return w


def _frequency_axis(values) -> np.ndarray:
    f = _uniform_axis("frequency", values, min_len=2, unit="Hz")
    if f[0] <= 0:
        raise InputError(f"frequency must be > 0 Hz, starts at {f[0]:g} Hz")
    if f[-1] < FC_MIN:  # as Waveform refuses such an fc: the same words either way
        raise InputError(
            f"frequency reaches only {f[-1]:g} Hz, below {FC_MIN:g} Hz: it looks "
            f"like {unit_hint(f[-1])}; give it in Hz"
        )
    if f[0] > FC_MAX:  # as Waveform refuses such an fc
        raise InputError(
            f"frequency starts at {f[0]:g} Hz, above {FC_MAX:g} Hz (10 THz): not "
            f"a radar band; give it in Hz"
        )
    return f


#: A spectrum is taken for a conjugated one when at least this share of its
#: compressed power lies in the last quarter of the unambiguous range (and
#: so, mirrored, in the first quarter of the conjugate's): noise alone puts a
#: quarter there, a scene in the near part of the range almost none.
CONJUGATE_FAR_SHARE = 0.5
#: An echo (a local maximum of the compressed power summed over the
#: antennas, at least WRAP_LEVEL of the largest and WRAP_ABOVE_MEDIAN times
#: the median over the axis, so not noise) in the last WRAP_EDGE of the
#: unambiguous range is warned about as possibly wrapped from beyond.
WRAP_EDGE = 0.05
WRAP_LEVEL = 0.01
WRAP_ABOVE_MEDIAN = 10.0


def _check_conjugated(signal, rng) -> None:
    """Warn when the compressed power sits in the far quarter of the
    unambiguous range ``[0, c / 2 df)``: a spectrum recorded as ``exp(+j 4 pi
    f R / c)`` puts each echo at ``R_u - R`` (its compression is the mirror
    image of the conjugate's, which then holds that power in the first
    quarter)."""
    import warnings

    mag = np.abs(np.asarray(signal)).reshape(-1, rng.size)
    top = float(mag.max()) if mag.size else 0.0
    if not top > 0:
        return
    power = np.sum((mag / top) ** 2, axis=0)
    r_u = float(rng[-1] + (rng[1] - rng[0]))
    share = float(power[rng >= 0.75 * r_u].sum() / power.sum())
    if share >= CONJUGATE_FAR_SHARE:
        warnings.warn(
            f"the spectrum looks conjugated: {share:.0%} of the compressed power "
            f"lies beyond {0.75 * r_u:.3g} m, in the last quarter of the unambiguous "
            f"range {r_u:.3g} m (an echo recorded as exp(+j 4 pi f R / c) lands at "
            f"{r_u:.3g} m - R); if so, load it with conjugate=True (--conjugate)",
            DataWarning,
            stacklevel=2,
        )
        return
    # an echo near the end of the axis may be one from beyond it, wrapped
    edge = rng >= (1.0 - WRAP_EDGE) * r_u
    inner = power[1:-1]
    peak = np.zeros(rng.size, bool)
    peak[1:-1] = (inner >= power[:-2]) & (inner >= power[2:])
    strong = (
        peak
        & edge
        & (power >= WRAP_LEVEL * power.max())
        & (power >= WRAP_ABOVE_MEDIAN * np.median(power))
    )
    if strong.any():
        r = float(rng[np.flatnonzero(strong)[0]])
        warnings.warn(
            f"an echo at {r:.3g} m lies within {WRAP_EDGE:.0%} of the unambiguous "
            f"range c/(2 df) = {r_u:.3g} m: it may be a target beyond it, wrapped "
            f"(at {r:.3g} + {r_u:.3g} m); a finer frequency step widens the range",
            DataWarning,
            stacklevel=2,
        )


def window_bandwidth(frequency, window: str = "hann") -> float:
    """The ``bandwidth`` a spectrum gets when the file gives none, Hz.

    The full width at half amplitude of the window over the band: ``nf df``
    times the fraction of the (finely sampled, continuous) window at or above
    half its peak.  rect: ``nf df``; hann: ``nf df / 2``; hamming: 0.53;
    blackman: 0.41; taylor (scipy's defaults, nbar 4, 30 dB): 0.64 (x ``nf df``).

    Parameters
    ----------
    frequency : ndarray, shape (nf,)
        Uniform frequency axis, Hz.
    window : str
        A key of :data:`RANGE_WINDOWS`.
    """
    f = np.asarray(frequency, np.float64)
    span = f.size * float(f[1] - f[0])
    w = _window(window, 4001)
    return span * float(np.mean(w >= 0.5 * w.max()))


def range_sidelobe_db(frequency, window: str, bandwidth: float) -> float | None:
    """The strongest range sidelobe of :func:`range_compress` that a peak
    search can take for an echo, dB relative to the main lobe.

    The compressed response of a lone echo, ``|sum_n w_n exp(j 4 pi n df R /
    c)| / sum_n w_n``, on the gates of :func:`range_compress`; its local
    maxima farther than half a range resolution ``c / (4 bandwidth)`` from
    the main lobe's peak (the k-space search's neighbourhood along R, so a
    sidelobe within it is never a centre) and the largest of them.  rect:
    -13.3 dB, hann -31.5, hamming -42.6 (of scipy's windows over 81 samples
    with the default bandwidth).

    Parameters
    ----------
    frequency : ndarray, shape (nf,)
        Uniform frequency axis, Hz.
    window : str
        A key of :data:`RANGE_WINDOWS`.
    bandwidth : float
        The engine's bandwidth B, Hz (its range resolution ``c / 2B``).

    Returns
    -------
    float or None
        dB (< 0); None where no sidelobe lies beyond that distance.
    """
    from scipy import fft

    f = np.asarray(frequency, np.float64)
    nf = f.size
    df = float(f[1] - f[0])
    n = fft.next_fast_len(RANGE_OVERSAMPLE * nf)
    w = _window(window, nf)
    resp = np.abs(fft.ifft(w, n=n)) * n / w.sum()
    dr = C0 / (2.0 * df * n)
    half = int(np.ceil(0.5 * C0 / (2.0 * bandwidth) / dr))
    lag = np.minimum(np.arange(n), n - np.arange(n))  # circular distance to the peak, gates
    peak = (resp >= np.roll(resp, 1)) & (resp >= np.roll(resp, -1)) & (lag > half)
    if not np.any(peak):
        return None
    top = float(resp[peak].max())
    return float(20.0 * np.log10(top)) if top > 0 else None


def range_compress(spectrum, frequency, fc: float, window: str = "hann"):
    """Range profiles of frequency-domain samples (the time-domain contract).

    ``s(R) = sum_n w_n Y_n exp(+j 4 pi (f_n - fc) R / c) / sum_n w_n`` on the
    gates ``R_m = m c / (2 df N)``, ``N = next_fast_len(RANGE_OVERSAMPLE nf)``,
    ``m = 0 .. N-1``: an inverse FFT along the last axis.

    Parameters
    ----------
    spectrum : ndarray, complex, shape (..., nf)
        Samples ``Y(f_n)``; an echo of range ``R`` and amplitude ``a`` is
        ``a exp(-j 4 pi f_n R / c)``.
    frequency : ndarray, shape (nf,)
        Uniform, strictly increasing, > 0, Hz.
    fc : float
        Centre frequency the baseband phase refers to, Hz.
    window : str
        A key of :data:`RANGE_WINDOWS` (``w_n``, symmetric over the band).

    Returns
    -------
    signal : ndarray, complex, shape (..., N)
        complex64 for complex64 input, else complex128; a lone echo peaks at
        ``|s| = a`` with phase ``exp(-j 2 k_c R)``.
    range_axis : ndarray, shape (N,)
        m, from 0 to just below the unambiguous range ``c / (2 df)``.
    """
    from scipy import fft

    y = np.asarray(spectrum)
    f = _frequency_axis(frequency)
    nf = f.size
    if y.shape[-1] != nf:
        raise InputError(f"spectrum's last axis ({y.shape[-1]}) must match frequency ({nf})")
    df = float(f[1] - f[0])
    n = fft.next_fast_len(RANGE_OVERSAMPLE * nf)
    w = _window(window, nf)
    rng = np.arange(n) * (C0 / (2.0 * df * n))
    out_dtype = np.complex64 if y.dtype == np.complex64 else np.complex128
    # sum_n (w_n Y_n) exp(+j 2 pi n m / N) = N ifft(w Y)[m]; the band's offset
    # from fc is one phase ramp in R
    s = fft.ifft(y * (w / w.sum()), n=n, axis=-1) * n
    s *= np.exp(4j * np.pi * (f[0] - fc) * rng / C0)
    return s.astype(out_dtype, copy=False), rng


def _compress_checked(values, freq, fc, bw, window, array):
    y = np.asarray(values)
    want = array.shape + (freq.size,)
    if y.shape != want:
        raise InputError(
            f"spectrum must have shape {want} (array {array.shape} x frequency "
            f"{freq.size}), got {y.shape}"
        )
    if not np.all(np.isfinite(y)):
        raise InputError("spectrum contains NaN or Inf")
    fc = float((freq[0] + freq[-1]) / 2) if fc is None else carrier(fc)
    if not freq[0] <= fc <= freq[-1]:  # before Waveform: its messages would miss the unit
        ratio = fc / freq[-1] if fc > freq[-1] else freq[0] / fc
        hint = (
            f": one of them looks like {scale_hint(1.0, ratio)}; give both in Hz"
            if ratio >= 100
            else ""
        )
        raise InputError(
            f"fc ({fc:g} Hz) must lie within the frequency band "
            f"({freq[0]:g} .. {freq[-1]:g} Hz){hint}"
        )
    bw = window_bandwidth(freq, window) if bw is None else bw
    waveform = Waveform(fc, bw)
    import warnings

    band = float(freq[-1] - freq[0])
    for ratio in (BANDWIDTH_SPAN_MAX, BANDWIDTH_SPAN_WARN):  # as RadarData's span test
        if waveform.bandwidth * ratio < band:
            line = (
                f"bandwidth = {waveform.bandwidth:g} Hz is below 1/{ratio:g} of the "
                f"frequency band ({band:g} Hz): it looks like "
                f"{scale_hint(waveform.bandwidth, band / BANDWIDTH_SPAN_WARN)}; give fc "
                f"and bandwidth in Hz"
            )
            if ratio == BANDWIDTH_SPAN_MAX:
                raise InputError(line)
            warnings.warn(line, DataWarning, stacklevel=2)
            break
    signal, rng = range_compress(y, freq, waveform.fc, window)
    return signal, rng, waveform


# --------------------------------------------------------------------------
# writing
def _h5_write_arrays(tmp: str, arrays: dict) -> None:
    """The arrays as an HDF5 file at ``tmp``, built in memory and written by
    Python: a full disk then raises OSError (HDF5 writing to a full disk
    itself crashed the process).  The price: the file is held in memory
    once more while written (a 1 GB array peaked at 2.2 GB against 1.1 GB)."""
    h5py = _h5py()
    bio = io.BytesIO()
    with h5py.File(bio, "w") as f:
        for k, v in arrays.items():
            v = np.asarray(v)
            if v.dtype.kind == "U":  # JSON strings: UTF-8 string datasets
                f.create_dataset(k, data=str(v), dtype=h5py.string_dtype("utf-8"))
            else:
                f.create_dataset(k, data=v)
    with open(tmp, "wb") as fh:
        fh.write(bio.getbuffer())


def _vtk_write(dataset, tmp: str, in_memory: bool = False) -> None:
    """A pyvista dataset as binary VTK XML at ``tmp`` (``.vtp`` PolyData,
    ``.vti`` ImageData).

    VTK only prints a failed write and leaves a truncated file, or crashes
    (a full disk part-way through a point cloud: a segmentation fault).
    Here its messages are kept off stderr and its error code raises OSError;
    with ``in_memory`` VTK writes a string that Python then writes, so a
    full disk is an OSError and never reaches VTK (point clouds; volumes
    are written by VTK directly, after :func:`rpm_cl.baselines.das.check_disk`)."""
    from vtkmodules.vtkCommonCore import vtkObject
    from vtkmodules.vtkCommonMisc import vtkErrorCode
    from vtkmodules.vtkIOXML import vtkXMLImageDataWriter, vtkXMLPolyDataWriter

    writer = (vtkXMLPolyDataWriter if tmp.endswith(".vtp") else vtkXMLImageDataWriter)()
    writer.SetInputData(dataset)
    writer.SetDataModeToBinary()
    if in_memory:
        writer.WriteToOutputStringOn()
    else:
        writer.SetFileName(tmp)
    shown = vtkObject.GetGlobalWarningDisplay()
    vtkObject.GlobalWarningDisplayOff()
    try:
        ok = writer.Write()
    finally:
        vtkObject.SetGlobalWarningDisplay(shown)
    code = writer.GetErrorCode()
    if not ok or code:
        full = code == vtkErrorCode.OutOfDiskSpaceError
        raise OSError(
            errno.ENOSPC if full else errno.EIO,
            "No space left on device"
            if full
            else f"VTK: {vtkErrorCode.GetStringFromErrorCode(code) or 'write failed'}",
        )
    if in_memory:
        with open(tmp, "wb") as fh:
            fh.write(writer.GetOutputString().encode("latin-1"))


def save_data(path, data: RadarData) -> None:
    """Write radar data (time domain, with its truth) as ``.npz`` or HDF5.

    Parameters
    ----------
    path : str or path-like
        ``.npz``, ``.h5`` or ``.hdf5``; the same names either way.
    data : RadarData
    """
    from .data import save_npz

    path = os.fspath(path)
    ext = _need_ext(path, DATA_EXTENSIONS, "data output")
    if ext == ".npz":
        save_npz(path, data)
        return
    out = data_arrays(data)
    _atomic_file(path, lambda tmp: _h5_write_arrays(tmp, out))


def result_arrays(result, meta: dict | None = None) -> dict:
    """The arrays of an image result, by name (the ``.npz`` / HDF5 content).

    ``points`` (M, 2|3) m, ``cluster``, ``score``, ``rp_index`` (M,), the RPs
    ``rp_x`` (``rp_z``), ``rp_range``, ``rp_amp``, ``rp_cluster``,
    ``rp_antenna`` (K,), and ``meta``: a JSON string (method, stage timings,
    and ``meta``: version, device, parameters ...).
    """
    rps, img = result.rps, result.image
    out = {
        "points": img.points,
        "cluster": img.cluster,
        "score": img.score,
        "rp_index": img.rp_index,
        "rp_x": rps.x,
        "rp_range": rps.range,
        "rp_amp": rps.amp,
        "rp_cluster": rps.cluster,
        "rp_antenna": rps.antenna,
    }
    if rps.z is not None:
        out["rp_z"] = rps.z
    if img.multipath is not None:
        out["multipath"] = img.multipath
    info = {"method": result.method, "timings": result.timings, **(meta or {})}
    out["meta"] = np.array(json.dumps(info, default=str))
    return out


def _points3(points: np.ndarray) -> np.ndarray:
    p = np.asarray(points, np.float64)
    if p.shape[1] == 2:  # (x, y) of a linear array: the z = 0 plane
        p = np.column_stack([p, np.zeros(len(p))])
    return np.ascontiguousarray(p)


def _write_ply(tmp: str, arrays: dict) -> None:
    """Binary little-endian PLY: vertices x, y, z (double), cluster (int),
    score (double); the meta JSON as a comment line."""
    pts = _points3(arrays["points"])
    rec = np.zeros(
        len(pts), [("x", "<f8"), ("y", "<f8"), ("z", "<f8"), ("cluster", "<i4"), ("score", "<f8")]
    )
    rec["x"], rec["y"], rec["z"] = pts.T
    rec["cluster"] = arrays["cluster"]
    rec["score"] = arrays["score"]
    meta = " ".join(str(arrays["meta"]).split())
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"comment rpm-cl {meta}\n"
        f"element vertex {len(pts)}\n"
        "property double x\nproperty double y\nproperty double z\n"
        "property int cluster\nproperty double score\nend_header\n"
    )
    with open(tmp, "wb") as fh:
        fh.write(header.encode("utf-8"))
        fh.write(rec.tobytes())


def _pyvista():
    try:
        import pyvista as pv
    except ImportError:
        raise InputError(
            "VTK outputs (.vtp, .vti) need pyvista: pip install 'rpm-cl[view]'"
        ) from None
    return pv


def _write_vtp(tmp: str, arrays: dict) -> None:
    pv = _pyvista()
    cloud = pv.PolyData(_points3(arrays["points"]))
    cloud.point_data["cluster"] = np.asarray(arrays["cluster"], np.int64)
    cloud.point_data["score"] = np.asarray(arrays["score"], np.float64)
    cloud.field_data["meta"] = [str(arrays["meta"])]
    _vtk_write(cloud, tmp, in_memory=True)


def save_result(path, result, meta: dict | None = None) -> None:
    """Write an image result; the format follows the extension.

    - ``.npz``: :func:`result_arrays` (the same file as
      :func:`rpm_cl.io.formats.save_result`);
    - ``.h5`` / ``.hdf5``: the same names as root datasets, ``meta`` a UTF-8
      string dataset;
    - ``.ply``: a binary point cloud, vertex properties ``x y z`` (m; z = 0
      for 2-D results), ``cluster``, ``score``, and the meta JSON as a comment;
    - ``.vtp``: a VTK PolyData point cloud with point arrays ``cluster`` and
      ``score`` and the field ``meta`` (needs pyvista).

    The RPs are kept by ``.npz`` and HDF5 only.

    Parameters
    ----------
    path : str or path-like
    result : rpm_cl.result.ImageResult
    meta : dict, optional
        Run metadata (version, device, parameters ...), stored as JSON.

    Raises
    ------
    InputError
        Unknown extension (the message lists the supported ones), the
        folder is missing or not writable, pyvista missing for ``.vtp``.
    """
    path = os.fspath(path)
    ext = _need_ext(path, RESULT_EXTENSIONS, "result")
    arrays = result_arrays(result, meta)
    if ext == ".npz":
        atomic_savez(path, **arrays)
    elif ext in _H5_EXT:
        _atomic_file(path, lambda tmp: _h5_write_arrays(tmp, arrays))
    elif ext == ".ply":
        _atomic_file(path, lambda tmp: _write_ply(tmp, arrays))
    else:
        _pyvista()  # fail before anything is written
        _atomic_file(path, lambda tmp: _write_vtp(tmp, arrays))


# --------------------------------------------------------------------------
# DAS volumes
def _grid_geometry(path: str, grid):
    """Origin and spacing (3 values each) of a uniform grid, m."""
    axes = list(grid.axes) + ([np.zeros(1)] if grid.dim == 2 else [])
    steps = []
    for name, a in zip("xyz", axes):
        if a.size >= 2:
            d = np.diff(a)
            if np.max(np.abs(d - d.mean())) > 1e-6 * abs(d.mean()):
                raise InputError(f"{path}: a .vti needs a uniform grid; axis {name} is not")
            steps.append(float(d.mean()))
        else:
            steps.append(None)
    known = [s for s in steps if s is not None] or [1.0]
    # a single-sample axis (a section) gets the spacing of the first axis that has one
    spacing = tuple(s if s is not None else known[0] for s in steps)
    origin = tuple(float(a[0]) for a in axes)
    return origin, spacing


def _slab_rows(shape, itemsize: int, target: int = 64 << 20) -> int:
    per = int(np.prod(shape[1:])) * itemsize
    return max(1, min(shape[0], target // max(1, per)))


def _fill_memmap(path: str, folder: str, grid, fill, dtype, tmps: list):
    fd, tmp = tempfile.mkstemp(prefix=temp_prefix(path), suffix=".npy", dir=folder)
    os.close(fd)
    tmps.append(tmp)
    out = np.lib.format.open_memmap(tmp, mode="w+", dtype=dtype, shape=grid.shape)
    fill(out)
    out.flush()
    del out
    return np.load(tmp, mmap_mode="r")


def _atomic_volume(path, folder, grid, fill, dtype, write) -> None:
    """``write(tmp, img)`` with the image filled into a temporary memory map
    beside ``path``, atomically; the memory map is removed whatever happens."""
    tmps = []

    def to_file(tmp):
        write(tmp, _fill_memmap(path, folder, grid, fill, dtype, tmps))

    try:
        _atomic_file(path, to_file)
    finally:
        for t in tmps:
            if os.path.exists(t):
                os.remove(t)


def _write_volume_h5(path, folder, grid, fill, dtype, meta):
    h5py = _h5py()

    def write(tmp, img):
        rows = _slab_rows(grid.shape, np.dtype(dtype).itemsize)
        inner = tuple(min(n, 256) for n in grid.shape[1:])  # chunks of at most ~4 MB
        per = int(np.prod(inner)) * np.dtype(dtype).itemsize
        chunks = (max(1, min(grid.shape[0], (4 << 20) // per)),) + inner
        with h5py.File(tmp, "w") as f:
            ds = f.create_dataset("image", shape=grid.shape, dtype=dtype, chunks=chunks)
            for r0 in range(0, grid.shape[0], rows):  # slab by slab: one slab in memory
                ds[r0 : r0 + rows] = img[r0 : r0 + rows]
            for name, a in zip("xyz", grid.axes):
                f.create_dataset(name, data=a)
            f.create_dataset(
                "meta", data=json.dumps(meta or {}, default=str), dtype=h5py.string_dtype("utf-8")
            )
        del img

    _atomic_volume(path, folder, grid, fill, dtype, write)


def _write_volume_vti(path, folder, grid, fill, dtype, meta):
    pv = _pyvista()
    origin, spacing = _grid_geometry(path, grid)

    def write(tmp, img):
        dims = grid.shape + ((1,) if grid.dim == 2 else ())
        vol = pv.ImageData(dimensions=dims, spacing=spacing, origin=origin)
        flat = np.asarray(img).reshape(dims).ravel(order="F")  # VTK: x fastest
        vol.point_data["magnitude"] = np.abs(flat)
        vol.point_data["real"] = flat.real.copy()
        vol.point_data["imag"] = flat.imag.copy()
        vol.field_data["meta"] = [json.dumps(meta or {}, default=str)]
        del flat, img
        _vtk_write(vol, tmp)

    _atomic_volume(path, folder, grid, fill, dtype, write)


def write_volume(path, grid, fill, dtype=np.complex64, meta: dict | None = None) -> None:
    """Write a DAS image by extension, atomically.

    ``fill(out)`` writes the image into ``out``, an array of shape
    ``grid.shape`` (a memory map in a temporary ``.npy`` beside ``path``).

    - ``.npz``: :func:`rpm_cl.baselines.das.write_image` (``image``, ``x``, ``y``
      [, ``z``], ``meta``), streamed from the memory map;
    - ``.h5`` / ``.hdf5``: the same names; ``image`` a chunked dataset
      copied from the memory map slab by slab (64 MB at a time);
    - ``.vti``: VTK ImageData (pyvista) with point arrays ``magnitude``
      (``|image|``), ``real``, ``imag``; origin and spacing from the grid (a
      single-sample axis takes the spacing of the first axis that has one; 2-D
      images are one slice thick in z).  VTK holds it in memory: about 1.5x
      the complex image.

    Parameters
    ----------
    path : str or path-like
    grid : rpm_cl.baselines.das.Grid
    fill : callable
    dtype : numpy dtype
        complex64 or complex128.
    meta : dict, optional
        Stored as JSON (``meta``).
    """
    from .images import check_disk, write_image

    path = os.fspath(path)
    ext = _need_ext(path, VOLUME_EXTENSIONS, "image")
    if ext == ".npz":
        write_image(path, grid, fill, dtype, meta)
        return
    path, folder = output_path(path)
    check_disk(path, folder, grid, dtype, 2.0 if ext in _H5_EXT else 3.0)
    if ext in _H5_EXT:
        _write_volume_h5(path, folder, grid, fill, dtype, meta)
    else:
        _write_volume_vti(path, folder, grid, fill, dtype, meta)
