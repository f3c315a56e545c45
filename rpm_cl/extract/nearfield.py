"""Near-field decomposition for sparse linear arrays (paper Section V-A4).

Why the plane-wave decomposition of :mod:`rpm_cl.extract.kspace` fails there
---------------------------------------------------------------------
At the sparse pitch of the paper (20 mm, lambda = 15 mm) the two-way phase
``exp(-j 2 k0 |X - p|)`` of a target is sampled coarser than lambda/2, so the
k axis wraps every ``2 pi / dx`` = 314 rad/m: targets whose directions differ
by ``delta sin(theta) = pi / (k0 dx)`` (0.375) land on the same k (in the
paper-2d scene +3 and +25 degrees fall 4 rad/m apart), and the paper's window
of 417 rad/m is wider than the whole axis.  Targets at 0.45 m seen across a
0.4 m aperture are also far from plane waves: each sweeps its local spatial
frequency over more than the whole wrapped axis, so no window in k holds one
target.

What is done instead
--------------------
The k-space peak of eq. 3 becomes a point ``p = R (sin theta, cos theta)``
(``k = 2 k0 sin theta``), and the plane wave ``exp(j k X)`` of eq. 4 becomes
the spherical wave of that point, ``a_p(X) = exp(-j 2 k0 (|X - p| - R))``.
Each cluster's signal is modelled as ``a_p(X)`` times a slowly varying
envelope across the array, a polynomial of low order in X whose coefficients
are free functions of R (the envelope's variation across X carries each
target's own range migration, i.e. its RPs)::

    s(X, R) ~ sum_m a_{p_m}(X) exp(j psi_m) sum_l b_l(X) c_{m,l}(R)

with real ``c`` (a point echo has one phase at every range gate after
matched filtering).  The centres ``p_m`` are found by matching pursuit on the
near-field beamformer map ``|sum_X w(X) s(X, R) conj(a_p(X))|`` over
(sin theta, R) -- the focused analogue of |S(k, R)| (eq. 3):

1. the strongest few peaks of the map of what the centres so far leave are
   tried as the next centre, and the one whose fit leaves the least energy is
   kept (the strongest peak of an aliased array is often two targets' grating
   lobes adding up);
2. after each addition every centre is re-placed on a local grid (+-1
   resolution cell in sin theta, +-1.5 depths of focus in R; 7 x 9 points,
   then 5 x 5 over +-half a step around the best), pairs whose waves
   correlate (aliases, as +3/+25 degrees) jointly on an 11 x 11 grid each,
   and each centre in turn is taken out and searched again from the map of
   the others' residual (again only while that changes the solution by more
   than a quarter cell: smaller moves are left to the polish; and not at
   all once the residual is down to the noise floor, :meth:`_Search.floor`:
   1.5 times the noise's share, estimated from the smaller half of the
   data's singular values, or 1e-3 of the energy -- the paper's case spent
   half its search re-seating a three-centre solution at -38 dB);
3. the search stops when a new centre lowers the residual energy by less than
   0.5 dB or no map peak is left above ``peak_threshold_db``;
4. (u, R) and the phase are polished with the real-amplitude model
   (``least_squares`` with the analytic variable-projection Jacobian).

Bounds (the search on input with no targets in it -- noise, a lone sample
-- otherwise ran to 8 centres and 20-25 s):

- fewer than ``MIN_SEARCH_GATES`` (3) range gates above the threshold and
  inside the axis give no cluster (3 range samples leave one; a one-sample
  spike is one gate);
- at most ``N // (2 SEARCH_TERMS)`` centres for N antennas (5 for the
  paper's 21), so that half the data's degrees of freedom stay for the
  residual: beyond that the 0.5 dB test passes on noise;
- at most ``FIT_BUDGET`` (3 M) candidate fits per search (the paper's sparse
  case spends 0.11 M, 0.08-0.23 M at 20 dB, a 5-target scene on the same
  array about 2 M): when it is spent the search stops with the centres it
  has (every step checks before its next scan, so it overshoots by one scan
  at most, 14641 fits);
- at most ``POLISH_MAX_NFEV`` (100) residual evaluations in the final
  polish (the paper's case converges in 8, 8-10 at 20 dB);
- at most ``MAP_TERMS_MAX`` (2**24, 16.8 M) terms in one focused map
  (directions x antennas x range samples), else :class:`InputError`.  The
  map is recomputed for every candidate search (15-35 times), its directions
  grow with the aperture in wavelengths (``4 pad L / lambda``) and its range
  samples with the gates above the threshold, without bound: a 20 m aperture
  at 1 m pitch with echoes over 11 m of range needs 4.0e8 terms (22079
  directions x 21 antennas x 866 samples), 16 s a map, and ran for minutes.
  Every map allowed fits the kept table (``MAP_TABLE_BYTES``, 128 MB of
  complex64), so it is built once.  Measured on the shared reference
  machine, one core, decomposition only: the paper's sparse case 0.96 M
  terms (50 ms); 64 antennas at 20 mm 10.2 M (0.71 s, 0.29 GB peak);
  21 antennas at 1 m over 0.4 m of range 14.8 M (1.7 s and 0.38 GB peak).
  These two larger cases were measured without the noise floor and the
  kept table: their whole-axis table is kept when it fits
  TABLE_CACHE_BYTES / 2, which adds up to 64 MB to the peak.

Worst case measured on one core of the reference machine: white noise on
the paper's sparse array (21 antennas, 600 gates) 0.95 s (5 clusters,
budget spent), a 5-target scene on it 0.75 s; band-limited noise 2.6 s on
21 antennas and 4.0 s on 32 with the slower search without the noise
floor's limits (an upper bound: the budget is the same and every fit is
cheaper; a fit costs about linearly more with N; with more antennas noise
stops earlier, as one more centre's gain on noise falls below 0.5 dB); 3
range samples or a one-sample spike: no search (milliseconds).

The decomposed signal of cluster m is its term of the joint least-squares fit
over every range gate: the clusters are separated jointly, so the part of one
target that a window around another's k would also pass is not counted twice.
The paper's sparse case took about 55 ms from s(X, R) to points on one
core of the reference machine (decomposition 50 ms, median of 20 after
warm-up; 107 ms without the noise floor's search limits and the kept
focusing table, 2.0x, measured interleaved in the same run; the paper:
2 s; worst case above), short of the 20 ms target; the plane-wave path is
untouched.  The focusing table of the map is kept across calls per geometry
(``TABLE_CACHE_BYTES``), so a first call on a new geometry pays about 10 ms
more.  ``rpm-cl bench --scene sparse-20mm --repeats 20 --no-das``: 47-52 ms
total, 50.7 ms of it decomposition.  What the parts save: the pair scan's
2 x 2 algebra written out once is 1.7x faster in itself, about 1 % of the
image; the map's peaks found without the full maximum filter
(:func:`_peaks`, the same peaks on layouts 0-199) 48 ms against 51.5 ms
per image interleaved in one run (1.06-1.08x over three runs).  Coarser
pair grids (9 x 9, 11 x 7) and a map sampled half as finely in sin(theta)
save 10-15 ms but lose 0.8-1.9 points on layouts 20-199.
Tried there and not kept: the grid re-placements replaced by a joint
Levenberg-Marquardt refinement of every centre (variable projection) lost
0.5-1.1 points on layouts 20-199 noise-free and was slower on the paper's
case (78 ms: its solutions set off more pair scans); a pair scan first on
every other grid point, skipped where that one stays, lost 1.5-2.6 points;
the pair scan in float32 with the best 32 pairs re-scored in float64 chose
another pair in 1 of 7686 scans and gained about 2 %; the re-seat deferred
until no centre can be added cost more pair scans; skipping the pair scans
of a trial at the noise floor, or its further candidates, lost up to 0.7
points of RP <= 10 mm (the latter alone held but gained nothing); one or two
candidates per re-seat instead of three lost 3-5 points and 0.6 points of
RP <= 10 mm.
The pair scans' per-pair 2 x 2 algebra (:func:`_pair_algebra`) runs as an OpenCL
float64 kernel (``pair_energy``, kernels/nearfield.cl,
:mod:`rpm_cl.extract.nearfield_cl`) where the caller passes an OpenCL environment
with float64 (``rpm_cl.imaging`` passes the RPM engine's; without one, the
NumPy reference), its arrays handed over in place (the copies of the two 0.9 MB
product matrices cost as much as the kernel); the BLAS products over the
antennas and gates stay on the host.  Inside the search a pair scan's
algebra takes 0.64 ms against 1.2-1.4 ms.  A search also keeps its grids'
unprojected atoms (23 of the paper's 102 grids are scanned again), and
:func:`_orthonormal` skips ``np.linalg.norm``'s dispatch.  The same figures on
every image of layouts 20-199 and pooled on layouts 0-19 and the paper's
case (noise-free and 20 dB), and bit for bit the same centres on layouts
20-59 and the paper's case, with the device and without; per image 1.12-1.19x faster
than the NumPy pair algebra with atoms recomputed, interleaved in one run (two runs of 20,
medians; ``rpm-cl bench --scene sparse-20mm --repeats 20 --no-das``
alternated three times: 60.9-65.5 ms against 74.7-78.9 ms on the machine
shared with two other jobs, 1.17-1.23x).  Tried there and not kept: the
one-centre scan as one kernel (steering, atoms, projection, Gram-Schmidt and
energy per candidate, one launch per scan) took 0.25 ms per 63-candidate
scan against 0.13 ms in NumPy: PoCL's launch alone costs 0.06 ms, the six
uploads 0.09 ms and the kernel 0.08 ms, so the 88 small scans of an image
do not pay for a launch each; a hand-written Levenberg-Marquardt polish
(box-clipped steps) in place of ``least_squares`` ended elsewhere on 26 of
80 images of layouts 20-59 (higher cost on 22, 100 evaluations on several),
and no other optimiser can meet scipy's solution to 1e-6 of a resolution
cell: scipy's own default-tolerance solution lies up to 2e-4 cells (median
3e-8) from its tight-tolerance one on those images.  The time left is spread
over the search's some 20 000 NumPy calls an image (the focused map alone,
8 maps of 0.96 M complex64 terms, reads its 7.7 MB table per map); issue
2's 20 ms needs less work, not faster scans.
``benchmarks/sparse_layouts.py`` measures accuracy and time on the paper's
case and on random three-target layouts.

Only the decomposition changes: RPs are still the local maxima of each
decomposed envelope along R (eq. 5) and the image is still RPM (eq. 6).
"""

