"""Pictures of image results: ``rpm-cl view OUT.npz --png FILE``.

- 3-D results (points (M, 3)): a pyvista point cloud coloured by cluster, the
  array as small dots and, when the result carries the true scene, the true
  surfaces faintly; rendered off-screen when ``png`` is given (no display
  needed), else in an interactive window.
- 2-D results (points (M, 2)): a matplotlib figure of the points coloured by
  cluster over the true boundary and the array.
- DAS / RMA images (``image`` complex with axes ``x``, ``y`` [, ``z``], as
  :func:`rpm_cl.io.formats.write_volume` writes them to ``.npz`` or ``.h5``):
  2-D as ``|I|`` in dB with matplotlib; 3-D as three orthogonal slices
  through the brightest voxel, or an iso-surface at a dB level (``iso``),
  with pyvista.

Big volumes (:func:`load_das_image`): ``rpm-cl das`` stores the image
uncompressed in the ``.npz``, so it is opened as a read-only memory map of
that member and never read whole: it is read in slabs of x planes (about
16 MB of |I| each), each through a mapping of its own released at once, so
neither copies nor mapped pages accumulate.  One pass finds the brightest
voxel and the block maxima; the slices are planes through that voxel, at full
resolution (a second pass collects the y and z planes); the iso-surface is
taken on the block maxima, at most ``max_side`` voxels per axis (a 667^3
complex64 volume, 2.4 GB, becomes a 223^3 float32 one, 44 MB).
A compressed ``.npz`` (``np.savez_compressed``) cannot be mapped and is read
into memory once.  An ``.h5`` image (a chunked ``image`` dataset) is read by
the same slabs, each through a short-lived open of the file.

pyvista and matplotlib are optional dependencies (``pip install
'rpm-cl[view]'``); without them :func:`view` raises :class:`InputError` with
the install command.

This module holds :func:`view`, the reading of image volumes slab by slab
(:func:`_block_max`, :func:`_planes`) and the pictures of images.  Result
files are read by :mod:`rpm_cl.viz.results`, image files opened by
:mod:`rpm_cl.viz.images`, and the drawing helpers and the pictures of point
results are :mod:`rpm_cl.viz.render`.
"""

from __future__ import annotations

import os

import numpy as np

from ..io.data import InputError
from .images import DASImage, load_das_image
from .render import (
    _atomic_png,
    _db,
    _edges,
    _finish_mpl,
    _finish_pv,
    _pool2,
    _pyplot,
    _pyvista,
    _render_2d,
    _render_3d,
)
from .results import load_result

__all__ = ["DASImage", "load_das_image", "load_result", "view"]


#: Bytes of |I| (float32) per slab while scanning a volume; the temporaries of
#: one slab (the complex rows, |I|, its padded copy) are about 5 times this.
SLAB_BYTES = 16 << 20


#: Default dynamic range of image pictures, dB.
DYNAMIC_RANGE_DEFAULT = 40.0


