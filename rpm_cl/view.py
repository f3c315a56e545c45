"""Pictures of image results: ``rpm-cl view OUT.npz --png FILE``.

- 3-D results (points (M, 3)): a pyvista point cloud coloured by cluster, the
  array as small dots and, when the result carries the true scene, the true
  surfaces faintly; rendered off-screen when ``png`` is given (no display
  needed), else in an interactive window.
- 2-D results (points (M, 2)): a matplotlib figure of the points coloured by
  cluster over the true boundary and the array.

pyvista and matplotlib are optional dependencies (``pip install
'rpm-cl[view]'``); without them :func:`view` raises :class:`InputError` with
the install command.
"""

from __future__ import annotations

import json
import os

import numpy as np

from .data import InputError, _usual_mode, output_path

__all__ = ["load_result", "view"]


def load_result(path) -> dict:
    """Read an image result written by :func:`rpm_cl.imaging.save_result`.

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
        :class:`~rpm_cl.scene.PointTarget` / :class:`~rpm_cl.scene.Ellipsoid`
        built from ``scene``).

    Raises
    ------
    InputError
        The file is missing or unreadable, or a field has the wrong type or
        shape; the message names the field.
    """
    path = os.fspath(path)
    try:
        if os.path.splitext(path)[1].lower() in (".h5", ".hdf5"):
            out, meta = _read_h5(path)
        else:
            with np.load(path, allow_pickle=False) as npz:
                out = {k: np.asarray(npz[k]) for k in ("points", "cluster", "rp_x")}
                out["rp_z"] = np.asarray(npz["rp_z"]) if "rp_z" in npz.files else None
                meta = json.loads(str(npz["meta"])) if "meta" in npz.files else {}
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except KeyError as exc:
        raise InputError(f"{path}: not an rpm-cl image result (missing {exc})") from None
    except Exception as exc:
        raise InputError(f"{path}: not a readable result file ({type(exc).__name__}: "
                         f"{_oneline(exc)})") from None
    pts = out["points"]
    if (pts.ndim != 2 or pts.shape[1] not in (2, 3) or not _is_real(pts)
            or not np.all(np.isfinite(pts))):
        raise InputError(f"{path}: points must be a finite (M, 2) or (M, 3) array")
    out["points"] = pts.astype(np.float64)
    m = len(pts)
    cl = out["cluster"]
    if cl.shape != (m,) or not (np.issubdtype(cl.dtype, np.integer) or cl.dtype == bool):
        raise InputError(f"{path}: cluster must be an integer array of shape ({m},) like "
                         f"points, got {cl.dtype} {cl.shape}")
    out["cluster"] = cl.astype(np.int64)
    for key in ("rp_x", "rp_z"):
        a = out[key]
        if a is None:
            continue
        if a.ndim != 1 or not _is_real(a) or not np.all(np.isfinite(a)):
            raise InputError(f"{path}: {key} must be a finite 1-D array, got {a.dtype} {a.shape}")
        out[key] = a.astype(np.float64)
    if out["rp_z"] is not None and out["rp_z"].shape != out["rp_x"].shape:
        raise InputError(f"{path}: rp_x and rp_z must have the same length, got "
                         f"{out['rp_x'].size} and {out['rp_z'].size}")
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
    (:func:`rpm_cl.formats.save_result`: the ``.npz`` names as root datasets)."""
    import h5py

    if not os.path.exists(path):
        raise FileNotFoundError(path)
    with h5py.File(path, "r") as f:
        for k in ("points", "cluster", "rp_x"):
            if k not in f:
                raise KeyError(k)
        out = {k: np.asarray(f[k][()]) for k in ("points", "cluster", "rp_x")}
        out["rp_z"] = np.asarray(f["rp_z"][()]) if "rp_z" in f else None
        meta = f["meta"][()] if "meta" in f else b"{}"
    return out, json.loads(meta.decode("utf-8") if isinstance(meta, bytes) else str(meta))


def _oneline(exc: BaseException) -> str:
    """An OS error as one line: its strerror, else its text with newlines folded."""
    return getattr(exc, "strerror", None) or " ".join(str(exc).split()) or type(exc).__name__


def _is_real(a: np.ndarray) -> bool:
    return np.issubdtype(a.dtype, np.integer) or np.issubdtype(a.dtype, np.floating)


def _targets(path: str, scene: dict) -> list:
    """The true targets of ``scene`` as scene objects; InputError names a bad one."""
    from .scene import Ellipsoid, PointTarget

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

    from .scene import Ellipsoid

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


def _render_3d(res: dict, png, size) -> None:
    if png is not None and not os.environ.get("DISPLAY"):
        # headless: render through EGL rather than trying (and warning about) X
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    try:
        import pyvista as pv
    except ImportError:
        raise InputError("pictures of 3-D results need pyvista: pip install 'rpm-cl[view]'") from None
    plotter = pv.Plotter(off_screen=png is not None, window_size=size)
    plotter.set_background("white")
    for mesh in _surfaces_3d(res["targets"]):
        plotter.add_mesh(mesh, color="lightgrey", opacity=0.15)
    pts = res["points"]
    if len(pts):
        cloud = pv.PolyData(pts)
        cloud["cluster"] = res["cluster"]
        plotter.add_mesh(cloud, scalars="cluster", cmap="tab20", point_size=6,
                         render_points_as_spheres=True, show_scalar_bar=False)
    if res["rp_z"] is not None and len(res["rp_x"]):
        ant = np.unique(np.stack([res["rp_x"], np.zeros(len(res["rp_x"])), res["rp_z"]], 1), axis=0)
        plotter.add_mesh(pv.PolyData(ant), color="purple", point_size=3)
    plotter.add_axes()
    plotter.show_grid(color="grey")
    plotter.view_vector((0.55, -1.0, 0.35), viewup=(0, 0, 1))
    plotter.add_text(f"{len(pts)} points, {len(np.unique(res['cluster']))} clusters",
                     font_size=10, color="black")
    if png is not None:
        plotter.screenshot(os.fspath(png))
        plotter.close()
    else:  # pragma: no cover - needs a display
        plotter.show()


def _render_2d(res: dict, png, size) -> None:
    try:
        import matplotlib

        if png is not None:
            matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise InputError("pictures of 2-D results need matplotlib: pip install 'rpm-cl[view]'") from None
    from .scene import Ellipsoid, boundary_samples

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
        ax.plot(1e3 * pts[sel, 0], 1e3 * pts[sel, 1], "o", ms=4, color=cmap(n % 10),
                label=f"cluster {c} ({sel.sum()} points)")
    xs = np.unique(res["rp_x"])
    ax.plot(1e3 * xs, np.zeros(xs.size), "|", color="purple", label="antennas")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.set_title(f"{res['meta'].get('method', 'rpm')}: {len(pts)} points")
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    if png is not None:
        fig.savefig(os.fspath(png))
        plt.close(fig)
    else:  # pragma: no cover - needs a display
        plt.show()


def view(path, png=None, size=(1000, 800)) -> None:
    """Draw an image result; write a PNG when ``png`` is given (off-screen).

    Parameters
    ----------
    path : str or path-like
        A result ``.npz`` of ``rpm-cl image``.
    png : str or path-like, optional
        Output picture (written atomically); None opens a window.
    size : (int, int)
        Picture size in pixels.

    Raises
    ------
    InputError
        The result is unreadable or malformed (see :func:`load_result`), the
        picture is not a ``.png``, or its folder is missing or not writable;
        no picture and no temporary file are left behind.
    """
    res = load_result(path)
    render = _render_3d if res["points"].shape[1] == 3 else _render_2d
    if png is None:
        render(res, None, size)
        return
    import tempfile

    png = os.fspath(png)
    if not png.lower().endswith(".png"):
        raise InputError(f"{png}: the picture must be a .png file")
    png, folder = output_path(png)
    # render beside the target, then rename: no half-written picture is left
    try:
        fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".png", dir=folder)
    except OSError as exc:
        raise InputError(f"{png}: cannot write in {folder} ({_oneline(exc)})") from None
    os.close(fd)
    try:
        render(res, tmp, size)
        _usual_mode(tmp)
        os.replace(tmp, png)
    except OSError as exc:
        raise InputError(f"{png}: cannot write ({_oneline(exc)})") from None
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
