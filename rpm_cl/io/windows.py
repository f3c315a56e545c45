"""The range windows of a spectrum's compression, symmetric, in NumPy.

The same arithmetic as ``scipy.signal.windows.get_window(name, n,
fftbins=False)`` for each name (SciPy's ``scipy.signal`` takes over a second
to import, more than loading a spectrum file); ``tests/test_filters.py``
checks them equal to SciPy's bit for bit.
"""

from __future__ import annotations

import numpy as np

__all__ = ["COSINE_TERMS", "TAYLOR_NBAR", "TAYLOR_SLL_DB", "window"]

#: Cosine-sum windows by SciPy name: the coefficients a_k of
#: ``sum_k a_k cos(k x)`` over x from -pi to pi (written as SciPy forms
#: them: 1 - 0.54 is not the float 0.46).
COSINE_TERMS = {
    "hann": (0.5, 1.0 - 0.5),
    "hamming": (0.54, 1.0 - 0.54),
    "blackman": (0.42, 0.50, 0.08),
}
#: The Taylor window's SciPy defaults: nearly constant sidelobes next to the
#: main lobe (nbar) and their level, dB below it.
TAYLOR_NBAR = 4
TAYLOR_SLL_DB = 30


def _cosine(n: int, a) -> np.ndarray:
    fac = np.linspace(-np.pi, np.pi, n, dtype=np.float64)
    w = np.zeros(n, dtype=np.float64)
    for k in range(len(a)):
        w += np.float64(a[k]) * np.cos(k * fac)
    return w


def _taylor(n: int, nbar: int = TAYLOR_NBAR, sll: float = TAYLOR_SLL_DB) -> np.ndarray:
    b = np.asarray(10 ** (sll / 20))
    a = np.arccosh(b) / np.pi
    s2 = nbar**2 / (a**2 + (nbar - 0.5) ** 2)
    ma = np.arange(1, nbar, dtype=np.float64)
    fm = np.empty(nbar - 1, dtype=np.float64)
    signs = np.empty_like(ma)
    signs[::2] = 1
    signs[1::2] = -1
    m2 = ma * ma
    for mi in range(len(ma)):
        numer = signs[mi] * np.prod(1 - m2[mi] / s2 / (a**2 + (ma - 0.5) ** 2))
        denom = 2 * np.prod(1 - m2[mi] / m2[:mi]) * np.prod(1 - m2[mi] / m2[mi + 1 :])
        fm[mi] = numer / denom

    def w_at(k):
        return 1 + 2 * np.matmul(
            fm, np.cos(2 * np.pi * ma[:, np.newaxis] * (k - n / 2.0 + 0.5) / n)
        )

    w = w_at(np.arange(n, dtype=np.float64))
    w *= 1.0 / w_at((n - 1) / 2)
    return w


def window(name: str, n: int) -> np.ndarray:
    """The symmetric window ``name`` ("boxcar", "hann", "hamming",
    "blackman", "taylor") over ``n`` samples, float64, shape (n,)."""
    if n <= 1:
        return np.ones(n, dtype=np.float64)
    if name == "boxcar":
        return np.ones(n, dtype=np.float64)
    if name == "taylor":
        return _taylor(n)
    return _cosine(n, COSINE_TERMS[name])
