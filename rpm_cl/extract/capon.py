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
from .frequency import (
    MIN_PERIOD_CELLS_DEFAULT,
    MIN_WEIGHT_DEFAULT,
    frequency_samples,
    matched_filter_weight,
)
from .rangepoints import RangePoints, _make

# isort: split
# The band-limited fit's parts that the tests name in this module,
# importable from here as well as from rpm_cl.extract.frequency:
from .frequency import FIT_RCOND, _band_limited_fit, _fit_rcond  # noqa: F401

__all__ = [
    "CaponParams",
    "capon_profiles",
    "frequency_samples",
    "matched_filter_weight",
    "rps_from_capon",
]


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
