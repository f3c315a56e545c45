"""The near-field search's model (:mod:`rpm_cl.extract.nearfield`): spherical
waves times a polynomial envelope across the array, fitted with complex
amplitudes to the compressed data.

:class:`_Model` evaluates the residual energy of a set of centres, of one
more centre at each point of a grid (:meth:`_Model.scan`) and of two more at
each pair of grid points (:meth:`_Model.scan_pair`); the pair scans' 2 x 2
algebra is :func:`_pair_algebra`, the float64 NumPy reference of the
``pair_energy`` kernel (kernels/nearfield.cl, run by
:mod:`rpm_cl.extract.nearfield_cl`).  Below it, the small helpers they share:
steering vectors, the envelope's basis, Gram-Schmidt and closed-form 2 x 2
inverses.
"""

from __future__ import annotations

import numpy as np

from .nearfield_cl import DEGENERATE_DET

#: Grids of atoms kept per search (:meth:`_Model._atoms`; at most
#: N x 121 x SEARCH_TERMS complex numbers each, 81 kB for 21 antennas).
ATOM_CACHE = 128


def _steer(x, u, r, k0):
    """Spherical waves of points (u, r), shape (N, n): exp(-j 2 k0 (|X - p| - r))."""
    u, r = np.atleast_1d(u), np.atleast_1d(r)
    d = np.sqrt(np.maximum(x[:, None] ** 2 - 2 * x[:, None] * (r * u)[None] + (r * r)[None], 0.0))
    return np.exp(-2j * k0 * (d - r[None]))


def _basis(x, terms):
    """Orthonormal polynomials in X (real), shape (N, terms)."""
    t = (x - x.mean()) / max(0.5 * float(np.ptp(x)), 1e-12)
    q, _ = np.linalg.qr(np.stack([t**l for l in range(terms)], axis=1))
    return q


def _compress(s):
    """U * sigma of the SVD: the same least-squares residuals with at most N columns."""
    u, sv, _ = np.linalg.svd(s, full_matrices=False)
    return u * sv


class _Model:
    """Complex-amplitude model (search) on compressed data."""

    def __init__(self, x, k0, sc, terms, device=None):
        self.x, self.k0, self.sc = x, k0, sc
        self.b = _basis(x, terms).astype(complex)
        # the pair scans' OpenCL twin (rpm_cl.extract.nearfield_cl), or None: NumPy
        self.device = device
        self.energy = float(np.sum(np.abs(sc) ** 2))
        self.fits = 0  # candidate fits evaluated (see FIT_BUDGET)
        self._last = None
        self._atom_cache = {}

    def columns(self, centres):
        n = self.x.size
        if len(centres) == 0:
            return np.zeros((n, 0), complex)
        c = np.asarray(centres, float)
        a = _steer(self.x, c[:, 0], c[:, 1], self.k0)[:, :, None] * self.b[:, None, :]
        return a.reshape(n, -1)

    def residual(self, centres, s=None):
        s = self.sc if s is None else s
        q, _ = np.linalg.qr(self.columns(centres))
        return s - q @ (q.conj().T @ s)

    def cost(self, centres):
        self.fits += 1
        return float(np.sum(np.abs(self.residual(centres)) ** 2))

    def _projector(self, fixed):
        if fixed.shape[1] == 0:
            return lambda y: y
        q, _ = np.linalg.qr(fixed)
        return lambda y: y - q @ (q.conj().T @ y)

    def _atoms(self, u, r, proj):
        n, t = self.x.size, self.b.shape[1]
        u, r = np.asarray(u, float), np.asarray(r, float)
        # the unprojected atoms of a grid, kept: a centre re-placed because
        # another one moved scans the same grid again (the paper's case:
        # 23 of 102 grids), and the re-seat searches meet earlier grids
        key = (u.tobytes(), r.tobytes())
        a = self._atom_cache.pop(key, None)
        if a is None:
            a = (_steer(self.x, u, r, self.k0)[:, :, None] * self.b[:, None, :]).reshape(n, -1)
            a.flags.writeable = False
            while len(self._atom_cache) >= ATOM_CACHE:
                self._atom_cache.pop(next(iter(self._atom_cache)))
        self._atom_cache[key] = a  # most recently used last
        return proj(a).reshape(n, -1, t)

    def _prepared(self, others):
        """Projector off ``others``' columns, the data projected and its
        energy (the last ``others`` kept: a placement scans it twice)."""
        key = tuple(tuple(c) for c in others)
        if self._last is None or self._last[0] != key:
            proj = self._projector(self.columns(others))
            sp = proj(self.sc)
            self._last = (key, proj, sp, float(np.sum(np.abs(sp) ** 2)))
        return self._last[1:]

    def scan(self, others, u, r):
        """Residual energy with the centres ``others`` and one more at each (u[i], r[i])."""
        self.fits += np.size(u)
        proj, sp, esp = self._prepared(others)
        a = self._atoms(u, r, proj)  # (N, n, t)
        if a.shape[2] == 2:
            q = _orthonormal(a).reshape(a.shape[0], -1)
            g = q.conj().T @ sp  # (2 n, G)
            return esp - np.sum(_abs2(g).reshape(-1, 2 * g.shape[1]), axis=1)
        n, t = a.shape[1], a.shape[2]
        g = (a.reshape(a.shape[0], -1).conj().T @ sp).reshape(n, t, -1)  # A^H S per candidate
        h = _gram(a)
        gg = g @ np.conj(np.swapaxes(g, 1, 2))
        return esp - _trace(_inv(h) @ gg)

    def scan_pair(self, others, um, rm, un, rn):
        """Residual energy with ``others`` and two more centres, for every
        combination of one of (um, rm) and one of (un, rn): shape (len(um), len(un))."""
        self.fits += np.size(um) * np.size(un)
        proj, sp, esp = self._prepared(others)
        am, an = self._atoms(um, rm, proj), self._atoms(un, rn, proj)
        if am.shape[2] == 2:
            algebra = None if self.device is None else self.device.pair_algebra
            return esp - _explained_pairs(_orthonormal(am), _orthonormal(an), sp, algebra)
        nx, ni, t = am.shape
        nj = an.shape[1]
        fm, fn = am.reshape(nx, -1), an.reshape(nx, -1)
        gm = (fm.conj().T @ sp).reshape(ni, t, -1)
        gn = (fn.conj().T @ sp).reshape(nj, t, -1)
        ainv = _inv(_gram(am))  # (ni, t, t)
        d = _gram(an)  # (nj, t, t)
        bm = (fm.conj().T @ fn).reshape(ni, t, nj, t).transpose(0, 2, 1, 3)  # B = Am^H An
        p = gm @ np.conj(np.swapaxes(gm, 1, 2))  # g_m g_m^H
        q = gm.reshape(ni * t, -1) @ gn.reshape(nj * t, -1).conj().T  # g_m g_n^H
        q = q.reshape(ni, t, nj, t).transpose(0, 2, 1, 3)
        rr = gn @ np.conj(np.swapaxes(gn, 1, 2))  # g_n g_n^H
        # block elimination of [[A, B], [B^H, D]]: first A, then the Schur complement
        kk = np.conj(np.swapaxes(bm, 2, 3)) @ ainv[:, None]  # K = B^H A^-1
        schur = d[None] - kk @ bm
        kq = kk @ q
        kpk = kk @ p[:, None] @ np.conj(np.swapaxes(kk, 2, 3))
        yy = rr[None] - kq - np.conj(np.swapaxes(kq, 2, 3)) + kpk  # (g_n - K g_m)(...)^H
        explained = _trace(ainv @ p)[:, None] + _trace(_inv(schur) @ yy)
        return esp - explained


