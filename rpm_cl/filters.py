"""Filters in NumPy, equal to SciPy's ``ndimage``: the moving maximum of the
centre searches and peak pickers, the dilation of the gates to search, and
the cubic B-spline prefilter of the range-walk alignment.

SciPy's ``ndimage`` takes 0.3-0.5 s to import (it pulls in its array-API
layer and ``numpy.f2py``), more than imaging a small scene or decomposing a
GPR line.  The rank filters are exact (a maximum is a comparison, no
rounding); the spline prefilter repeats SciPy's recursions operation for
operation, across rows at once; ``tests/test_filters.py`` checks each
against SciPy, bit for bit, on random inputs.  The rank filters take finite
inputs (NumPy's maximum propagates NaN, SciPy's filter skips it); every
caller passes finite maps.
"""

from __future__ import annotations

import numpy as np

__all__ = ["binary_dilation", "maximum_filter", "spline_filter_nearest"]

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


#: The pole of the cubic B-spline prefilter, sqrt(3) - 2 (SciPy's constant).
_CUBIC_POLE = -0.267949192431122706472553658494127633


def spline_filter_nearest(a) -> np.ndarray:
    """``scipy.ndimage.spline_filter1d(a, 3, axis=-1, mode="nearest")``:
    cubic B-spline coefficients of each row, float64.

    SciPy's recursions (``ni_splines.c``: the gain, then the causal pass
    from the "reflect" boundary's first coefficient and the anticausal pass
    from its last), in the same order of operations, each step over every
    row at once.

    Parameters
    ----------
    a : ndarray, real, shape (..., n)

    Returns
    -------
    ndarray, float64, shape of ``a``
    """
    c = np.array(a, dtype=np.float64, order="C")  # C order, as SciPy's output
    n = c.shape[-1]
    if n <= 1:
        return c
    z = _CUBIC_POLE
    c *= (1.0 - z) * (1.0 - 1.0 / z)
    z_n = z ** float(n)  # C's pow, as SciPy's
    first = c[..., 0].copy()
    c0 = c[..., 0] + z_n * c[..., n - 1]
    z_i = z
    for i in range(1, n):
        # SciPy sums into c[0] in place: its last term reads that sum
        c0 += z_i * (c[..., i] + z_n * (c[..., n - 1 - i] if i < n - 1 else c0))
        z_i *= z
    c0 *= z / (1 - z_n * z_n)
    c0 += first
    c[..., 0] = c0
    for i in range(1, n):
        c[..., i] += z * c[..., i - 1]
    c[..., n - 1] *= z / (z - 1)
    for i in range(n - 2, -1, -1):
        c[..., i] = z * (c[..., i + 1] - c[..., i])
    return c
