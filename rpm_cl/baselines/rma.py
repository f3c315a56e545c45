"""Range migration algorithm (f-k migration, Stolt interpolation), linear arrays.

The paper's coherent comparator for the sparse 20 mm array (Section V-A4,
Fig. 12(b), its refs. [7], [20]): an image on an ``(x, y)`` grid from
``s(X, R)`` by FFTs and one interpolation.

Model
-----
The frequency samples of a monostatic linear array at ``y = 0``
(:func:`rpm_cl.extract.frequency.frequency_samples`, matched-filter weight kept) are
``Y(X, k) = sum_t a_t W(f) exp(-j 2 k R_t(X))`` with ``k = 2 pi (fc + f) / c``
and ``R_t(X) = sqrt((X - x_t)^2 + y_t^2)``.  Their FFT along X,
``S(kx, k) = sum_X Y(X, k) exp(-j kx X)``, is by stationary phase
``~ a_t exp(-j kx x_t - j ky y_t)`` with the dispersion relation
``ky = sqrt(4 k^2 - kx^2)`` (``4 k^2 > kx^2``; the rest is evanescent and
dropped).  Resampling ``S`` onto a uniform ``ky`` grid (Stolt interpolation,
times the Jacobian ``dk/dky = ky / 4k``) and an inverse 2-D FFT give the
image ``I(x, y) = sum S(kx, ky) exp(j kx x + j ky y)``, which peaks at the
targets.  No reference range is needed: the samples are referenced to
``y = 0``.

Sampling: ``kx`` spans ``+-pi/dx``; a target seen at angle ``theta`` from
broadside has ``kx ~ 2 k sin(theta)``, so an array coarser than ``lambda/4``
aliases wide angles into grating lobes at ``sin(theta) + m lambda / (2 dx)``
(the sparse 20 mm array of the paper: ``lambda/(2 dx) = 0.375``).  The image's
``x`` pixel is ``dx / upsample_x``; its ``y`` period is the frequency grid's
unambiguous range ``c / (2 df)``.

The samples are the zero-padded FFT of the windowed profiles (no band-limited
extrapolation, unlike the Capon filter's): the image is that of the data as
given, and a range window shorter than the echoes' responses (paper-2d) only
cuts the image's range streaks.

In a medium (:class:`rpm_cl.io.medium.Medium`): a homogeneous one is imaged as
its equivalent air scene (:func:`rpm_cl.io.medium.in_medium`: the same maths
with the wavenumber ``n k``), exactly.  Above a half-space (antennas ``h``
above the surface) the image is a *phase-shift migration through the air
layer, then Stolt in the material*: ``S(kx, k)`` is continued down to the
surface by ``exp(+j sqrt(4 k^2 - kx^2) h)`` (the exact two-way propagator of
a plane-wave component through ``h`` of air; the evanescent part,
``|kx| > 2k``, is dropped), which leaves the data of antennas on the surface
of a homogeneous material, and those are Stolt-mapped with the material's
dispersion relation ``ky = sqrt(4 n^2 k^2 - kx^2)``.  ``kx`` is conserved
across a flat surface (Snell's law), so both steps are exact for the travel
times of every plane-wave component; the approximations are RMA's own
(stationary phase, linear interpolation in ``k``) and the surface's
transmission coefficients, which change amplitudes, not positions, and are
left out.  Components steeper than the critical angle (``2k < |kx| <
2nk``) never reach the air and are absent from the data.  The half-space
image covers the material, ``y >= h``.

Accuracy: with 3 GHz of bandwidth a point images within 1-2 mm of itself.
With paper-2d's 0.2 GHz (750 mm range resolution, 0.1 m aperture) each
target is a streak along its line of sight: its bearing comes out within
0.3 deg, its range 60-125 mm short (measured; it moves with ``pad_x``),
because the range response, half a metre wide, is weighted by the image
gain that falls with range.
"""

from __future__ import annotations

import numpy as np

from ..extract.frequency import frequency_samples
from ..io.data import C0, InputError, RadarData

__all__ = ["RMA_MIN_WEIGHT", "rma_image"]