from __future__ import annotations

import threading

import numpy as np

from ..io.data import InputError
from .blas import one_blas_thread
from .nearfield_cl import DEGENERATE_DET, device_for
from .types import Cluster, Decomposition

__all__ = ["decompose_near_field", "near_field_wanted"]

#: Terms of the polynomial envelope across X in the final fit (4: a target
#: 20 degrees off axis at 0.4 m migrates 140 mm across the sparse aperture;
#: 3 terms leave up to 7 mm of RP error on it, 4 terms under 1 mm).
ENVELOPE_TERMS = 4
#: Same while the centres are searched (fewer: a flexible model forgives a
#: misplaced centre, and the search then settles between targets).
SEARCH_TERMS = 2
#: Peaks of the residual map tried for each new centre.
CANDIDATES = 3
#: A new centre must lower the residual energy by this much, dB.
MIN_GAIN_DB = 0.5
#: Most clusters.  Fewer with few antennas: at most ``N // (2 SEARCH_TERMS)``
#: centres for N antennas (see :meth:`_Search.max_centres`).
MAX_CLUSTERS = 8
#: Fewest range gates searched (above the map threshold, not at the axis's
#: ends): a centre's range is where the focused map peaks along R, which
#: takes a gate on each side of the peak.
MIN_SEARCH_GATES = 3
#: Budget of candidate fits per search (one per centre position tried by a
#: grid scan, one per pair of positions by a pair scan, one per cost).
#: The paper's sparse case spends 0.11 M (20 dB: 0.08-0.23 M); when the
#: budget is spent the search stops where it is (see the module docstring).
FIT_BUDGET = 3_000_000
#: Most residual evaluations of the final (u, R, phase) polish
#: (``max_nfev`` of ``scipy.optimize.least_squares``; the analytic Jacobians
#: come on top, one per iteration).  The paper's sparse case converges in 8
#: (seeds 0-4 at 20 dB: 8-10); pure noise took 448 (1.3 s for 5 centres,
#: with finite differences) and a constant signal ran to scipy's own cap,
#: 100 per parameter.
POLISH_MAX_NFEV = 100
#: Longest aperture, in range resolutions c / 2B, decomposed in the near
#: field (see :func:`near_field_wanted`).
MAX_APERTURE_RESOLUTIONS = 1.2
#: Largest |sin theta| searched.
U_MAX = 0.985
#: Pairs of centres whose waves correlate above this are re-placed jointly.
PAIR_CORRELATION = 0.2
#: Local grids (points in sin(theta) over +-1 resolution cell, points in R over
#: +-1.5 depths of focus) for re-placing one centre, and a pair of centres.
#: The one-centre scan is then refined REFINE_STAGES times on REFINE_GRID
#: over +-half a step of the grid before (each divides the step by 4: du / 12
#: and 0.09 depths of focus in the end, finer than the former single 21 x 25
#: grid); a pair that moves is followed by the one-centre scans.  The pair
#: grid stays fine: (7, 7), and (7, 7) refined on (3, 3) or (5, 5), lost 1-4
#: points of RPM <= 50 mm on random layouts.
EACH_GRID = (7, 9)
PAIR_GRID = (11, 11)
REFINE_GRID = (5, 5)
REFINE_STAGES = 1
#: A centre counts as moved (another re-placing sweep, another re-seat
#: cycle) when it moves by more than this fraction of a resolution cell in
#: sin(theta) or of a depth of focus in R; smaller moves are kept but are
#: left to the final polish.
MOVE_TOLERANCE = 0.25
#: Passes that take each centre out and search its place again.
RESEAT_CYCLES = 2
#: The re-seat cycles are skipped once the residual energy is below
#: FLOOR_MARGIN times the noise's expected share or FLOOR_REL of the
#: searched energy (see :meth:`_Search.floor`).
FLOOR_MARGIN = 1.5
FLOOR_REL = 1e-3
#: Grids of atoms kept per search (:meth:`_Model._atoms`; at most
#: N x 121 x SEARCH_TERMS complex numbers each, 81 kB for 21 antennas).
ATOM_CACHE = 128
#: Largest table of focusing phases kept for the detection map, bytes.
MAP_TABLE_BYTES = 128 << 20
#: Most terms (directions x antennas x range samples) of one focused map:
#: as many as the kept table holds (complex64), so that every map allowed
#: is built once; a larger search is refused (see the module docstring).
MAP_TERMS_MAX = MAP_TABLE_BYTES // 8
#: Focusing tables kept across calls (one per geometry: antennas,
#: frequency, directions, range axis), bytes in all; one table is kept only
#: when it takes at most half of this (the paper's sparse case: 44 MB for
#: its 600 gates, of which the rows of the gates searched are filled).
TABLE_CACHE_BYTES = 128 << 20
_TABLES = {}
# one thread at a time reads or changes _TABLES (a Dask worker may run
# several searches in threads)
_TABLES_LOCK = threading.Lock()


