"""DAS images written by extension, atomically (:func:`write_volume`): the
image filled into a temporary memory map beside the target, then ``.npz``,
chunked HDF5 (slab by slab) or VTK ImageData."""

from __future__ import annotations

import json
import os
import tempfile

import numpy as np

from .atomic import _atomic_file, output_path, temp_prefix
from .checks import InputError
from .filetypes import _H5_EXT, VOLUME_EXTENSIONS, _h5py, _need_ext
from .writers import _pyvista, _vtk_write


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
