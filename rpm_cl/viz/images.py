"""Image files of ``rpm-cl das`` and ``rpm-cl rma`` opened for the pictures
(:func:`load_das_image`, :class:`DASImage`): an uncompressed ``.npz`` image
as a read-only memory map of its member, a compressed one read once, an
``.h5`` image through a reader that opens the file for each slab; the axes
and the image checked.
"""

from __future__ import annotations

import json
import os
import zipfile
from dataclasses import dataclass

import numpy as np

from ..baselines.das import GRID_COORD_MAX
from ..io.data import InputError
from ..io.sources import read_npy_header
from .results import _h5_meta, _is_real, _oneline


@dataclass(frozen=True)
class DASImage:
    """An image file of ``rpm-cl das`` (or ``rpm-cl rma``), validated.

    Attributes
    ----------
    image : ndarray, numpy.memmap or _H5Image, shape (nx, ny) or (nx, ny, nz)
        The image as stored (complex or real); a read-only memory map when the
        ``.npz`` member is uncompressed; for an ``.h5`` file a reader of the
        ``image`` dataset (``shape``, ``dtype``, slicing), read on demand.
    axes : tuple of ndarray
        ``x``, ``y`` [, ``z``], m, each strictly increasing, lengths the image's shape.
    meta : dict
    mapped : bool
        Whether ``image`` is a memory map (not read into memory).
    path : str
        The file, for messages.
    """

    image: np.ndarray
    axes: tuple
    meta: dict
    mapped: bool
    path: str = ""

    @property
    def dim(self) -> int:
        return self.image.ndim


def _stored_member(path: str, name: str):
    """A read-only memory map of the ``.npy`` member ``name`` of an uncompressed
    zip (``.npz``); None when the member is compressed."""
    import struct

    with zipfile.ZipFile(path) as zf:
        info = zf.getinfo(name)
    if info.compress_type != zipfile.ZIP_STORED:
        return None
    with open(path, "rb") as fh:
        fh.seek(info.header_offset)
        head = fh.read(30)
        if len(head) < 30 or head[:4] != b"PK\x03\x04":
            raise ValueError(f"bad local header of {name}")
        n_name, n_extra = struct.unpack("<HH", head[26:30])
        fh.seek(info.header_offset + 30 + n_name + n_extra)
        shape, fortran, dtype = read_npy_header(fh)
        offset = fh.tell()
    if dtype.hasobject:
        raise ValueError(f"{name} holds Python objects")
    if offset + int(np.prod(shape)) * dtype.itemsize > os.path.getsize(path):
        raise ValueError(f"{name} is truncated")
    if int(np.prod(shape)) == 0:
        return np.zeros(shape, dtype)
    return np.memmap(
        path, dtype=dtype, mode="r", offset=offset, shape=shape, order="F" if fortran else "C"
    )


class _H5Image:
    """The ``image`` dataset of an HDF5 image file, read on demand: each
    slicing opens the file, reads those elements and closes it, so no file
    handle outlives a read (as each slab of an ``.npz`` gets its own map)."""

    def __init__(self, path: str, shape: tuple, dtype):
        self.path, self.shape, self.dtype = path, tuple(shape), np.dtype(dtype)

    @property
    def ndim(self) -> int:
        return len(self.shape)

    @property
    def size(self) -> int:
        return int(np.prod(self.shape))

    def __getitem__(self, key) -> np.ndarray:
        import h5py

        try:
            with h5py.File(self.path, "r") as f:
                return np.asarray(f["image"][key])
        except OSError as exc:  # a file changed or damaged since it was opened
            raise InputError(f"{self.path}: cannot read the image ({_oneline(exc)})") from None

    def __array__(self, dtype=None, copy=None):
        a = self[()]
        return a if dtype is None else a.astype(dtype)