#: Lower bound of the matched-filter weight ``cos^4(pi f / 2B)`` on the band
#: used: 1e-4 keeps ``|f| <= 0.94 B``; the rest carries less than 1e-4 of the
#: spectrum's amplitude.
RMA_MIN_WEIGHT = 1e-4


def _positive_int(name: str, v) -> int:
    if isinstance(v, bool) or int(v) != v or v < 1:
        raise InputError(f"{name} must be an integer >= 1, got {v!r}")
    return int(v)


def _stolt(
    spec: np.ndarray, kx: np.ndarray, k: np.ndarray, ky: np.ndarray, jacobian: bool
) -> np.ndarray:
    """Resample ``S(kx, k)`` onto ``S(kx, ky)``, ``ky = sqrt(4 k^2 - kx^2)``.

    Linear interpolation in ``k`` at ``k = sqrt(kx^2 + ky^2) / 2`` (the
    inverse of the dispersion relation, so each output sample is one lookup
    on the uniform ``k`` grid, all ``kx`` at once); zero where that ``k`` is
    outside the band.

    Parameters
    ----------
    spec : ndarray, complex, shape (nkx, L)
    kx : ndarray, shape (nkx,)
        rad/m.
    k : ndarray, shape (L,)
        Uniform, increasing, rad/m.
    ky : ndarray, shape (nky,)
        rad/m, > 0.
    jacobian : bool
        Multiply by ``dk/dky = ky / (4 k)``.

    Returns
    -------
    ndarray, complex, shape (nkx, nky)
    """
    dk = k[1] - k[0]
    k_need = 0.5 * np.hypot(kx[:, None], ky[None, :])  # (nkx, nky)
    u = (k_need - k[0]) / dk
    inside = (u >= 0) & (u <= k.size - 1)
    i0 = np.clip(np.floor(u).astype(np.int64), 0, k.size - 2)
    t = np.clip(u - i0, 0.0, 1.0)
    rows = np.arange(kx.size)[:, None]
    out = (1 - t) * spec[rows, i0] + t * spec[rows, i0 + 1]
    if jacobian:
        out = out * (ky[None, :] / (4 * np.maximum(k_need, k[0])))
    return np.where(inside, out, 0)


def rma_image(
    data: RadarData,
    *,
    pad_x: int = 8,
    upsample_x: int = 1,
    zero_pad_r: int = 8,
    dy: float | None = None,
    y_min: float | None = None,
    y_max: float | None = None,
    jacobian: bool = True,
    medium=None,
):
    """f-k migration image of a linear array's data.

    Parameters
    ----------
    data : RadarData
        Linear array only.
    pad_x : int
        The FFT along X is ``pad_x`` times the array (>= 1): the image spans
        ``pad_x * nx * dx`` in x, centred on the array, so targets beyond the
        aperture's ends do not wrap onto it.
    upsample_x : int
        Image x pixel ``dx / upsample_x`` (>= 1), by zero-padding ``kx``
        (interpolation: the resolution and the aliasing stay those of ``dx``).
    zero_pad_r : int
        Zero-padding of the FFT along R (>= 1): the frequency grid is
        ``c / (2 zero_pad_r nr dr)``.  The Stolt interpolation is linear in
        ``k``; a target at range ``R`` turns the phase by
        ``2 pi R / (zero_pad_r nr dr)`` per sample, ``2 pi / 8`` at
        ``R = nr dr`` with the default 8, where linear interpolation keeps
        92 % of the amplitude midway between samples.
    dy : float, optional
        Image y pixel, m (> 0); default a quarter of the shortest wavelength
        used, ``pi / ky_max``, fine enough for ``|I|`` to be read off the
        pixels.  The pixel is never coarser than the ``ky`` grid's own,
        ``2 pi / (ky extent)``; finer pixels come from zero-padding ``ky``.
    y_min, y_max : float, optional
        Crop of the image in y, m; default the data's range axis.
    jacobian : bool
        Apply ``dk/dky`` in the Stolt mapping.
    medium : rpm_cl.io.medium.Medium, optional
        The material (module notes); None or air: free space.  ``y`` is
        then in true metres; above a half-space the default crop is the
        material, from the surface ``y = h`` to the depth the range axis
        reaches, and a crop above the surface is refused.

    Returns
    -------
    image : ndarray, complex128, shape (nx_img, ny_img)
        ``I(x, y)``; ``|image|`` is the usual picture.  Its phase carries a
        factor ``exp(j ky_0 y)`` of the ``ky`` grid's origin.
    x : ndarray, shape (nx_img,)
        Pixel x, m, uniform, increasing.
    y : ndarray, shape (ny_img,)
        Pixel y, m, uniform, increasing.

    Raises
    ------
    InputError
        Planar data (RMA is implemented for linear arrays only), bad options,
        an empty crop.
    """
    if data.array.planar:
        raise InputError("RMA is implemented for linear arrays only; this array is planar")
    from ..io.medium import Medium, in_medium

    medium = Medium() if medium is None else medium
    data = in_medium(data, medium)  # a homogeneous medium: its equivalent air scene
    n_in, height = (medium.n, medium.antenna_height) if medium.half_space else (1.0, 0.0)
    pad_x = _positive_int("pad_x", pad_x)
    upsample_x = _positive_int("upsample_x", upsample_x)
    zero_pad_r = _positive_int("zero_pad_r", zero_pad_r)
    if dy is not None and not (np.isfinite(dy) and dy > 0):
        raise InputError(f"dy must be > 0, got {dy}")
    y_lo, y_hi = _crop(data, medium.half_space, n_in, height, y_min, y_max)
    f, k, kx, spec = _spectrum(data, pad_x, zero_pad_r, medium.half_space, n_in, height)
    ky, dky = _ky_grid(k, kx)
    img_k = _stolt(spec, kx, k, ky, jacobian)  # (n_kx, nky)
    want = dy if dy is not None else C0 / (data.waveform.fc + f[-1]) / n_in / 4
    return _image(data, img_k, ky, dky, upsample_x, want, height, (y_lo, y_hi))


