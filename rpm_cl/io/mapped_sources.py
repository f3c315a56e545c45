"""Files of named arrays, one interface each (``keys``, ``header``: shape and
dtype before the data, ``read``): ``.npy``, ``.npz``, MATLAB v4 to v7.2
(``scipy.io.loadmat``), and HDF5 / MATLAB v7.3 through hard links only, with
MATLAB's axes order and classes (:func:`_open_source` picks one by
extension and MAT-file version)."""

from __future__ import annotations

import os

import numpy as np

from .checks import InputError
from .guard import check_declared, h5_chunks_bounded, h5_inside, h5_stored
from .sources import read_npy_header

#: Input extensions.
MAPPED_EXTENSIONS = (".mat", ".npz", ".npy", ".h5", ".hdf5")


#: The MATLAB classes read (numbers; ``logical``, ``char``, ``cell``,
#: ``struct``, ``function_handle`` ... are not), and the bytes a value of
#: each takes at least (a complex one twice).
_MATLAB_BYTES = {
    "double": 8,
    "single": 4,
    "int8": 1,
    "uint8": 1,
    "int16": 2,
    "uint16": 2,
    "int32": 4,
    "uint32": 4,
    "int64": 8,
    "uint64": 8,
}
_MATLAB_NUMERIC = tuple(_MATLAB_BYTES)


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
            shape, _, dtype = read_npy_header(fh)
        return tuple(shape), np.dtype(dtype)

    def read(self, key):
        return np.load(self.path, allow_pickle=False)

    def close(self):
        pass


class _NpzSource:
    def __init__(self, path: str):
        from .sources import _NpzSource as Npz

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
        # a v5 variable may be deflated: what it declares against the whole
        # file, before loadmat inflates it
        check_declared(
            key, int(np.prod(shape, dtype=object)) * _MATLAB_BYTES[cls], os.path.getsize(self.path)
        )
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
        from .gprmax_h5 import _get

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
        check_declared(key, int(np.prod(shape, dtype=object)) * ds.dtype.itemsize, h5_stored(ds))
        h5_chunks_bounded(ds, key)
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