def _h5_image_parts(path: str):
    """``axes``, ``meta`` and an :class:`_H5Image` of an HDF5 image file
    (:func:`rpm_cl.io.formats.write_volume`: the ``.npz`` names as root datasets,
    ``meta`` a JSON string)."""
    import h5py

    if not os.path.exists(path):
        raise FileNotFoundError(path)
    with h5py.File(path, "r") as f:
        for key in ("image", "x", "y"):
            if key not in f:
                raise InputError(f"{path}: not an rpm-cl image file (missing {key!r})")
            if not isinstance(f[key], h5py.Dataset):
                raise InputError(f"{path}: {key} must be a dataset at the file root, not a group")
        axes = [np.asarray(f[k][()]) for k in ("x", "y", "z") if k in f]
        meta = _h5_meta(f)
        img = _H5Image(path, f["image"].shape, f["image"].dtype)
    return axes, meta, img


def load_das_image(path) -> DASImage:
    """Open an image ``.npz`` (``image``, ``x``, ``y`` [, ``z``], ``meta``)
    without reading the image into memory when it is stored uncompressed,
    or an ``.h5`` / ``.hdf5`` image (the same names as root datasets), read
    on demand slab by slab.

    Raises
    ------
    InputError
        Missing file or key, wrong shapes, axes not finite and strictly
        increasing, or an image that is not numeric.
    """
    from ..io.formats import check_members

    path = os.fspath(path)
    # the image is read slab by slab: only the axes and meta count against memory
    check_members(path, ("x", "y", "z", "meta", "image"), budget=("x", "y", "z", "meta"))
    try:
        if os.path.splitext(path)[1].lower() in (".h5", ".hdf5"):
            axes, meta, img = _h5_image_parts(path)
            mapped = False
        else:
            axes, meta, img, mapped = _npz_image_parts(path)
    except InputError:
        raise
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except Exception as exc:  # noqa: BLE001 - any unreadable file is one line
        raise InputError(
            f"{path}: not a readable image file ({type(exc).__name__}: {_oneline(exc)})"
        ) from None
    if not isinstance(meta, dict):
        raise InputError(f"{path}: meta must be a JSON object, got {type(meta).__name__}")
    if img.ndim not in (2, 3) or not (_is_real(img) or np.iscomplexobj(img)):
        raise InputError(
            f"{path}: image must be a numeric 2-D or 3-D array, got {img.dtype} {img.shape}"
        )
    if img.size == 0:
        raise InputError(f"{path}: image is empty {img.shape}")
    axes = axes[: img.ndim] if img.ndim == 2 and len(axes) == 3 else axes
    if len(axes) != img.ndim:
        raise InputError(
            f"{path}: a {img.ndim}-D image needs axes x, y{', z' if img.ndim == 3 else ''}"
        )
    for name, a, n in zip("xyz", axes, img.shape):
        if (
            a.shape != (n,)
            or not _is_real(a)
            or not np.all(np.isfinite(a))
            or np.any(np.diff(a.astype(np.float64)) <= 0)
        ):
            raise InputError(
                f"{path}: {name} must be a finite, strictly increasing axis of "
                f"{n} values (the image's shape {img.shape}), got {a.dtype} {a.shape}"
            )
        # the grids `rpm-cl das` writes (GRID_COORD_MAX); beyond, the picture's
        # extents and millimetre labels overflow
        big = float(np.max(np.abs(a.astype(np.float64))))
        if big > GRID_COORD_MAX:
            raise InputError(
                f"{path}: {name} reaches {big:.3g} m, beyond the +-"
                f"{GRID_COORD_MAX:g} m of an image grid (a corrupt axis, or not m)"
            )
    axes = tuple(a.astype(np.float64) for a in axes)
    return DASImage(img, axes, meta, mapped, path)


def _npz_image_parts(path: str):
    """``axes``, ``meta``, the image (a memory map when stored uncompressed)
    and whether it is mapped, of an image ``.npz``."""
    with np.load(path, allow_pickle=False) as npz:
        files = npz.files
        for key in ("image", "x", "y"):
            if key not in files:
                raise InputError(f"{path}: not an rpm-cl image file (missing {key!r})")
        axes = [np.asarray(npz[k]) for k in ("x", "y", "z") if k in files]
        meta = json.loads(str(npz["meta"])) if "meta" in files else {}
    img = _stored_member(path, "image.npy")
    mapped = img is not None and isinstance(img, np.memmap)
    if img is None:
        with np.load(path, allow_pickle=False) as npz:
            img = npz["image"]
    return axes, meta, img, mapped
