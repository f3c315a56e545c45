"""Range-walk alignment of the k-space decomposition's clusters
(:mod:`rpm_cl.extract.kspace`, step 4).

Each antenna's profile is shifted in range by the cluster's range walk
(cubic B-spline interpolation along R, :func:`shift_rows`), for the alias of
the cluster's k whose alignment gives the largest coherent peak
(:func:`_alias_options`, :func:`_block_profile`), and focused where the
cluster is (:mod:`rpm_cl.extract.kspace_focus`).

The steps named in the docstrings below ("module notes, step N") are those
of the notes of :mod:`rpm_cl.extract.kspace`.
"""

from __future__ import annotations

import numpy as np

from ..io.data import InputError, RadarData
from .kspace_focus import _autofocus, _focus_range
from .kspace_geometry import _centred_grids

#: A non-principal alias must give a coherent peak this much larger (module notes, step 4).
ALIAS_MARGIN = 1.05
#: With focusing (sub-aperture ranking), a non-principal alias is taken only
#: where its aligned coherent peak lies within this many range resolutions
#: of the cluster's own gate (module notes, step 4): one sub-aperture can
#: carry the ranking.  At a half-wavelength pitch every direction has a visible
#: alias (|u| and |u| - 1); on 45 x 45 antennas at 7.5 mm, 20 GHz, a weak
#: cluster of the nearest sphere took u_z = 0.9 because its shifts carried a
#: stronger sphere's echo in at the edge of its gates, 0.1 m from its own.
ALIAS_REACH = 0.5
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
        (:func:`rpm_cl.filters.spline_filter_nearest`, SciPy's
        ``ndimage.spline_filter1d(..., order 3, mode="nearest")``).
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
    g, w = _taps(coeffs, shift, lo, hi)
    return (
        w[0] * g[:, 0:n] + w[1] * g[:, 1 : n + 1] + w[2] * g[:, 2 : n + 2] + w[3] * g[:, 3 : n + 3]
    )