def near_field_wanted(data) -> bool:
    """True where the array is linear, sampled coarser than half a wavelength
    (the paper's Nyquist criterion, Section III-A) and at most
    ``MAX_APERTURE_RESOLUTIONS`` range resolutions long.

    The second condition is the model's own: the envelope across X is a
    polynomial of ``ENVELOPE_TERMS`` terms, which follows a target's range
    walk across the aperture (up to its length, for a steep target) only
    while that walk stays within about a range resolution.  A longer
    aperture resolves the walk, and the plane-wave path's range-walk
    alignment (:mod:`rpm_cl.extract.kspace`, step 4) then tells the k aliases apart
    by it.  Measured with one point or one 50 mm circle at 0.8 m, 0-65
    degrees, 20 dB (``benchmarks/path_choice.py``): 21 antennas at 20 mm
    (0.4 m) are imaged fully by the near-field path up to 0.4 GHz (0.4 m /
    0.375 m = 1.07 resolutions; the plane-wave path loses targets from 45
    degrees at 0.3 GHz) and fully by the plane-wave path from 0.5 GHz (1.33;
    there the near-field path loses the 65 degree ones, at 1 GHz those from
    55 degrees, at 3 GHz nearly all off broadside); 32 and 64 antennas at
    7.5 mm with 3 GHz (4.7 and 9.5 resolutions) lose nearly every target
    off broadside through the near-field path and none through the other.
    """
    arr = data.array
    if arr.planar or arr.n < 4 or arr.dx <= 0.5 * data.waveform.wavelength:
        return False
    aperture = float(arr.x[-1] - arr.x[0])
    return aperture <= MAX_APERTURE_RESOLUTIONS * data.waveform.range_resolution


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


