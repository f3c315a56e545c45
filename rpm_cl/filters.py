"""Rank filters in NumPy, equal to SciPy's: the moving maximum of the
centre searches and peak pickers, and the dilation of the gates to search.

SciPy's ``ndimage`` takes about half a second to import (it pulls in its
array-API layer and ``numpy.f2py``), more than imaging a small scene; these
are exact (a maximum is a comparison, no rounding) and
``tests/test_filters.py`` checks them against SciPy on random inputs.
They take finite inputs (NumPy's maximum propagates NaN, SciPy's filter
skips it); every caller passes finite maps.
"""

from __future__ import annotations

import numpy as np

__all__ = ["binary_dilation", "maximum_filter"]

#: np.pad's name of each SciPy boundary mode used here.
_PAD = {"wrap": "wrap", "nearest": "edge", "reflect": "symmetric", "constant": "constant"}


def _max1d(a: np.ndarray, size: int, axis: int, mode: str) -> np.ndarray:
    """Moving maximum of ``size`` samples along ``axis`` by doubling: the
    maxima of runs of 1, 2, 4, ... w <= size samples, each from two of the
    last, then every window as two overlapping runs of w.  About log2(size)
    whole-array comparisons, where comparing each window's samples costs
    ``size``."""
    if size <= 1:
        return a
    n = a.shape[axis]
    left = size // 2
    pad = [(0, 0)] * a.ndim
    pad[axis] = (left, size - 1 - left)
    m = np.pad(a, pad, mode=_PAD[mode]) if mode != "constant" else np.pad(a, pad)
    # the filtered axis first: each comparison below is then one contiguous run
    m = np.ascontiguousarray(np.moveaxis(m, axis, 0))
    w = 1
    while 2 * w <= size:  # m[i] = max of the padded samples i .. i + w - 1
        m = np.maximum(m[: m.shape[0] - w], m[w:])
        w *= 2
    return np.moveaxis(np.maximum(m[:n], m[size - w : size - w + n]), 0, axis)


def maximum_filter(a, size, mode="reflect") -> np.ndarray:
    """``scipy.ndimage.maximum_filter(a, size=size, mode=mode)`` (origin 0,
    ``cval`` 0).

    Parameters
    ----------
    a : ndarray
        Real.
    size : int or sequence of int
        Window length per axis (>= 1).
    mode : str or sequence of str
        Per axis: "wrap", "nearest", "reflect" or "constant".

    Returns
    -------
    ndarray
        Same shape and dtype as ``a``.
    """
    a = np.asarray(a)
    sizes = [int(size)] * a.ndim if np.ndim(size) == 0 else [int(s) for s in size]
    modes = [mode] * a.ndim if isinstance(mode, str) else list(mode)
    out = a
    for axis, (s, m) in enumerate(zip(sizes, modes)):
        out = _max1d(out, s, axis, m)
    return np.ascontiguousarray(out) if out is not a else out.copy()


def binary_dilation(a, iterations: int = 1) -> np.ndarray:
    """``scipy.ndimage.binary_dilation(a, iterations=iterations)`` of a 1-D
    boolean array (the default structure: each step adds the two
    neighbours; beyond the ends nothing)."""
    a = np.asarray(a, bool)
    if a.ndim != 1:
        raise ValueError("binary_dilation here takes 1-D arrays")
    k = int(iterations)
    if k <= 0 or not a.any():
        return a.copy()
    return _max1d(a, 2 * k + 1, 0, "constant")
