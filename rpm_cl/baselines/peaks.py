"""The one peak picker of coherent images (DAS, RMA): local maxima of
``|I|`` turned into points, the form in which the paper scores an imager
(Err_RPM) and in which ``rpm-cl image --method das|rma`` reports them."""

from __future__ import annotations

import numpy as np

from ..filters import maximum_filter
from ..io.data import InputError

__all__ = ["image_peaks"]


def image_peaks(
    image: np.ndarray,
    axes,
    *,
    threshold_db: float = -10.0,
    size: int = 3,
    n_peaks: int | None = None,
    min_separation: float = 0.0,
):
    """The local maxima of ``|image|``, strongest first.

    A pixel (voxel) is a peak when no pixel within ``size`` (a
    ``size``-wide cube about it, clipped at the borders) exceeds it and it
    reaches ``threshold_db`` of the image's maximum.  Taken strongest
    first, a peak closer than ``min_separation`` to one already taken is
    skipped, and at most ``n_peaks`` are kept.

    Parameters
    ----------
    image : ndarray, shape (n_0, ..., n_{d-1})
        Complex or real, d = 2 or 3.
    axes : sequence of d ndarray
        The coordinates of each axis, m.
    threshold_db : float
        dB relative to the maximum, <= 0.
    size : int
        Odd width of the neighbourhood, pixels (>= 1).
    n_peaks : int, optional
        At most this many; None: all.
    min_separation : float
        m, >= 0.

    Returns
    -------
    points : ndarray, shape (K, d)
        m, strongest first.
    level_db : ndarray, shape (K,)
        ``20 log10(|I| / max |I|)`` at each, dB (<= 0).
    """
    a = np.abs(np.asarray(image))
    dim = a.ndim
    if len(axes) != dim or any(np.size(ax) != n for ax, n in zip(axes, a.shape)):
        raise InputError(
            f"image shape {a.shape} does not match the axes {tuple(np.size(x) for x in axes)}"
        )
    if not (isinstance(size, (int, np.integer)) and size >= 1 and size % 2 == 1):
        raise InputError(f"size must be an odd number of pixels >= 1, got {size!r}")
    if n_peaks is not None and not (isinstance(n_peaks, (int, np.integer)) and n_peaks >= 1):
        raise InputError(f"n_peaks must be an integer >= 1, got {n_peaks!r}")
    if not (np.isfinite(min_separation) and min_separation >= 0):
        raise InputError(f"min_separation must be >= 0, got {min_separation}")
    top = float(a.max()) if a.size else 0.0
    if not top > 0:
        return np.zeros((0, dim)), np.zeros(0)
    # 'nearest' pads with border values already in the neighbourhood: the
    # border compares with its real neighbours only
    local = (a == maximum_filter(a, size, "nearest")) & (a >= top * 10.0 ** (threshold_db / 20.0))
    idx = np.nonzero(local)
    order = np.argsort(-a[idx], kind="stable")
    pts = np.stack([np.asarray(axes[k], np.float64)[idx[k]] for k in range(dim)], axis=1)[order]
    lev = 20.0 * np.log10(a[idx][order] / top)
    if min_separation > 0 or n_peaks is not None:
        keep: list[int] = []
        for i, p in enumerate(pts):
            if all(np.linalg.norm(p - pts[j]) >= min_separation for j in keep):
                keep.append(i)
                if n_peaks is not None and len(keep) == n_peaks:
                    break
        pts, lev = pts[keep], lev[keep]
    return pts, lev
