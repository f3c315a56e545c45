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
   Where clusters are focused (step 5), the maxima are searched on the
   spectrum of the data with the Fresnel curvature removed per gate,
   ``s(X, R) exp(j k_c |X - X_c|^2 / R)`` (a unit-modulus factor: the noise
   floor is unchanged): the curvature spreads each target over about
   ``2 k_c L / R`` of k, more than a window, and the overlapping spreads of
   neighbouring parts raised maxima between them (the human body seen by a
   32 x 32 array: a cluster at k_x = 0 between the thighs at +-72 rad/m,
   359 of its 782 points more than 50 mm off; at 64 x 64 five such clusters).
   A target's dechirped peak lies where its spread was centred (the k of the
   array's centre), so the alignment's aliases are unchanged.
   Skips: a centre must also exceed the noise floor (``noise_pfa``: the
   level pure noise reaches anywhere in the map with that probability, from
   a known or estimated noise power, :func:`noise_floor`), and range gates
   that cannot hold a centre are not transformed or searched at all: the sum
   over the array of |w s(X, R)| bounds max_k |S(k, R)| from above, the
   strongest gate's spectrum bounds the global maximum from below, and a gate
   whose bound is under both thresholds is skipped (exact: the centres are
   those of a full search).  An all-zero input costs one pass over the data;
   a lone target, the gates around it.
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
   coherent peak is taken.  With focusing (step 5) the peak is summed over
   sub-apertures instead, the sum of the magnitudes of their coherent sums
   (:func:`_block_peak`): the aperture is then large enough that a point
   focus at R~ is the wrong wavefront for an extended surface (an elongated
   body part is flatter than a point along its length), the whole-aperture
   sum of the right alias partly cancels, and a wrong alias, whose steep
   range walk gathers pieces of other echoes, won (the human body's lower
   legs seen by a 64 x 64 array: 4.8 for the true u_x = 0.11, 7.9 at
   u_x = -0.89).  Within a sub-aperture the wavefront error is small, while
   the nearest wrong alias still misaligns the envelopes by a range
   resolution across it: neighbouring aliases differ in u by lambda / (2 d),
   i.e. by lambda / 2 of range walk per antenna, so a sub-aperture is
   ``ceil(2 resolution / lambda)`` antennas along each axis (7 for the
   human body's 50 mm at 15 mm).
5. Near-field focusing (``focus``, default: when needed).  After the
   alignment a target's phase still carries the wavefront curvature,
   2 k_c (|dX|^2 - (u . dX)^2) / (2 R), which spreads its k content over
   about 2 k_c L / R: a window sized for a small aperture then cuts a large
   one's edges (measured: a 32 x 32 array at 7.5 mm found 5814 of 11264 RPs).
   With focusing, the alignment's offsets include the range of a point at
   the cluster's range R~ in the direction of u beyond the linear term,
   exactly, not only its Fresnel term (:func:`_focus_range`; the envelopes of
   a target there line up across the whole aperture, not only to first
   order) and the signal is multiplied by the conjugate of its phase (a plane
   wave again).  On by default when the curvature phase at the array's
   corners exceeds pi (the array is in the targets' near field: the
   Fraunhofer criterion); not for the paper's 11 x 17 array (2.1 rad), where
   it measured slightly worse (RPM <= 10 mm 75 % against 83.5 %).
6. Autofocus (``autofocus``, default on, with focusing).  A convex surface
   of curvature radius rho at range R returns a flatter wavefront than a
   point there, with the Fresnel term divided by ``1 + rho / R``; focused as
   a point its echo keeps the difference, which spreads it over k again (the
   human body seen by a 64 x 64 array: 0.55 m along a thigh at 1.03 m, about
   9 rad at the array's edge).  So each focused cluster's Fresnel term is
   scaled by a factor per array axis, chosen among a few (0 to 1.2) for the
   largest whole-aperture coherent peak (:func:`_autofocus`), and where that
   peak is at least AUTOFOCUS_MARGIN (1.25) times the point focus's, it and
   the offsets are taken from that wavefront.  Measured on the human body at
   20 dB, seeds 0-3 (``python benchmarks/large_arrays.py``): a 64 x 64 array
   finds 97.2-97.4 % of the 45056 true echoes within 10 mm (83.5-83.7 %
   with a point's Fresnel term only, 91.3 % with the exact point focus of
   step 5 alone); on 32 x 32 no cluster gains the margin.

A linear array sampled coarser than half a wavelength (the paper's sparse
case) aliases the k axis and bends each target's wave across the aperture
beyond what a window in k can hold; ``near_field`` selects the spherical-wave
decomposition of :mod:`rpm_cl.extract.nearfield` for it (automatically by default,
where the aperture is also at most about a range resolution long: a longer
one resolves each target's range walk, and the alignment of step 4 tells the
aliases apart by it; see :func:`rpm_cl.extract.nearfield.near_field_wanted`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..io.data import InputError, RadarData
from ..lazy import lazy
from .blas import one_blas_thread
from .nearfield import decompose_near_field, near_field_wanted
from .types import Cluster, Decomposition

sfft = lazy("scipy.fft")
ndimage = lazy("scipy.ndimage")

__all__ = ["Cluster", "Decomposition", "KSpaceParams", "decompose", "kspace_spectrum"]


#: Largest zero-padding factor of the k-space FFT: beyond it the k samples
#: are finer than a 64th of the aperture's resolution cell, which locates
#: no peak better, while memory grows with it (a factor of 1e9 asked for
#: exabytes).
PAD_MAX = 64


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
        Zero-padding factor of the FFT along each array axis (1 .. PAD_MAX = 64).
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
        Use the near-field decomposition (:mod:`rpm_cl.extract.nearfield`, linear
        arrays only); None = where the pitch exceeds half a wavelength and
        the aperture is at most 1.2 range resolutions long
        (:func:`rpm_cl.extract.nearfield.near_field_wanted`).
    focus : bool or None
        Remove each aligned cluster's wavefront curvature (step 5 of the
        module notes).  None (default): where the curvature phase at the
        array's corners exceeds pi at the cluster's range.
    autofocus : bool
        With focusing, fit the wavefront curvature of each cluster along each
        array axis (step 6 of the module notes) rather than take that of a
        point at the cluster's range (default True).
    noise_pfa : float or None
        Noise floor of the centre search (step 2 of the module notes): the
        probability that pure noise yields a cluster anywhere in the (k, R)
        map; a centre must also exceed that floor.  None: no floor, only
        ``peak_threshold_db``.
    noise_power : float or None
        Noise power per sample of the range profiles (mean |noise|^2, in the
        signal's units squared), e.g. measured on an empty frame.  None:
        estimated from the data where that is sound (the range axis spans at
        least :data:`NOISE_ESTIMATE_CELLS` range resolutions, so that most
        gates hold no echo), else no floor.
    skip_gates : bool
        Skip the range gates that cannot hold a centre (module notes, step 2;
        exact).  False transforms and searches every gate: the reference the
        skip is tested and benchmarked against.
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
    autofocus: bool = True
    noise_pfa: float | None = 1e-3
    noise_power: float | None = None
    skip_gates: bool = True

    def __post_init__(self):
        for name in ("window_x", "window_z", "range_gate"):
            v = getattr(self, name)
            if v is not None and not (np.isfinite(v) and v > 0):
                raise InputError(f"{name} must be > 0, got {v}")
        try:
            pad_ok = 1 <= float(self.pad) <= PAD_MAX and int(self.pad) == self.pad
        except (TypeError, ValueError, OverflowError):  # NaN passes the first test
            pad_ok = False
        if not pad_ok:
            raise InputError(f"pad must be an integer from 1 to {PAD_MAX}, got {self.pad}")
        if not (np.isfinite(self.peak_threshold_db) and self.peak_threshold_db < 0):
            raise InputError(f"peak_threshold_db must be < 0, got {self.peak_threshold_db}")
        if self.noise_pfa is not None and not (0 < self.noise_pfa < 1):
            raise InputError(f"noise_pfa must be in (0, 1) or None, got {self.noise_pfa}")
        if self.noise_power is not None and not (
            np.isfinite(self.noise_power) and self.noise_power >= 0
        ):
            raise InputError(f"noise_power must be >= 0 or None, got {self.noise_power}")
        if self.near_field not in (None, True, False):
            raise InputError(f"near_field must be True, False or None, got {self.near_field!r}")


def _taper(shape: tuple) -> np.ndarray:
    """Hann taper across the array axes, shape ``shape + (1,)``."""
    w = np.ones(tuple(shape) + (1,))
    for a, n in enumerate(shape):
        shp = [1] * (len(shape) + 1)
        shp[a] = n
        w = w * np.hanning(n + 2)[1:-1].reshape(shp)
    return w


def kspace_spectrum(data: RadarData, pad: int = 4, taper: bool = False, gates=None, dechirp=None):
    """Zero-padded FFT of the data along the array axes (eq. 2/7).

    Parameters
    ----------
    data : RadarData
    pad : int
        Zero-padding factor per array axis.
    taper : bool
        Multiply by a Hann window across each array axis first.
    gates : slice or None
        Range gates to transform (default: all).
    dechirp : ndarray of bool, shape (nr,), or None
        Gates whose wavefront curvature is removed first (module notes,
        step 2): gate R is multiplied by ``exp(j k_c |X - X_c|^2 / R)``, the
        conjugate of the Fresnel phase of a target at range R.

    Returns
    -------
    spectrum : ndarray, complex, shape (pad*nx[, pad*nz], n_gates)
    k_axes : tuple of ndarray
        Wavenumber grids (FFT order), rad/m.
    """
    arr = data.array
    shape = tuple(pad * n for n in arr.shape)
    gates = slice(None) if gates is None else gates
    sig = data.signal[..., gates]
    if dechirp is not None and np.any(dechirp[gates]):
        sig = sig * _fresnel(data, dechirp[gates], data.range[gates])
    if taper:
        sig = sig * _taper(arr.shape)
    if max(arr.shape) <= MATRIX_DFT_MAX:
        # the zero-padded DFT along each array axis as a (pad*n, n) matrix:
        # the same numbers as fftn(s=shape) to rounding, 3x faster for the
        # body's 11 x 17 -> 44 x 68 (small transforms, many of them)
        spec = _apply_axes([_dft(m, n) for m, n in zip(shape, arr.shape)], sig)
    else:
        spec = sfft.fftn(sig, s=shape, axes=tuple(range(arr.dim - 1)))
    steps = (arr.dx,) if not arr.planar else (arr.dx, arr.dz)
    k_axes = tuple(2 * np.pi * np.fft.fftfreq(n, d) for n, d in zip(shape, steps))
    return spec, k_axes


def _fresnel(data: RadarData, on: np.ndarray, ranges: np.ndarray) -> np.ndarray:
    """exp(j k_c |X - X_c|^2 / R) per antenna and gate where ``on``, else 1;
    shape (nx[, nz], n_gates): the curvature phase of :func:`_curvature` at
    u = 0, removed as :func:`_align` removes it."""
    axes_x = _array_axes(data.array)
    half_d2 = _curvature(np.zeros(len(axes_x)), axes_x, 1.0)  # |X - X_c|^2 / 2
    phase = 2 * data.waveform.kc * half_d2[..., None] / np.maximum(ranges, 1e-9)[None, :]
    return np.exp(1j * phase * on[None, :])


def _dechirp_gates(data: RadarData, params: KSpaceParams) -> np.ndarray | None:
    """Gates whose clusters are focused (step 5) and where the Fresnel
    (quadratic) phase describes a point's wavefront: there detection runs on
    the spectrum with that phase removed (step 2).  None: no gate.

    The gate is a broadside criterion: the next term of the expansion of the
    two-way path of a broadside point, ``2 k_c h^4 / (8 R^3)`` at the array's
    corners (``h`` the half-diagonal), stays under a quarter cycle: 1.3 rad
    for the human body seen by a 64 x 64 array at 1 m, 72 rad for a 1 m
    linear array at 0.45 m (whose detection keeps the plain spectrum).  An
    oblique target keeps more (``k_c (u . dX)^2 / R``, about 10 rad at
    ``|u| = 0.5`` on 64 x 64), but its peak still gains (8.5 times for
    u = (-0.3, -0.2), 19 times at broadside, in a check at 1 m).  Dechirped
    and plain gates are thresholded apart (:func:`_regimes`)."""
    focused = _focused_gates(data, params)
    if not focused.any():
        return None
    h2 = _half_diagonal2(_array_axes(data.array))
    r = np.maximum(data.range, 1e-9)
    on = focused & (2 * data.waveform.kc * h2 * h2 / (8 * r**3) < 0.5 * np.pi)
    return on if on.any() else None


def _focused_gates(data: RadarData, params: KSpaceParams) -> np.ndarray:
    """Per range gate, whether a cluster centred there is focused (step 5):
    never without the alignment, everywhere or nowhere by ``focus``, and by
    default where the curvature phase at the array's corners exceeds pi.
    Detection (:func:`_dechirp_gates`) and the clusters (:func:`_clusters`)
    both ask this."""
    if not _align_on(data, params):
        return np.zeros(data.range.size, bool)
    if params.focus is not None:
        return np.full(data.range.size, bool(params.focus))
    return _max_curvature(_array_axes(data.array), data.waveform.kc, data.range) > np.pi


def _align_on(data: RadarData, params: KSpaceParams) -> bool:
    """Whether clusters get the range-walk alignment (step 4): ``align``, or by
    default where the aperture spans a quarter range resolution."""
    if params.align is not None:
        return bool(params.align)
    extent = max(float(ax[-1] - ax[0]) for ax in _array_axes(data.array))
    return extent >= 0.25 * data.waveform.range_resolution


def _array_axes(arr) -> list:
    """The antenna coordinates along each array axis, m: [x], or [x, z]."""
    return [arr.x, arr.z] if arr.planar else [arr.x]


#: The noise power is estimated from the data only where the range axis spans
#: at least this many range resolutions (c / 2B): the median over gates of the
#: power is then that of gates without echoes for scenes up to half that deep.
#: The paper's 2-D scene spans 2 (0.2 GHz: one echo covers the whole axis),
#: the human body 20.
NOISE_ESTIMATE_CELLS = 8


def noise_floor(
    data: RadarData, weights: np.ndarray, pfa: float, noise_power: float | None = None
) -> float:
    """Level of |S(k, R)| that pure noise exceeds with probability ``pfa``
    anywhere in the map (module notes, step 2).

    The noise power per sample is ``noise_power`` if given, else the median
    over range gates of the mean power across the array where the range axis
    spans at least :data:`NOISE_ESTIMATE_CELLS` resolutions (robust while
    fewer than half the gates hold echoes), else unknown (floor 0).  A k cell
    then holds complex Gaussian noise of power
    ``sum(weights**2) * sigma2``, whose magnitude exceeds ``T`` with
    probability ``exp(-T**2 / (sum(weights**2) * sigma2))``; the cells are
    counted as ``n_antennas * n_gates`` independent ones.

    Parameters
    ----------
    data : RadarData
    weights : ndarray, shape (nx[, nz], 1)
        Taper applied across the array before the FFT.
    pfa : float
        Probability of a false cluster on a noise-only input.
    noise_power : float or None
        Known noise power per sample, signal units squared.

    Returns
    -------
    float
        The floor, in the units of |S|; 0 where the noise power is unknown,
        or for noise-free data whose echoes leave most gates empty.
    """
    scale = 1.0  # |S| units = scale * sqrt(...): squares of the data's own scale overflow
    if noise_power is not None:
        sigma2 = float(noise_power)
    elif data.range[-1] - data.range[0] >= NOISE_ESTIMATE_CELLS * data.waveform.range_resolution:
        axes = tuple(range(data.array.dim - 1))
        mag = np.abs(data.signal)
        scale = float(mag.max()) or 1.0
        sigma2 = float(np.median(np.mean((mag / scale) ** 2, axis=axes)))
    elif data.array.n >= NOISE_KSPACE_MIN_ANTENNAS:
        scale = float(np.abs(data.signal).max()) or 1.0
        sigma2 = _kspace_noise(data, weights, scale)
    else:
        return 0.0
    cells = data.array.n * data.range.size
    return scale * float(np.sqrt(np.sum(weights**2) * sigma2 * np.log(cells / pfa)))


#: The noise power is estimated from the k-space map (:func:`_kspace_noise`)
#: for range axes too short for the median over gates, where the array has at
#: least this many antennas (a map of fewer k cells is mostly echo).
NOISE_KSPACE_MIN_ANTENNAS = 16
#: Quantile of the tapered map's power that :func:`_kspace_noise` reads: low
#: enough that echoes may fill most of the map (with half the cells holding
#: echoes the estimate is 2.1 times the noise, with 80 % 6.6 times).
NOISE_KSPACE_QUANTILE = 0.1


def _kspace_noise(data: RadarData, weights: np.ndarray, scale: float) -> float:
    """Noise power per sample, in units of ``scale**2``, from the low tail of
    the Hann-tapered k-space map ``|S(k, R)|^2`` over every gate.

    Echoes occupy a few k cells per gate (their wavenumbers, spread by the
    taper's mainlobe and the wavefront's curvature), sidelobes are at -31 dB,
    so the cells below the map's :data:`NOISE_KSPACE_QUANTILE` quantile hold
    noise.  A cell of complex Gaussian noise has power ``sum(w**2) sigma2``,
    exponentially distributed, whose q-quantile is ``-ln(1 - q)`` times its
    mean.  Echoes in more of the map raise the estimate (a higher floor, never
    a lower one); on noise-free data it is the sidelobe level.
    """
    taper = _taper(data.array.shape)
    spec = kspace_spectrum(data, 1, taper=True)[0] / scale
    q = float(np.quantile(np.abs(spec) ** 2, NOISE_KSPACE_QUANTILE))
    return q / (-np.log1p(-NOISE_KSPACE_QUANTILE)) / float(np.sum(taper**2))


def _runs(mask: np.ndarray):
    """Contiguous runs of True in a 1-D mask, as (start, stop) pairs."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.nonzero(d == 1)[0], np.nonzero(d == -1)[0]))


def _search_gates(
    data: RadarData,
    weights,
    taper: bool,
    pad: int,
    rel: float,
    floor: float,
    margin: int,
    dechirp=None,
):
    """Range gates that can hold a cluster centre, dilated by ``margin``.

    ``A(R) = sum_X w(X) |s(X, R)|`` bounds ``max_k |S(k, R)|`` from above
    (triangle inequality; the dechirp factor has unit modulus), and the
    strongest gate's spectrum bounds the maximum from below (``L``), per
    regime of :func:`_regimes`; a gate with ``A(R) < max(rel L, floor)``
    cannot hold a centre, so skipping it changes nothing (step 2 of the
    module notes).  Returns a boolean mask over the range gates.
    """
    axes = tuple(range(data.array.dim - 1))
    bound = np.sum(np.abs(data.signal) * weights, axis=axes)
    active = np.zeros(data.range.size, bool)
    for m in _regimes(dechirp, data.range.size):
        if not bound[m].max() > 0:
            continue
        top = int(np.flatnonzero(m)[np.argmax(bound[m])])
        lower = float(
            np.abs(kspace_spectrum(data, pad, taper, slice(top, top + 1), dechirp)[0]).max()
        )
        active[m] = bound[m] >= max(rel * lower, floor)
    return ndimage.binary_dilation(active, iterations=margin) if margin > 0 else active


def _regimes(dechirp, nr: int) -> list:
    """The gates whose detection maxima are compared with each other: all of
    them, or the dechirped and the plain ones apart (dechirping raises a
    focused target's peak, by 9 dB on the tapered map of a 64 x 64 array, so
    one relative threshold over both would drop targets at plain gates).
    Boolean masks over the range gates, none empty."""
    if dechirp is None:
        return [np.ones(nr, bool)]
    return [m for m in (np.asarray(dechirp, bool), ~np.asarray(dechirp, bool)) if m.any()]


def _window(k: np.ndarray, k0: float, period: float, k_period: float) -> np.ndarray:
    dk = (k - k0 + 0.5 * k_period) % k_period - 0.5 * k_period  # wrapped
    return np.where(np.abs(dk) < 0.5 * period, 0.5 * (1 + np.cos(2 * np.pi * dk / period)), 0.0)


def _centres(det: np.ndarray, size: list, n_k: int, threshold, g0: int, nr: int):
    """Local maxima of ``det`` (one run of range gates starting at gate g0)
    at or above ``threshold`` (a scalar, or one value per gate of the run):
    (indices with global gates, values)."""
    mode = ["wrap"] * n_k + ["nearest"]
    # a window wider than its axis sees the whole axis, as the axis's own
    # length (wrapped) or twice it (edges repeated) does: the same maxima,
    # at a cost bounded by the data, not by the resolution
    size = [min(int(s), n if m == "wrap" else 2 * n + 1) for s, n, m in zip(size, det.shape, mode)]
    local = det == ndimage.maximum_filter(det, size=size, mode=mode)
    # a strict maximum along R (a flat run of equal values, e.g. a constant
    # signal, is not a peak: every gate of it would pass the test above)
    strict = np.zeros_like(local)
    strict[..., 1:-1] = (det[..., 1:-1] > det[..., :-2]) & (det[..., 1:-1] >= det[..., 2:])
    local &= strict & (det >= threshold) & (det > 0)
    idx = np.argwhere(local)
    vals = det[tuple(idx.T)]
    idx[:, -1] += g0
    # a peak on the first or last range gate is the edge of the axis, not a maximum
    keep = (idx[:, -1] > 0) & (idx[:, -1] < nr - 1)
    return idx[keep], vals[keep]


def decompose(data: RadarData, params: KSpaceParams = KSpaceParams(), env=None) -> Decomposition:
    """Decompose the data into clusters in k-space (eq. 2-4, 7-9).

    Parameters
    ----------
    data : RadarData
    params : KSpaceParams
    env : CLEnv, optional
        OpenCL environment for the near-field search's pair scans
        (:func:`rpm_cl.extract.nearfield.decompose_near_field`); None: NumPy.

    Returns
    -------
    Decomposition
        ``magnitude`` is computed on the range gates searched and 0 elsewhere
        (gates that cannot hold a centre are skipped, step 2 of the module
        notes).
    """
    with one_blas_thread():  # small DFT matrices: see rpm_cl.extract.blas
        return _decompose(data, params, env)


def _decompose(data: RadarData, params: KSpaceParams, env=None) -> Decomposition:
    arr = data.array
    n_k = arr.dim - 1
    if params.near_field or (params.near_field is None and near_field_wanted(data)):
        if arr.planar:
            raise InputError("the near-field decomposition handles linear arrays only")
        spec, k_axes = kspace_spectrum(data, params.pad)
        mag = np.abs(spec)
        if not mag.max() > 0:
            return Decomposition(k_axes, mag, ())
        return decompose_near_field(data, params, (mag, k_axes), env)
    gate = params.range_gate or data.waveform.range_resolution
    dr = data.dr
    nr = data.range.size
    periods = (
        (params.window_x,) if n_k == 1 else (params.window_x, params.window_z or params.window_x)
    )
    k_axes = kspace_spectrum(data, params.pad, gates=slice(0, 0))[1]
    # non-maximum suppression neighbourhood: a quarter window period in k,
    # half a range resolution in R; k axes periodic, R not.
    size = [
        2 * int(np.ceil(0.25 * periods[a] / abs(k_axes[a][1] - k_axes[a][0]))) + 1
        for a in range(n_k)
    ]
    size = [min(s_, len(k)) for s_, k in zip(size, k_axes)]
    half_r = int(np.ceil(0.5 * data.waveform.range_resolution / dr))
    size.append(2 * half_r + 1)
    weights = _taper(arr.shape) if params.detect_taper else np.ones(arr.shape + (1,))
    rel = 10.0 ** (params.peak_threshold_db / 20.0)
    floor = (
        noise_floor(data, weights, params.noise_pfa, params.noise_power)
        if params.noise_pfa is not None
        else 0.0
    )
    # gates searched: those that can hold a centre, with room for the
    # neighbourhood and the strict test (half_r + 1) and for each cluster's
    # range interval (gate / dr + 1)
    margin = max(half_r + 1, int(np.ceil(gate / dr)) + 1)
    dechirp = _dechirp_gates(data, params)
    need = (
        _search_gates(data, weights, params.detect_taper, params.pad, rel, floor, margin, dechirp)
        if params.skip_gates
        else np.ones(nr, bool)
    )
    shape = tuple(len(k) for k in k_axes) + (nr,)
    det = np.zeros(shape)
    for g0, g1 in _runs(need):
        det[..., g0:g1] = np.abs(
            kspace_spectrum(data, params.pad, params.detect_taper, slice(g0, g1), dechirp)[0]
        )
    # the threshold per gate: relative to the strongest peak of its regime
    gate_max = det.reshape(-1, nr).max(axis=0) if nr else np.zeros(0)
    threshold = np.zeros(nr)
    for m in _regimes(dechirp, nr):
        threshold[m] = max(float(gate_max[m].max()) * rel, floor)
    # second pass: only gates whose spectrum reaches the threshold (and their
    # neighbourhood) are searched and get the untapered spectrum
    hot = (gate_max >= threshold) & (gate_max > 0)
    if params.skip_gates:
        need = ndimage.binary_dilation(hot, iterations=margin) & need
    spec = np.zeros(shape, complex)
    mag = np.zeros(shape)
    found = []
    for g0, g1 in _runs(need):
        part = kspace_spectrum(data, params.pad, gates=slice(g0, g1), dechirp=dechirp)[0]
        spec[..., g0:g1] = part
        mag[..., g0:g1] = np.abs(part)
        found.append((det[..., g0:g1] if params.detect_taper else mag[..., g0:g1], g0))
    if not found:
        return Decomposition(k_axes, mag, ())
    peaks = [_centres(d, size, n_k, threshold[g0 : g0 + d.shape[-1]], g0, nr) for d, g0 in found]
    idx = np.concatenate([p[0] for p in peaks])
    vals = np.concatenate([p[1] for p in peaks])
    idx = idx[np.argsort(-vals, kind="stable")]
    return Decomposition(
        k_axes, mag, tuple(_clusters(data, params, spec, mag, k_axes, periods, idx, gate))
    )


def _clusters(data: RadarData, params: KSpaceParams, spec, mag, k_axes, periods, idx, gate):
    """One :class:`Cluster` per centre ``idx`` (window, alignment, inverse FFT)."""
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
        coeffs = ndimage.spline_filter1d(
            flat.real, 3, axis=-1, mode="nearest"
        ) + 1j * ndimage.spline_filter1d(flat.imag, 3, axis=-1, mode="nearest")
    # the zero-padded DFT of each array axis, shared by every cluster (none:
    # FFTs for a large array)
    dfts = (
        [_dft(k_axes[a].size, arr.shape[a]) for a in range(n_k)]
        if max(arr.shape) <= MATRIX_DFT_MAX
        else []
    )
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
                data, coeffs, kc, k_periods, axes_x, kc_w, lo, hi, r_c, params.autofocus
            )
        else:
            sig = spec[..., lo:hi]
        if dfts:
            sub = _apply_axes(
                [_window_operator(wins[a], dfts[a], padded=not align) for a in range(n_k)], sig
            )
        else:  # large arrays: FFTs (n log n beats the n^2 of the matrices)
            w = np.ones([1] * (n_k + 1))
            for a in range(n_k):
                w = w * wins[a].reshape([-1 if b == a else 1 for b in range(n_k + 1)])
            part = sfft.fftn(sig, s=spec.shape[:n_k], axes=tuple(range(n_k))) if align else sig
            sub = sfft.ifftn(w * part, axes=tuple(range(n_k)))
            sub = sub[tuple(slice(0, n) for n in arr.shape)]
        clusters.append(
            Cluster(
                kc,
                float(data.range[ir]),
                slice(lo, hi),
                sub,
                float(mag[tuple(ind)]),
                offset,
                u,
                focus,
            )
        )
    return clusters


#: Largest array axis (antennas) transformed with DFT matrices rather than
#: FFTs: measured faster for 11 x 17 (decomposition 107 -> 71 ms), 32 x 32
#: (485 -> 339 ms) and 64 x 64 at pad 2 (1443 -> 1293 ms); beyond, the
#: matrices' n^2 cost per line overtakes the FFT's n log n.
MATRIX_DFT_MAX = 128


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


#: A non-principal alias must give a coherent peak this much larger (module notes, step 4).
ALIAS_MARGIN = 1.05
#: Most alias directions the alignment tries per cluster (each is one
#: shifted copy of the cluster's profiles): a pitch d gives about 4 d /
#: lambda of them per array axis (5 for the paper's 20 mm sparse array,
#: 513 for 0.5 m at 77 GHz; ALIAS_MAX_AXIS is 1.5 m there, 15 m at 20
#: GHz), a planar array the product over its two axes within |u| < 1
#: (8949 for the human body's array at 0.4 m pitch, 11 s; ALIAS_MAX is a
#: pitch of about 1.3 m at 20 GHz, a minute a cluster).  An array of 5 km
#: pitch (x in mm read as m) had 1.3 million and ran for five minutes.
ALIAS_MAX_AXIS = 4096
ALIAS_MAX = 100_000


def shift_rows(coeffs: np.ndarray, shift: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """Each row of a cubic B-spline along the last axis, evaluated at samples
    ``lo .. hi-1`` plus that row's ``shift``.

    The rows are independent: each is interpolated along R only.  (Before,
    ``ndimage.map_coordinates`` on the 2-D coefficient array also spread the
    cubic B-spline across rows, at integer row coordinates weights 1/6, 2/3,
    1/6, so every aligned profile was a blend of three antennas; the test
    pins this.)  A row's shift is the same at every gate, so its four taps
    and weights are found once per row.

    Parameters
    ----------
    coeffs : ndarray, complex, shape (n_rows, nr)
        Cubic B-spline coefficients along the last axis
        (``ndimage.spline_filter1d(..., order 3, mode="nearest")``).
    shift : ndarray, float, shape (n_rows,)
        Shift of each row, in samples (range gates).
    lo, hi : int
        The gates evaluated, ``lo:hi``.

    Returns
    -------
    ndarray, complex, shape (n_rows, hi - lo)
        Equal to ``ndimage.map_coordinates`` on each row alone (order 3,
        ``prefilter=False``) where all four taps lie on the axis; beyond its
        ends the edge coefficients are repeated.
    """
    n = hi - lo
    if n <= 0:
        return np.zeros((coeffs.shape[0], 0), coeffs.dtype)
    # beyond the axis every tap is an edge coefficient (and a huge shift
    # would overflow the integer index)
    shift = np.clip(shift, -coeffs.shape[1] - 2.0, coeffs.shape[1] + 2.0)
    i0 = np.floor(shift)
    t = (shift - i0)[:, None]
    idx = i0.astype(np.intp)[:, None] + np.arange(lo - 1, hi + 2)[None, :]
    np.clip(idx, 0, coeffs.shape[1] - 1, out=idx)
    g = np.take_along_axis(coeffs, idx, axis=1)
    t2 = t * t
    t3 = t2 * t
    w0 = (1.0 - t) ** 3 / 6.0
    w1 = (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0
    w2 = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0
    w3 = t3 / 6.0
    return w0 * g[:, 0:n] + w1 * g[:, 1 : n + 1] + w2 * g[:, 2 : n + 2] + w3 * g[:, 3 : n + 3]


def _block_peak(c: np.ndarray, block: int) -> float:
    """Largest, over range gates, sum of |coherent sum| over sub-apertures.

    Parameters
    ----------
    c : ndarray, complex, shape (n_0[, n_1], n_gates)
        The aligned signal times the plane wave at the cluster's k.
    block : int
        Sub-aperture length along each array axis, antennas: each axis of
        n antennas is cut into ``max(1, round(n / block))`` nearly equal
        runs.

    Returns
    -------
    float
        ``max_g sum_b |sum_{X in b} c(X, g)|`` (0 for no gates).
    """
    out = c
    for a in range(c.ndim - 1):
        n = c.shape[a]
        edges = np.linspace(0, n, max(1, round(n / max(block, 1))) + 1).astype(int)
        out = np.add.reduceat(out, edges[:-1], axis=a)
    val = np.abs(out).reshape(-1, c.shape[-1]).sum(axis=0)
    return float(val.max()) if val.size else 0.0


def _curvature(u, axes_x, r_c: float) -> np.ndarray:
    """q(X) = (|dX|^2 - (u . dX)^2) / (2 r_c), m: the curvature term of the
    range of a target at range r_c with range slope u (step 5)."""
    grids = _centred_grids(axes_x)
    d2 = sum(g * g for g in grids)
    ud = sum(u[a] * grids[a] for a in range(len(u)))
    return (d2 - ud * ud) / (2.0 * max(r_c, 1e-9))


def _centred_grids(axes_x) -> list:
    """Each antenna's offset from the array's centre along each array axis,
    m: one array of the array's shape per axis."""
    centres = [0.5 * (ax[0] + ax[-1]) for ax in axes_x]
    return np.meshgrid(*[ax - c for ax, c in zip(axes_x, centres)], indexing="ij")


def _half_diagonal2(axes_x) -> float:
    """Squared distance from the array's centre to its corners, m^2."""
    return sum((0.5 * (ax[-1] - ax[0])) ** 2 for ax in axes_x)


def _max_curvature(axes_x, kc_w: float, r_c):
    """Curvature phase at the array's corners for a broadside target at range
    ``r_c`` (m, a number or an array of them), rad."""
    return 2 * kc_w * _half_diagonal2(axes_x) / (2.0 * np.maximum(r_c, 1e-9))


def _align(data: RadarData, coeffs, kc, k_periods, axes_x, kc_w, lo, hi, r_c=None, autofocus=False):
    """Range-walk alignment of one cluster (module notes, step 4).

    ``coeffs`` are the cubic-spline coefficients of the profiles
    (n_antennas, nr), complex, along R; the shifted profiles are
    interpolated from them by :func:`shift_rows` (a local interpolator: a
    Fourier shift would ring where a profile does not vanish at the ends of
    the range axis).

    With ``r_c`` (focusing, step 5) the offsets include the focus term
    q(X) of a point at that range (:func:`_focus_range`), and the signal's
    phase exp(-j 2 k_c q) is removed; with ``autofocus`` too (step 6), q is
    then fitted to the cluster (:func:`_autofocus`).

    Returns the range slopes u = dR_t/dX, the per-antenna offsets delta(X) (m),
    the aligned signal over range gates ``lo:hi`` and the focus factors
    (:attr:`Cluster.focus`; None unfocused).
    """
    n_k = len(kc)
    offsets = _centred_grids(axes_x)
    # candidate direction cosines along each axis: every alias of kc with |u| < 1
    per_axis = []
    for a in range(n_k):
        nmax = int(np.ceil(2 * kc_w / k_periods[a])) + 1
        cands = -(kc[a] + np.arange(-nmax, nmax + 1) * k_periods[a]) / (2 * kc_w)
        per_axis.append(cands[np.abs(cands) < 1.0])
    grids = np.meshgrid(*per_axis, indexing="ij")
    options = np.stack([g.ravel() for g in grids], axis=1)
    options = options[np.sum(options**2, axis=1) < 1.0]
    if len(options) > ALIAS_MAX or max(len(c) for c in per_axis) > ALIAS_MAX_AXIS:
        pitch = [float(np.diff(ax[:2])[0]) if ax.size > 1 else 0.0 for ax in axes_x]
        raise InputError(
            f"the range-walk alignment would try {len(options)} alias directions "
            f"(array pitch {max(pitch):g} m, {max(pitch) / data.waveform.wavelength:.3g}"
            f" wavelengths; at most {ALIAS_MAX_AXIS} per axis and {ALIAS_MAX} in "
            f"all): check the units of x / z (m), or "
            f"switch the alignment off (--align false)"
        )
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
    # the coherent peak's sub-aperture, antennas a side (module notes, step
    # 4): the whole array unless focused
    block = (
        int(np.ceil(data.waveform.range_resolution * kc_w / np.pi))
        if r_c is not None
        else max(data.array.shape)
    )

    def aligned(delta, q, gates=(lo, hi), block=block):
        """The profiles shifted by ``delta`` (and the focus phase of ``q``
        removed) over ``gates``, and their coherent peak at kc summed over
        sub-apertures of ``block`` antennas (:func:`_block_peak`)."""
        g0, g1 = gates
        sig = shift_rows(coeffs, delta.ravel() / data.dr, g0, g1)
        sig = sig.reshape(data.array.shape + (g1 - g0,))
        if q is not None:
            sig = sig * np.exp(2j * kc_w * q)[..., None]
        return sig, _block_peak(sig * steer[..., None], block)

    best = None
    for u in options:
        delta = sum(u[a] * offsets[a] for a in range(n_k))
        q = None
        if r_c is None:
            sig, peak = aligned(delta, None)
        else:
            # focused: ranked by the sub-aperture peak (module notes, step 4;
            # it replaced the better of the whole-aperture focused and plain
            # peaks, which took the u_x = -0.89 alias for the lower legs of
            # the human body seen by a 64 x 64 array)
            q = _focus_range(u, axes_x, r_c)
            delta = delta + q
            sig, peak = aligned(delta, q)
        # 5 % margin: a wrong alias misaligns the envelopes by a sizeable part
        # of the resolution and loses far more than that; near-ties (flat or
        # degenerate data) keep the principal alias
        if best is None or peak > ALIAS_MARGIN * best[0]:
            best = (peak, u, delta, sig, q)
    _, u, delta, sig, q = best
    if r_c is None:
        return u, delta, sig, None
    # the whole aperture as one block: the coherent peak itself
    f = (
        _autofocus(
            aligned, delta - q, sig * steer[..., None], u, axes_x, r_c, lo, max(data.array.shape)
        )
        if autofocus
        else None
    )
    if f is None:
        return u, delta, sig, np.ones(n_k)
    delta = delta - q
    q = _focus_range(u, axes_x, r_c, f)
    delta = delta + q
    return u, delta, aligned(delta, q)[0], f


#: Factors of the Fresnel (quadratic) part of the wavefront tried along each
#: array axis by the autofocus (module notes, step 6): ``r_c / (r_c + rho)``
#: for a convex surface of curvature radius ``rho`` at range ``r_c`` (1: a
#: point, 0: flat along that axis), a little beyond 1 for concave ones.  The
#: best of these is then refined by AUTOFOCUS_REFINE on each side.
AUTOFOCUS_FACTORS = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0, 1.2)
AUTOFOCUS_REFINE = 0.1
#: Range gates on each side of the coherent peak's gate that the autofocus
#: compares the wavefronts on.
AUTOFOCUS_GATES = 2
#: The fitted wavefront replaces the point's only where it raises the
#: coherent peak by this factor.  Measured on the human body at 20 dB: 2.4-6.5
#: for the torso, arms and thighs seen by 64 x 64 (where it finds 97.4 % of
#: the echoes instead of 91.3 %), 1.005-1.14 on 32 x 32 (where it found 0.4 %
#: more echoes but cost about a point of RPM <= 10 mm, in the forearms); an
#: any-gain rule also took factors from noise-only clusters (9 of 10 on a
#: 48 x 48 array).
AUTOFOCUS_MARGIN = 1.25


def _autofocus(aligned, lin, coherent, u, axes_x, r_c, lo, whole):
    """Per-axis factors of the Fresnel part of the focus wavefront that
    maximise a cluster's whole-aperture coherent peak (module notes, step 6),
    or None where the point focus (all 1) stays best.

    ``aligned(delta, q, gates, block)`` is :func:`_align`'s: the profiles
    shifted by ``delta`` and focused by ``q`` over ``gates``, and their
    coherent peak over sub-apertures of ``block`` antennas (``whole``: the
    whole aperture).  ``lin`` is the cluster's linear range walk u . dX (m,
    the alignment without the focus term), ``coherent`` its signal aligned
    and focused as a point at ``r_c``, times the conjugate plane wave of its
    k, over gates ``lo:lo + n``.  Each candidate wavefront re-aligns the
    profiles (the focus term is part of the range offset) over the
    ``2 AUTOFOCUS_GATES + 1`` gates around the point focus's coherent peak
    only.  One axis at a time, the
    others held: :data:`AUTOFOCUS_FACTORS`, then AUTOFOCUS_REFINE either side
    of the best (within the factors' range); two sweeps over the axes at
    most.  The result is kept only where its peak is AUTOFOCUS_MARGIN times
    the point focus's.
    """
    n = coherent.shape[-1]
    g = int(np.argmax(np.abs(coherent.reshape(-1, n).sum(axis=0))))
    gates = (lo + max(0, g - AUTOFOCUS_GATES), lo + min(n, g + AUTOFOCUS_GATES + 1))
    terms = _focus_terms(u, axes_x, r_c)
    memo = {}

    def peak(f):
        key = tuple(np.round(f, 6))
        if key not in memo:
            q = _with_factors(*terms, f)
            memo[key] = aligned(lin + q, q, gates, whole)[1]
        return memo[key]

    f = np.ones(len(axes_x))
    best = point = peak(f)
    lo_f, hi_f = min(AUTOFOCUS_FACTORS), max(AUTOFOCUS_FACTORS)
    for _ in range(2):
        start = f.copy()
        for a in range(len(axes_x)):
            for values in (AUTOFOCUS_FACTORS, None):
                if values is None:  # refine around the best so far
                    values = [
                        v
                        for v in (f[a] - AUTOFOCUS_REFINE, f[a] + AUTOFOCUS_REFINE)
                        if lo_f <= v <= hi_f
                    ]
                for v in values:
                    trial = f.copy()
                    trial[a] = v
                    p = peak(trial)
                    if p > best:
                        best, f = p, trial
        if np.array_equal(f, start):
            break
    return None if np.all(f == 1.0) or not best >= AUTOFOCUS_MARGIN * point else f


def _focus_terms(u, axes_x, r_c: float):
    """The exact focus term of :func:`_focus_range` and the Fresnel part of
    each axis, ``(1 - u_a^2) dX_a^2 / (2 r_c)``, m (arrays of the array's
    shape)."""
    grids = _centred_grids(axes_x)
    r_c = max(float(r_c), 1e-9)
    u = np.asarray(u, float)
    ud = sum(u[a] * grids[a] for a in range(len(grids)))
    d2 = sum(g * g for g in grids)
    # |X - p| - r_c = (|dX|^2 + 2 r_c u.dX) / (|X - p| + r_c), without cancellation
    dist = np.sqrt(np.maximum(d2 + 2 * r_c * ud + r_c * r_c, 0.0))
    exact = (d2 + 2 * r_c * ud) / (dist + r_c) - ud
    return exact, [(1.0 - u[a] ** 2) * grids[a] ** 2 / (2.0 * r_c) for a in range(len(grids))]


def _focus_range(u, axes_x, r_c: float, f=None) -> np.ndarray:
    """Focus term of the range walk, m (module notes, steps 5-6): the range
    of a point at range ``r_c`` from the array's centre with range slope
    ``u`` (direction cosines ``-u``), minus ``r_c`` and the linear term
    ``u . dX``, exactly (not only the Fresnel term of :func:`_curvature`:
    at ``|u| = 0.5`` across a 0.47 m aperture at 1.2 m the next term is
    1.5 rad of phase).  ``f`` (one factor per array axis) scales the Fresnel
    part along each axis, ``(1 - u_a^2) dX_a^2 / (2 r_c)``: the wavefront of
    a surface curved more gently than a point.

    Returns
    -------
    ndarray, shape of the array
    """
    exact, quads = _focus_terms(u, axes_x, r_c)
    return exact if f is None else _with_factors(exact, quads, f)


def _with_factors(exact, quads, f) -> np.ndarray:
    """The focus term with the Fresnel part of axis a scaled by ``f[a]``."""
    return exact + sum((f[a] - 1.0) * quads[a] for a in range(len(quads)))
