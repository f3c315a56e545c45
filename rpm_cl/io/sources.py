"""One interface over the members of an ``.npz`` (:class:`_NpzSource`, read
through their ``.npy`` headers) and the root datasets of an HDF5 file
(:class:`_H5Source`): shapes and dtypes from the headers, checked against
what the file stores before any data are read; :func:`check_members` over a
whole file; :func:`_guarded`, which turns every failure of a read into one
:class:`~rpm_cl.io.checks.InputError` line naming the file."""

from __future__ import annotations

import os
import zipfile

import numpy as np

from .checks import InputError
from .filetypes import _H5_EXT, DATA_EXTENSIONS, _ext, _h5py, _need_ext
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

#: Longest ``.npy`` header read, bytes (NumPy's own limit is 10 000; a v2
#: header may declare up to 4 GB, which NumPy reads before checking).
NPY_HEADER_MAX = 1 << 16
#: ``truth_scene`` (a JSON description) is read only up to this size, bytes.
TEXT_MAX_BYTES = 1 << 20
TEXT_MAX_ITEMS = 1


def read_npy_header(fh):
    """The ``.npy`` header at ``fh``'s position (shape, fortran, dtype),
    its length checked before NumPy reads it (a v2 header may declare
    4 GB); ``fh`` is left at the array's first byte.

    Raises
    ------
    ValueError
        No NumPy magic, or a header longer than :data:`NPY_HEADER_MAX`.
    """
    start = fh.tell()
    magic = fh.read(8)
    if len(magic) < 8 or magic[:6] != b"\x93NUMPY":
        raise ValueError("not a .npy member (no NumPy magic)")
    size = fh.read(2 if magic[6] == 1 else 4)
    n = int.from_bytes(size, "little") if len(size) in (2, 4) else -1
    if not 0 < n <= NPY_HEADER_MAX:
        raise ValueError(f"header length {n} bytes, beyond {NPY_HEADER_MAX}")
    fh.seek(start)
    version = np.lib.format.read_magic(fh)
    if version == (1, 0):
        return np.lib.format.read_array_header_1_0(fh)
    return np.lib.format.read_array_header_2_0(fh)


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

    def _checked_header(self, key, fh):
        """The member's (shape, fortran, dtype) once its sizes agree: the
        header's array fits the member's declared size, which fits what the
        archive stores for it (:func:`rpm_cl.io.guard.check_declared`)."""
        try:
            shape, fortran, dtype = read_npy_header(fh)
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


def check_members(path, keys=None, *, budget=True, max_memory=None) -> dict:
    """Check the members ``keys`` of an ``.npz`` or HDF5 file from their
    headers, before a reader of that file reads them.

    Each present member's header must fit what the file stores for it (no
    truncation, no compression bomb, for HDF5 no data outside the file:
    :mod:`rpm_cl.io.guard`); the bytes of those ``budget`` names together
    must fit ``max_memory`` (:func:`rpm_cl.io.guard.memory_limit`).  One
    opening of the file checks them all.

    Parameters
    ----------
    path : str or path-like
        A regular ``.npz`` / ``.h5`` / ``.hdf5`` file (any other extension is
        read as an ``.npz``).
    keys : iterable of str, optional
        The members the reader uses; absent ones are skipped.  None: every
        member.
    budget : bool or iterable of str, optional
        Which of them the reader holds in memory at once: True (default)
        all, False none (members read slab by slab), or their names.

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
    held = found if budget is True else {} if budget is False else set(budget)
    if held:
        total = sum(_nbytes(*sd) for k, sd in found.items() if k in held)
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


def _nbytes(shape, dtype) -> int:
    return int(np.prod(shape, dtype=object)) * np.dtype(dtype).itemsize
