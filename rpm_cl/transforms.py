"""FFTs that give ``scipy.fft``'s numbers without importing it where NumPy's
are the same.

``scipy.fft`` takes 0.16-0.21 s to import here (its array-API layer parses
docstrings), more than a small line's whole decomposition.  For complex128
input NumPy's ``fft``/``ifft`` run the same pocketfft and return the same
numbers bit for bit (``tests/test_filters.py`` checks them on random
shapes, lengths and axes); for complex64 and real input they differ by
rounding, and SciPy's run there, imported only then.
"""

from __future__ import annotations

import numpy as np

__all__ = ["fft", "ifft"]


def fft(a, n: int | None = None, axis: int = -1) -> np.ndarray:
    """``scipy.fft.fft(a, n=n, axis=axis)`` (module notes)."""
    a = np.asarray(a)
    if a.dtype == np.complex128:
        return np.fft.fft(a, n=n, axis=axis)
    import scipy.fft

    return scipy.fft.fft(a, n=n, axis=axis)


def ifft(a, n: int | None = None, axis: int = -1) -> np.ndarray:
    """``scipy.fft.ifft(a, n=n, axis=axis)`` (module notes)."""
    a = np.asarray(a)
    if a.dtype == np.complex128:
        return np.fft.ifft(a, n=n, axis=axis)
    import scipy.fft

    return scipy.fft.ifft(a, n=n, axis=axis)
