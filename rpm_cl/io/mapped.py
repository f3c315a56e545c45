"""Recorded arrays -> the input schema by a key mapping.

Reads named arrays from MATLAB ``.mat`` files (v4 to v7.2 through
``scipy.io.loadmat``, v7.3 through h5py), ``.npz`` archives, ``.npy`` files
(the key of each is its file name without ``.npy``) and HDF5 files, and
renames them to the input schema's names (docs/input-format.md, "Input schema")::

    KeyMap.parse("spectrum=F,frequency=f,x=da")

maps the file's ``F`` to ``spectrum``, ``f`` to ``frequency`` and ``da`` to
``x``.  Frequency domain: ``spectrum``, ``frequency``, ``x`` (``z`` for a
planar array; ``fc`` and ``bandwidth`` optional).  Time domain: ``signal``,
``range``, ``fc``, ``bandwidth``, ``x`` (``z``).

Shapes
------
Arrays come out with the shape MATLAB shows (``size(F)``), whichever version
wrote them: a v7.3 file stores every array with its axes reversed (HDF5 is
row-major, MATLAB column-major), and the reader reverses them back.  The
data array (``spectrum`` or ``signal``) must then be ``(nx[, nz], n)`` (or a
stack ``(frames, nx[, nz], n)``); ``transpose=True`` (``--transpose``)
reverses all its axes first, as MATLAB's ``F(nf, nx)`` needs.  Axes
(``x``, ``z``, ``frequency``, ``range``) may be MATLAB row or column vectors
(a ``1 x n`` or ``n x 1`` matrix); ``fc`` and ``bandwidth`` ``1 x 1``.
Complex arrays: MATLAB v7.3 stores them as an HDF5 compound of ``real`` and
``imag``; MATLAB saves an array whose imaginary part is all zero as real,
so a real data array is taken as complex.

Nothing about the sign is changed: the file must hold an echo of range R as
``a exp(-j 4 pi f R / c)`` (``conjugate=True`` takes the conjugate of a
spectrum recorded as ``exp(+j ...)``).  ``scale_x`` multiplies ``x`` and
``z`` (1e-3 for millimetres), ``scale_f`` ``frequency``, ``fc`` and
``bandwidth`` (1e9 for GHz).

Safety: the shape and type of every array are read from its header (the
``.mat`` variable directory, the ``.npy`` header, the HDF5 dataset) and
checked before its data are; HDF5 external links, soft links, external raw
storage and virtual datasets are refused; MATLAB cells, structs of v4-v7.2
files, strings and sparse matrices are refused.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from .data import Array, InputError, Waveform, _finite_scalar, _uniform_axis
from .guard import h5_inside

__all__ = [
    "DATA_NAMES",
    "MAPPED_EXTENSIONS",
    "MAX_ELEMENTS",
    "SCHEMA_NAMES",
    "KeyMap",
    "convert",
    "list_keys",
]

#: Names a mapping may give (the input schema's, without the truth).
SCHEMA_NAMES = ("spectrum", "frequency", "signal", "range", "fc", "bandwidth", "x", "z")
#: The data arrays: one of them, exactly.
DATA_NAMES = ("spectrum", "signal")
#: What each data array needs, and what it refuses.
_NEEDS = {"spectrum": ("frequency", "x"), "signal": ("range", "fc", "bandwidth", "x")}
_REFUSES = {"spectrum": ("range",), "signal": ("frequency",)}
_AXES = ("x", "z", "frequency", "range")
_SCALARS = ("fc", "bandwidth")
#: Input extensions.
MAPPED_EXTENSIONS = (".mat", ".npz", ".npy", ".h5", ".hdf5")
#: Most elements read from one array (1 GB of float64).
MAX_ELEMENTS = 1 << 27
#: MATLAB classes read (numbers; ``logical``, ``char``, ``cell``, ``struct``,
#: ``function_handle`` ... are not).
_MATLAB_NUMERIC = (
    "double",
    "single",
    "int8",
    "uint8",
    "int16",
    "uint16",
    "int32",
    "uint32",
    "int64",
    "uint64",
)


@dataclass(frozen=True)
class KeyMap:
    """Which array of the input becomes which name of the schema.

    Attributes
    ----------
    pairs : tuple of (str, str)
        ``(schema name, key in the file)``; a key may name a member of a
        group (HDF5, MATLAB v7.3 struct) as ``a/b`` or ``a.b``.
    transpose : bool
        Reverse all axes of the data array (``spectrum`` / ``signal``).
    scale_x : float
        Factor applied to ``x`` and ``z`` (to metres), > 0.
    scale_f : float
        Factor applied to ``frequency``, ``fc`` and ``bandwidth`` (to Hz), > 0.
    conjugate : bool
        Conjugate a ``spectrum`` (one recorded as ``a exp(+j 4 pi f R / c)``).
    """

    pairs: tuple
    transpose: bool = False
    scale_x: float = 1.0
    scale_f: float = 1.0
    conjugate: bool = False

    def __post_init__(self):
        pairs = tuple((str(a), str(b)) for a, b in self.pairs)
        object.__setattr__(self, "pairs", pairs)
        names = [a for a, _ in pairs]
        for name, key in pairs:
            if name not in SCHEMA_NAMES:
                raise InputError(
                    f"unknown name {name!r} in the mapping; the schema's names are "
                    f"{', '.join(SCHEMA_NAMES)}"
                )
            if not key:
                raise InputError(f"{name} is mapped to an empty key")
            if names.count(name) > 1:
                raise InputError(f"{name} is mapped twice")
        data = [n for n in DATA_NAMES if n in names]
        if not data:
            raise InputError(
                "the mapping names neither spectrum (frequency domain) nor signal (time domain)"
            )
        if len(data) == 2:
            raise InputError("the mapping names both spectrum and signal; keep one")
        kind = data[0]
        extra = [n for n in _REFUSES[kind] if n in names]
        if extra:
            raise InputError(
                f"{extra[0]} does not go with {kind} (spectrum takes frequency, signal takes range)"
            )
        missing = [n for n in _NEEDS[kind] if n not in names]
        if missing:
            raise InputError(
                f"the mapping lacks {', '.join(missing)} ({kind} needs {', '.join(_NEEDS[kind])})"
            )
        if self.conjugate and kind != "spectrum":
            raise InputError("conjugate applies to a spectrum, not to a time-domain signal")
        for what in ("scale_x", "scale_f"):
            object.__setattr__(self, what, _finite_scalar(what, getattr(self, what)))

    @classmethod
    def parse(cls, text: str, **options) -> KeyMap:
        """``"spectrum=F,frequency=f,x=da"`` (``NAME=KEY`` pairs, commas between)."""
        pairs = []
        for part in str(text).split(","):
            name, sep, key = part.partition("=")
            if not sep or "=" in key:
                raise InputError(
                    f"the mapping must be NAME=KEY pairs separated by commas "
                    f"(e.g. spectrum=F,frequency=f,x=da), got {part.strip()!r}"
                )
            pairs.append((name.strip(), key.strip()))
        return cls(tuple(pairs), **options)

    @property
    def kind(self) -> str:
        """``"spectrum"`` or ``"signal"``."""
        return next(a for a, _ in self.pairs if a in DATA_NAMES)


# --------------------------------------------------------------------------
# sources: (shape, dtype) from the header, then the data
def _h5py():
    import h5py

    return h5py


class _NpySource:
    def __init__(self, path: str):
        self.path = path
        self.key = os.path.splitext(os.path.basename(path))[0]

    def keys(self):
        return [self.key]

    def header(self, key):
        with open(self.path, "rb") as fh:
            version = np.lib.format.read_magic(fh)
            read = (
                np.lib.format.read_array_header_1_0
                if version == (1, 0)
                else np.lib.format.read_array_header_2_0
            )
            shape, _, dtype = read(fh)
        return tuple(shape), np.dtype(dtype)

    def read(self, key):
        return np.load(self.path, allow_pickle=False)

    def close(self):
        pass


class _NpzSource:
    def __init__(self, path: str):
        from .formats import _NpzSource as Npz

        self.path = path
        self.src = Npz(path)

    def keys(self):
        return sorted(self.src.keys())

    def header(self, key):
        return self.src.shape_dtype(key)

    def read(self, key):
        return self.src.read(key)

    def close(self):
        self.src.close()


class _MatSource:
    """MATLAB v4 to v7.2 (``scipy.io.loadmat``); top-level variables only."""

    def __init__(self, path: str):
        from scipy.io import whosmat

        self.path = path
        self.vars = {name: (tuple(shape), cls) for name, shape, cls in whosmat(path)}

    def keys(self):
        return sorted(self.vars)

    def header(self, key):
        shape, cls = self.vars[key]
        if cls not in _MATLAB_NUMERIC:
            how = (
                (" (a struct of a v4-v7.2 file: save its fields as variables, or save with -v7.3)")
                if cls == "struct"
                else ""
            )
            raise InputError(f"{key} is a MATLAB {cls}, not a numeric array{how}")
        return shape, None

    def read(self, key):
        from scipy.io import loadmat

        v = loadmat(self.path, variable_names=[key], squeeze_me=False)[key]
        if v.dtype.kind not in "iufc":
            raise InputError(f"{key} is not a numeric array (dtype {v.dtype})")
        return v

    def close(self):
        pass


class _H5Source:
    """HDF5 datasets reached through hard links; with ``matlab=True`` (a v7.3
    MAT-file) axes are reversed to MATLAB's order and MATLAB's classes checked."""

    def __init__(self, path: str, matlab: bool):
        self.path = path
        self.matlab = matlab
        self.f = _h5py().File(path, "r")

    def keys(self):
        h5py = _h5py()
        out = []

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and not name.startswith("#"):
                out.append(name)

        self.f.visititems(visit)
        return sorted(out)[:50]

    def _ds(self, key):
        from .gprmax import _get

        path = key.replace(".", "/") if self.matlab else key
        ds = _get(self.f, path, f"{key!r}")
        h5py = _h5py()
        if isinstance(ds, h5py.Group):
            cls = _matlab_class(ds)
            raise InputError(
                f"{key} is a group{f' (a MATLAB {cls})' if cls else ''}, not an "
                f"array; name one of its members as {key}/NAME"
            )
        h5_inside(self.f, ds, key)
        if self.matlab:
            cls = _matlab_class(ds)
            if cls is not None and cls not in _MATLAB_NUMERIC:
                raise InputError(f"{key} is a MATLAB {cls}, not a numeric array")
            if ds.attrs.get("MATLAB_empty"):
                raise InputError(f"{key} is an empty MATLAB array")
        return ds

    def header(self, key):
        ds = self._ds(key)
        dt = ds.dtype
        if dt.names is not None:
            if set(dt.names) != {"real", "imag"}:
                raise InputError(
                    f"{key} is a compound of {', '.join(dt.names)}; a complex "
                    f"array is a compound of real and imag"
                )
            dt = np.result_type(dt["real"], dt["imag"], np.complex64)
        elif dt.kind not in "iufc":
            raise InputError(f"{key} is not a numeric array (dtype {dt})")
        shape = tuple(ds.shape)
        return (shape[::-1] if self.matlab else shape), dt

    def read(self, key):
        ds = self._ds(key)
        v = ds[()]
        if ds.dtype.names is not None:
            v = v["real"] + 1j * v["imag"]
        v = np.asarray(v)
        return v.transpose() if self.matlab else v

    def close(self):
        self.f.close()


def _matlab_class(obj) -> str | None:
    v = obj.attrs.get("MATLAB_class")
    if v is None:
        return None
    return v.decode("ascii", "replace") if isinstance(v, bytes) else str(v)


def _mat_version(path: str) -> int:
    """0 (v4), 1 (v5 to v7.2) or 2 (v7.3, HDF5)."""
    from scipy.io.matlab import matfile_version

    try:
        return int(matfile_version(path)[0])
    except Exception as exc:  # noqa: BLE001 - scipy raises ValueError, MatReadError ...
        raise InputError(f"not a MATLAB file ({' '.join(str(exc).split())})") from None


def _open_source(path: str):
    ext = os.path.splitext(path)[1].lower()
    if ext not in MAPPED_EXTENSIONS:
        raise InputError(
            f"unknown input extension {ext or '(none)'!r}; supported: "
            f"{', '.join(MAPPED_EXTENSIONS)}"
        )
    if not os.path.isfile(path):
        raise InputError("no such file")
    if ext == ".npy":
        return _NpySource(path)
    if ext == ".npz":
        return _NpzSource(path)
    if ext in (".h5", ".hdf5"):
        return _H5Source(path, matlab=False)
    if _mat_version(path) == 2:
        return _H5Source(path, matlab=True)
    return _MatSource(path)


class _Sources:
    """The keys of several files; a key held by two of them is refused."""

    def __init__(self, paths):
        from .formats import _guarded

        self.srcs = []
        self.where = {}
        try:
            for p in paths:
                src = _guarded(p, lambda p=p: _open_source(p))
                self.srcs.append(src)
                for k in _guarded(p, src.keys):
                    if k in self.where:
                        raise InputError(f"{k!r} is in both {self.where[k].path} and {p}")
                    self.where[k] = src
        except BaseException:
            self.close()  # the files opened so far
            raise

    def read(self, key: str, name: str):
        from .formats import _guarded

        src = self._find(key)
        if src is None:
            held = ", ".join(sorted(self.where)[:20]) or "nothing"
            raise InputError(f"no {key!r} (for {name}) in {self._files()}; it holds: {held}")

        def get():
            shape, _ = src.header(key)
            n = math.prod(shape)
            if n > MAX_ELEMENTS:
                raise InputError(f"{key} holds {n} values, more than {MAX_ELEMENTS}")
            if n == 0:
                raise InputError(f"{key} is empty (shape {shape})")
            v = np.asarray(src.read(key))
            if tuple(v.shape) != tuple(shape):  # what the header promised
                raise InputError(f"{key}: shape {v.shape} read, {shape} declared")
            return v

        return _guarded(src.path, get)

    def _find(self, key):
        if key in self.where:
            return self.where[key]
        # a member of an HDF5 group or MATLAB v7.3 struct need not be listed
        for src in self.srcs:
            if isinstance(src, _H5Source):
                path = key.replace(".", "/") if src.matlab else key
                if path.strip("/") and path.strip("/").split("/")[0] in src.f:
                    return src
        return None

    def _files(self):
        return ", ".join(s.path for s in self.srcs)

    def close(self):
        for s in self.srcs:
            s.close()


def list_keys(paths) -> list:
    """The keys a mapping may name in these files (HDF5: the first 50 datasets)."""
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    srcs = _Sources([os.fspath(p) for p in paths])
    try:
        return sorted(srcs.where)
    finally:
        srcs.close()


# --------------------------------------------------------------------------
# the schema's arrays
def _vector(name: str, key: str, v: np.ndarray) -> np.ndarray:
    if v.ndim > 1 and sum(s != 1 for s in v.shape) <= 1:
        v = v.reshape(-1)  # MATLAB 1 x n or n x 1
    if v.ndim != 1:
        raise InputError(f"{name} ({key}) must be a vector, got shape {v.shape}")
    if v.dtype.kind == "c":
        if np.any(v.imag != 0):
            raise InputError(f"{name} ({key}) must be real, got complex values")
        v = v.real
    return v


def _scalar(name: str, key: str, v: np.ndarray) -> float:
    if v.size != 1:
        raise InputError(f"{name} ({key}) must be one number, got shape {v.shape}")
    v = v.reshape(())
    if v.dtype.kind == "c":
        if v.imag != 0:
            raise InputError(f"{name} ({key}) must be real")
        v = v.real
    return _finite_scalar(f"{name} ({key})", v)


def _data(kind: str, key: str, v: np.ndarray, keymap: KeyMap) -> np.ndarray:
    if keymap.transpose:
        v = v.transpose()
    if v.dtype.kind == "c":
        v = v.astype(np.complex64 if v.dtype == np.complex64 else np.complex128, copy=False)
    else:  # MATLAB saves an all-real complex array as real
        v = v.astype(np.complex64 if v.dtype == np.float32 else np.complex128)
    if not np.all(np.isfinite(v)):
        raise InputError(f"{kind} ({key}) contains NaN or Inf")
    return np.conj(v) if keymap.conjugate else v


def _check_shape(
    kind: str, key: str, v: np.ndarray, core: tuple, what: str, transpose: bool
) -> None:
    if v.shape == core or (v.ndim == len(core) + 1 and v.shape[1:] == core and v.shape[0] > 0):
        return
    hint = ""
    rev = v.shape[::-1]
    if rev == core or (len(rev) == len(core) + 1 and rev[1:] == core):
        hint = (
            "; --transpose (transpose=True) reverses its axes to that"
            if not transpose
            else "; it fits without --transpose"
        )
    raise InputError(
        f"{kind} ({key}) has shape {v.shape}; expected {core} ({what}) or a stack "
        f"(frames, {', '.join(map(str, core))}){hint}"
    )


def convert(inputs, keymap: KeyMap) -> dict:
    """Read the mapped arrays and return them under the schema's names.

    Parameters
    ----------
    inputs : path or list of paths
        ``.mat``, ``.npz``, ``.npy`` (key: the file name without ``.npy``),
        ``.h5`` / ``.hdf5``; a key held by two files is refused.
    keymap : KeyMap
        Names, transpose, scales, conjugation.

    Returns
    -------
    dict
        Frequency domain: ``spectrum`` complex ``(nx[, nz], nf)`` (or a stack
        with a leading frame axis), ``frequency`` ``(nf,)`` Hz, ``x`` ``(nx,)``
        m, ``z`` ``(nz,)`` m, ``fc`` and ``bandwidth`` Hz where mapped.  Time
        domain: ``signal`` ``(nx[, nz], nr)``, ``range`` ``(nr,)`` m, ``fc``,
        ``bandwidth``, ``x`` (``z``).  Axes float64, validated as
        :func:`rpm_cl.load_data` does (uniform, increasing, > 0 Hz ...).

    Raises
    ------
    InputError
        One line: a key not in the files (naming what they hold), a name
        outside the schema, a name missing or one that does not go with the
        data array, a wrong shape (naming the expected one, and
        ``--transpose`` where it would fit), a non-numeric or oversized
        array, an unreadable file.
    """
    from .formats import _frequency_axis

    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    paths = [os.fspath(p) for p in inputs]
    if not paths:
        raise InputError("no input given")
    srcs = _Sources(paths)
    try:
        raw = {name: srcs.read(key, name) for name, key in keymap.pairs}
    finally:
        srcs.close()
    keys = dict(keymap.pairs)
    out = {}
    for name in _AXES:
        if name in raw:
            v = _vector(name, keys[name], raw[name]).astype(np.float64)
            if name in ("x", "z"):
                v = v * keymap.scale_x
            elif name == "frequency":
                v = v * keymap.scale_f
            out[name] = v
    for name in _SCALARS:
        if name in raw:
            out[name] = _scalar(name, keys[name], raw[name]) * keymap.scale_f
    kind = keymap.kind
    values = _data(kind, keys[kind], raw[kind], keymap)
    array = Array(out["x"], out.get("z"))
    if kind == "spectrum":
        freq = _frequency_axis(out["frequency"])
        n_axis, what = freq.size, "frequency"
        if "fc" in out and not freq[0] <= out["fc"] <= freq[-1]:
            raise InputError(
                f"fc ({out['fc']:g} Hz) must lie within the frequency band "
                f"({freq[0]:g} .. {freq[-1]:g} Hz)"
            )
        if "bandwidth" in out or "fc" in out:
            Waveform(out.get("fc", (freq[0] + freq[-1]) / 2), out.get("bandwidth", 1.0))
    else:
        rng = _uniform_axis("range", out["range"], 2)
        n_axis, what = rng.size, "range"
        Waveform(out["fc"], out["bandwidth"])
    axes = " x ".join(f"{a} {s}" for a, s in zip(("x", "z"), array.shape))
    _check_shape(
        kind,
        keys[kind],
        values,
        array.shape + (n_axis,),
        f"{axes} x {what} {n_axis}",
        keymap.transpose,
    )
    out[kind] = values
    return out