def _crop(data: RadarData, half_space: bool, n_in: float, height: float, y_min, y_max):
    """The image's y crop, m: ``y_min`` .. ``y_max``, by default the data's
    range axis (above a half-space: the material it reaches).

    Raises
    ------
    InputError
        An empty crop, or one beyond where a target can lie.
    """
    # |y| <= R for every target: pixels beyond the range axis hold only the
    # FFT's periodic copies of the scene (every zero_pad_r * nr * dr in y),
    # which would read as targets; below a surface the deepest point an
    # air-equivalent range R reaches is h + (R - h) / n
    r_max = float(data.range[-1]) + data.dr
    lo_lim, hi_lim = (
        (height, height + max(r_max - height, 0.0) / n_in) if half_space else (-r_max, r_max)
    )
    y_lo = (float(data.range[0]) if not half_space else lo_lim) if y_min is None else float(y_min)
    y_hi = (float(data.range[-1]) if not half_space else hi_lim) if y_max is None else float(y_max)
    if not (np.isfinite(y_lo) and np.isfinite(y_hi) and y_hi > y_lo):
        raise InputError(f"need y_min < y_max, got {y_lo} and {y_hi}")
    if y_lo < lo_lim or y_hi > hi_lim:
        what = (
            "the material below the surface at y = h and the depth the range axis reaches"
            if half_space
            else "the data's range axis: no target lies farther"
        )
        raise InputError(
            f"the y crop {y_lo:g} .. {y_hi:g} m must lie within {lo_lim:g} .. {hi_lim:g} m ({what})"
        )
    return y_lo, y_hi


