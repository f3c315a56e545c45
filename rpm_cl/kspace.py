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
4. Range-walk alignment (``align``, default on).  A target's range across the
   array is R_t(X) = R_c + u . (X - X_c) + O(X^2 / R), with the range slope u
   equal to minus its direction cosines, and its phase exp(-j 2 k_c R_t) gives
   it the wavenumber k = -2 k_c u.  Windowing in k is
   a convolution along X, which mixes the profiles of neighbouring antennas; with
   the envelope walking in range across X, that mixing biases the RP ranges,
   and at the ends of the aperture (where the convolution is one-sided) by
   several mm, the "inaccuracy at both ends of the aperture" the paper notes
   (Section V-A2).  So, per cluster, each antenna's profile is shifted in range
   by delta(X) = u . (X - X_c) (cubic-spline interpolation along R) before the
   window, which aligns the envelopes; the RPs found in the
   aligned signal are mapped back by adding delta(X) (``Cluster.offset``).
   u = -(k~ + n 2 pi / d) / (2 k_c): when the array is sparser than a quarter
   wavelength, k~ is aliased and the alias n whose alignment gives the largest
   coherent peak is taken.
5. Near-field focusing (``focus``, default: when needed).  After the
   alignment a target's phase still carries the wavefront curvature,
   2 k_c (|dX|^2 - (u . dX)^2) / (2 R), which spreads its k content over
   about 2 k_c L / R: a window sized for a small aperture then cuts a large
   one's edges (measured: a 32 x 32 array at 7.5 mm found 5814 of 11264 RPs).
   With focusing, the alignment's offsets include that curvature term at the
   cluster's range R~ (the envelopes of a target there line up across the
   whole aperture, not only to first order) and the signal is multiplied by
   the conjugate of its phase (a plane wave again).  On by default when the curvature phase at the array's
   corners exceeds pi (the array is in the targets' near field: the
   Fraunhofer criterion); not for the paper's 11 x 17 array (2.1 rad), where
   it measured slightly worse (RPM <= 10 mm 75 % against 83.5 %).

A linear array sampled coarser than half a wavelength (the paper's sparse
case) aliases the k axis and bends each target's wave across the aperture
beyond what a window in k can hold; ``near_field`` selects the spherical-wave
decomposition of :mod:`rpm_cl.nearfield` for it (automatically by default).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import fft as sfft
from scipy import ndimage

from .data import C0, InputError, RadarData
from .nearfield import decompose_near_field, near_field_wanted