def least_squares(*args, **kwargs):
    """:func:`scipy.optimize.least_squares`, imported at the first call
    (SciPy's optimize costs 0.2 s of import; :mod:`rpm_cl.lazy`)."""
    from scipy.optimize import least_squares as solve

    return solve(*args, **kwargs)


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


def _peaks(fmap, size, floor, count):
    """Indices (i, j) of the ``count`` largest local maxima of ``fmap`` (2-D)
    at or above ``floor``, largest first (ties in row-major order).

    A local maximum is a point equal to the maximum of the ``size`` window
    centred on it, clipped at the edges: the points where ``fmap`` equals
    ``ndimage.maximum_filter(fmap, size, mode="nearest")``.  Such a point is
    no smaller than its eight neighbours (windows of one point along an axis
    leave those neighbours out), so only those points are checked against
    their whole window, strongest first, until ``count`` are found: the same
    peaks (the paper's sparse case: 140-300 of the map's 45864 points pass
    the first test; 0.25 ms against 0.45 ms for the filter alone)."""
    near = fmap.copy()  # the maximum over each point's 3 x 3 neighbours, by rows then columns
    if size[0] > 1:
        np.maximum(near[1:], fmap[:-1], out=near[1:])
        np.maximum(near[:-1], fmap[1:], out=near[:-1])
    if size[1] > 1:
        rows = near.copy()
        np.maximum(near[:, 1:], rows[:, :-1], out=near[:, 1:])
        np.maximum(near[:, :-1], rows[:, 1:], out=near[:, :-1])
    idx = np.argwhere((fmap >= near) & (fmap >= floor))
    idx = idx[np.argsort(-fmap[tuple(idx.T)], kind="stable")]
    hu, hr = size[0] // 2, size[1] // 2
    out = []
    for i, j in idx:
        if len(out) == count:
            break
        win = fmap[max(i - hu, 0) : i + size[0] - hu, max(j - hr, 0) : j + size[1] - hr]
        if fmap[i, j] >= win.max():
            out.append((int(i), int(j)))
    return out


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


