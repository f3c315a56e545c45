"""k-space decomposition of range profiles (paper eq. 2-4 and 7-9).

1. ``S(k, R) = FFT_X s(X, R)`` per range gate (zero-padded by ``pad`` along the
   array axes, so the peaks are located on a finer k grid; eq. 2/7).
2. Cluster centres: local maxima of ``|S(k, R)|`` over (k, R) (eq. 3/8), with
   the k axes periodic, above ``peak_threshold_db`` of the global maximum.
   The maxima are searched on the spectrum of the data tapered by a Hann
   window across the array (aperture sidelobes at -31 dB instead of -13 dB,
   which would otherwise each become a spurious cluster), and a centre must be
   the largest value within a quarter window period in k and half a range
   resolution in R (closer centres would decompose nearly the same signal).
   The decomposition itself uses the untapered spectrum.
3. For each centre, a raised-cosine window ``W`` of full width (period) ``T``
   in each k axis, ``W(dk) = (1 + cos(2 pi dk / T)) / 2`` for ``|dk| < T/2``
   (``dk`` wrapped onto the periodic k axis), and an inverse FFT gives the
   decomposed signal of that cluster (eq. 4/9).  The window acts on k only, not
   on R (multiplying along R would move the range peaks); instead each cluster
   keeps the range gates within ``range_gate`` of its centre.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from .data import InputError, RadarData

__all__ = ["KSpaceParams", "Cluster", "Decomposition", "kspace_spectrum", "decompose"]


@dataclass(frozen=True)
class KSpaceParams:
    """Settings of the decomposition.

    Attributes
    ----------
    window_x : float
        Raised-cosine window period (full width) along k_x, rad/m (paper: 417).
    window_z : float or None
        Same along k_z for planar arrays, rad/m; None = ``window_x``.
    pad : int
        Zero-padding factor of the FFT along each array axis (>= 1).
    peak_threshold_db : float
        Cluster centres below this level relative to max |S| are ignored, dB (< 0).
    detect_taper : bool
        Search the centres on the Hann-tapered spectrum (default True).
    range_gate : float or None
        Half-width of the range interval kept per cluster, m; None = the
        nominal range resolution c / 2B.
    """

    window_x: float = 417.0
    window_z: float | None = None
    pad: int = 4
    peak_threshold_db: float = -20.0
    range_gate: float | None = None
    detect_taper: bool = True

    def __post_init__(self):
        for name in ("window_x", "window_z", "range_gate"):
            v = getattr(self, name)
            if v is not None and not (np.isfinite(v) and v > 0):
                raise InputError(f"{name} must be > 0, got {v}")
        if int(self.pad) != self.pad or self.pad < 1:
            raise InputError(f"pad must be an integer >= 1, got {self.pad}")
        if not (np.isfinite(self.peak_threshold_db) and self.peak_threshold_db < 0):
            raise InputError(f"peak_threshold_db must be < 0, got {self.peak_threshold_db}")


@dataclass(frozen=True)
class Cluster:
    """One decomposed signal.

    Attributes
    ----------
    k : ndarray, shape (n_k_axes,)
        Centre wavenumber(s) (k_x[, k_z]), rad/m.
    r_centre : float
        Centre range R~, m.
    r_slice : slice
        Range gates kept (indices into the data's range axis).
    signal : ndarray, complex, shape (nx, n_gates) or (nx, nz, n_gates)
        The decomposed signal s~(X[,Z], R) over ``r_slice``.
    peak : float
        |S| at the centre.
    """

    k: np.ndarray
    r_centre: float
    r_slice: slice
    signal: np.ndarray
    peak: float


@dataclass(frozen=True)
class Decomposition:
    """Result of :func:`decompose`.

    Attributes
    ----------
    k_axes : tuple of ndarray
        k_x (and k_z) sample grids of the padded FFT, rad/m, FFT order.
    magnitude : ndarray, shape (nkx[, nkz], nr)
        |S(k, R)|.
    clusters : tuple of Cluster
        Strongest first.
    """

    k_axes: tuple
    magnitude: np.ndarray
    clusters: tuple


def kspace_spectrum(data: RadarData, pad: int = 4, taper: bool = False):
    """Zero-padded FFT of the data along the array axes (eq. 2/7).

    Parameters
    ----------
    data : RadarData
    pad : int
        Zero-padding factor per array axis.
    taper : bool
        Multiply by a Hann window across each array axis first.

    Returns
    -------
    spectrum : ndarray, complex, shape (pad*nx[, pad*nz], nr)
    k_axes : tuple of ndarray
        Wavenumber grids (FFT order), rad/m.
    """
    arr = data.array
    axes = tuple(range(arr.dim - 1))
    shape = tuple(pad * n for n in arr.shape)
    sig = data.signal
    if taper:
        for a, n in enumerate(arr.shape):
            shp = [1] * sig.ndim
            shp[a] = n
            sig = sig * np.hanning(n + 2)[1:-1].reshape(shp)
    spec = np.fft.fftn(sig, s=shape, axes=axes)
    steps = (arr.dx,) if not arr.planar else (arr.dx, arr.dz)
    k_axes = tuple(2 * np.pi * np.fft.fftfreq(n, d) for n, d in zip(shape, steps))
    return spec, k_axes


def _window(k: np.ndarray, k0: float, period: float, k_period: float) -> np.ndarray:
    dk = (k - k0 + 0.5 * k_period) % k_period - 0.5 * k_period  # wrapped
    return np.where(np.abs(dk) < 0.5 * period, 0.5 * (1 + np.cos(2 * np.pi * dk / period)), 0.0)


def decompose(data: RadarData, params: KSpaceParams = KSpaceParams()) -> Decomposition:
    """Decompose the data into clusters in k-space (eq. 2-4, 7-9).

    Parameters
    ----------
    data : RadarData
    params : KSpaceParams

    Returns
    -------
    Decomposition
    """
    arr = data.array
    n_k = arr.dim - 1
    spec, k_axes = kspace_spectrum(data, params.pad)
    mag = np.abs(spec)
    gmax = float(mag.max()) if mag.size else 0.0
    if gmax == 0.0:
        return Decomposition(k_axes, mag, ())
    det = np.abs(kspace_spectrum(data, params.pad, True)[0]) if params.detect_taper else mag
    gate = params.range_gate or data.waveform.range_resolution
    dr = data.dr
    periods = (params.window_x,) if n_k == 1 else (params.window_x, params.window_z or params.window_x)
    # non-maximum suppression neighbourhood: a quarter window period in k,
    # half a range resolution in R; k axes periodic, R not.
    size = [2 * int(np.ceil(0.25 * periods[a] / abs(k_axes[a][1] - k_axes[a][0]))) + 1
            for a in range(n_k)]
    size = [min(s_, n) for s_, n in zip(size, det.shape)]
    size.append(2 * int(np.ceil(0.5 * data.waveform.range_resolution / dr)) + 1)
    mode = ["wrap"] * n_k + ["nearest"]
    local = det == ndimage.maximum_filter(det, size=size, mode=mode)
    local &= det >= float(det.max()) * 10.0 ** (params.peak_threshold_db / 20.0)
    local &= det > 0
    # a peak on the first or last range gate is the edge of the axis, not a maximum
    local[..., 0] = False
    local[..., -1] = False
    idx = np.argwhere(local)
    idx = idx[np.argsort(-det[tuple(idx.T)])]

    steps = (arr.dx,) if n_k == 1 else (arr.dx, arr.dz)
    clusters = []
    for ind in idx:
        kc = np.array([k_axes[a][ind[a]] for a in range(n_k)])
        ir = int(ind[-1])
        lo = max(0, int(np.floor(ir - gate / dr)))
        hi = min(data.range.size, int(np.ceil(ir + gate / dr)) + 1)
        w = np.ones([1] * (n_k + 1))
        for a in range(n_k):
            shape = [1] * (n_k + 1)
            shape[a] = -1
            w = w * _window(k_axes[a], kc[a], periods[a], 2 * np.pi / steps[a]).reshape(shape)
        sub = np.fft.ifftn(w * spec[..., lo:hi], axes=tuple(range(n_k)))
        sub = sub[tuple(slice(0, n) for n in arr.shape)]
        clusters.append(Cluster(kc, float(data.range[ir]), slice(lo, hi), sub, float(mag[tuple(ind)])))
    return Decomposition(k_axes, mag, tuple(clusters))
