"""Baseband frequency samples of every antenna, from its range profile: the
input of the Capon range filter (:mod:`rpm_cl.extract.capon`) and of RMA
(:mod:`rpm_cl.baselines.rma`).

:func:`frequency_samples` recovers ``Y(f)`` on a grid ``f_k = k df`` from
``s(X, R)``: the FFT along R where the range window spans enough range
resolutions, else a least-squares fit over the whole band by a
truncated-SVD pseudo-inverse (:func:`_band_limited_fit`, the same bit for
bit whatever the number of BLAS threads); the matched-filter weight
(:func:`matched_filter_weight`) is divided out or kept.
"""

from __future__ import annotations

import numpy as np

from ..io.data import C0, InputError, RadarData

__all__ = ["frequency_samples", "matched_filter_weight"]

#: Default lower bound of the matched-filter weight ``W(f) = cos^4(pi f/2B)``
#: on the kept band: ``W >= 0.01`` keeps ``|f| <= 0.80 B`` and bounds the
#: inverse filter's noise gain ``1/W`` at 100.
MIN_WEIGHT_DEFAULT = 0.01
#: Default shortest fitted range period, in range resolutions ``c/2B`` (see
#: :func:`frequency_samples`).
MIN_PERIOD_CELLS_DEFAULT = 10.0


#: Relative singular-value cutoff of the band-limited fit (see
#: :func:`frequency_samples`): components of the model below ``FIT_RCOND``
#: times the largest singular value are dropped (truncated SVD).
FIT_RCOND = 3e-11
#: Antennas per block of the fit's matrix product (temporaries stay small).
_FIT_CHUNK = 4096


def _fit_rcond(dtype) -> float:
    """Cutoff for data of ``dtype``: FIT_RCOND, or twice the unit roundoff
    when that is coarser (complex64 data are only known to 2**-24)."""
    eps = np.finfo(np.result_type(dtype, np.float32)).eps  # 2 * unit roundoff
    return max(FIT_RCOND, float(eps))


def _householder_qr(a: np.ndarray):
    """Householder QR of a tall matrix with NumPy reductions only (no BLAS).

    Parameters
    ----------
    a : ndarray, complex, shape (m, n), m >= n

    Returns
    -------
    vs : list of ndarray
        Unit Householder vectors, ``vs[j]`` of shape (m - j,) (None where the
        column below the diagonal is already zero).
    r : ndarray, complex128, shape (n, n)
        Upper triangular, ``a = Q [r; 0]`` with ``Q = H_0 H_1 ... H_{n-1}``,
        ``H_j = I - 2 v_j v_j^H``.
    """
    r = np.array(a, np.complex128)
    n = r.shape[1]
    vs = []
    for j in range(n):
        x = r[j:, j]
        norm = np.sqrt(np.sum(x.real**2 + x.imag**2))
        if norm == 0:
            vs.append(None)
            continue
        v = x.copy()
        v[0] += (x[0] / abs(x[0]) if x[0] != 0 else 1.0) * norm  # no cancellation
        v /= np.sqrt(np.sum(v.real**2 + v.imag**2))
        r[j:, j:] -= 2.0 * v[:, None] * np.sum(v.conj()[:, None] * r[j:, j:], axis=0)
        vs.append(v)
    return vs, np.triu(r[:n])


def _band_limited_fit(nr: int, step: float, k: np.ndarray, rcond: float) -> np.ndarray:
    """Truncated-SVD pseudo-inverse of ``A[n, i] = exp(2 pi j n k_i step)``.

    ``A = Q R`` (Householder, :func:`_householder_qr`), ``R = U S V^H``
    (LAPACK on the small ``len(k)`` square matrix), singular values below
    ``rcond * S[0]`` dropped: ``A^+ = V S^-1 U^H Q^H`` on the kept ones.  With
    fewer range gates than frequencies (a wide matrix) the same is done on
    ``A^H``, whose pseudo-inverse is that of ``A`` transposed and conjugated
    (the minimum-norm fit, as ``lstsq`` gave).
    Every product is a NumPy reduction or ``einsum`` and the only LAPACK call
    is on a matrix far below BLAS's threading thresholds, so the operator is
    the same bit for bit whatever the number of BLAS threads (``lstsq`` on the
    tall matrix was not: its QR runs threaded BLAS, and with the full rank
    kept, rounding amplified by 1e14 changed the RPs).

    Parameters
    ----------
    nr : int
        Range gates (rows).
    step : float
        ``dr / T``: range gate over the fitted period.
    k : ndarray of int, shape (n,)
        Frequency indices (columns), n <= nr.
    rcond : float
        Relative singular-value cutoff.

    Returns
    -------
    ndarray, complex128, shape (n, nr)
        ``coef = op @ s`` fits ``s`` (nr,) by ``A coef``.
    """
    a = np.exp(2j * np.pi * np.outer(np.arange(nr), k) * step)
    tall = nr >= k.size
    mat = a if tall else a.conj().T  # (p, q), p >= q
    p, q = mat.shape
    vs, r = _householder_qr(mat)
    u, sv, vh = np.linalg.svd(r)
    keep = sv > rcond * sv[0]
    # the first q columns of Q: the reflections applied, last first, to [I; 0]
    q1 = np.eye(p, q, dtype=np.complex128)
    for j in range(q - 1, -1, -1):
        v = vs[j]
        if v is not None:
            q1[j:] -= 2.0 * v[:, None] * np.sum(v.conj()[:, None] * q1[j:], axis=0)
    inner = np.einsum("ki,i,ji->kj", vh[keep].conj().T, 1.0 / sv[keep], u[:, keep].conj())
    op = np.einsum("kj,rj->kr", inner, q1.conj())  # mat's pseudo-inverse, (q, p)
    return op if tall else op.conj().T