def _spectrum(
    data: RadarData, pad_x: int, zero_pad_r: int, half_space: bool, n_in: float, height: float
):
    """``S(kx, k)``: the frequency samples' FFT along X, referred to the
    surface of a half-space below the array.

    Returns
    -------
    f : ndarray, shape (L,)
        Baseband frequencies, Hz.
    k : ndarray, shape (L,)
        Wavenumbers, rad/m (in the material below a half-space).
    kx : ndarray, shape (pad_x nx,)
        rad/m, FFT order.
    spec : ndarray, complex, shape (pad_x nx, L)
    """
    # frequency samples with the matched-filter weight (a tapered spectrum:
    # low range sidelobes), from the zero-padded FFT of the windowed profiles
    f, y_f = frequency_samples(
        data, min_weight=RMA_MIN_WEIGHT, min_period_cells=0.0, deconvolve=False, zero_pad=zero_pad_r
    )
    k = 2 * np.pi * (data.waveform.fc + f) / C0  # (L,)
    nx, dx = data.array.x.size, data.array.dx
    n_kx = pad_x * nx
    spec = np.fft.fft(y_f, n=n_kx, axis=0)  # (n_kx, L): X relative to x[0]
    kx = 2 * np.pi * np.fft.fftfreq(n_kx, dx)
    if half_space:
        # phase shift through the air layer: the data referred to the surface
        kz2 = 4 * k[None, :] ** 2 - kx[:, None] ** 2
        spec = np.where(kz2 > 0, spec * np.exp(1j * np.sqrt(np.maximum(kz2, 0.0)) * height), 0)
        k = n_in * k  # then Stolt with the material's wavenumber
    return f, k, kx, spec


def _ky_grid(k: np.ndarray, kx: np.ndarray):
    """The uniform ``ky`` grid (rad/m, > 0) of the Stolt mapping, and its spacing."""
    # uniform ky grid over every ky the band reaches, spaced 2 dk (the spacing
    # of ky = 2k at kx = 0, so the y period stays c / 2 df)
    dk = k[1] - k[0]
    dky = 2 * dk
    ky_max = 2 * k[-1]
    ky_min = np.sqrt(max(4 * k[0] ** 2 - np.max(kx**2), 0.0))
    ky = ky_min + dky * np.arange(int(np.floor((ky_max - ky_min) / dky)) + 1)
    ky = ky[ky > 0]
    return ky, dky


def _image(data: RadarData, img_k, ky, dky: float, upsample_x: int, want: float, height, crop):
    """``I(x, y)`` from ``S(kx, ky)`` by inverse FFTs, on the crop's pixels.

    Parameters
    ----------
    img_k : ndarray, complex, shape (n_kx, nky)
        The Stolt-mapped spectrum.
    ky : ndarray, shape (nky,)
        rad/m, spaced ``dky``.
    upsample_x : int
        Zero-padding factor of ``kx``.
    want : float
        The y pixel asked for, m (zero-padding of ``ky`` where finer than
        the grid's own).
    height : float
        Depth origin, m (the surface below a half-space, else 0).
    crop : (float, float)
        y_lo, y_hi, m.

    Returns
    -------
    image, x, y
        As :func:`rma_image`.
    """
    y_lo, y_hi = crop
    nx, dx = data.array.x.size, data.array.dx
    n_kx = img_k.shape[0]
    # inverse FFTs: kx zero-padded for upsample_x, ky for dy
    n_x = n_kx * upsample_x
    if upsample_x > 1:
        full = np.zeros((n_x, ky.size), np.complex128)
        h = n_kx // 2
        full[:h] = img_k[:h]
        full[n_x - (n_kx - h) :] = img_k[h:]
        img_k = full
    period_y = 2 * np.pi / dky
    dy_nat = 2 * np.pi / (ky.size * dky)
    n_y = max(ky.size, int(np.ceil(period_y / min(want, dy_nat))))
    img = np.fft.ifft(np.fft.ifft(img_k, axis=0), n=n_y, axis=1) * (n_x * n_y)

    # axes: column j is x[0] + j dx/upsample_x (mod the x period), row n is
    # n period_y / n_y (mod period_y); centre x on the array, put y in
    # [y_lo, y_lo + period_y)
    px = dx / upsample_x
    jx = np.arange(n_x) - n_x // 2 + (nx - 1) * upsample_x // 2
    x_axis = data.array.x[0] + jx * px
    img = img[jx % n_x]
    ny_step = period_y / n_y
    # below a surface the image's y is the depth under it, y - h
    first = int(np.ceil((y_lo - height) / ny_step))
    last = int(np.floor((y_hi - height) / ny_step))
    if last - first + 1 > n_y:
        last = first + n_y - 1  # the crop is longer than the y period
    iy = np.arange(first, last + 1)
    if iy.size == 0:
        raise InputError(f"the crop [{y_lo}, {y_hi}] m holds no pixel of {ny_step:g} m")
    return img[:, iy % n_y], x_axis, height + iy * ny_step
