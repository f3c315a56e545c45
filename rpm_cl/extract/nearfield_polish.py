"""The near-field decomposition's last steps (:mod:`rpm_cl.extract.nearfield`):
the real-amplitude model that polishes the centres, and the clusters of the
joint fit over every range gate.

:func:`_real_fit` fits spherical waves with one phase each and real
polynomial envelopes (``ENVELOPE_TERMS`` terms) to the data; :class:`_Polish`
gives its residual and variable-projection Jacobian to ``least_squares``;
:func:`_clusters` cuts each centre's term of the final fit into a
:class:`rpm_cl.extract.types.Cluster`.
"""

from __future__ import annotations

import numpy as np

from .nearfield_model import _basis, _steer
from .types import Cluster

#: Terms of the polynomial envelope across X in the final fit (4: a target
#: 20 degrees off axis at 0.4 m migrates 140 mm across the sparse aperture;
#: 3 terms leave up to 7 mm of RP error on it, 4 terms under 1 mm).
ENVELOPE_TERMS = 4


def _real_fit(x, k0, centres, terms, s):
    """Fit with real coefficients; ``centres`` rows are (u, r, psi).

    Returns the complex design matrix, the coefficients and the residual
    (real and imaginary parts stacked)."""
    c = np.atleast_2d(np.asarray(centres, float))
    b = _basis(x, terms)
    d = (_steer(x, c[:, 0], c[:, 1], k0) * np.exp(1j * c[:, 2])[None])[:, :, None] * b[:, None, :]
    d = d.reshape(x.size, -1)
    dr = np.concatenate([d.real, d.imag])
    sr = np.concatenate([s.real, s.imag])
    coef, *_ = np.linalg.lstsq(dr, sr, rcond=None)
    return d, coef, sr - dr @ coef


class _Polish:
    """Residual and Jacobian of the real-amplitude fit (:func:`_real_fit`)
    as functions of the centres' (u, r, psi), for ``least_squares``.

    The Jacobian is Kaufman's variable-projection one, ``-P (dD/dv) c``
    (``P`` the projector off the model's columns, ``c`` the fitted real
    coefficients): analytic, one evaluation instead of one per parameter,
    and its gradient ``J^T res`` is the exact one (the term it drops is
    orthogonal to the residual), so the minimum is the same.
    """

    def __init__(self, x, k0, terms, s):
        self.x, self.k0, self.t = x, k0, terms
        self.b = _basis(x, terms)
        self.sr = np.concatenate([s.real, s.imag])
        self._v, self._fit = None, None

    def _solve(self, v):
        if self._v is None or not np.array_equal(v, self._v):
            c = v.reshape(-1, 3)
            e = _steer(self.x, c[:, 0], c[:, 1], self.k0) * np.exp(1j * c[:, 2])[None]  # (N, M)
            d = (e[:, :, None] * self.b[:, None, :]).reshape(self.x.size, -1)
            q, rr = np.linalg.qr(np.concatenate([d.real, d.imag]))
            qs = q.T @ self.sr
            self._v = np.array(v, copy=True)
            self._fit = (d, q, np.linalg.solve(rr, qs) if rr.size else qs, self.sr - q @ qs)
        return self._fit

    def fun(self, v):
        return self._solve(v)[3].ravel()

    def jac(self, v):
        d, q, coef, _ = self._solve(v)
        c = v.reshape(-1, 3)
        x, u, r = self.x[:, None], c[None, :, 0], c[None, :, 1]
        dist = np.sqrt(np.maximum(x * x - 2 * x * r * u + r * r, 1e-30))
        n, m = d.shape[0], c.shape[0]
        # d/du, d/dr, d/dpsi of each centre's column factor exp(-j2k0(d-r)+j psi), (N, M, 3)
        fac = np.stack(
            [
                2j * self.k0 * x * r / dist,
                -2j * self.k0 * ((r - x * u) / dist - 1.0),
                np.broadcast_to(1j, dist.shape),
            ],
            axis=-1,
        )
        fitted = np.einsum("nmt,mtg->nmg", d.reshape(n, m, self.t), coef.reshape(m, self.t, -1))
        e = fac[..., None] * fitted[:, :, None, :]  # (N, M, 3, G)
        er = np.concatenate([e.real, e.imag]).reshape(2 * n, 3 * m, -1)
        er = er - np.einsum("ik,kjg->ijg", q, np.einsum("ik,ijg->kjg", q, er))
        return -er.transpose(0, 2, 1).reshape(-1, 3 * m)


def _clusters(data, params, search, th, peaks):
    """The clusters of the polished centres, strongest map peak first.

    Parameters
    ----------
    data : RadarData
        Linear array.
    params : KSpaceParams
        ``range_gate`` (None: the range resolution).
    search : rpm_cl.extract.nearfield._Search
        The search the centres came from (array and range resolution).
    th : ndarray, shape (M, 3)
        Polished centres (u, r, psi): sin(theta), m, rad.
    peaks : list of float
        Each centre's map peak.

    Returns
    -------
    tuple of Cluster
        Each centre's term of the joint fit over every range gate, over the
        gates within ``range_gate`` of its range.
    """
    x, k0, n = search.x, search.k0, search.n
    sig = data.signal
    # the decomposition: the joint fit over every gate, one term per cluster
    d, coef, _ = _real_fit(x, k0, th, ENVELOPE_TERMS, sig)
    t = ENVELOPE_TERMS
    rng, dr = data.range, data.dr
    gate = params.range_gate or search.res_r
    clusters = []
    for m, (u, r, _) in enumerate(th):
        s_m = d[:, m * t : (m + 1) * t] @ coef[m * t : (m + 1) * t]
        ir = int(np.clip(np.round((r - rng[0]) / dr), 0, rng.size - 1))
        lo = max(0, int(np.floor(ir - gate / dr)))
        hi = min(rng.size, int(np.ceil(ir + gate / dr)) + 1)
        # not aligned (offset 0): the envelope terms follow the range walk
        clusters.append(
            Cluster(
                np.array([2 * k0 * u]),
                float(r),
                slice(lo, hi),
                s_m[:, lo:hi],
                peaks[m],
                np.zeros(n),
                np.zeros(1),
            )
        )
    order = np.argsort([-c.peak for c in clusters], kind="stable")
    return tuple(clusters[i] for i in order)