def matched_filter_weight(f, bandwidth: float) -> np.ndarray:
    """The matched-filter spectrum ``W(f) = |P(f)|^2 = cos^4(pi f / 2B)``.

    Parameters
    ----------
    f : array_like
        Baseband frequencies, Hz.
    bandwidth : float
        B, Hz (rpm_cl.simulate's ``P(f) = cos^2(pi f / 2B)`` for ``|f| < B``).

    Returns
    -------
    ndarray, same shape as ``f``
        0 outside ``|f| < B``; 1 at ``f = 0``.
    """
    f = np.asarray(f, np.float64)
    return np.where(np.abs(f) < bandwidth, np.cos(np.pi * f / (2 * bandwidth)) ** 4, 0.0)


def frequency_samples(
    data: RadarData,
    *,
    min_weight: float = MIN_WEIGHT_DEFAULT,
    min_period_cells: float = MIN_PERIOD_CELLS_DEFAULT,
    deconvolve: bool = True,
    zero_pad: int = 1,
):
    """Baseband frequency samples ``Y(f)`` of every antenna, from ``s(X, R)``.

    ``s(R_n) = sum_k c_k exp(+j 4 pi f_k (R_n - R_0) / c)``, ``R_0 =
    data.range[0]``, is solved for ``c_k`` on the grid ``f_k = k df``,
    ``|f_k| < B``; then ``Y(f_k) = g c_k exp(-j 4 pi f_k R_0 / c) / W(f_k)``:
    the range axis's origin restored (so a target at range ``R`` contributes
    ``a exp(-j 4 pi (fc + f) R / c)`` whatever ``R_0``), ``W`` divided out when
    ``deconvolve``, and ``g = sum_k W(f_k)`` the gain that makes a lone echo
    of amplitude ``a`` give ``|Y| = a`` (``s`` is normalised by it).

    The grid spacing is ``df = c / (2 T)``, ``T = zero_pad * max(nr dr,
    min_period_cells * c / 2B)``:

    - *FFT* -- when the range window ``nr dr`` spans at least
      ``min_period_cells`` resolutions: the coefficients are the FFT of ``s``
      along R, zero-padded to ``zero_pad * nr`` (the spectrum of the windowed
      profile; the least-squares fit on the FFT's own grid).  Exact when the
      window holds the echoes' whole responses: the human-body preset (1 m
      window, 50 mm cells) matches the simulator's spectrum to 1e-5.
    - *Band-limited extrapolation* -- a shorter window cuts the responses
      (the paper-2d preset: 1.5 m, 2 resolutions of 750 mm, targets 0.45 m
      from R = 0), and its 3 in-band FFT bins are wrong by 25-35 %.  The
      coefficients are then the least-squares fit on the whole band
      ``|f| < B`` with the period ``T``, by a truncated-SVD pseudo-inverse
      (below).  A lone echo's spectrum (paper-2d's waveform and window) is
      fitted to 1.1e-2 with 5 resolutions and 1.2e-4 with 10, the default
      (at most 2.3e-4 for echoes anywhere in the window; absolute errors of
      samples of unit modulus; Capon's super-resolution needs the latter).
      The fit amplifies noise: at 20 dB
      paper-2d's samples are off by 7 % rms (against 36 % for human-body's
      FFT samples, whose S/N per echo is lower), and Capon results on such
      data measure this extrapolation as well as the filter.

    *Cutoff of the fit.*  The model matrix ``A[n, k] = exp(+j 4 pi f_k n dr /
    c)`` is ill-conditioned: its singular values fall geometrically (paper-2d,
    10 resolutions: 19 columns, ``s_min / s_max = 6e-15``; 5 resolutions:
    2e-4).  A component with singular value ``s_i`` changes the fitted window
    by ``s_i / s_max`` of its share of the spectrum, so below the data's
    relative precision it is not determined by the data, only by their
    rounding, amplified ``s_max / s_i`` times.  ``numpy.linalg.lstsq``
    (``rcond=None``, cutoff 1.3e-13) kept such components, and its QR runs
    threaded BLAS, so the samples changed by 2e-4 with the number of BLAS
    threads (1 or 2) and paper-2d's noise-free RPs from 18 to 20.  Here the
    pseudo-inverse drops singular values below ``FIT_RCOND = 3e-11`` of the
    largest, which

    - bounds the amplification of rounding (1.1e-16 in complex128) at 4e-6,
      50 times below the fit's own error (2.3e-4 above);
    - lies in the middle of the measured plateau: the lone echo's worst
      error over the window is 2.3e-4 for cutoffs from 1e-11 to 1e-10,
      3.4e-4 at 1e-12 and 1.1e-3 at 1e-13 (rounding amplified), 2.1e-3 at
      3e-10 and 1.5e-2 at 1e-8 (signal dropped); paper-2d keeps 16 of 19
      components, the nearest singular values (1.1e-10 and 5.8e-12) 4 and 5
      times from the cutoff;
    - is raised to twice the unit roundoff (1.2e-7) for complex64 data,
      which hold 7 significant digits: at ``lstsq``'s cutoff their rounding,
      amplified up to 1e13 times, leaves nothing to fit (0 RPs on noise-free
      paper-2d); at this one 3 of 4 RPs are within 10 mm and a lone echo is
      fitted to 1.2e-1, what 7 digits allow for this extrapolation.

    The operator is computed once per call by a Householder QR in NumPy
    reductions and an SVD of the small triangular factor, and applied with
    ``einsum``: no step runs threaded BLAS, so the samples, and the RPs, are
    the same bit for bit whatever ``OPENBLAS_NUM_THREADS`` is.

    Parameters
    ----------
    data : RadarData
        Linear or planar.
    min_weight : float
        Keep the samples where ``W(f) >= min_weight`` (0 < min_weight <= 1):
        the band where the spectrum is significant, and a bound ``1/min_weight``
        on the noise gain of the division by ``W``; 0.01 keeps
        ``|f| <= 0.80 B``, 0.1 keeps ``|f| <= 0.62 B``.
    min_period_cells : float
        Shortest fitted range period, in resolutions ``c / 2B`` (>= 0; 0 is
        always the FFT).
    deconvolve : bool
        Divide by ``W`` (the inverse filter).  If False, ``Y`` keeps the
        matched-filter weight: a lone echo gives ``a W(f) exp(...)``.
    zero_pad : int
        Grid refinement factor (>= 1): the FFT's zero-padding factor, or the
        fitted period's multiplier.

    Returns
    -------
    f : ndarray, shape (L,)
        Baseband frequencies, Hz, increasing, spaced ``df``; the RF
        frequency is ``fc + f``.
    Y : ndarray, complex128, shape (n_antennas, L)
        Samples per antenna (flat antenna index, C order of the array).

    Raises
    ------
    InputError
        Bad options, or fewer than 2 samples in the kept band.
    """
    if not (0 < min_weight <= 1):
        raise InputError(f"min_weight must be in (0, 1], got {min_weight}")
    if not (np.isfinite(min_period_cells) and min_period_cells >= 0):
        raise InputError(f"min_period_cells must be >= 0, got {min_period_cells}")
    if int(zero_pad) != zero_pad or zero_pad < 1:
        raise InputError(f"zero_pad must be an integer >= 1, got {zero_pad}")
    zero_pad = int(zero_pad)
    bw, res = data.waveform.bandwidth, data.waveform.range_resolution
    nr, dr = data.range.size, data.dr
    s = data.signal.reshape(-1, nr)
    window = nr * dr
    use_fft = window >= min_period_cells * res
    period = zero_pad * (window if use_fft else min_period_cells * res)
    df = C0 / (2.0 * period)
    # the model grid: every bin inside |f| < B (W > 0)
    n_all = int(np.ceil(bw / df * (1 - 1e-12))) - 1
    k_all = np.arange(-n_all, n_all + 1)
    f_all = k_all * df
    if use_fft:
        n_fft = zero_pad * nr
        if 2 * n_all + 1 > n_fft:  # only with a range axis coarser than c/4B
            raise InputError(
                f"range spacing {dr:g} m aliases the band: it must be below "
                f"c/(4B) = {C0 / (4 * bw):g} m"
            )
        # zero-padding interpolates the unpadded grid's coefficients, whose
        # normalisation sum_k W(f_k) is 1/zero_pad of the fine grid's
        coef = np.fft.fft(s, n=n_fft, axis=1)[:, k_all % n_fft] / (nr * zero_pad)
    else:
        op = _band_limited_fit(nr, dr / period, k_all, _fit_rcond(s.dtype))
        coef = np.empty((s.shape[0], k_all.size), np.complex128)
        for lo in range(0, s.shape[0], _FIT_CHUNK):  # bounded temporaries
            coef[lo : lo + _FIT_CHUNK] = np.einsum("ar,kr->ak", s[lo : lo + _FIT_CHUNK], op)
    w_all = matched_filter_weight(f_all, bw)
    keep = w_all >= min_weight
    if keep.sum() < 2:
        raise InputError(
            f"fewer than 2 frequency samples (spacing {df:g} Hz) where the "
            f"matched-filter weight is >= {min_weight}; lower min_weight"
        )
    f = f_all[keep]
    y = coef[:, keep] * np.exp(-4j * np.pi * f * data.range[0] / C0) * w_all.sum()
    if deconvolve:
        y = y / w_all[keep]
    return f, y
