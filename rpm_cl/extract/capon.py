"""Capon (MVDR) range filter with frequency averaging: the paper's comparator.

The paper compares k-space RPM with RPM on RPs from a Capon range filter
(its refs. [18], [23]) with "a simple frequency averaging scheme, in which the
number of averaging is optimized [...] to retain the resolution for highly
correlated signal decomposition" (Section V-A2).  This module is that filter.

Model
-----
*Frequency samples* (:func:`frequency_samples`).  The matched-filter output is
``s(R) = sum_f W(f) Y(f) exp(+j 4 pi f R / c) / sum_f W(f)`` with the
matched-filter weight ``W(f) = |P(f)|^2 = cos^4(pi f / 2B)`` (``|f| < B``,
rpm_cl.simulate) and, for echoes of amplitude ``a_e`` at ranges ``R_e``,
``Y(f) = sum_e a_e exp(-j 4 pi (fc + f) R_e / c)``.  The samples of ``Y`` on a
grid ``f_k = k df`` are recovered by least squares from ``s(X, R)`` (see
:func:`frequency_samples` for the grid and why it is not always the FFT's)
and divided by ``W`` (the "inverse filter" the paper names as the reason the
Capon filter is sensitive to noise), so a target at range ``R`` contributes
``a exp(-j 4 pi (fc + f) R / c)`` whatever the range axis's origin.

*Capon spectrum* (:func:`capon_profiles`).  With ``L`` samples per antenna,
the ``K = L - M + 1`` sub-bands ``y_m = Y[m : m + M]`` are averaged into
``Rxx = sum_m y_m y_m^H / K`` (frequency averaging: the sub-band version of
spatial smoothing, which decorrelates coherent echoes -- without it the
covariance of one snapshot has rank one and Capon resolves nothing), loaded
with ``loading * trace(Rxx) / M`` on the diagonal, and
``P(R) = 1 / (a(R)^H Rxx^-1 a(R))`` with ``a_i(R) = exp(-j 4 pi f_i R / c)``
over the first sub-band's frequencies (a common phase cancels).  The
quadratic form is evaluated from the eigen-decomposition of ``Rxx`` as a sum
of positive terms, batched over antennas and range gates.  ``|a|^2 = M``, so
a lone echo of amplitude ``a`` gives ``P(R_e) = a^2`` (plus the loading's
share): ``sqrt(P)`` is on the scale of the matched filter's ``|s|``.

*Range points* (:func:`rps_from_capon`): local maxima of ``P`` along R per
antenna, each refined by maximising ``P(R)`` between its neighbouring gates,
all in one cluster (as :func:`rpm_cl.extract.rangepoints.rps_from_profiles` does for
the matched filter); the RP amplitude is ``sqrt(P)`` at the refined peak.

Defaults, measured (Err_range <= 10 mm; 20 dB pooled over seeds 0-4 for
paper-2d; ``min_weight`` / sub-band rule / loading; the same with 1 and 2
BLAS threads, see :func:`frequency_samples`):

=====================  ================  ==================  ==================
setting                paper-2d, inf     paper-2d, 20 dB     human-body, inf
=====================  ================  ==================  ==================
0.01 / L//3 / 1e-9     89 % (16/18)      69 % (43/62)        100 % (388/388)
0.01 / L//3 / 1e-6     100 % (4/4)       69 % (43/62)        98 % (423/430)
0.01 / L//4 / 1e-9     100 % (2/2)       62 % (50/80)        99 % (469/473)
0.01 / L//2 / 1e-9     87 % (13/15)      70 % (31/44)        100 % (232/232)
0.1 / L//3 / 1e-9      78 % (7/9)        57 % (40/70)        99 % (411/414)
0.1 / L//2 / 1e-9      79 % (15/19)      72 % (28/39)        100 % (242/242)
matched filter         65 % (11/17)      64 % (54/85)        65 % (181/278)
=====================  ================  ==================  ==================

Over more noise: the default gives 70 % (84/120) on paper-2d at 20 dB over
seeds 0-9, and on human-body 100 % (388/388) noise-free, 59 % (1698/2890) at
20 dB over seeds 0-9.  The default (first row) is the one accurate on both
presets with a useful number of RPs; the paper-2d column moves by whole RPs
between neighbouring settings (its three echoes lie within 0.05-0.15 of a
resolution of each other, at the edge of what Capon resolves), and with the
band-limited fit's cutoff (noise-free RPs, within 10 mm / all: 2/3 with the
cutoff at 1e-13 or below, 13/14 at 1e-12, 16/18 from 1e-11 to 1e-10, 17/19
at 1e-9, 17/21 at 1e-8, 7/9 at 1e-7; the 20 dB pool stays at 64-70 %).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..io.data import C0, InputError, RadarData
from .rangepoints import RangePoints, _make

__all__ = [
    "CaponParams",
    "capon_profiles",
    "frequency_samples",
    "matched_filter_weight",
    "rps_from_capon",
]

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
      which hold 7 significant digits: with ``lstsq`` their rounding,
      amplified up to 1e13 times, left nothing to fit (0 RPs on noise-free
      paper-2d); now 3 of 4 RPs are within 10 mm and a lone echo is fitted
      to 1.2e-1, what 7 digits allow for this extrapolation.

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


@dataclass(frozen=True)
class CaponParams:
    """Settings of the Capon range filter.

    Attributes
    ----------
    n_sub : int or None
        Sub-band length ``M`` (samples); ``K = L - M + 1`` sub-bands are
        averaged for ``L`` frequency samples.  None: ``M = max(2, L // 3)``,
        ``K ~ 2M``.  ``M`` sets the resolution (the sub-band spans ``M df``
        of the band); ``K`` the decorrelation of coherent echoes, which needs
        at least as many sub-bands as interfering echoes and, for echoes
        ``dR`` apart, a phase turn ``4 pi K df dR / c`` that is not small
        (0.3 rad over the whole band for paper-2d's 40 mm spacings, so more
        averaging keeps paying).  A third is the split measured best on both
        presets (module docstring); the paper "optimises" this number the
        same way.
    loading : float
        Diagonal loading relative to the mean eigenvalue ``trace(Rxx)/M``
        (>= 0).  The default 1e-9 is no robustness setting: noisy data load
        themselves with their noise floor, and noise-free data need the
        smallest loading that keeps ``Rxx`` (rank min(K, echoes)) invertible,
        because paper-2d's echoes lie 0.05 of a resolution apart: at 1e-6 only
        4 of its noise-free RPs pass the -10 dB threshold instead of 16 (the
        peaks' heights spread), and human-body's accuracy drops from 100 % to
        98 %.
        ``P`` is computed from the eigen-decomposition as a sum of positive
        terms, so 1e-9 is numerically safe in float64.
    min_weight : float
        Band kept, see :func:`frequency_samples`; 0.01 (``|f| <= 0.80 B``)
        resolves more than 0.1 (``|f| <= 0.62 B``) on both presets.
    min_period_cells : float
        Shortest fitted range period, see :func:`frequency_samples`; 10
        resolutions fit a lone echo's spectrum in paper-2d's window to 1.2e-4
        (5: 1.1e-2, too coarse for Capon's super-resolution).
    """

    n_sub: int | None = None
    loading: float = 1e-9
    min_weight: float = MIN_WEIGHT_DEFAULT
    min_period_cells: float = MIN_PERIOD_CELLS_DEFAULT

    def __post_init__(self):
        if self.n_sub is not None and (
            isinstance(self.n_sub, bool) or int(self.n_sub) != self.n_sub or self.n_sub < 2
        ):
            raise InputError(f"n_sub must be an integer >= 2 or None, got {self.n_sub!r}")
        if not (np.isfinite(self.loading) and self.loading >= 0):
            raise InputError(f"loading must be finite and >= 0, got {self.loading}")
        if not (0 < self.min_weight <= 1):
            raise InputError(f"min_weight must be in (0, 1], got {self.min_weight}")
        if not (np.isfinite(self.min_period_cells) and self.min_period_cells >= 0):
            raise InputError(f"min_period_cells must be >= 0, got {self.min_period_cells}")

    def sub_band(self, n_samples: int) -> int:
        """Sub-band length ``M`` for ``n_samples`` frequency samples.

        Raises
        ------
        InputError
            ``n_sub`` larger than the number of samples.
        """
        m = max(2, n_samples // 3) if self.n_sub is None else int(self.n_sub)
        if m > n_samples:
            raise InputError(f"n_sub={m} exceeds the {n_samples} frequency samples in the band")
        return m


def _whitening_filters(data: RadarData, params: CaponParams):
    """The Capon quadratic form of every antenna, factored.

    ``Rxx = U diag(lam) U^H`` (frequency averaged, ``lam`` loaded), so
    ``a^H Rxx^-1 a = sum_i |u_i^H a|^2 / lam_i = |V^H a|^2`` with
    ``V = U diag(lam^-1/2)``: a sum of positive terms, accurate however
    ill-conditioned ``Rxx`` is.

    Returns
    -------
    f_sub : ndarray, shape (M,)
        Frequencies of the first sub-band relative to its first one, Hz (a
        common phase of the steering vector cancels in ``a^H Rxx^-1 a``).
    v : ndarray, complex, shape (n_antennas, M, M)
    """
    f, y = frequency_samples(
        data, min_weight=params.min_weight, min_period_cells=params.min_period_cells
    )
    m = params.sub_band(f.size)
    k = f.size - m + 1
    sub = np.lib.stride_tricks.sliding_window_view(y, m, axis=1)  # (n, K, M)
    rxx = np.einsum("nki,nkj->nij", sub, sub.conj()) / k
    lam, u = np.linalg.eigh(rxx)
    lam = np.maximum(lam, 0.0)  # rounding can leave tiny negatives
    mean = lam.sum(axis=1, keepdims=True) / m
    # a profile without signal (mean 0): any loading (its V is zeroed below)
    load = np.where(mean > 0, params.loading * mean, 1.0)
    lam = lam + np.maximum(load, np.finfo(np.float64).tiny)
    v = u / np.sqrt(lam)[:, None, :]
    # no signal at all: no spectrum (P = 0 below), not the flat 1/M whose
    # rounding ripples would be taken for peaks
    v[mean[:, 0] <= 0] = 0.0
    return f[:m] - f[0], v


def _power(f_sub: np.ndarray, v: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``P = 1 / (a^H Rxx^-1 a)``, each antenna at its own ranges.

    Parameters
    ----------
    f_sub : ndarray, shape (M,)
        Hz.
    v : ndarray, complex, shape (n, M, M)
        From :func:`_whitening_filters`.
    r : ndarray, shape (n, q) or (q,)
        Ranges, m; (q,) evaluates every antenna on the same ranges.

    Returns
    -------
    ndarray, shape (n, q)
    """
    phase = -4j * np.pi / C0
    if r.ndim == 1:
        a = np.exp(phase * np.outer(f_sub, r))  # (M, q), shared
        proj = np.einsum("nmi,mq->niq", v.conj(), a)
    else:
        a = np.exp(phase * f_sub[None, :, None] * r[:, None, :])  # (n, M, q)
        proj = np.einsum("nmi,nmq->niq", v.conj(), a)
    q = np.sum(proj.real**2 + proj.imag**2, axis=1)
    with np.errstate(divide="ignore"):
        return np.where(q > 0, 1.0 / np.where(q > 0, q, 1.0), 0.0)


def capon_profiles(data: RadarData, params: CaponParams | None = None) -> np.ndarray:
    """Capon spectrum ``P(R) = 1 / (a(R)^H Rxx^-1 a(R))`` on ``data.range``.

    Parameters
    ----------
    data : RadarData
        Linear or planar.
    params : CaponParams, optional

    Returns
    -------
    ndarray, float64, shape of ``data.signal`` ((nx, nr) or (nx, nz, nr))
        Capon power, >= 0, on the scale of ``|s|^2`` (a lone echo of
        amplitude ``a`` gives ``a^2`` at its range).
    """
    f_sub, v = _whitening_filters(data, params or CaponParams())
    return _power(f_sub, v, data.range).reshape(data.signal.shape)


#: Golden-section steps of the peak refinement: the bracket of two range
#: gates shrinks by 0.618 per step, to 1e-7 of a gate after 34.
_REFINE_STEPS = 34


def _refine_peaks(f_sub, v, row, r_lo, r_hi):
    """Maximise ``P(R)`` of antenna ``row`` over ``[r_lo, r_hi]`` (golden section).

    Parameters
    ----------
    f_sub : ndarray, shape (M,)
    v : ndarray, complex, shape (n_antennas, M, M)
    row : ndarray of int, shape (K,)
    r_lo, r_hi : ndarray, shape (K,)
        Bracket of each peak, m.

    Returns
    -------
    r : ndarray, shape (K,)
        Range of the maximum, m.
    power : ndarray, shape (K,)
        ``P`` there.
    """
    g = (np.sqrt(5.0) - 1.0) / 2.0
    vr = v[row]
    a, b = np.asarray(r_lo, np.float64), np.asarray(r_hi, np.float64)
    c, d = b - g * (b - a), a + g * (b - a)
    pc, pd = _power(f_sub, vr, np.stack([c, d], 1)).T
    for _ in range(_REFINE_STEPS):
        left = pc > pd  # the maximum lies in [a, d]
        a, b = np.where(left, a, c), np.where(left, d, b)
        new = np.where(left, b - g * (b - a), a + g * (b - a))
        p_new = _power(f_sub, vr, new[:, None])[:, 0]
        c, d = np.where(left, new, d), np.where(left, c, new)
        pc, pd = np.where(left, p_new, pd), np.where(left, pc, p_new)
    r = 0.5 * (a + b)
    return r, _power(f_sub, vr, r[:, None])[:, 0]


def rps_from_capon(
    data: RadarData, params: CaponParams | None = None, rp_threshold_db: float = -10.0
) -> RangePoints:
    """RPs at the local maxima of the Capon profiles: one cluster.

    Every local maximum of ``P`` on ``data.range`` (per antenna) is refined by
    maximising ``P(R)`` itself between the neighbouring range gates (golden
    section), not by a parabola: with little loading a Capon peak can be much
    narrower than a range gate, so its sampled height and a parabola through
    it say little about its true height and place.  Peaks whose refined
    ``sqrt(P)`` is below ``rp_threshold_db`` of the largest (over all
    antennas) are dropped, as for the matched filter's ``|s|``.

    Parameters
    ----------
    data : RadarData
    params : CaponParams, optional
    rp_threshold_db : float
        dB (< 0).

    Returns
    -------
    RangePoints
        Cluster 0 for all; ``range`` the refined peak, m; ``amp`` is
        ``sqrt(P)`` there (an amplitude, on the scale of the matched filter's
        ``|s|``).
    """
    if not (np.isfinite(rp_threshold_db) and rp_threshold_db < 0):
        raise InputError(f"rp_threshold_db must be < 0, got {rp_threshold_db}")
    f_sub, v = _whitening_filters(data, params or CaponParams())
    rng = data.range
    p = _power(f_sub, v, rng)
    mid = p[:, 1:-1]
    row, col = np.nonzero((mid > p[:, :-2]) & (mid >= p[:, 2:]))
    r, power = _refine_peaks(f_sub, v, row, rng[col], rng[col + 2])
    amp = np.sqrt(power)
    keep = amp >= 10.0 ** (rp_threshold_db / 20.0) * (amp.max() if amp.size else 0.0)
    return _make(data, row[keep], r[keep], amp[keep], np.zeros(int(keep.sum()), int))
