"""Paper-style figures: ``rpm-cl figure {kspace,rps,compare} IN.npz --png OUT``.

Each figure is computed first, into a small frozen dataclass holding exactly
the arrays drawn (so tests can check them against the truth), then drawn with
matplotlib:

- ``kspace`` (:func:`kspace_map`): the k-space map ``|S(k_x, R)|`` in dB of
  a linear-array file with the detected cluster centres marked (the paper's
  Fig. 3/7); for planar data the ``k_x``-``R`` map at the strongest ``k_z``,
  with the centres within a quarter window period of that ``k_z``.
- ``rps`` (:func:`rp_sets`): the decomposed range points per cluster (antenna
  x against range, coloured by cluster) over the true RPs when the file
  carries them (Fig. 4/8); for planar data the antenna row at the middle z.
- ``compare`` (:func:`compare_images`): k-space RPM points beside the SAR /
  DAS image of the same linear-array data on a grid around the scene
  (Fig. 5/10/12).

matplotlib is imported lazily (``pip install 'rpm-cl[view]'``).

This module holds :func:`figure`; the ``kspace`` and ``rps`` figures are
computed and drawn by :mod:`rpm_cl.viz.decomposition`, ``compare`` by
:mod:`rpm_cl.viz.compare`.
"""

from __future__ import annotations

import os
import warnings

import numpy as np

from ..io.data import InputError
from .compare import Comparison, auto_grid, compare_images, draw_compare
from .decomposition import KSpaceMap, RPSets, draw_kspace, draw_rps, kspace_map, rp_sets

__all__ = [
    "FIGURES",
    "Comparison",
    "KSpaceMap",
    "RPSets",
    "auto_grid",
    "compare_images",
    "draw_compare",
    "draw_kspace",
    "draw_rps",
    "figure",
    "kspace_map",
    "rp_sets",
]

#: Figure names.
FIGURES = ("kspace", "rps", "compare")


def figure(
    name: str,
    path,
    png=None,
    *,
    size=(1200, 700),
    dynamic_range: float = 40.0,
    grid=None,
    engine=None,
    das=None,
    frame: int | None = None,
    range_window: str = "hann",
    params=None,
    conjugate: bool = False,
) -> object:
    """Compute and draw one paper-style figure of a data file.

    Parameters
    ----------
    name : {"kspace", "rps", "compare"}
    path : str or path-like
        An input ``.npz`` (input contract).
    png : str or path-like, optional
        Picture to write (off-screen, atomically); None opens a window.
    size : (int, int)
        Picture size, pixels.
    dynamic_range : float
        dB below the maximum shown on the maps (> 0).
    grid : rpm_cl.baselines.das.Grid, optional
        ``compare``: the DAS grid; default :func:`auto_grid`.
    engine : object
        ``compare``: the RPM engine (required there).
    das : rpm_cl.baselines.das.DeviceDAS, optional
        ``compare``: DAS on the device; None uses NumPy.
    frame : int, optional
        Frame of a stacked input (as :func:`rpm_cl.load_data`).
    range_window : str
        Range window of a frequency-domain input (as :func:`rpm_cl.load_data`).
    params : rpm_cl.rpm.params.ImagingParams or callable, optional
        The imaging parameters of the figure, or a function of the loaded
        :class:`~rpm_cl.io.data.RadarData` returning them (how ``rpm-cl figure``
        applies ``--config`` and the flags over the defaults derived from the
        data, as ``rpm-cl image`` does).  Default
        :func:`rpm_cl.rpm.params.default_params` of the data.
    conjugate : bool
        Conjugate a frequency-domain input first (as :func:`rpm_cl.load_data`).

    Returns
    -------
    KSpaceMap, RPSets or Comparison
        The arrays drawn.

    Raises
    ------
    InputError
        Unknown name, unreadable or invalid input, planar data for
        ``compare``, a bad option or output path.
    """
    from ..io.formats import load_data
    from .render import _atomic_png, _finish_mpl, _pyplot

    if name not in FIGURES:
        raise InputError(f"unknown figure {name!r}; choose from {', '.join(FIGURES)}")
    if not (np.isfinite(dynamic_range) and dynamic_range > 0):
        raise InputError(f"the dynamic range must be > 0 dB, got {dynamic_range:g}")
    if png is not None:  # check the output before computing
        from ..io.data import output_path

        if not os.fspath(png).lower().endswith(".png"):
            raise InputError(f"{os.fspath(png)}: the picture must be a .png file")
        output_path(png)
    data = load_data(path, frame=frame, range_window=range_window, conjugate=conjugate)
    if callable(params):
        params = params(data)
    if name == "kspace":
        what = kspace_map(data, params)
    elif name == "rps":
        what = rp_sets(data, params)
    else:
        if engine is None:
            raise InputError("the compare figure needs an RPM engine")
        what = compare_images(data, engine, das, grid, params)

    def render(out):
        plt = _pyplot(out, "figures")
        ncols = 2 if name == "compare" else 1
        fig, axes = plt.subplots(
            1, ncols, figsize=(size[0] / 100, size[1] / 100), dpi=100, squeeze=False
        )
        axes = axes[0]
        if name == "kspace":
            fig.colorbar(draw_kspace(what, axes[0], dynamic_range), ax=axes[0], label="dB")
        elif name == "rps":
            draw_rps(what, axes[0])
        else:
            from mpl_toolkits.axes_grid1 import make_axes_locatable

            im = draw_compare(what, axes, dynamic_range)
            cax = make_axes_locatable(axes[0]).append_axes("right", size="4%", pad=0.08)
            fig.colorbar(im, cax=cax, label="dB")
        fig.suptitle(f"{os.path.basename(os.fspath(path))}: {name}", fontsize=11)
        with warnings.catch_warnings():  # the compare colorbar's axes: "not compatible"
            warnings.filterwarnings("ignore", message=".*tight_layout", category=UserWarning)
            fig.tight_layout()
        _finish_mpl(fig, out)

    if png is None:
        render(None)
    else:
        _atomic_png(png, render)
    return what
