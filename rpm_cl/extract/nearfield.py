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

import numpy as np

from ..io.data import InputError
from .blas import one_blas_thread
from .nearfield_cl import device_for
from .nearfield_map import _FocusMap
from .nearfield_model import _compress, _Model
from .nearfield_pairs import _PairPlacement
from .nearfield_place import _Placement
from .nearfield_polish import _clusters, _Polish
from .nearfield_pursuit import _Pursuit
from .types import Decomposition

# isort: split
# The search's parts that kernels/nearfield.cl, these notes and the tests
# name in this module, importable from here as well as from their own:
from .nearfield_cl import DEGENERATE_DET  # noqa: F401
from .nearfield_map import (  # noqa: F401
    _TABLES,
    MAP_TABLE_BYTES,
    MAP_TERMS_MAX,
    TABLE_CACHE_BYTES,
    _peaks,
)
from .nearfield_model import _explained_pairs, _orthonormal, _pair_algebra, _steer  # noqa: F401
from .nearfield_place import PAIR_CORRELATION, PAIR_GRID  # noqa: F401
from .nearfield_polish import ENVELOPE_TERMS, _real_fit  # noqa: F401

__all__ = ["decompose_near_field", "near_field_wanted"]

#: Terms of the polynomial envelope across X while the centres are searched
#: (fewer than the final fit's ENVELOPE_TERMS: a flexible model forgives a
#: misplaced centre, and the search then settles between targets).
SEARCH_TERMS = 2
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
#: The re-seat cycles are skipped once the residual energy is below
#: FLOOR_MARGIN times the noise's expected share or FLOOR_REL of the
#: searched energy (see :meth:`_Search.floor`).
FLOOR_MARGIN = 1.5
FLOOR_REL = 1e-3


def near_field_wanted(data) -> bool:
    """True where the array is linear, sampled at half a wavelength or
    coarser (the paper's Nyquist criterion, Section III-A) and at most
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
    # a pitch of half a wavelength counts as coarse, however its last bit
    # rounds (x from c / (2 fc), fc from a frequency grid): a monostatic
    # array's two-way phase aliases beyond 30 degrees there, and three
    # targets in one cell of a 0.25-1 GHz band put 70-88 % of the points
    # within 50 mm through the plane-wave path against 100 % through this one
    if arr.planar or arr.n < 4 or arr.dx < 0.5 * data.waveform.wavelength * (1 - 1e-9):
        return False
    aperture = float(arr.x[-1] - arr.x[0])
    return aperture <= MAX_APERTURE_RESOLUTIONS * data.waveform.range_resolution


def least_squares(*args, **kwargs):
    """:func:`scipy.optimize.least_squares`, imported at the first call
    (SciPy's optimize costs 0.2 s of import; :mod:`rpm_cl.lazy`)."""
    from scipy.optimize import least_squares as solve

    return solve(*args, **kwargs)


class _Search(_Pursuit, _PairPlacement, _Placement, _FocusMap):
    """Matching pursuit of the cluster centres (see the module docstring).

    Composed of the search's stages, one mixin each: candidate centres from
    the focused map (:class:`rpm_cl.extract.nearfield_map._FocusMap`), one
    centre re-placed on local grids (:class:`rpm_cl.extract.nearfield_place._Placement`),
    correlated pairs re-placed jointly
    (:class:`rpm_cl.extract.nearfield_pairs._PairPlacement`) and the pursuit
    that adds and re-seats centres (:class:`rpm_cl.extract.nearfield_pursuit._Pursuit`).
    This class holds the data searched, the model and the search's limits.
    """

    def __init__(self, data, thr, pad, device=None):
        # positions from the array's centre: the spherical waves' (u, R) are
        # taken from the origin, so positions as recorded (a scan starting
        # 12 m along a line) would put every candidate's centre there
        x = np.asarray(data.array.x, float)
        x = x - 0.5 * (x[0] + x[-1])
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
        self._memo = {}
        self._units = {}
        self._init_map(data, pad)

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
    th = _polished(search, data, centres)
    return Decomposition(k_axes, mag, _clusters(data, params, search, th, peaks), near_field=True)


def _polished(search, data, centres):
    """The centres' (u, r) and one phase each, polished with the
    real-amplitude model (:class:`_Polish`, ``least_squares``).

    Returns
    -------
    ndarray, shape (M, 3)
        Rows (u, r, psi): sin(theta), m, rad.
    """
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
    return th