def _orthonormal(a):
    """Orthonormal bases (Gram-Schmidt) of each candidate's two atoms (N, n, 2).

    The column norms are ``np.linalg.norm(., axis=0)``'s own sum, written
    out (the same numbers without its dispatch), and the two columns are
    written into one array (no stack)."""
    a0, a1 = a[:, :, 0], a[:, :, 1]
    q = np.empty(a.shape, complex)
    q0, q1 = q[:, :, 0], q[:, :, 1]
    np.divide(a0, np.maximum(_colnorm(a0), 1e-300), out=q0)
    v = a1 - q0 * np.add.reduce(q0.conj() * a1, axis=0)
    np.divide(v, np.maximum(_colnorm(v), 1e-300), out=q1)
    return q


def _colnorm(z):
    """Euclidean norms of the columns of a complex (N, n) array, as
    ``np.linalg.norm(z, axis=0)`` computes them."""
    return np.sqrt(np.add.reduce((z.conj() * z).real, axis=0))


def _explained_pairs(qm, qn, sp, algebra=None):
    """Energy of ``sp`` explained jointly by candidates m and n, for every
    pair: shape (n_m, n_n).  ``qm``, ``qn``: orthonormal bases (N, n, 2).

    The products over the antennas and gates are BLAS matrix products here;
    the 2 x 2 algebra of every pair is ``algebra`` (:func:`_pair_algebra`,
    or its OpenCL twin :meth:`rpm_cl.extract.nearfield_cl.NearFieldDevice.pair_algebra`
    with the same signature)."""
    nx, ni, _ = qm.shape
    nj = qn.shape[1]
    fm, fn = qm.reshape(nx, -1), qn.reshape(nx, -1)
    gm, gn = fm.conj().T @ sp, fn.conj().T @ sp  # (2 n, G)
    c = fm.conj().T @ fn  # (2 ni, 2 nj)
    x = gm @ gn.conj().T  # g_m g_n^H
    gm3, gn3 = gm.reshape(ni, 2, -1), gn.reshape(nj, 2, -1)
    pm = gm3 @ gm3.conj().transpose(0, 2, 1)  # (ni, 2, 2)
    pn = gn3 @ gn3.conj().transpose(0, 2, 1)  # (nj, 2, 2)
    em = np.sum(np.abs(gm3) ** 2, axis=(1, 2))
    return (algebra or _pair_algebra)(c, x, pm, pn, em)