__all__ = ["Cluster", "Decomposition", "KSpaceParams", "decompose", "kspace_spectrum"]


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
    align : bool or None
        Align each cluster's envelopes across the array before windowing
        (step 4 of the module notes).  None (default): align when the array
        is at least a quarter of the range resolution long, i.e. when a target's
        range walk across it can be a sizeable fraction of the resolution (the
        paper's 3-D case: 0.13 m against 0.05 m); for shorter arrays (the
        paper's 2-D case: 0.1 m against 0.75 m) it is measured to cost more,
        through interpolation and leakage, than it gains.
    near_field : bool or None
        Use the near-field decomposition (:mod:`rpm_cl.nearfield`, linear
        arrays only); None = where the pitch exceeds half a wavelength.
    focus : bool or None
        Remove each aligned cluster's wavefront curvature (step 5 of the
        module notes).  None (default): where the curvature phase at the
        array's corners exceeds pi at the cluster's range.
    """

    window_x: float = 417.0
    window_z: float | None = None
    pad: int = 4
    peak_threshold_db: float = -20.0
    range_gate: float | None = None
    detect_taper: bool = True
    align: bool | None = None
    near_field: bool | None = None
    focus: bool | None = None

    def __post_init__(self):
        for name in ("window_x", "window_z", "range_gate"):
            v = getattr(self, name)
            if v is not None and not (np.isfinite(v) and v > 0):
                raise InputError(f"{name} must be > 0, got {v}")
        if int(self.pad) != self.pad or self.pad < 1:
            raise InputError(f"pad must be an integer >= 1, got {self.pad}")
        if not (np.isfinite(self.peak_threshold_db) and self.peak_threshold_db < 0):
            raise InputError(f"peak_threshold_db must be < 0, got {self.peak_threshold_db}")
        if self.near_field not in (None, True, False):
            raise InputError(f"near_field must be True, False or None, got {self.near_field!r}")


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
        The decomposed signal s~(X[,Z], R + offset) over ``r_slice``: range
        gate g of antenna X holds range ``range[g] + offset[X]``.
    peak : float
        |S| at the centre.
    offset : ndarray, shape (nx,) or (nx, nz)
        Range offset of each antenna's decomposed profile, m (0 without
        alignment).
    direction : ndarray, shape (n_k_axes,)
        Range slopes u = dR/dX (and dR/dZ) used for the alignment, i.e. minus
        the direction cosines of the cluster's targets (0 without alignment).
    """

    k: np.ndarray
    r_centre: float
    r_slice: slice
    signal: np.ndarray
    peak: float
    offset: np.ndarray
    direction: np.ndarray


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
    spec = sfft.fftn(sig, s=shape, axes=axes)
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
    if params.near_field or (params.near_field is None and near_field_wanted(data)):
        if arr.planar:
            raise InputError("the near-field decomposition handles linear arrays only")
        return decompose_near_field(data, params, (mag, k_axes))
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
    # a strict maximum along R (a flat run of equal values, e.g. a constant
    # signal, is not a peak: every gate of it would pass the test above)
    strict = np.zeros_like(local)
    strict[..., 1:-1] = (det[..., 1:-1] > det[..., :-2]) & (det[..., 1:-1] >= det[..., 2:])
    local &= strict
    local &= det >= float(det.max()) * 10.0 ** (params.peak_threshold_db / 20.0)
    local &= det > 0
    # a peak on the first or last range gate is the edge of the axis, not a maximum
    local[..., 0] = False
    local[..., -1] = False
    idx = np.argwhere(local)
    idx = idx[np.argsort(-det[tuple(idx.T)])]

    steps = (arr.dx,) if n_k == 1 else (arr.dx, arr.dz)
    k_periods = [2 * np.pi / st for st in steps]
    axes_x = [arr.x] if n_k == 1 else [arr.x, arr.z]
    kc_w = 2 * np.pi * data.waveform.fc / C0  # carrier wavenumber, rad/m
    align = params.align
    if align is None:
        extent = max(float(ax[-1] - ax[0]) for ax in axes_x)
        align = extent >= 0.25 * data.waveform.range_resolution
    if align:
        flat = data.signal.reshape(-1, data.range.size)
        coeffs = (ndimage.spline_filter1d(flat.real, 3, axis=-1, mode="nearest"),
                  ndimage.spline_filter1d(flat.imag, 3, axis=-1, mode="nearest"))
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
            w = w * _window(k_axes[a], kc[a], periods[a], k_periods[a]).reshape(shape)
        offset = np.zeros(arr.shape)
        u = np.zeros(n_k)
        if align:
            focus = params.focus
            if focus is None:
                focus = _max_curvature(axes_x, kc_w, float(data.range[ir])) > np.pi
            r_c = float(data.range[ir]) if focus else None
            u, offset, sig = _align(data, coeffs, kc, k_periods, axes_x, kc_w, lo, hi, r_c)
            part = sfft.fftn(sig, s=spec.shape[:n_k], axes=tuple(range(n_k)))
        else:
            part = spec[..., lo:hi]
        sub = sfft.ifftn(w * part, axes=tuple(range(n_k)))
        sub = sub[tuple(slice(0, n) for n in arr.shape)]
        clusters.append(Cluster(kc, float(data.range[ir]), slice(lo, hi), sub,
                                float(mag[tuple(ind)]), offset, u))
    return Decomposition(k_axes, mag, tuple(clusters))


#: A non-principal alias must give a coherent peak this much larger (module notes, step 4).
ALIAS_MARGIN = 1.05


def _curvature(u, axes_x, r_c: float) -> np.ndarray:
    """q(X) = (|dX|^2 - (u . dX)^2) / (2 r_c), m: the curvature term of the
    range of a target at range r_c with range slope u (step 5)."""
    centres = [0.5 * (ax[0] + ax[-1]) for ax in axes_x]
    grids = np.meshgrid(*[ax - c for ax, c in zip(axes_x, centres)], indexing="ij")
    d2 = sum(g * g for g in grids)
    ud = sum(u[a] * grids[a] for a in range(len(u)))
    return (d2 - ud * ud) / (2.0 * max(r_c, 1e-9))


