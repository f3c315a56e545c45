"""The clusters of the k-space decomposition (:mod:`rpm_cl.extract.kspace`,
step 3): a raised-cosine window in k around each centre and the inverse
transform that gives the cluster's signal, aligned (step 4) where asked.

The window and the transforms are separable: along each array axis they are
one small matrix (:func:`_window_operator`, from the zero-padded DFT
matrix :func:`_dft`, which the spectrum itself also uses), or FFTs for large
arrays.

The steps named in the docstrings below ("module notes, step N") are those
of the notes of :mod:`rpm_cl.extract.kspace`.
"""

from __future__ import annotations

import numpy as np

from ..filters import spline_filter_nearest
from ..io.data import RadarData
from ..transforms import fft, ifft
from .kspace_align import _align
from .kspace_geometry import _align_on, _array_axes, _focused_gates
from .kspace_params import KSpaceParams
from .types import Cluster


def _window(k: np.ndarray, k0: float, period: float, k_period: float) -> np.ndarray:
    dk = (k - k0 + 0.5 * k_period) % k_period - 0.5 * k_period  # wrapped
    return np.where(np.abs(dk) < 0.5 * period, 0.5 * (1 + np.cos(2 * np.pi * dk / period)), 0.0)


def _dft(npad, n):
    """DFT of n samples zero-padded to npad, as an (npad, n) matrix (the same
    numbers as ``fft(x, npad)`` to rounding)."""
    return np.exp(-2j * np.pi * np.outer(np.arange(npad), np.arange(n)) / npad)


def _window_operator(win, dft, padded=False):
    """One axis of "zero-pad to len(win), FFT, multiply by ``win``, inverse
    FFT, keep the first n samples" as a matrix: (n, n), or (n, len(win)) from
    an already padded spectrum (``padded``); ``dft`` is :func:`_dft`
    (len(win), n).  Equal to the FFT route up to rounding; for the 11 x 17
    array at pad 4 it replaces two 44 x 68 2-D FFTs per range gate and
    cluster by two products with 11 x 11 and 17 x 17 matrices."""
    inv = dft.conj().T / win.size  # inverse DFT, the first n rows kept
    if padded:
        return inv * win[None, :]
    return inv @ (win[:, None] * dft)


def _apply_axes(ops, sig):
    """sig (n_0[, n_1], gates) with ops[a] applied along axis a."""
    out = np.tensordot(ops[0], sig, axes=(1, 0))
    if len(ops) == 2:
        out = np.moveaxis(np.tensordot(ops[1], out, axes=(1, 1)), 0, 1)
    return out


def _gates(spec, gate0: int, lo: int, hi: int) -> np.ndarray:
    """Gates ``lo:hi`` of a spectrum that covers the gates from ``gate0`` on,
    0 at those it does not cover."""
    n = spec.shape[-1]
    if gate0 <= lo and hi <= gate0 + n:
        return spec[..., lo - gate0 : hi - gate0]
    out = np.zeros(spec.shape[:-1] + (hi - lo,), spec.dtype)
    a, b = max(lo, gate0), min(hi, gate0 + n)
    if a < b:
        out[..., a - lo : b - lo] = spec[..., a - gate0 : b - gate0]
    return out


def _window_fft(sig, wins, shape, padded: bool) -> np.ndarray:
    """:func:`_window_operator` along every array axis by FFTs, one axis at a
    time (the window is separable): zero-pad axis a to ``len(wins[a])``,
    FFT, multiply by ``wins[a]``, inverse FFT, keep its first ``shape[a]``
    samples; ``padded``: ``sig`` is already the padded spectrum (no forward
    FFT).  Each axis's transforms then run over the other axes' unpadded
    samples: a quarter of the 2-D padded transform's work at pad 4."""
    out = sig
    for a, win in enumerate(wins):
        bcast = [1] * out.ndim
        bcast[a] = -1
        part = out if padded else fft(out, n=win.size, axis=a)
        part = ifft(part * win.reshape(bcast), axis=a)
        out = part[(slice(None),) * a + (slice(0, shape[a]),)]
    return out


def _clusters(
    data: RadarData, params: KSpaceParams, spec, mag, gate0, k_axes, periods, idx, gate, matrix_dft
):
    """One :class:`Cluster` per centre ``idx`` (window, alignment, inverse FFT).

    ``spec`` and ``mag`` cover the range gates from ``gate0`` on (``spec``:
    None where the clusters are aligned, which cut their signals from the
    shifted profiles instead).
    ``matrix_dft``: window and transforms as DFT matrices along each array
    axis (:func:`_window_operator`); False: FFTs (large arrays,
    ``rpm_cl.extract.kspace.MATRIX_DFT_MAX``)."""
    arr = data.array
    n_k = arr.dim - 1
    dr = data.dr
    steps = (arr.dx,) if n_k == 1 else (arr.dx, arr.dz)
    k_periods = [2 * np.pi / st for st in steps]
    axes_x = _array_axes(arr)
    kc_w = data.waveform.kc  # carrier wavenumber, rad/m
    align = _align_on(data, params)
    focused = _focused_gates(data, params)
    if align:
        flat = data.signal.reshape(-1, data.range.size)
        coeffs = spline_filter_nearest(flat.real) + 1j * spline_filter_nearest(flat.imag)
    # the zero-padded DFT of each array axis, shared by every cluster (none:
    # FFTs for a large array)
    dfts = [_dft(k_axes[a].size, arr.shape[a]) for a in range(n_k)] if matrix_dft else []
    clusters = []
    for ind in idx:
        kc = np.array([k_axes[a][ind[a]] for a in range(n_k)])
        ir = int(ind[-1])
        lo = max(0, int(np.floor(ir - gate / dr)))
        hi = min(data.range.size, int(np.ceil(ir + gate / dr)) + 1)
        # the window is separable (a product of one raised cosine per axis),
        # so window and transforms act along each axis as one small matrix
        wins = [_window(k_axes[a], kc[a], periods[a], k_periods[a]) for a in range(n_k)]
        offset = np.zeros(arr.shape)
        u = np.zeros(n_k)
        focus = None
        if align:
            r_c = float(data.range[ir]) if focused[ir] else None
            u, offset, sig, focus = _align(
                data, coeffs, kc, k_periods, axes_x, kc_w, lo, hi, r_c, params.autofocus, ir - lo
            )
        else:
            sig = _gates(spec, gate0, lo, hi)
        if dfts:
            sub = _apply_axes(
                [_window_operator(wins[a], dfts[a], padded=not align) for a in range(n_k)], sig
            )
        else:  # large arrays: FFTs (n log n beats the n^2 of the matrices)
            sub = _window_fft(sig, wins, arr.shape, padded=not align)
        clusters.append(
            Cluster(
                kc,
                float(data.range[ir]),
                slice(lo, hi),
                sub,
                float(mag[tuple(ind[:-1]) + (ir - gate0,)]),
                offset,
                u,
                focus,
            )
        )
    return clusters