def _pair_algebra(c, x, pm, pn, em):
    """Joint explained energy of every pair from its products (float64
    NumPy reference of the ``pair_energy`` kernel, kernels/nearfield.cl).

    Parameters
    ----------
    c : complex ndarray, shape (2 ni, 2 nj)
        ``Fm^H Fn``: row ``2 i + a``, column ``2 j + b`` is
        ``C_ij[a, b] = qm_i[:, a]^H qn_j[:, b]``.
    x : complex ndarray, shape (2 ni, 2 nj)
        ``Gm Gn^H``, the same layout (``g = Q^H S``, the data's coefficients).
    pm : complex ndarray, shape (ni, 2, 2)
        ``g_m g_m^H``.
    pn : complex ndarray, shape (nj, 2, 2)
        ``g_n g_n^H``.
    em : ndarray, shape (ni,)
        ``|g_m|^2``.

    Returns
    -------
    ndarray, shape (ni, nj)
        ``|g_m|^2 + tr((I - C^H C)^-1 Y)``, Y = (g_n - C^H g_m)(g_n - C^H g_m)^H,
        or ``|g_m|^2`` alone where det(I - C^H C) <= :data:`DEGENERATE_DET`
        (the block elimination of the joint Gram matrix [[I, C], [C^H, I]]);
        the 2 x 2 algebra is written out per element over all pairs at once
        (the stacked 2 x 2 matrix products it replaces cost 3-5 times more).
    """
    ni, nj = pm.shape[0], pn.shape[0]
    c = c.reshape(ni, 2, nj, 2).transpose(1, 3, 0, 2)  # c[a][b]: (ni, nj)
    x = x.reshape(ni, 2, nj, 2).transpose(1, 3, 0, 2)
    pm = pm.transpose(1, 2, 0)[:, :, :, None]  # (2, 2, ni, 1)
    pn = pn.transpose(1, 2, 0)[:, :, None, :]  # (2, 2, 1, nj)
    # D = I - C^H C and Y = Pn - C^H X - X^H C + C^H Pm C, Hermitian 2 x 2,
    # element by element; tr(D^-1 Y) = tr(adj(D) Y) / det(D) with
    # tr(adj(D) Y) = d11 y00 + d00 y11 - 2 Re(conj(d01) y01)
    c00, c01, c10, c11 = c[0][0], c[0][1], c[1][0], c[1][1]
    k00, k10 = c00.conj(), c10.conj()
    a00, a11 = _abs2(c00) + _abs2(c10), _abs2(c01) + _abs2(c11)
    d01 = -(k00 * c01 + k10 * c11)
    pm01 = pm[0][1]
    # Pm C, column by column
    e00, e10 = pm[0][0].real * c00 + pm01 * c10, pm01.conj() * c00 + pm[1][1].real * c10
    e01, e11 = pm[0][0].real * c01 + pm01 * c11, pm01.conj() * c01 + pm[1][1].real * c11
    y00 = pn[0][0].real - 2 * (k00 * x[0][0] + k10 * x[1][0]).real + (k00 * e00 + k10 * e10).real
    y11 = (
        pn[1][1].real
        - 2 * (c01.conj() * x[0][1] + c11.conj() * x[1][1]).real
        + (c01.conj() * e01 + c11.conj() * e11).real
    )
    y01 = (
        pn[0][1]
        - (k00 * x[0][1] + k10 * x[1][1])
        - (x[0][0].conj() * c01 + x[1][0].conj() * c11)
        + k00 * e01
        + k10 * e11
    )
    d00, d11 = 1.0 - a00, 1.0 - a11
    eps = 1e-12 * (d00 + d11)  # the regularisation of _inv
    d00, d11 = d00 + eps, d11 + eps
    det = d00 * d11 - _abs2(d01)
    tr = d11 * y00 + d00 * y11 - 2 * (d01.conj() * y01).real
    with np.errstate(divide="ignore", invalid="ignore"):
        joint = np.where(det > DEGENERATE_DET, tr / det, 0.0)
    return np.asarray(em)[:, None] + joint


def _abs2(z):
    """|z|^2 of a complex array, real."""
    return z.real**2 + z.imag**2


def _gram(a):
    """Per-candidate Gram matrices of atoms (N, n, t): shape (n, t, t)."""
    b = np.ascontiguousarray(a.transpose(1, 0, 2))
    return np.conj(np.swapaxes(b, 1, 2)) @ b


def _inv(h):
    """Inverse of a stack of small Hermitian matrices (closed form up to 2 x 2),
    regularised by 1e-12 of the trace."""
    t = h.shape[-1]
    h = h + 1e-12 * np.trace(h, axis1=-2, axis2=-1).real[..., None, None] * np.eye(t)
    if t == 1:
        return 1.0 / h
    if t == 2:
        a, b, c, d = h[..., 0, 0], h[..., 0, 1], h[..., 1, 0], h[..., 1, 1]
        det = a * d - b * c
        return np.stack([np.stack([d, -b], -1), np.stack([-c, a], -1)], -2) / det[..., None, None]
    return np.linalg.inv(h)


def _trace(m):
    return np.trace(m, axis1=-2, axis2=-1).real
