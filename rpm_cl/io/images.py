"""Image grids and image files: the voxel grid every coherent image lies on
(:class:`Grid`, :func:`parse_grid`) and the writer of image ``.npz`` files too
large for memory (:func:`write_image`, with :func:`check_disk`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .data import InputError
from .guard import fmt_bytes

__all__ = ["GRID_COORD_MAX", "Grid", "check_disk", "parse_grid", "write_image"]


#: Largest grid coordinate, m (1000 km): far beyond any scene a near-field
#: imager sees, and far enough from float64's limit that a picture's
#: extents and millimetre labels stay finite numbers.
GRID_COORD_MAX = 1e6


def _axis(name: str, lo: float, hi: float, step: float) -> np.ndarray:
    if not all(map(math.isfinite, (lo, hi, step))) or step <= 0 or hi < lo:
        raise InputError(
            f"grid axis {name}: need finite start <= stop and step > 0, got {lo}:{hi}:{step}"
        )
    if max(abs(lo), abs(hi)) > GRID_COORD_MAX:
        raise InputError(
            f"grid axis {name}: coordinates must lie within +-{GRID_COORD_MAX:g} m, "
            f"got {lo}:{hi}:{step}"
        )
    q = (hi - lo) / step
    if not math.isfinite(q) or q >= 100_000:
        raise InputError(f"grid axis {name}: more than 100000 samples ({lo}:{hi}:{step})")
    n = math.floor(q + 1e-9) + 1
    return lo + step * np.arange(n)


@dataclass(frozen=True)
class Grid:
    """Image grid.

    Attributes
    ----------
    x, y : ndarray
        Axes, m (y > 0 in front of the array).
    z : ndarray or None
        Third axis for 3-D images, m.
    """

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray | None = None

    def __post_init__(self):
        for name in ("x", "y", "z"):
            v = getattr(self, name)
            if v is None:
                continue
            v = np.asarray(v, np.float64).ravel()
            if v.size == 0 or not np.all(np.isfinite(v)):
                raise InputError(f"grid axis {name} must be non-empty and finite")
            object.__setattr__(self, name, v)

    @property
    def dim(self) -> int:
        return 2 if self.z is None else 3

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(a.size for a in self.axes)

    @property
    def axes(self) -> tuple:
        return (self.x, self.y) if self.z is None else (self.x, self.y, self.z)

    @property
    def size(self) -> int:
        return int(np.prod(self.shape))

    def points(self, lo: int = 0, hi: int | None = None) -> np.ndarray:
        """Coordinates of the flat voxels ``lo:hi`` (C order), shape (n, 3), m."""
        hi = self.size if hi is None else hi
        idx = np.unravel_index(np.arange(lo, hi), self.shape)
        out = np.zeros((hi - lo, 3))
        out[:, 0] = self.x[idx[0]]
        out[:, 1] = self.y[idx[1]]
        if self.z is not None:
            out[:, 2] = self.z[idx[2]]
        return out


def parse_grid(text: str) -> Grid:
    """``"x0:x1:dx,y0:y1:dy[,z0:z1:dz]"`` (m) -> :class:`Grid` (ends inclusive)."""
    parts = [p.strip() for p in str(text).split(",")]
    if len(parts) not in (2, 3):
        raise InputError(f"--grid needs 'x0:x1:dx,y0:y1:dy[,z0:z1:dz]', got {text!r}")
    axes = []
    for name, p in zip("xyz", parts):
        try:
            lo, hi, step = (float(v) for v in p.split(":"))
        except ValueError:
            raise InputError(f"grid axis {name}: need 'start:stop:step' in m, got {p!r}") from None
        axes.append(_axis(name, lo, hi, step))
    return Grid(*axes)


def check_disk(path: str, folder: str, grid, dtype, copies: float = 2.0) -> None:
    """Refuse, before any work, an image that cannot be written: it needs
    ``copies`` times its size on disk while written (a memory map, then the
    file: 2 for ``.npz`` and HDF5; 3 for ``.vti``, whose three real arrays
    ``magnitude``, ``real``, ``imag`` take 1.5 times the complex image, and
    base64 a third more), with 10 % to spare.

    Raises
    ------
    InputError
        Less than ``1.1 * copies`` times the image's bytes free in ``folder``.
    """
    need = copies * grid.size * np.dtype(dtype).itemsize
    free = _free_bytes(folder)
    if free is not None and 1.1 * need > free:
        raise InputError(
            f"{path}: the image needs {fmt_bytes(need)} of disk while written, "
            f"{fmt_bytes(free)} free"
        )


def write_image(path, grid: Grid, fill, dtype=np.complex64, meta: dict | None = None) -> None:
    """Write an image ``.npz`` (``image``, ``x``, ``y`` [, ``z``], ``meta``)
    without holding the image in memory, atomically.

    ``fill(out)`` writes the image into ``out``, a memory-mapped array of shape
    ``grid.shape`` in a temporary ``.npy`` beside ``path``; the ``.npz`` is then
    assembled by streaming that file into the zip.

    Parameters
    ----------
    path : str or path-like
    grid : Grid
    fill : callable
    dtype : numpy dtype
        complex64 or complex128.
    meta : dict, optional
        Stored as a JSON string under ``meta``.
    """
    import io
    import json
    import os
    import tempfile
    import zipfile

    from .data import _usual_mode, output_path, temp_prefix

    path, folder = output_path(path)
    check_disk(path, folder, grid, dtype)
    tmps = []
    try:
        for suffix in (".npy", ".npz"):
            fd, tmp = tempfile.mkstemp(prefix=temp_prefix(path), suffix=suffix, dir=folder)
            os.close(fd)
            tmps.append(tmp)
        tmp_npy, tmp_zip = tmps
        out = np.lib.format.open_memmap(tmp_npy, mode="w+", dtype=dtype, shape=grid.shape)
        fill(out)
        out.flush()
        del out
        with zipfile.ZipFile(tmp_zip, "w", zipfile.ZIP_STORED, allowZip64=True) as zf:
            zf.write(tmp_npy, "image.npy")
            extra = dict(zip("xyz", grid.axes))
            extra["meta"] = np.array(json.dumps(meta or {}, default=str))
            for name, arr in extra.items():
                buf = io.BytesIO()
                np.save(buf, arr)
                zf.writestr(name + ".npy", buf.getvalue())
        _usual_mode(tmp_zip)
        os.replace(tmp_zip, path)
    except OSError as exc:
        raise InputError(f"{path}: cannot write ({exc})") from None
    finally:
        for t in tmps:
            if os.path.exists(t):
                os.remove(t)


def _free_bytes(folder):
    import shutil

    try:
        return shutil.disk_usage(folder).free
    except OSError:
        return None