def _taps(coeffs: np.ndarray, shift: np.ndarray, lo: int, hi: int):
    """The samples and weights :func:`shift_rows` combines: each row's
    coefficients at its gates ``lo - 1 .. hi + 1`` plus its whole shift
    (edge coefficients beyond the axis), shape (n_rows, hi - lo + 3), and
    the four cubic B-spline weights of its fractional shift, each (n_rows, 1)."""
    # beyond the axis every tap is an edge coefficient (and a huge shift
    # would overflow the integer index)
    shift = np.clip(shift, -coeffs.shape[1] - 2.0, coeffs.shape[1] + 2.0)
    i0 = np.floor(shift)
    t = (shift - i0)[:, None]
    nr = coeffs.shape[1]
    idx = i0.astype(np.intp)[:, None] + np.arange(lo - 1, hi + 2)[None, :]
    np.clip(idx, 0, nr - 1, out=idx)
    # one flat gather (take_along_axis builds a row index per sample: 3 ms
    # for 16384 rows of 8 taps against under 1 ms)
    idx += np.arange(0, idx.shape[0] * nr, nr, dtype=np.intp)[:, None]
    g = np.ascontiguousarray(coeffs).reshape(-1).take(idx)
    t2 = t * t
    t3 = t2 * t
    w0 = (1.0 - t) ** 3 / 6.0
    w1 = (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0
    w2 = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0
    w3 = t3 / 6.0
    return g, (w0, w1, w2, w3)


def coherent_sum(coeffs: np.ndarray, shift: np.ndarray, lo: int, hi: int, weights) -> np.ndarray:
    """``sum over rows of weights * shift_rows(coeffs, shift, lo, hi)``, per
    gate, without forming the shifted rows: four matrix-vector products
    with the taps (the autofocus compares one coherent sum per candidate
    wavefront; the shifted rows of a 128 x 128 array are 16384 x n complex
    samples, formed and summed on every try).

    Parameters
    ----------
    weights : ndarray, complex, shape (n_rows,)

    Returns
    -------
    ndarray, complex, shape (hi - lo,)
    """
    n = hi - lo
    if n <= 0:
        return np.zeros(0, complex)
    g, w = _taps(coeffs, shift, lo, hi)
    return sum((weights * w[k][:, 0]) @ g[:, k : k + n] for k in range(4))


def _block_profile(c: np.ndarray, block: int) -> np.ndarray:
    """Per range gate, the sum of |coherent sum| over sub-apertures.

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
    ndarray, shape (n_gates,)
        ``sum_b |sum_{X in b} c(X, g)|``; its largest value is the coherent
        peak the aliases are ranked by.
    """
    out = c
    for a in range(c.ndim - 1):
        n = c.shape[a]
        edges = np.linspace(0, n, max(1, round(n / max(block, 1))) + 1).astype(int)
        out = np.add.reduceat(out, edges[:-1], axis=a)
    return np.abs(out).reshape(-1, c.shape[-1]).sum(axis=0)


def _alias_options(data: RadarData, kc, k_periods, axes_x, kc_w) -> np.ndarray:
    """Range slopes u of a cluster at ``kc``: every alias with |u| < 1, the
    principal alias (smallest |u|) first.

    Returns
    -------
    ndarray, shape (n_options, n_k)
        One row of slopes per option (at least one: u = 0 where no alias
        lies within |u| < 1).

    Raises
    ------
    InputError
        More than ALIAS_MAX options, or ALIAS_MAX_AXIS along an axis.
    """
    n_k = len(kc)
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
    return options


def _plane_wave(kc, axes_x) -> np.ndarray:
    """exp(-j kc . X) across the array (the array's shape): the plane wave
    at ``kc`` of the coherent sum that ranks the aliases."""
    n_k = len(kc)
    steer = np.ones([1] * n_k)
    for a in range(n_k):
        shp = [1] * n_k
        shp[a] = -1
        steer = steer * np.exp(-1j * kc[a] * axes_x[a]).reshape(shp)
    return steer


def _align(
    data: RadarData,
    coeffs,
    kc,
    k_periods,
    axes_x,
    kc_w,
    lo,
    hi,
    r_c=None,
    autofocus=False,
    centre=None,
):
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

    ``centre``: the cluster's own gate (its k-space maximum), counted from
    ``lo``; with focusing, a non-principal alias whose aligned peak lies
    farther from it than :data:`ALIAS_REACH` range resolutions is not taken
    (module notes, step 4).  None: the middle of ``lo:hi``.

    Returns the range slopes u = dR_t/dX, the per-antenna offsets delta(X) (m),
    the aligned signal over range gates ``lo:hi`` and the focus factors
    (:attr:`Cluster.focus`; None unfocused).
    """
    n_k = len(kc)
    offsets = _centred_grids(axes_x)
    options = _alias_options(data, kc, k_periods, axes_x, kc_w)
    # a plane wave at kc, for the coherent sum that ranks the aliases
    steer = _plane_wave(kc, axes_x)
    # the coherent peak's sub-aperture, antennas a side (module notes, step
    # 4): the whole array unless focused
    block = (
        int(np.ceil(data.waveform.range_resolution * kc_w / np.pi))
        if r_c is not None
        else max(data.array.shape)
    )

    def aligned(delta, q, gates=(lo, hi), block=block):
        """The profiles shifted by ``delta`` (and the focus phase of ``q``
        removed) over ``gates``, their coherent peak at kc summed over
        sub-apertures of ``block`` antennas (:func:`_block_profile`) and the
        gate of that peak, counted from ``gates[0]``."""
        g0, g1 = gates
        sig = shift_rows(coeffs, delta.ravel() / data.dr, g0, g1)
        sig = sig.reshape(data.array.shape + (g1 - g0,))
        if q is not None:
            sig = sig * np.exp(2j * kc_w * q)[..., None]
        prof = _block_profile(sig * steer[..., None], block)
        if prof.size == 0:
            return sig, 0.0, None
        top = int(np.argmax(prof))
        return sig, float(prof[top]), top

    def whole_peak(delta, q, gates):
        """``aligned(delta, q, gates, whole aperture)``'s peak alone, from
        :func:`coherent_sum` (the autofocus's many tries)."""
        weights = steer if q is None else steer * np.exp(2j * kc_w * q)
        prof = np.abs(coherent_sum(coeffs, delta.ravel() / data.dr, *gates, weights.ravel()))
        return float(prof.max()) if prof.size else 0.0

    centre = (hi - lo - 1) / 2 if centre is None else centre
    reach = ALIAS_REACH * data.waveform.range_resolution / data.dr

    best = None
    for u in options:
        delta = sum(u[a] * offsets[a] for a in range(n_k))
        q = None
        if r_c is None:
            sig, peak, top = aligned(delta, None)
        else:
            # focused: ranked by the sub-aperture peak (module notes, step 4;
            # it replaced the better of the whole-aperture focused and plain
            # peaks, which took the u_x = -0.89 alias for the lower legs of
            # the human body seen by a 64 x 64 array)
            q = _focus_range(u, axes_x, r_c)
            delta = delta + q
            sig, peak, top = aligned(delta, q)
        # 5 % margin: a wrong alias misaligns the envelopes by a sizeable part
        # of the resolution and loses far more than that; near-ties (flat or
        # degenerate data) keep the principal alias.  A wrong alias's shifts
        # can also carry a stronger echo from beyond the cluster's gates into
        # them, whose peak then sits away from the cluster's own gate
        # (the aligned peak within ALIAS_REACH of the cluster's own gate)
        own_echo = top is not None and abs(top - centre) <= reach
        if best is None or (peak > ALIAS_MARGIN * best[0] and (r_c is None or own_echo)):
            best = (peak, u, delta, sig, q)
    _, u, delta, sig, q = best
    if r_c is None:
        return u, delta, sig, None
    # the whole aperture as one block: the coherent peak itself
    f = (
        _autofocus(whole_peak, delta - q, sig * steer[..., None], u, axes_x, r_c, lo, kc_w)
        if autofocus
        else None
    )
    if f is None:
        return u, delta, sig, np.ones(n_k)
    delta = delta - q
    q = _focus_range(u, axes_x, r_c, f)
    delta = delta + q
    return u, delta, aligned(delta, q)[0], f
