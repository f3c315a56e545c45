"""Drawing for the pictures of :mod:`rpm_cl.viz`: matplotlib and pyvista
imported on demand (without them an :class:`rpm_cl.io.data.InputError` names
the install command), a picture finished into a file or a window, a ``.png``
written atomically (:func:`_atomic_png`); the pictures of point results
(2-D with matplotlib, 3-D with pyvista over the true surfaces); and the dB
scale, extents and block maxima of image planes.
"""

from __future__ import annotations

import os

import numpy as np

from ..io.data import InputError, _atomic_file


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

    from ..cl import load_pyopencl

    with contextlib.suppress(Exception):  # any failure: no OpenCL to protect
        load_pyopencl().get_platforms()


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


def _atomic_png(png, render) -> None:
    """``render(tmp)`` draws to a temporary ``.png`` beside ``png``, renamed on
    success (:func:`rpm_cl.io.data._atomic_file`); InputError for a bad suffix,
    folder or write failure."""
    png = os.fspath(png)
    if not png.lower().endswith(".png"):
        raise InputError(f"{png}: the picture must be a .png file")
    _atomic_file(png, render, ".png")
