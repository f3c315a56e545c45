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
"""

from __future__ import annotations

import json
import os
import zipfile
from dataclasses import dataclass

import numpy as np

from ..baselines.das import GRID_COORD_MAX
from ..io.data import InputError, _atomic_file

__all__ = ["DASImage", "load_das_image", "load_result", "view"]


def load_result(path) -> dict:
    """Read an image result written by :func:`rpm_cl.io.formats.save_result`.

    Everything the pictures use is checked here, so that an odd file (edited by
    hand, or written by another tool) gives one :class:`InputError` rather than
    a traceback from matplotlib or pyvista.  Malformed true targets in
    ``meta["scene"]`` are rejected, not skipped: ``rpm-cl image`` always writes
    them whole, so one that is not means the file was altered, and drawing the
    rest would show a truth that is not the one the data were simulated from.

    Parameters
    ----------
    path : str or path-like
        A result ``.npz``, or ``.h5`` / ``.hdf5`` (the same names).

    Returns
    -------
    dict
        ``points`` (M, 2|3) float64, ``cluster`` (M,) int64, ``rp_x`` (K,)
        float64, ``rp_z`` (K,) float64 or None, ``meta`` (dict), ``scene``
        (dict, ``{}`` when absent) and ``targets`` (list of
        :class:`~rpm_cl.simulate.scene.PointTarget` / :class:`~rpm_cl.simulate.scene.Ellipsoid`
        built from ``scene``).

    Raises
    ------
    InputError
        The file is missing or unreadable, or a field has the wrong type or
        shape; the message names the field.
    """
    from ..io.formats import check_members

    path = os.fspath(path)
    if (
        os.path.isfile(path)
        and not os.path.splitext(path)[1].lower() in (".h5", ".hdf5")
        and not zipfile.is_zipfile(path)
    ):
        raise InputError(f"{path}: not an .npz result (not a zip archive)")
    check_members(path, ("points", "cluster", "rp_x", "rp_z", "meta"))
    try:
        if os.path.splitext(path)[1].lower() in (".h5", ".hdf5"):
            out, meta = _read_h5(path)
        else:
            if os.path.isfile(path) and not zipfile.is_zipfile(path):
                raise InputError(f"{path}: not an .npz result (not a zip archive)")
            with np.load(path, allow_pickle=False) as npz:
                missing = [k for k in ("points", "cluster", "rp_x") if k not in npz.files]
                if missing:
                    hint = (
                        f"; it holds radar data: image it first (rpm-cl image {path} -o OUT.npz)"
                        if {"signal", "spectrum"} & set(npz.files)
                        else ""
                    )
                    raise InputError(
                        f"{path}: not an rpm-cl image result (no {missing[0]!r}{hint})"
                    )
                out = {k: np.asarray(npz[k]) for k in ("points", "cluster", "rp_x")}
                out["rp_z"] = np.asarray(npz["rp_z"]) if "rp_z" in npz.files else None
                meta = json.loads(str(npz["meta"])) if "meta" in npz.files else {}
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except InputError:
        raise
    except KeyError as exc:
        raise InputError(f"{path}: not an rpm-cl image result (missing {exc})") from None
    except Exception as exc:  # noqa: BLE001 - any unreadable file is one line
        raise InputError(
            f"{path}: not a readable result file ({type(exc).__name__}: {_oneline(exc)})"
        ) from None
    pts = out["points"]
    if (
        pts.ndim != 2
        or pts.shape[1] not in (2, 3)
        or not _is_real(pts)
        or not np.all(np.isfinite(pts))
    ):
        raise InputError(f"{path}: points must be a finite (M, 2) or (M, 3) array")
    out["points"] = pts.astype(np.float64)
    m = len(pts)
    cl = out["cluster"]
    if cl.shape != (m,) or not (np.issubdtype(cl.dtype, np.integer) or cl.dtype == bool):
        raise InputError(
            f"{path}: cluster must be an integer array of shape ({m},) like "
            f"points, got {cl.dtype} {cl.shape}"
        )
    out["cluster"] = cl.astype(np.int64)
    for key in ("rp_x", "rp_z"):
        a = out[key]
        if a is None:
            continue
        if a.ndim != 1 or not _is_real(a) or not np.all(np.isfinite(a)):
            raise InputError(f"{path}: {key} must be a finite 1-D array, got {a.dtype} {a.shape}")
        out[key] = a.astype(np.float64)
    if out["rp_z"] is not None and out["rp_z"].shape != out["rp_x"].shape:
        raise InputError(
            f"{path}: rp_x and rp_z must have the same length, got "
            f"{out['rp_x'].size} and {out['rp_z'].size}"
        )
    if not isinstance(meta, dict):
        raise InputError(f"{path}: meta must be a JSON object, got {type(meta).__name__}")
    scene = meta.get("scene") or {}
    if not isinstance(scene, dict):
        raise InputError(f"{path}: meta.scene must be a JSON object, got {type(scene).__name__}")
    out["meta"] = meta
    out["scene"] = scene
    out["targets"] = _targets(path, scene)
    return out


def _read_h5(path: str):
    """The fields :func:`load_result` uses, from an HDF5 result
    (:func:`rpm_cl.io.formats.save_result`: the ``.npz`` names as root datasets)."""
    import h5py

    if not os.path.exists(path):
        raise FileNotFoundError(path)
    with h5py.File(path, "r") as f:
        for k in ("points", "cluster", "rp_x"):
            if k not in f:
                raise KeyError(k)
        out = {k: np.asarray(f[k][()]) for k in ("points", "cluster", "rp_x")}
        out["rp_z"] = np.asarray(f["rp_z"][()]) if "rp_z" in f else None
        meta = _h5_meta(f)
    return out, meta


def _h5_meta(f) -> object:
    """The ``meta`` JSON string dataset of an open HDF5 file, parsed ({} when absent)."""
    meta = f["meta"][()] if "meta" in f else b"{}"
    if isinstance(meta, np.ndarray) and meta.ndim == 0:
        meta = meta.item()
    return json.loads(meta.decode("utf-8") if isinstance(meta, bytes) else str(meta))


def _oneline(exc: BaseException) -> str:
    """An OS error as one line: its strerror, else its text with newlines folded."""
    return getattr(exc, "strerror", None) or " ".join(str(exc).split()) or type(exc).__name__


def _is_real(a: np.ndarray) -> bool:
    return np.issubdtype(a.dtype, np.integer) or np.issubdtype(a.dtype, np.floating)


def _targets(path: str, scene: dict) -> list:
    """The true targets of ``scene`` as scene objects; InputError names a bad one."""
    from ..simulate.scene import Ellipsoid, PointTarget

    targets = scene.get("targets", [])
    if not isinstance(targets, list):
        raise InputError(f"{path}: meta.scene.targets must be a list, got {type(targets).__name__}")
    need = {"point": ("position",), "ellipsoid": ("center", "semi_axes")}
    out = []
    for i, t in enumerate(targets):
        where = f"{path}: meta.scene.targets[{i}]"
        if not isinstance(t, dict):
            raise InputError(f"{where} must be a JSON object, got {type(t).__name__}")
        kind = t.get("type")
        if kind not in need:
            raise InputError(f"{where}: unknown type {kind!r} (expected 'point' or 'ellipsoid')")
        missing = [k for k in need[kind] if k not in t]
        if missing:
            raise InputError(f"{where}: the {kind} target has no {' or '.join(missing)}")
        try:
            if kind == "point":
                out.append(PointTarget(t["position"]))
            else:
                out.append(Ellipsoid(t["center"], t["semi_axes"], t.get("angles", (0.0,))))
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None
        except (TypeError, ValueError) as exc:
            raise InputError(f"{where}: not numeric ({_oneline(exc)})") from None
    return out


def _surfaces_3d(targets: list):
    """pyvista meshes of the true 3-D targets (ellipsoids; points as 5 mm spheres)."""
    import pyvista as pv

    from ..simulate.scene import Ellipsoid

    meshes = []
    for t in targets:
        if t.dim != 3:
            continue
        if isinstance(t, Ellipsoid):
            m = pv.ParametricEllipsoid(*t.semi_axes, u_res=40, v_res=40, w_res=40)
            m.points = m.points @ t.rotation.T + t.center
            meshes.append(m)
        else:
            meshes.append(pv.Sphere(0.005, t.position))
    return meshes


def _pyplot(png, what: str):
    """matplotlib.pyplot, on the Agg backend when drawing to a file."""
    try:
        import matplotlib

        if png is not None:
            matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise InputError(
            f"pictures of {what} need matplotlib: pip install 'rpm-cl[view]'"
        ) from None
    return plt


def _finish_mpl(fig, png) -> None:
    import matplotlib.pyplot as plt

    if png is not None:
        fig.savefig(os.fspath(png))
        plt.close(fig)
    else:  # pragma: no cover - needs a display
        plt.show()


def _finish_pv(plotter, png) -> None:
    if png is not None:
        plotter.screenshot(os.fspath(png))
        plotter.close()
    else:  # pragma: no cover - needs a display
        plotter.show()


def _render_3d(res: dict, png, size) -> None:
    pv = _pyvista(png)
    plotter = pv.Plotter(off_screen=png is not None, window_size=size)
    plotter.set_background("white")
    for mesh in _surfaces_3d(res["targets"]):
        plotter.add_mesh(mesh, color="lightgrey", opacity=0.15)
    pts = res["points"]
    if len(pts):
        cloud = pv.PolyData(pts)
        cloud["cluster"] = res["cluster"]
        plotter.add_mesh(
            cloud,
            scalars="cluster",
            cmap="tab20",
            point_size=6,
            render_points_as_spheres=True,
            show_scalar_bar=False,
        )
    if res["rp_z"] is not None and len(res["rp_x"]):
        ant = np.unique(np.stack([res["rp_x"], np.zeros(len(res["rp_x"])), res["rp_z"]], 1), axis=0)
        plotter.add_mesh(pv.PolyData(ant), color="purple", point_size=3)
    plotter.add_axes()
    plotter.show_grid(color="grey")
    plotter.view_vector((0.55, -1.0, 0.35), viewup=(0, 0, 1))
    plotter.add_text(
        f"{len(pts)} points, {len(np.unique(res['cluster']))} clusters", font_size=10, color="black"
    )
    _finish_pv(plotter, png)


def _render_2d(res: dict, png, size) -> None:
    plt = _pyplot(png, "2-D results")
    from ..simulate.scene import Ellipsoid, boundary_samples

    fig, ax = plt.subplots(figsize=(size[0] / 100, size[1] / 100), dpi=100)
    truth_label = "true boundary"
    for t in res["targets"]:
        if t.dim != 2:
            continue
        if isinstance(t, Ellipsoid):
            b = boundary_samples(t, 1e-3)
            ax.plot(1e3 * b[:, 0], 1e3 * b[:, 1], ".", color="lightgrey", ms=1, label=truth_label)
        else:
            ax.plot(1e3 * t.position[0], 1e3 * t.position[1], "kx", ms=10, label=truth_label)
        truth_label = None  # one legend entry
    pts = res["points"]
    cmap = plt.get_cmap("tab10")
    for n, c in enumerate(np.unique(res["cluster"])):
        sel = res["cluster"] == c
        ax.plot(
            1e3 * pts[sel, 0],
            1e3 * pts[sel, 1],
            "o",
            ms=4,
            color=cmap(n % 10),
            label=f"cluster {c} ({sel.sum()} points)",
        )
    xs = np.unique(res["rp_x"])
    ax.plot(1e3 * xs, np.zeros(xs.size), "|", color="purple", label="antennas")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.set_title(f"{res['meta'].get('method', 'rpm')}: {len(pts)} points")
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    _finish_mpl(fig, png)


# --------------------------------------------------------------------------
# DAS / RMA images

#: Bytes of |I| (float32) per slab while scanning a volume; the temporaries of
#: one slab (the complex rows, |I|, its padded copy) are about 5 times this.
SLAB_BYTES = 16 << 20
#: Default dynamic range of image pictures, dB.
DYNAMIC_RANGE_DEFAULT = 40.0


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
        version = np.lib.format.read_magic(fh)
        reader = (
            np.lib.format.read_array_header_1_0
            if version == (1, 0)
            else np.lib.format.read_array_header_2_0
        )
        shape, fortran, dtype = reader(fh)
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
    check_members(path, ("x", "y", "z", "meta"))
    check_members(path, ("image",), budget=False)  # read slab by slab
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


def _db(mag, top: float) -> np.ndarray:
    """20 log10(mag / top), floored at -600 dB; an all-zero image (top 0, a
    target-free input) is the floor everywhere."""
    if not top > 0:
        return np.full(np.shape(mag), -600.0, np.float32)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.maximum(20.0 * np.log10(np.asarray(mag) / top), -600.0).astype(np.float32)


def _edges(ax: np.ndarray) -> tuple:
    """Extent (first - half step, last + half step) of an axis, m."""
    h = 0.5 * (ax[1] - ax[0]) if ax.size > 1 else 5e-4
    return ax[0] - h, ax[-1] + h


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


def _pyvista(png):
    """pyvista; headless pictures render through EGL rather than trying (and
    warning about) X.  OpenCL is loaded before VTK either way (a software
    OpenGL on a display brings an LLVM too)."""
    if png is not None and not os.environ.get("DISPLAY"):
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    _load_opencl_first()
    try:
        import pyvista as pv
    except ImportError:
        raise InputError(
            "pictures of 3-D results need pyvista: pip install 'rpm-cl[view]'"
        ) from None
    return pv


def _load_opencl_first() -> None:
    """Load the OpenCL platforms (PoCL's LLVM) before VTK's EGL renderer.

    Both register LLVM command-line options; when EGL's LLVM (Mesa's) is
    loaded first, PoCL's later registration aborts the process ("LLVM ERROR:
    inconsistency in registered CommandLine options") at the next program
    build.  The other order works, so a process that renders off-screen and
    then images (the Python API, a notebook) loads PoCL here.  Without
    pyopencl, or without a platform, there is nothing to protect."""
    import contextlib

    with contextlib.suppress(Exception):  # any failure: no OpenCL to protect
        import pyopencl as cl

        cl.get_platforms()


def _pool2(a: np.ndarray, ax0: np.ndarray, ax1: np.ndarray, side: int):
    """Block maxima of a plane (n0, n1) to at most ``side`` a side, with the
    blocks' centre coordinates."""
    f = [max(1, -(-n // side)) for n in a.shape]
    if f == [1, 1]:
        return a, ax0, ax1
    pad = [(0, -(-n // k) * k - n) for n, k in zip(a.shape, f)]
    b = np.pad(a, pad).reshape(-(-a.shape[0] // f[0]), f[0], -(-a.shape[1] // f[1]), f[1])
    centres = [
        np.array([ax[i : i + k].mean() for i in range(0, ax.size, k)])
        for ax, k in zip((ax0, ax1), f)
    ]
    return b.max(axis=(1, 3)), centres[0], centres[1]


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


def _atomic_png(png, render) -> None:
    """``render(tmp)`` draws to a temporary ``.png`` beside ``png``, renamed on
    success (:func:`rpm_cl.io.data._atomic_file`); InputError for a bad suffix,
    folder or write failure."""
    png = os.fspath(png)
    if not png.lower().endswith(".png"):
        raise InputError(f"{png}: the picture must be a .png file")
    _atomic_file(png, render, ".png")


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
