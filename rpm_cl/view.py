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

from .data import InputError, _usual_mode

__all__ = ["load_result", "view"]


def load_result(path) -> dict:
    """Read an image result written by :func:`rpm_cl.imaging.save_result`.

    Returns
    -------
    dict
        ``points`` (M, 2|3), ``cluster`` (M,), ``rp_x`` (K,), ``rp_z`` (K,)
        or None, ``meta`` (dict), ``scene`` (dict, ``{}`` when absent).
    """
    path = os.fspath(path)
    try:
        with np.load(path, allow_pickle=False) as npz:
            out = {k: np.asarray(npz[k]) for k in ("points", "cluster", "rp_x")}
            out["rp_z"] = np.asarray(npz["rp_z"]) if "rp_z" in npz.files else None
            meta = json.loads(str(npz["meta"])) if "meta" in npz.files else {}
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except KeyError as exc:
        raise InputError(f"{path}: not an rpm-cl image result (missing {exc})") from None
    except Exception as exc:
        raise InputError(f"{path}: not a readable result file ({type(exc).__name__}: {exc})") from None
    pts = out["points"]
    if pts.ndim != 2 or pts.shape[1] not in (2, 3) or not np.all(np.isfinite(pts)):
        raise InputError(f"{path}: points must be a finite (M, 2) or (M, 3) array")
    out["meta"] = meta
    out["scene"] = meta.get("scene") or {}
    return out


def _surfaces_3d(scene: dict):
    """pyvista meshes of the true targets (ellipsoids; points as 5 mm spheres)."""
    import pyvista as pv

    from .scene import _rotation

    meshes = []
    for t in scene.get("targets", []):
        if t.get("type") == "ellipsoid" and len(t["center"]) == 3:
            m = pv.ParametricEllipsoid(*t["semi_axes"], u_res=40, v_res=40, w_res=40)
            rot = _rotation(3, t["angles"])
            m.points = m.points @ rot.T + np.asarray(t["center"])
            meshes.append(m)
        elif t.get("type") == "point" and len(t["position"]) == 3:
            meshes.append(pv.Sphere(0.005, t["position"]))
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
    for mesh in _surfaces_3d(res["scene"]):
        plotter.add_mesh(mesh, color="lightgrey", opacity=0.15)
    pts = res["points"]
    if len(pts):
        cloud = pv.PolyData(pts)
        cloud["cluster"] = res["cluster"].astype(np.int64)
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
    from .scene import Ellipsoid, PointTarget, boundary_samples

    fig, ax = plt.subplots(figsize=(size[0] / 100, size[1] / 100), dpi=100)
    truth_label = "true boundary"
    for t in res["scene"].get("targets", []):
        if t.get("type") == "ellipsoid" and len(t["center"]) == 2:
            b = boundary_samples(Ellipsoid(t["center"], t["semi_axes"], t["angles"]), 1e-3)
            ax.plot(1e3 * b[:, 0], 1e3 * b[:, 1], ".", color="lightgrey", ms=1, label=truth_label)
        elif t.get("type") == "point" and len(t["position"]) == 2:
            p = PointTarget(t["position"]).position
            ax.plot(1e3 * p[0], 1e3 * p[1], "kx", ms=10, label=truth_label)
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
    folder = os.path.dirname(os.path.abspath(png))
    if not os.path.isdir(folder):
        raise InputError(f"{png}: output folder {folder} does not exist")
    # render beside the target, then rename: no half-written picture is left
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".png", dir=folder)
    os.close(fd)
    try:
        render(res, tmp, size)
        _usual_mode(tmp)
        os.replace(tmp, png)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