def _max_curvature(axes_x, kc_w: float, r_c: float) -> float:
    """Curvature phase at the array's corners for a broadside target, rad."""
    half2 = sum((0.5 * (ax[-1] - ax[0])) ** 2 for ax in axes_x)
    return 2 * kc_w * half2 / (2.0 * max(r_c, 1e-9))


def _align(data: RadarData, coeffs, kc, k_periods, axes_x, kc_w, lo, hi, r_c=None):
    """Range-walk alignment of one cluster (module notes, step 4).

    ``coeffs`` are the cubic-spline coefficients of the real and imaginary
    parts of the profiles (n_antennas, nr) along R; the shifted profiles are
    interpolated from them (a local interpolator: a Fourier shift would ring
    where a profile does not vanish at the ends of the range axis).

    With ``r_c`` (focusing, step 5) the offsets include the curvature term
    q(X) at that range, and the signal's curvature phase exp(-j 2 k_c q) is
    removed.

    Returns the range slopes u = dR_t/dX, the per-antenna offsets delta(X) (m)
    and the aligned signal over range gates ``lo:hi``.
    """
    n_k = len(kc)
    centres = [0.5 * (ax[0] + ax[-1]) for ax in axes_x]
    # candidate direction cosines along each axis: every alias of kc with |u| < 1
    per_axis = []
    for a in range(n_k):
        nmax = int(np.ceil(2 * kc_w / k_periods[a])) + 1
        cands = -(kc[a] + np.arange(-nmax, nmax + 1) * k_periods[a]) / (2 * kc_w)
        per_axis.append(cands[np.abs(cands) < 1.0])
    grids = np.meshgrid(*per_axis, indexing="ij")
    options = np.stack([g.ravel() for g in grids], axis=1)
    options = options[np.sum(options**2, axis=1) < 1.0]
    if len(options) == 0:
        options = np.zeros((1, n_k))
    # the principal alias (smallest |u|) first; another must beat it clearly
    options = options[np.argsort(np.sum(options**2, axis=1), kind="stable")]
    # a plane wave at kc, for the coherent sum that ranks the aliases
    steer = np.ones([1] * n_k)
    for a in range(n_k):
        shp = [1] * n_k
        shp[a] = -1
        steer = steer * np.exp(-1j * kc[a] * axes_x[a]).reshape(shp)
    best = None
    for u in options:
        delta = np.zeros(data.array.shape)
        for a in range(n_k):
            shp = [1] * n_k
            shp[a] = -1
            delta = delta + (u[a] * (axes_x[a] - centres[a])).reshape(shp)
        q = _curvature(u, axes_x, r_c) if r_c is not None else None
        if q is not None:
            delta = delta + q
        rows = np.arange(delta.size)[:, None] + np.zeros((1, hi - lo))
        cols = np.arange(lo, hi)[None, :] + (delta.ravel() / data.dr)[:, None]
        sig = (ndimage.map_coordinates(coeffs[0], [rows, cols], order=3, mode="nearest",
                                       prefilter=False)
               + 1j * ndimage.map_coordinates(coeffs[1], [rows, cols], order=3, mode="nearest",
                                              prefilter=False))
        sig = sig.reshape(data.array.shape + (hi - lo,))
        if q is not None:
            sig = sig * np.exp(2j * kc_w * q)[..., None]
        # coherent sum over the antennas (elementwise: BLAS threads cost more
        # than they save on a few hundred antennas)
        beam = (sig.reshape(steer.size, -1) * steer.reshape(-1, 1)).sum(axis=0)
        peak = float(np.max(np.abs(beam))) if beam.size else 0.0
        # 5 % margin: a wrong alias misaligns the envelopes by a sizeable part
        # of the resolution and loses far more than that; near-ties (flat or
        # degenerate data) keep the principal alias
        if best is None or peak > ALIAS_MARGIN * best[0]:
            best = (peak, u, delta, sig)
    return best[1], best[2], best[3]