class _Search:
    """Matching pursuit of the cluster centres (see the module docstring)."""

    def __init__(self, data, thr, pad, device=None):
        x = np.asarray(data.array.x, float)
        self.x, self.n, self.k0 = x, x.size, data.waveform.kc
        self.dr = data.dr
        self.res_r = data.waveform.range_resolution
        self.aperture = float(np.ptp(x))
        self.du = np.pi / (self.k0 * self.aperture)  # resolution cell in sin(theta)
        self.thr = thr
        sig = data.signal
        env = np.abs(sig).max(axis=0)
        gsel = np.nonzero(env >= thr * env.max())[0]
        self.gates = gsel[(gsel > 0) & (gsel < data.range.size - 1)]
        self.model = _Model(x, self.k0, _compress(sig[:, self.gates]), SEARCH_TERMS, device)
        # noise energy per dimension across the array: the smaller half of the
        # data's squared singular values (the echoes take the larger ones)
        sv2 = np.sort(np.sum(np.abs(self.model.sc) ** 2, axis=0))
        self.noise = float(np.mean(sv2[: max(1, self.n // 2)]))
        # the focused map on every few gates (it varies slowly along R)
        step = max(1, round(self.res_r / 64 / self.dr))
        gdet = self.gates[::step]
        self.s_det, self.r_det = sig[:, gdet], data.range[gdet]
        self._rows, self._step, self._axis = gdet, step, data.range
        dk = 2 * np.pi / (pad * self.n * data.array.dx)
        nk = int(np.floor(2 * self.k0 * U_MAX / dk))
        self._check_size(data, 2 * nk + 1)
        self.u_det = np.arange(-nk, nk + 1) * dk / (2 * self.k0)
        self.w = np.hanning(self.n + 2)[1:-1]
        self._tables = {}
        self._memo = {}
        self._units = {}
        self.nms = [
            2 * int(np.ceil(self.du * 2 * self.k0 / dk)) + 1,
            2 * int(np.ceil(0.5 * self.res_r / (step * self.dr))) + 1,
        ]
        self.gmax = float(self.focus_map(self.s_det).max())

    def _check_size(self, data, n_dirs: int) -> None:
        """InputError when one focused map of ``n_dirs`` directions exceeds
        MAP_TERMS_MAX terms (checked before the directions are allocated)."""
        terms = n_dirs * self.n * self.r_det.size
        if terms > MAP_TERMS_MAX:
            raise InputError(
                f"the near-field search of this sparse array is too large: a focused map of "
                f"{terms:.3g} terms ({n_dirs} directions x {self.n} antennas x "
                f"{self.r_det.size} range samples; at most {MAP_TERMS_MAX:.3g}), as the "
                f"{self.aperture:g} m aperture spans {self.aperture / data.waveform.wavelength:.0f}"
                f" wavelengths and {self.gates.size} range gates hold echoes; crop the range "
                f"axis to the scene, or use the plane-wave decomposition (near_field = false, "
                f"--near-field false)"
            )

    @property
    def spent(self) -> bool:
        """True once the search has evaluated FIT_BUDGET candidate fits."""
        return self.model.fits >= FIT_BUDGET

    def max_centres(self) -> int:
        """Most centres for this array: MAX_CLUSTERS, and no more than leave
        half the antennas' degrees of freedom to the residual (each centre
        takes SEARCH_TERMS per gate).  Beyond that the 0.5 dB gain test
        passes on noise: fitting t more complex terms to noise in N - m t
        dimensions gains ``10 log10((N - m t) / (N - (m + 1) t))`` dB, which
        is 0.54 dB for the 3rd centre on 21 antennas (measured on pure
        noise: 0.59), and with ``m t = N`` the fit is exact whatever the
        centres (4 antennas and 2 centres of 2 terms).  21 antennas: 5."""
        return max(1, min(MAX_CLUSTERS, self.n // (2 * SEARCH_TERMS)))

    def floor(self, m) -> float:
        """Residual energy of m centres that leaves nothing to re-seat:
        FLOOR_MARGIN times the noise's share of the searched gates (the
        N - m SEARCH_TERMS dimensions the model leaves, each with the mean
        of the smaller half of the data's squared singular values), and no
        less than FLOOR_REL of the searched energy."""
        noise = self.noise * max(self.n - m * SEARCH_TERMS, 1)
        return max(FLOOR_MARGIN * noise, FLOOR_REL * self.model.energy)

    def dof(self, r):
        """Depth of focus at range r: the range change that bends the edge phase by pi."""
        return min(4 * np.pi * r * r / (self.k0 * self.aperture**2), 0.5 * self.res_r)

    def focus_map(self, s):
        """|sum_X w(X) s(X, R) conj(a_p(X))| over (u_det, r_det), in chunks of gates.

        The focusing phases are kept as complex64 (the map only ranks
        candidate centres: float32's 1e-7 is far below any peak difference
        that matters), laid out (gate, direction, antenna) so that each gate
        is one matrix-vector product."""
        out = np.empty((self.u_det.size, self.r_det.size))
        table = self._table()
        if table is not None:  # the whole axis's table, kept: runs of gates a step apart
            rows, step = self._rows, self._step
            cuts = np.flatnonzero(np.diff(rows) != step) + 1
            for a, b in zip(np.r_[0, cuts], np.r_[cuts, rows.size]):
                sg = np.ascontiguousarray(s[:, a:b].T, dtype=np.complex64)[:, :, None]
                tab = table[rows[a] : rows[b - 1] + 1 : step]
                out[:, a:b] = np.abs(np.matmul(tab, sg)[..., 0]).T
            return out
        chunk = max(1, int(MAP_TABLE_BYTES // (8 * self.u_det.size * self.n)))
        cache = self.u_det.size * self.n * self.r_det.size * 8 <= MAP_TABLE_BYTES
        for g0 in range(0, self.r_det.size, chunk):
            tab = self._tables.get(g0)
            if tab is None:
                tab = self._phases(self.r_det[g0 : g0 + chunk])
                if cache:
                    self._tables[g0] = tab
            sg = np.ascontiguousarray(s[:, g0 : g0 + chunk].T, dtype=np.complex64)[:, :, None]
            out[:, g0 : g0 + chunk] = np.abs(np.matmul(tab, sg)[..., 0]).T
        return out

    def _phases(self, r):
        """Weighted focusing phases (len(r), directions, antennas), complex64."""
        x, u, r = self.x[None, None, :], self.u_det[None, :, None], np.asarray(r)[:, None, None]
        d = np.sqrt(np.maximum(x * x - 2 * x * r * u + r * r, 0.0))
        phase = (2 * self.k0 * (d - r)).astype(np.float32)
        tab = np.empty(phase.shape, np.complex64)
        np.cos(phase, out=tab.real)
        np.sin(phase, out=tab.imag)
        tab *= self.w.astype(np.float32)
        return tab

    def _table(self):
        """The focusing table of every gate of the range axis, kept across
        calls for the same geometry (antennas, frequency, directions, range
        axis; least recently used first out, TABLE_CACHE_BYTES in all), its
        rows filled as gates are asked for (the memory of a row is touched
        only then); None where one table would take more than
        TABLE_CACHE_BYTES / 2 (then :meth:`focus_map` builds the searched
        gates' rows, once per search)."""
        nrows = self._axis.size
        size = nrows * self.u_det.size * self.n * 8
        if size > TABLE_CACHE_BYTES // 2:
            return None
        key = (
            self.x.tobytes(),
            self.k0,
            self.u_det.size,
            float(self.u_det[-1]),
            float(self._axis[0]),
            float(self._axis[-1]),
            nrows,
        )
        with _TABLES_LOCK:
            return self._kept_table(key, nrows, size)

    def _kept_table(self, key, nrows, size):
        entry = _TABLES.pop(key, None)
        if entry is None:
            while _TABLES and sum(t.nbytes for t, _ in _TABLES.values()) + size > TABLE_CACHE_BYTES:
                _TABLES.pop(next(iter(_TABLES)))
            entry = (
                np.empty((nrows, self.u_det.size, self.n), np.complex64),
                np.zeros(nrows, bool),
            )
        _TABLES[key] = entry  # most recently used last
        table, built = entry
        need = self._rows[~built[self._rows]]
        if need.size:
            table[need] = self._phases(self._axis[need])
            built[need] = True
        return table

    def _grid(self, centre, shape, half=None):
        """Grid of ``shape`` points over +-``half`` (sin theta, m) around
        ``centre``; default half widths: a resolution cell, 1.5 depths of focus."""
        u0, r0 = centre
        hu, hr = (self.du, 1.5 * self.dof(r0)) if half is None else half
        unit = self._units.get(shape)
        if unit is None:
            unit = self._units[shape] = [
                g.ravel()
                for g in np.meshgrid(
                    np.linspace(-1, 1, shape[0]), np.linspace(-1, 1, shape[1]), indexing="ij"
                )
            ]
        return np.clip(u0 + hu * unit[0], -U_MAX, U_MAX), np.maximum(r0 + hr * unit[1], self.dr)

    def moved(self, a, b) -> bool:
        """True when centre ``a`` lies more than MOVE_TOLERANCE of a cell from ``b``."""
        return abs(a[0] - b[0]) > MOVE_TOLERANCE * self.du or abs(
            a[1] - b[1]
        ) > MOVE_TOLERANCE * self.dof(b[1])

    def same(self, a, b) -> bool:
        """True when the centre sets ``a`` and ``b`` match one to one within
        MOVE_TOLERANCE (the same solution placed a little differently)."""
        left = list(b)
        for c in a:
            k = next((i for i, d in enumerate(left) if not self.moved(c, d)), None)
            if k is None:
                return False
            left.pop(k)
        return not left

    def place_one(self, others, centre):
        """Best place of one centre near ``centre``, ``others`` fixed: the
        EACH_GRID scan, then REFINE_STAGES scans of REFINE_GRID over +-half a
        step of the grid before (stopping where the budget is spent)."""
        half = np.array([self.du, 1.5 * self.dof(centre[1])])
        shape, best = EACH_GRID, list(centre)
        for stage in range(1 + REFINE_STAGES):
            if stage and self.spent:
                break
            uu, rr = self._grid(best, shape, half)
            i = int(np.argmin(self.model.scan(others, uu, rr)))
            best = [float(uu[i]), float(rr[i])]
            half = half / (np.asarray(shape) - 1)  # half a step of this grid
            shape = REFINE_GRID
        return best

    def place_each(self, centres, sweeps=3):
        """Re-place each centre in turn on a local grid, the others fixed.

        In list order: the new centre last, the others first (placing the new
        one first, from its map peak, lost 3 points of RPM <= 50 mm on random
        layouts).  A centre is not placed again while no other one has moved
        since it was placed (it would stay where it is)."""
        centres = [list(c) for c in centres]
        step, placed, last_move = 0, [-1] * len(centres), [0] * len(centres)
        for _ in range(sweeps):
            moved = False
            for m in range(len(centres)):
                step += 1
                if placed[m] >= 0 and all(
                    last_move[k] < placed[m] for k in range(len(centres)) if k != m
                ):
                    continue
                u0, r0 = centres[m]
                if self.spent:
                    return centres
                best = self.place_one(centres[:m] + centres[m + 1 :], (u0, r0))
                placed[m] = step
                if self.moved(best, (u0, r0)):
                    moved, last_move[m] = True, step
                centres[m] = best
            if not moved:
                break
        return centres

    def place_two(self, rest, cm, ck):
        """Joint place of two centres near ``cm`` and ``ck`` on PAIR_GRID,
        ``rest`` fixed; (None, None) where the pair stays (the grids' middle)."""
        um, rm = self._grid(cm, PAIR_GRID)
        uk, rk = self._grid(ck, PAIR_GRID)
        c = self.model.scan_pair(rest, um, rm, uk, rk)
        i, j = np.unravel_index(int(np.argmin(c)), c.shape)
        if i == c.shape[0] // 2 and j == c.shape[1] // 2:
            return None, None
        return [float(um[i]), float(rm[i])], [float(uk[j]), float(rk[j])]

    def place_pairs(self, centres):
        """Re-place pairs of centres with correlated waves jointly (aliases)."""
        for _ in range(2):
            changed = False
            for m in range(len(centres)):
                for k in range(m + 1, len(centres)):
                    am = _steer(self.x, centres[m][0], centres[m][1], self.k0)[:, 0]
                    ak = _steer(self.x, centres[k][0], centres[k][1], self.k0)[:, 0]
                    if abs(np.vdot(am, ak)) / self.n < PAIR_CORRELATION:
                        continue
                    if self.spent:
                        return centres
                    rest = [c for i, c in enumerate(centres) if i not in (m, k)]
                    pm, pk = self.place_two(rest, centres[m], centres[k])
                    if pm is not None:
                        changed = True
                        centres[m], centres[k] = pm, pk
            if not changed:
                break
            centres = self.place_each(centres)
        return centres

    def candidates(self, fixed):
        """Strongest peaks (u, r, value) of the focused map of what ``fixed`` leaves."""
        s = self.s_det
        if fixed:
            q, _ = np.linalg.qr(self.model.columns(fixed))
            s = s - q @ (q.conj().T @ s)
        fmap = self.focus_map(s)
        return [
            (float(self.u_det[i]), float(self.r_det[j]), float(fmap[i, j]))
            for i, j in _peaks(fmap, self.nms, self.thr * self.gmax, CANDIDATES)
        ]

    def best_with(self, fixed, exclude=None):
        """Best candidate added to ``fixed``, all centres re-placed:
        (centres, cost, peak), or None without candidates.  Candidates
        within a resolution cell and a depth of focus of ``exclude`` are not
        tried (re-seating: the centre taken out, whose solution is known).
        Remembered per question (the re-seat cycles ask some again)."""
        key = (tuple(tuple(c) for c in fixed), None if exclude is None else tuple(exclude))
        if key not in self._memo:
            self._memo[key] = self._best_with(fixed, exclude)
        best = self._memo[key]
        return None if best is None else ([list(c) for c in best[0]], best[1], best[2])

    def _best_with(self, fixed, exclude):
        best = None
        for u0, r0, value in self.candidates(fixed):
            if self.spent:
                break
            if exclude is not None and (
                abs(u0 - exclude[0]) <= self.du and abs(r0 - exclude[1]) <= self.dof(exclude[1])
            ):
                continue
            trial = self.place_each(fixed + [[u0, r0]])
            if len(trial) > 1:
                trial = self.place_pairs(trial)
            c = self.model.cost(trial)
            if best is None or c < best[1]:
                best = (trial, c, value)
        return best

    def run(self):
        """Centres [(u, r)] and their map peaks."""
        centres, peaks = [], []
        cost = self.model.energy
        for _ in range(self.max_centres()):
            if self.spent:
                break
            best = self.best_with(centres)
            if best is None:
                break
            if centres and 10 * np.log10(cost / max(best[1], 1e-300)) < MIN_GAIN_DB:
                break
            centres, cost = best[0], best[1]
            peaks.append(best[2])
            # re-seat: a centre chosen before the others were known may sit
            # between targets; take each out in turn and search its place again
            # (not once the residual is down to the noise: nothing is left
            # that another placement could explain)
            cycles = RESEAT_CYCLES if len(centres) > 1 and cost > self.floor(len(centres)) else 0
            for _ in range(cycles):
                changed = False
                for m in range(len(centres)):
                    if self.spent:
                        break
                    alt = self.best_with(centres[:m] + centres[m + 1 :], exclude=centres[m])
                    if alt is not None and alt[1] < cost * (1 - 1e-3):
                        # a better placement of the same centres is kept; only
                        # a different solution asks for another cycle
                        changed |= not self.same(alt[0], centres)
                        centres, cost = alt[0], alt[1]
                        peaks = peaks[:m] + peaks[m + 1 :] + [alt[2]]
                if not changed:
                    break
        return centres, peaks


def decompose_near_field(data, params, spectrum, env=None):
    """Decompose a linear array's data with near-field (spherical-wave) clusters.

    Parameters
    ----------
    data : RadarData
        Linear array.
    params : KSpaceParams
        ``peak_threshold_db`` (map peaks and the gates searched), ``range_gate``,
        ``pad`` (map sampling in sin(theta)).
    spectrum : (magnitude, k_axes)
        The plane-wave |S(k, R)| and its k grid, returned in the Decomposition
        as they are.
    env : CLEnv, optional
        OpenCL environment for the pair scans' 2 x 2 algebra
        (:mod:`rpm_cl.extract.nearfield_cl`, float64); None, or a device without
        float64: NumPy.

    Returns
    -------
    Decomposition
        ``Cluster.k`` is ``2 k0 sin(theta)`` of the centre, not wrapped.
    """
    # thousands of products of small matrices (21 x 2 ... 21 x 21): one BLAS
    # thread (rpm_cl.extract.blas; 0.11 s against 0.20 s with OpenBLAS's threads)
    with one_blas_thread():
        return _decompose_near_field(data, params, spectrum, env)


def _decompose_near_field(data, params, spectrum, env):
    mag, k_axes = spectrum
    if data.array.planar or data.array.n < 4:
        raise InputError("the near-field decomposition needs a linear array of at least 4 antennas")
    if not np.any(data.signal):
        return Decomposition(k_axes, mag, ())
    search = _Search(data, 10.0 ** (params.peak_threshold_db / 20.0), params.pad, device_for(env))
    if search.gates.size < MIN_SEARCH_GATES:
        return Decomposition(k_axes, mag, ())
    centres, peaks = search.run()
    if not centres:
        return Decomposition(k_axes, mag, ())
    x, k0, n, du = search.x, search.k0, search.n, search.du
    sig = data.signal

    # polish (u, r) and one phase per centre with the real-amplitude model
    t = SEARCH_TERMS
    coef, *_ = np.linalg.lstsq(search.model.columns(centres), search.model.sc, rcond=None)
    psi = [float(np.angle(np.sum(coef[m * t] * np.abs(coef[m * t])))) for m in range(len(centres))]
    th0 = np.column_stack([np.asarray(centres), psi])
    sr = _compress(np.concatenate([sig[:, search.gates].real, sig[:, search.gates].imag]))
    s_c = sr[:n] + 1j * sr[n:]
    f = np.array([search.dof(r) for r in th0[:, 1]])
    inf = np.full(len(th0), np.inf)
    lb = np.column_stack([th0[:, 0] - 0.2 * du, th0[:, 1] - f / 6, -inf]).ravel()
    ub = np.column_stack([th0[:, 0] + 0.2 * du, th0[:, 1] + f / 6, inf]).ravel()
    fit = _Polish(x, k0, t, s_c)
    sol = least_squares(
        fit.fun,
        th0.ravel(),
        jac=fit.jac,
        bounds=(lb, ub),
        x_scale=np.tile([0.1 * du, 1e-3, 0.1], len(th0)),
        max_nfev=POLISH_MAX_NFEV,
    )
    th = sol.x.reshape(-1, 3)

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
    return Decomposition(k_axes, mag, tuple(clusters[i] for i in order), near_field=True)
