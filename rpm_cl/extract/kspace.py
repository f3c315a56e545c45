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
   With ``close_centres`` (phase-rpm's default, linear arrays) the k
   neighbourhood is at most one aperture resolution cell ``2 pi / L``:
   targets closer in direction than a quarter window but resolved by the
   aperture each get a centre.  Their windows overlap, but each is centred
   on its own target, and phase-rpm's coherent sum along each echo's phase
   history (:mod:`rpm_cl.extract.phase`) separates what the windows share.
   Measured on random narrow-band scenes (``python
   benchmarks/random_scenes.py``, docs/benchmarks.md): every target is hit
   in 26 of 30 scenes noise-free with close centres, in 19 with the quarter
   period; narrowing each window to zero on its nearest centre as well hits
   no more and puts the gprMax narrow-band fixture's median at 5.2 mm
   instead of 2.1 mm.  The near-field decomposition (sparse arrays) has its
   own search and does not read the setting.
   The decomposition itself uses the untapered spectrum.
   With ``coherent_centres`` (phase-rpm's default) on a linear array whose
   band is at least a fifth of its carrier, the peaks of the coherent
   (delay-and-sum) image of the tapered data over the searched gates, on
   nodes (sin theta, R) from the array's middle, become centres too where no
   centre's window holds them (within a quarter period in k and the range
   gate): a weak echo on the flank of a strong one's spread over (k, R) is
   no maximum of the map, but the image focuses it (the gprMax fixture's c4,
   8 mm at 0.58 m beside a plate's echo several times stronger; the rods of
   the half-space fixture: 95 % of the points within 20 mm, 77 % without
   these centres).  A peak
   must reach ``peak_threshold_db`` of the image's maximum and stand
   :data:`rpm_cl.extract.kspace_detect.COHERENT_FLOOR_DB` above its median
   (side lobes and noise); nodes on the edges of the searched gates and of
   the directions are no peaks.  With a narrower band the image is close
   to a one-frequency hologram, whose side lobes are peaks of their own.
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
   Where the data carry their samples (a compressed spectrum, whose window
   is known), a centre must also stand LEAK_MARGIN times above the range
   sidelobes that the map's stronger gates put at its gate at its own k
   (:func:`rpm_cl.extract.kspace_detect.above_leakage`): with the noise far
   below them, a plain regime's threshold took a flat plate's sidelobes
   for echoes.
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
   (:func:`rpm_cl.extract.kspace_align._block_profile`): the aperture is
   then large enough that a point focus at R~ is the wrong wavefront for an
   extended surface (an elongated body part is flatter than a point along
   its length), the whole-aperture
   sum of the right alias partly cancels, and a wrong alias, whose steep
   range walk gathers pieces of other echoes, won (the human body's lower
   legs seen by a 64 x 64 array: 4.8 for the true u_x = 0.11, 7.9 at
   u_x = -0.89).  Within a sub-aperture the wavefront error is small, while
   the nearest wrong alias still misaligns the envelopes by a range
   resolution across it: neighbouring aliases differ in u by lambda / (2 d),
   i.e. by lambda / 2 of range walk per antenna, so a sub-aperture is
   ``ceil(2 resolution / lambda)`` antennas along each axis (7 for the
   human body's 50 mm at 15 mm).  And a wrong alias's steep walk can carry
   a stronger echo from beyond the cluster's gates into one sub-aperture:
   with focusing, a non-principal alias is taken only where its aligned
   peak lies within half a range resolution of the cluster's own gate
   (:data:`rpm_cl.extract.kspace_align.ALIAS_REACH`).
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
   the offsets are taken from that wavefront, the factor then refined to a
   quarter cycle of phase at the aperture's edge.  Where every factor f is
   below 1 the wavefront is exactly a point's at R / f (a sphere's echo),
   not only the Fresnel term scaled: a surface 0.1 m under a 0.56 m scan
   otherwise kept a point's higher-order terms, 0.19 m at its corners
   (:func:`rpm_cl.extract.kspace_focus._surface_term`).  Measured on the human body at
   20 dB, seeds 0-3 (``python benchmarks/large_arrays.py``): a 64 x 64 array
   finds 97.2-97.4 % of the 45056 true echoes within 10 mm (83.5-83.7 %
   with a point's Fresnel term only, 91.3 % with the exact point focus of
   step 5 alone); on 32 x 32 no cluster gains the margin.

A linear array sampled at half a wavelength or coarser (the paper's sparse
case) aliases the k axis and bends each target's wave across the aperture
beyond what a window in k can hold; ``near_field`` selects the spherical-wave
decomposition of :mod:`rpm_cl.extract.nearfield` for it (automatically by default,
where the aperture is also at most about a range resolution long: a longer
one resolves each target's range walk, and the alignment of step 4 tells the
aliases apart by it; see :func:`rpm_cl.extract.nearfield.near_field_wanted`).
Chosen automatically, it gives way to the plane-wave path where its focused
map would exceed ``MAP_TERMS_MAX`` terms (an aperture of hundreds of
wavelengths over many gates); asked for, that is an error.
"""

from __future__ import annotations

import numpy as np

from ..filters import binary_dilation
from ..io.data import InputError, RadarData
from ..transforms import fft
from .blas import one_blas_thread
from .kspace_clusters import _apply_axes, _clusters, _dft
from .kspace_detect import (
    _nms_size,
    _ranked_centres,
    _regimes,
    _runs,
    _taper,
    above_leakage,
    coherent_centres,
    wants_coherent_centres,
)
from .kspace_geometry import _align_on, _dechirp_gates, _fresnel
from .kspace_params import KSpaceParams
from .nearfield import decompose_near_field, near_field_wanted
from .nearfield_map import MapTooLarge
from .types import Cluster, Decomposition

# isort: split
# The decomposition's parts that these notes, the tests and
# rpm_cl.extract.rangepoints name in this module, importable from here as
# well as from their own:
from .kspace_align import shift_rows  # noqa: F401
from .kspace_clusters import _window  # noqa: F401
from .kspace_detect import _centres  # noqa: F401
from .kspace_focus import _autofocus, _focus_range  # noqa: F401
from .kspace_geometry import _array_axes, _centred_grids, _curvature  # noqa: F401

__all__ = [
    "Cluster",
    "Decomposition",
    "KSpaceParams",
    "decompose",
    "kspace_spectrum",
    "measured_noise_power",
]


#: Largest array axis (antennas) transformed with DFT matrices rather than
#: FFTs: measured faster for 11 x 17 (decomposition 107 -> 71 ms), 32 x 32
#: (485 -> 339 ms) and 64 x 64 at pad 2 (1443 -> 1293 ms); beyond, the
#: matrices' n^2 cost per line overtakes the FFT's n log n.
MATRIX_DFT_MAX = 128


def _padded_fft(sig: np.ndarray, shape: tuple) -> np.ndarray:
    """``fftn(sig, s=shape)`` over the leading ``len(shape)`` axes, one axis
    at a time from the last: each axis's transform runs over the others'
    samples before they are padded (a 187 x 144 array at pad 4 transforms
    187 x 576, then 748 x 576 lines' worth, against 748 x 576 twice), the
    same sums in another order."""
    out = sig
    for a in reversed(range(len(shape))):
        out = fft(out, n=shape[a], axis=a)
    return out


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
        spec = _padded_fft(sig, shape)
    steps = (arr.dx,) if not arr.planar else (arr.dx, arr.dz)
    k_axes = tuple(2 * np.pi * np.fft.fftfreq(n, d) for n, d in zip(shape, steps))
    return spec, k_axes


#: Most a dechirped (focused) gate's peak can stand above the same target's
#: on a plain gate, dB: 19x (25.6 dB) at broadside on a 64 x 64 array
#: (:func:`rpm_cl.extract.kspace_geometry._dechirp_gates`), with margin.  Each
#: regime is thresholded against its own strongest peak, but never below the
#: strongest regime's threshold less this; and the dechirped regime, whose
#: peaks stand at or above the same targets' plain ones, never below the
#: plain regime's threshold.
REGIME_GAIN_DB = 30.0

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
    gates = _gate_noise(data) if noise_power is None else None
    if noise_power is not None:
        sigma2 = float(noise_power)
    elif gates is not None:
        scale, sigma2 = gates
    elif data.array.n >= NOISE_KSPACE_MIN_ANTENNAS:
        scale = float(np.abs(data.signal).max()) or 1.0
        sigma2 = _kspace_noise(data, weights, scale)
    else:
        return 0.0
    cells = data.array.n * data.range.size
    return scale * float(np.sqrt(np.sum(weights**2) * sigma2 * np.log(cells / pfa)))


def _gate_noise(data: RadarData) -> tuple[float, float] | None:
    """``(scale, p)``: the median over range gates of the mean power across
    the array is ``p * scale**2`` (``scale`` the largest |s|, so that squares
    of the data's own scale cannot overflow); None where the range axis spans
    fewer than :data:`NOISE_ESTIMATE_CELLS` range resolutions."""
    if data.range[-1] - data.range[0] < NOISE_ESTIMATE_CELLS * data.waveform.range_resolution:
        return None
    axes = tuple(range(data.array.dim - 1))
    mag = np.abs(data.signal)
    scale = float(mag.max()) or 1.0
    return scale, float(np.median(np.mean((mag / scale) ** 2, axis=axes)))


def measured_noise_power(data: RadarData) -> float | None:
    """Noise power per sample of the range profiles, signal units squared,
    as :func:`noise_floor` estimates it from the data (the median over range
    gates of the mean power across the array), or None where the range axis
    is too short for that estimate (fewer than :data:`NOISE_ESTIMATE_CELLS`
    range resolutions) or its square leaves float64's range.

    Measured on the whole axis before a region of interest cuts it
    (:func:`rpm_cl.imaging.prepared`): the gates a user keeps are those
    that hold the scene, whose median is no longer the noise's.
    """
    gates = _gate_noise(data)
    if gates is None:
        return None
    power = gates[0] ** 2 * gates[1]
    return power if np.isfinite(power) else None


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
    return binary_dilation(active, margin) if margin > 0 else active


def decompose(
    data: RadarData,
    params: KSpaceParams = KSpaceParams(),  # noqa: B008 - frozen, one shared default
    env=None,
) -> Decomposition:
    """Decompose the data into clusters in k-space (eq. 2-4, 7-9).

    Parameters
    ----------
    data : RadarData
    params : KSpaceParams
    env : CLEnv, optional
        OpenCL environment for the near-field search's pair scans
        (:func:`rpm_cl.extract.nearfield.decompose_near_field`) and the
        coherent centres' image (:func:`rpm_cl.extract.kspace_detect.coherent_centres`),
        in float64 where its device takes doubles; None: NumPy.

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
        try:
            return _near_field(data, params, env)
        except MapTooLarge:
            if params.near_field:
                raise
            # chosen, not asked for: an aperture of so many wavelengths over
            # so many gates takes the plane-wave path, whose cost does not
            # grow with the directions x antennas x gates of one map
    gate = params.range_gate or data.waveform.range_resolution
    dr = data.dr
    nr = data.range.size
    periods = (
        (params.window_x,) if n_k == 1 else (params.window_x, params.window_z or params.window_x)
    )
    k_axes = kspace_spectrum(data, params.pad, gates=slice(0, 0))[1]
    size, half_r = _nms_size(data, periods, k_axes, bool(params.close_centres))
    # gates searched: those that can hold a centre, with room for the
    # neighbourhood and the strict test (half_r + 1) and for each cluster's
    # range interval (gate / dr + 1)
    margin = max(half_r + 1, int(np.ceil(gate / dr)) + 1)
    dechirp = _dechirp_gates(data, params)
    det, det0, threshold, need = _detection(data, params, k_axes, margin, dechirp)
    runs = _runs(need)
    if params.detect_taper:
        # the centres come from the tapered map, which is then dropped before
        # the untapered one is formed: only one map over the searched gates
        # is held at a time (0.28 GB each for 187 x 144 antennas at pad 4 over
        # 81 gates)
        idx = above_leakage(_centres_of(det, det0, runs, size, n_k, threshold, nr), det, det0, data)
        del det
    # aligned clusters are cut from the shifted profiles, not from S(k, R):
    # then only its magnitude is kept (a 128 x 128 array's complex map is
    # 1.7 GB)
    spec, mag, span = _spectra(data, params, need, dechirp, not _align_on(data, params))
    if not params.detect_taper:
        idx = _centres_of(mag, span.start, runs, size, n_k, threshold, nr)
        idx = above_leakage(idx, mag, span.start, data)
    if wants_coherent_centres(data, params):
        rel = 10.0 ** (params.peak_threshold_db / 20.0)
        from .backprojection_cl import sums_on

        extra = coherent_centres(data, idx, runs, k_axes[0], rel, periods[0], gate, sums_on(env))
        idx = np.concatenate([idx, extra]) if extra.size else idx
    if not idx.size:
        return Decomposition(k_axes, mag, (), gate0=span.start)
    matrix_dft = max(arr.shape) <= MATRIX_DFT_MAX
    return Decomposition(
        k_axes,
        mag,
        tuple(
            _clusters(data, params, spec, mag, span.start, k_axes, periods, idx, gate, matrix_dft)
        ),
        gate0=span.start,
    )


def _centres_of(det, det0: int, runs, size, n_k: int, threshold, nr: int) -> np.ndarray:
    """The ranked centres (:func:`_ranked_centres`) of a detection map that
    covers gates ``det0 ..`` over the runs of gates searched; shape
    (n_centres, n_k + 1), none without runs."""
    if not runs:
        return np.zeros((0, n_k + 1), np.intp)
    found = [(det[..., g0 - det0 : g1 - det0], g0) for g0, g1 in runs]
    return _ranked_centres(found, size, n_k, threshold, nr)


def _near_field(data: RadarData, params: KSpaceParams, env) -> Decomposition:
    """The near-field decomposition (:mod:`rpm_cl.extract.nearfield`), with
    the plane-wave |S(k, R)| it returns; nothing to search on all-zero data."""
    if data.array.planar:
        raise InputError("the near-field decomposition handles linear arrays only")
    spec, k_axes = kspace_spectrum(data, params.pad)
    mag = np.abs(spec)
    if not mag.max() > 0:
        return Decomposition(k_axes, mag, ())
    return decompose_near_field(data, params, (mag, k_axes), env)


def _detection(data: RadarData, params: KSpaceParams, k_axes, margin: int, dechirp):
    """The detection map and where the centres are searched (module notes,
    step 2).

    Returns
    -------
    det : ndarray, shape (nk_0[, nk_1], n)
        |S(k, R)| of the (tapered, dechirped) data over the n gates from the
        first to the last that can hold a centre, 0 at those between that
        cannot.
    det0 : int
        The first of those gates.
    threshold : ndarray, shape (nr,)
        Per gate: ``peak_threshold_db`` below the strongest peak of its
        regime (:func:`_regimes`), no less than the strongest regime's less
        :data:`REGIME_GAIN_DB`, at dechirped gates no less than the plain
        regime's, and no less than the noise floor.
    need : ndarray of bool, shape (nr,)
        The gates searched: those whose map reaches the threshold, dilated
        by ``margin`` (every gate without ``skip_gates``).
    """
    arr = data.array
    nr = data.range.size
    weights = _taper(arr.shape) if params.detect_taper else np.ones(arr.shape + (1,))
    rel = 10.0 ** (params.peak_threshold_db / 20.0)
    floor = (
        noise_floor(data, weights, params.noise_pfa, params.noise_power)
        if params.noise_pfa is not None
        else 0.0
    )
    need = (
        _search_gates(data, weights, params.detect_taper, params.pad, rel, floor, margin, dechirp)
        if params.skip_gates
        else np.ones(nr, bool)
    )
    det0, det = _magnitude_map(data, params.pad, params.detect_taper, need, dechirp)[1:]
    gate_max = np.zeros(nr)
    if det.shape[-1]:
        gate_max[det0 : det0 + det.shape[-1]] = det.reshape(-1, det.shape[-1]).max(axis=0)
    # the threshold per gate: relative to the strongest peak of its regime
    threshold = np.zeros(nr)
    # a regime without a target of its own holds the other's leakage (-67 dB
    # on a 15 x 15 array), which its own relative threshold would take for
    # centres: no regime's threshold falls more than REGIME_GAIN_DB below
    # the strongest regime's
    top = float(gate_max.max()) * rel * 10.0 ** (-REGIME_GAIN_DB / 20.0) if nr else 0.0
    # ... and dechirping only raises a target's peak, so the dechirped gates
    # answer to the plain regime's own threshold too: below it they hold the
    # plain targets' leakage (-46 dB at 0.95 m, where no echo is, on a 64 x 64
    # array whose targets all lie at plain gates)
    plain = None if dechirp is None else ~np.asarray(dechirp, bool)
    plain_top = float(gate_max[plain].max()) * rel if plain is not None and plain.any() else 0.0
    for m in _regimes(dechirp, nr):
        own = max(float(gate_max[m].max()) * rel, top, floor)
        dechirped = plain is not None and not np.array_equal(m, plain)
        threshold[m] = max(own, plain_top) if dechirped else own
    # second pass: only gates whose spectrum reaches the threshold (and their
    # neighbourhood) are searched and get the untapered spectrum
    hot = (gate_max >= threshold) & (gate_max > 0)
    if params.skip_gates:
        need = binary_dilation(hot, margin) & need
    return det, det0, threshold, need


def _spectra(data: RadarData, params: KSpaceParams, need, dechirp, keep: bool = True):
    """The untapered spectrum on the gates searched, ``need`` (module notes,
    step 3).

    Returns
    -------
    spec, mag : ndarray, shape (nk_0[, nk_1], n)
        S(k, R) and |S(k, R)| over the n gates ``span`` from the first to the
        last of ``need``, 0 at those between that are not searched;
        ``spec`` None unless ``keep``.
    span : slice
        Those gates.
    """
    spec, g_lo, mag = _magnitude_map(data, params.pad, False, need, dechirp, keep)
    return spec, mag, slice(g_lo, g_lo + mag.shape[-1])


#: Largest complex spectrum one FFT call forms, bytes, on arrays transformed
#: by FFTs (beyond :data:`MATRIX_DFT_MAX`): the gates of a run are transformed
#: in chunks of this size (each gate's transform is its own), so that the
#: transient copies stay small beside the map (a 187 x 144 array at pad 4
#: over 81 gates would form 0.56 GB at once).  Not much smaller: each chunk
#: is written into the map as runs of its gates, and 4-gate runs (32 MB
#: there) took 1.7 s over 110 gates against 0.17 s for 16.
FFT_CHUNK_BYTES = 128 << 20


def _magnitude_map(data: RadarData, pad: int, taper: bool, need, dechirp, keep: bool = False):
    """|S(k, R)| (and S where ``keep``) over the gates from the first to the
    last of ``need``, 0 at those between that are not in it.

    Returns
    -------
    spec : ndarray, complex, or None
        S(k, R) there (None unless ``keep``).
    g_lo : int
        The first gate of ``need`` (0 when none is).
    mag : ndarray, shape (pad*nx[, pad*nz], n)
    """
    arr = data.array
    shape = tuple(pad * n for n in arr.shape)
    on = np.flatnonzero(need)
    g_lo, g_hi = (int(on[0]), int(on[-1]) + 1) if on.size else (0, 0)
    mag = np.zeros(shape + (g_hi - g_lo,))
    spec = np.zeros(mag.shape, complex) if keep else None
    step = max(1, g_hi - g_lo)
    if max(arr.shape) > MATRIX_DFT_MAX:
        step = max(1, FFT_CHUNK_BYTES // (16 * int(np.prod(shape))))
    for r0, r1 in _runs(need):
        for c0 in range(r0, r1, step):
            c1 = min(r1, c0 + step)
            part = kspace_spectrum(data, pad, taper, slice(c0, c1), dechirp)[0]
            if keep:
                spec[..., c0 - g_lo : c1 - g_lo] = part
            np.abs(part, out=mag[..., c0 - g_lo : c1 - g_lo])
    return spec, g_lo, mag