def _slab_rows(img: DASImage, multiple: int = 1) -> int:
    """Rows (x planes) per slab: about :data:`SLAB_BYTES` of |I|, a multiple of ``multiple``."""
    plane = int(np.prod(img.image.shape[1:])) * 4
    return max(multiple, (SLAB_BYTES // max(1, plane)) // multiple * multiple)


def _rows(img: DASImage, lo: int, hi: int) -> np.ndarray:
    """A copy of ``image[lo:hi]``.  A memory-mapped image is read through a
    mapping of those rows only, released at once, so the pages read do not
    stay in the process (reading through the whole-file map would keep every
    page touched resident, up to the whole volume)."""
    a = img.image
    hi = min(hi, a.shape[0])
    if not (isinstance(a, np.memmap) and a.flags.c_contiguous) or hi <= lo:
        return np.array(a[lo:hi])
    row = int(np.prod(a.shape[1:])) * a.dtype.itemsize
    part = np.memmap(
        img.path,
        dtype=a.dtype,
        mode="r",
        offset=a.offset + lo * row,
        shape=(hi - lo,) + a.shape[1:],
    )
    out = np.array(part)
    del part
    return out


def _planes(img: DASImage, peak) -> tuple:
    """The three planes of a volume through the voxel ``peak``: image[i],
    image[:, j], image[:, :, k], each (n, m), read slab by slab."""
    i, j, k = peak
    nx, ny, nz = img.image.shape
    px = _rows(img, i, i + 1)[0]
    py = np.empty((nx, nz), img.image.dtype)
    pz = np.empty((nx, ny), img.image.dtype)
    step = _slab_rows(img)
    for r0 in range(0, nx, step):
        slab = _rows(img, r0, r0 + step)
        py[r0 : r0 + len(slab)] = slab[:, j, :]
        pz[r0 : r0 + len(slab)] = slab[:, :, k]
    return px, py, pz


def _block_max(img: DASImage, max_side: int):
    """|I| reduced by block maxima to at most ``max_side`` samples per axis.

    Reads the image slab by slab along x (about :data:`SLAB_BYTES` of |I| at
    a time), so a memory-mapped volume is never held whole.

    Returns
    -------
    reduced : ndarray, float32
    axes : tuple of ndarray
        Block-centre coordinates, m.
    peak : tuple of int
        Index of the brightest sample of the full image.
    top : float
        |I| there.
    """
    a = img.image
    f = [max(1, -(-n // max_side)) for n in a.shape]
    rows = _slab_rows(img, f[0])
    out_shape = [-(-n // k) for n, k in zip(a.shape, f)]
    reduced = np.zeros(out_shape, np.float32)
    top, peak = -1.0, (0,) * a.ndim
    for r0 in range(0, a.shape[0], rows):
        slab = np.abs(_rows(img, r0, r0 + rows)).astype(np.float32, copy=False)
        if not np.all(np.isfinite(slab)):
            raise InputError(f"{img.path}: the image contains NaN or Inf")
        j = np.unravel_index(int(np.argmax(slab)), slab.shape)
        if slab[j] > top:
            top, peak = float(slab[j]), (r0 + int(j[0]),) + tuple(int(v) for v in j[1:])
        pad = [(0, -(-n // k) * k - n) for n, k in zip(slab.shape, f)]
        if any(p for _, p in pad):
            slab = np.pad(slab, pad)
        shp = []
        for n, k in zip(slab.shape, f):
            shp += [n // k, k]
        blk = slab.reshape(shp).max(axis=tuple(range(1, 2 * a.ndim, 2)))
        reduced[r0 // f[0] : r0 // f[0] + blk.shape[0]] = blk
    axes = tuple(
        np.array([ax[i : i + k].mean() for i in range(0, ax.size, k)]) for ax, k in zip(img.axes, f)
    )
    return reduced, axes, peak, top


def _render_das_2d(img: DASImage, png, size, dynamic_range: float, max_side: int = 2000) -> None:
    plt = _pyplot(png, "2-D images")
    mag, axes, peak, top = _block_max(img, max_side)
    db = _db(mag, top)
    fig, ax = plt.subplots(figsize=(size[0] / 100, size[1] / 100), dpi=100)
    x0, x1 = _edges(axes[0])
    y0, y1 = _edges(axes[1])
    im = ax.imshow(
        db.T,
        origin="lower",
        extent=(1e3 * x0, 1e3 * x1, 1e3 * y0, 1e3 * y1),
        vmin=-dynamic_range,
        vmax=0.0,
        cmap="inferno",
        aspect="equal",
        interpolation="nearest",
    )
    fig.colorbar(im, ax=ax, label="|I| (dB)")
    px, py = (img.axes[k][peak[k]] for k in range(2))
    ax.plot(1e3 * px, 1e3 * py, "c+", ms=12, label="maximum")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(
        f"{img.meta.get('method', 'image')} |I|, {dynamic_range:g} dB range; "
        f"maximum at ({1e3 * px:.0f}, {1e3 * py:.0f}) mm"
    )
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    _finish_mpl(fig, png)


def _render_das_3d(
    img: DASImage,
    png,
    size,
    dynamic_range: float,
    iso=None,
    max_side: int = 224,
    plane_side: int = 400,
) -> None:
    pv = _pyvista(png)
    mag, axes, peak, top = _block_max(img, max_side)
    plotter = pv.Plotter(off_screen=png is not None, window_size=size)
    plotter.set_background("white")
    x, y, z = img.axes
    where = tuple(img.axes[k][peak[k]] for k in range(3))
    if iso is None:
        # three planes through the brightest voxel, each as block maxima, at
        # most plane_side a side: as fine as the picture's pixels, and VTK's
        # memory stays small for big volumes
        i, j, k = peak
        mx, my, mz = (np.abs(p) for p in _planes(img, peak))
        mx, ay, az = _pool2(mx, y, z, plane_side)
        planes = [(x[i : i + 1], ay, az, mx[None, :, :])]
        my, ax_, az = _pool2(my, x, z, plane_side)
        planes.append((ax_, y[j : j + 1], az, my[:, None, :]))
        mz, ax_, ay = _pool2(mz, x, y, plane_side)
        planes.append((ax_, ay, z[k : k + 1], mz[:, :, None]))
        for px, py, pz, vals in planes:
            grid = pv.RectilinearGrid(px, py, pz)
            grid.point_data["dB"] = _db(vals, top).ravel(order="F")
            plotter.add_mesh(
                grid,
                scalars="dB",
                cmap="inferno",
                clim=(-dynamic_range, 0.0),
                show_scalar_bar=False,
            )
        what = f"slices through the maximum, {dynamic_range:g} dB range"
        plotter.add_scalar_bar("|I| (dB)", color="black")
    else:
        grid = pv.RectilinearGrid(*axes)
        grid.point_data["dB"] = _db(mag, top).ravel(order="F")
        surf = grid.contour([iso], scalars="dB")
        if surf.n_points:
            plotter.add_mesh(surf, color="orange", smooth_shading=True)
        what = (
            f"iso-surface at {iso:g} dB"
            + ("" if surf.n_points else " (empty)")
            + (
                f" on {mag.shape[0]}x{mag.shape[1]}x{mag.shape[2]} block maxima"
                if mag.shape != img.image.shape
                else ""
            )
        )
    plotter.add_mesh(
        pv.Sphere(radius=0.01 * max(np.ptp(a) for a in img.axes) + 1e-4, center=where), color="cyan"
    )
    plotter.show_bounds(color="grey", xtitle="x (m)", ytitle="y (m)", ztitle="z (m)")
    plotter.view_vector((0.55, -1.0, 0.35), viewup=(0, 0, 1))
    plotter.add_text(
        f"{img.meta.get('method', 'image')} {img.image.shape}: {what}; maximum at "
        f"({where[0]:.3f}, {where[1]:.3f}, {where[2]:.3f}) m",
        font_size=9,
        color="black",
    )
    _finish_pv(plotter, png)


def _is_image_file(path) -> bool:
    """Whether ``path`` (``.npz``, or ``.h5`` / ``.hdf5``) is an image file
    (``image``, no ``points``); False when unreadable (:func:`load_result`
    then reports why)."""
    path = os.fspath(path)
    try:
        if os.path.splitext(path)[1].lower() in (".h5", ".hdf5"):
            import h5py

            with h5py.File(path, "r") as f:
                return "image" in f and "points" not in f
        with np.load(path, allow_pickle=False) as npz:
            return "image" in npz.files and "points" not in npz.files
    except Exception:  # noqa: BLE001 - load_result reports what is wrong
        return False


def view(
    path,
    png=None,
    size=(1000, 800),
    dynamic_range: float = DYNAMIC_RANGE_DEFAULT,
    iso: float | None = None,
) -> None:
    """Draw an image result or a DAS/RMA image; write a PNG when ``png`` is
    given (off-screen).

    Parameters
    ----------
    path : str or path-like
        A result ``.npz`` / ``.h5`` of ``rpm-cl image``, or an image ``.npz`` /
        ``.h5`` of ``rpm-cl das`` / ``rpm-cl rma`` (recognised by its ``image``
        key).
    png : str or path-like, optional
        Output picture (written atomically); None opens a window.
    size : (int, int)
        Picture size in pixels.
    dynamic_range : float
        Images: the colour scale spans this many dB below the maximum (> 0).
    iso : float, optional
        3-D images: draw the iso-surface at this level, dB relative to the
        maximum (< 0), instead of the three slices through the maximum.

    Raises
    ------
    InputError
        The file is unreadable or malformed (see :func:`load_result`,
        :func:`load_das_image`), an option does not apply or is out of range,
        the picture is not a ``.png``, or its folder is missing or not
        writable; no picture and no temporary file are left behind.
    """
    from functools import partial

    ext = os.path.splitext(os.fspath(path))[1].lower()
    if ext in (".ply", ".vtp", ".vti"):
        raise InputError(
            f"{os.fspath(path)}: view draws the .npz or .h5 files of rpm-cl; open "
            f"{ext} files in ParaView (or write .npz/.h5 with -o)"
        )
    if not (np.isfinite(dynamic_range) and dynamic_range > 0):
        raise InputError(f"the dynamic range must be > 0 dB, got {dynamic_range:g}")
    if iso is not None and not (np.isfinite(iso) and iso < 0):
        raise InputError(f"the iso-surface level must be below the maximum (< 0 dB), got {iso:g}")
    from ..io.guard import regular_file

    regular_file(path)  # before anything opens it: a FIFO would block
    if _is_image_file(path):
        img = load_das_image(path)
        if img.dim == 2:
            if iso is not None:
                raise InputError(f"{os.fspath(path)}: --iso needs a 3-D image; this one is 2-D")
            render = partial(_render_das_2d, img, size=size, dynamic_range=dynamic_range)
        else:
            render = partial(_render_das_3d, img, size=size, dynamic_range=dynamic_range, iso=iso)
    else:
        res = load_result(path)
        if iso is not None:
            raise InputError(f"{os.fspath(path)}: --iso applies to 3-D DAS images, not to points")
        fn = _render_3d if res["points"].shape[1] == 3 else _render_2d

        def render(out):
            fn(res, out, size)

    if png is None:
        render(None)
    else:
        _atomic_png(png, render)
