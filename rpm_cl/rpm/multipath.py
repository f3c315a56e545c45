"""Multiple-scattering echoes: clusters whose ranges a double bounce explains.

An echo that went antenna -> object A -> object B -> antenna arrives with
the range ``R_AB(X) = min over a in A, b in B of (|X - a| + |a - b| + |b - X|) / 2``
(Fermat: the path of a specular double bounce between convex objects is the
shortest one), which is longer than either object's own range.  RPM knows
only single bounces, so it turns such an echo into a cluster of "boundary"
points behind and between the two objects, where nothing is.

Test (per cluster, nearest first): a cluster is a double bounce when, for
some pair of clusters already accepted as single-bounce (nearer ones: a
double bounce is longer than both of its legs), its image points lie where
RPM would image that double bounce: the envelope points
``X + R_AB (-dR_AB/dX, sqrt(1 - |grad R_AB|^2), -dR_AB/dZ)`` of the predicted
ranges at the cluster's own antennas (in air the gradient of the shortest
path in closed form, above a half-space by central differences of
:data:`GRADIENT_STEP`).  "Lie there" is relative to how far the predicted
ghost is from its legs: the cluster's median distance to the predicted
points (its part along the line of sight weighted by :data:`RADIAL_WEIGHT`)
must be below :data:`GHOST_TOL` times the distance from the
predicted points' median to the nearer leg's (coordinate-wise medians: a few
stray points of a leg must not pull it onto the ghost), and its echo must be
weaker than both legs' by :data:`GHOST_AMP` and its range within
:data:`LEVEL_TOL` range resolutions of the predicted one.  (A test on the range walk
alone fails where the ghost's cluster also holds the ends of its legs'
stronger echoes, whose wavenumbers reach into its window; RPM's density
leaves those out of the points.)

On a planar array decomposed in tiles (:mod:`rpm_cl.extract.segments`) a
leg found in another tile than the cluster was seen from other antennas,
and its amplitude is compared as the cluster's antennas would see it: times
``(R_leg / R)^2``, its median range over the range from the antenna of the
cluster's median-range RP to its nearest point (two-way spherical
spreading).  Three
spheres before a 128 x 128 array at 7.5 mm (+-0.48 m, 0.55-0.7 m away):
a patch of one sphere, seen from a corner tile at 0.79 m, has 0.66 of the
amplitude nearer tiles measured on that sphere and on another (median
ranges 0.63 and 0.55 m), lies where a double bounce between those two
would image, and was dropped; seen from the corner (0.81 and 0.64 m) those
legs give 0.61 and 0.74 of their amplitude, and 0.66 is above 0.7 times
that.  Linear arrays keep the amplitudes as measured: on the rebar line,
decomposed in segments, the double bounces are weaker than their legs only
as the legs' own antennas see them (rescaled from another segment by the
2-D spreading, ``tests/test_gprmax_rebar.py`` loses them).

Above a dielectric half-space (:class:`rpm_cl.io.medium.Medium` with an
antenna height) the legs from and to the antenna are refracted optical
paths (:func:`rpm_cl.io.medium.one_way`), the leg between the objects is ``n``
times its length, and the envelope point lies on the refracted ray whose
parameter is the predicted range's slope (:func:`rpm_cl.io.medium.point_on_ray`).

Repeats: an antenna sends part of an echo back to the object, which
returns it once more: the same path twice, at ``n`` times the object's range
at every antenna (a near-field scanner 0.1 m before a sample records it at
0.2 m), which RPM images as a surface as far again behind the object.  A
cluster is such a repeat (:func:`repeats`) when, at the antennas it shares
with a nearer cluster already accepted (at least :data:`REPEAT_SHARED` of
its own), its ranges are ``n`` times the other's (``n`` in
:data:`REPEAT_ORDERS`) within :data:`REPEAT_LEVEL` range resolutions in the
median and :data:`REPEAT_SHAPE` wavelengths RMS about it, and its echo is
weaker by :data:`GHOST_AMP`.  The range walks are the phase-refined ones
(:mod:`rpm_cl.extract.phase`): a wavefront to a small fraction of a
wavelength, where two echoes at different places differ by millimetres (two
broadside points at 0.35 and 0.7 m before 0.12 m of antennas: 2.4 mm RMS
about the median of ``r_2 - 2 r_1``; the repeat of a rough sample 0.1 m
before a 60 x 48 scan at 24 GHz: 1.0 mm, an eighth of a wavelength 1.55 mm).

The objects are represented by their image points (at most
:data:`MAX_OBJECT_POINTS` of each, evenly spread), and accepted clusters
whose points touch (lie in the same or neighbouring cubes of :data:`TOUCH`
metres, directly or through other accepted clusters) are one object: a double bounce between
two parts of one surface is not sought (a large array splits each sphere
into several clusters, whose "double bounces" lie on the sphere's other
clusters).  A cluster that fails the test is accepted and may itself be a
leg of later ones.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "GHOST_AMP",
    "GHOST_TOL",
    "GRADIENT_STEP",
    "LEVEL_TOL",
    "MAX_OBJECT_POINTS",
    "RADIAL_WEIGHT",
    "TOUCH",
    "double_bounce",
    "flag_multipath",
    "ghost_points",
    "repeats",
]

#: A cluster is a double bounce when its points lie closer to the predicted
#: ghost than this fraction of the ghost's distance to its nearer leg.
#: Measured on two point targets and their double bounce (0.25 GHz at 22 GHz,
#: 31 antennas at 4 mm, noise-free to 20 dB in-band): the ghost's clusters
#: lie at 0.01-0.2 of that distance, the targets' own at 0.6 or more.
GHOST_TOL = 0.35
#: ... and when its echo is at most this fraction of the weaker leg's (median
#: RP amplitudes): each bounce loses energy, while two real objects that
#: happen to lie where a double bounce would image (three or four point
#: targets at 0.35-0.5 m spread over +-35 degrees: 3 in 8 scenes within 0.35
#: of the ghost distance) are usually as strong as the others.
GHOST_AMP = 0.7
#: A double bounce's range is the predicted one within this many range
#: resolutions (the envelope's constant is no better than a fraction of
#: one); checked at one antenna first, it spares the full test of most pairs.
LEVEL_TOL = 0.5
#: Weight of the gap along the line of sight: a cluster's direction is the
#: phase's (a few mm across), its range the envelope's (narrow band, 20 dB:
#: 20-75 mm off), so a miss in range counts a quarter of one across.
RADIAL_WEIGHT = 0.25
#: Repeat orders the repeat test looks for: the echo that the antennas
#: send back to the object once, twice (ranges 2 R and 3 R).
REPEAT_ORDERS = (2, 3)
#: A repeat's ranges follow ``n`` times its leg's walk to this fraction of a
#: wavelength (RMS over their shared antennas about the median offset):
#: phase-refined walks hold a wavefront to a small fraction of a wavelength;
#: an eighth keeps the physical-optics scan's repeat (1.0 mm at 24 GHz,
#: 1.55 mm the bound) and refuses two broadside points at 0.35 and 0.7 m
#: before 0.12 m of antennas (2.4 mm; module notes).
REPEAT_SHAPE = 0.125
#: ... and their median offset is at most this many range resolutions: the
#: coherent level puts a phase-refined walk's constant to a few hundredths
#: of a resolution at 30 dB (:mod:`rpm_cl.extract.phase`), and a real
#: object behind another is seldom at exactly n times its range.
REPEAT_LEVEL = 0.1
#: ... and the leg holds RPs at no fewer than this share of the cluster's
#: antennas (and at 3 or more).
REPEAT_SHARED = 0.5
#: Step of the central differences of the predicted ranges above a
#: half-space, m (in air the gradient is closed-form: :func:`_bounce_gradient`).
GRADIENT_STEP = 1e-4
#: Image points of an object used to predict its double bounces, and
#: antennas of a cluster the prediction is made for (evenly spread): the
#: cost of a pair grows as their cube.
MAX_OBJECT_POINTS = 32
#: Accepted clusters with points in the same or neighbouring cubes of this
#: edge (closer than it always, than twice it at most) are parts of one
#: object, m: neighbouring parts of a surface meet (their windows overlap),
#: while the objects the test was measured on lie 50 mm or more apart.
TOUCH = 0.01


def double_bounce(antennas: np.ndarray, a: np.ndarray, b: np.ndarray, medium=None) -> np.ndarray:
    """Range of the shortest path antenna -> A -> B -> antenna, halved.

    Parameters
    ----------
    antennas : ndarray, shape (N, 3)
        Antenna positions, m.
    a, b : ndarray, shape (Ma, 3), (Mb, 3)
        Points of the two objects, m.
    medium : rpm_cl.io.medium.Medium, optional
        A half-space: optical paths (air-equivalent, both objects in the
        material); None: air.

    Returns
    -------
    ndarray, shape (N,)
        m.
    """
    if medium is None:
        return _bounce_gradient(antennas, a, b)[0]
    from ..io.medium import one_way

    da = one_way(medium, antennas[:, None, :], a[None])
    db = one_way(medium, antennas[:, None, :], b[None])
    ab = medium.n * np.linalg.norm(a[:, None, :] - b[None], axis=2)
    total = da[:, :, None] + ab[None] + db[:, None, :]
    return 0.5 * total.reshape(len(antennas), -1).min(axis=1)


def _spread(points: np.ndarray, n: int) -> np.ndarray:
    if len(points) <= n:
        return points
    return points[np.linspace(0, len(points) - 1, n).round().astype(int)]


def _xyz(p: np.ndarray) -> np.ndarray:
    """(x, y) or (x, y, z) points as (x, y, z), m."""
    p = np.asarray(p, np.float64)
    if p.shape[1] == 3:
        return p
    return np.column_stack([p, np.zeros(len(p))])


def flag_multipath(
    positions: np.ndarray,
    rps,
    image,
    resolution: float,
    medium=None,
    parts=None,
    wavelength: float | None = None,
) -> np.ndarray:
    """Which image points come from double-bounce clusters (module notes).

    Parameters
    ----------
    positions : ndarray, shape (n_antennas, 2) or (n_antennas, 3)
        Antenna positions, ``Array.positions()`` (flat index order), m.
    rps : RangePoints
        The RPs the image was made from (phase-refined where available).
    image : Image
        Points (M, 2|3), their clusters and main RPs.
    resolution : float
        Range resolution c / 2B, m (:data:`LEVEL_TOL`).
    medium : rpm_cl.io.medium.Medium, optional
        A half-space below the antennas (module notes); None: air (or a
        homogeneous medium's equivalent air scene).
    parts : ndarray of int, shape (N,), optional
        Per RP, the segment or tile whose decomposition found it
        (:mod:`rpm_cl.extract.segments`); None: one decomposition.  On a
        planar array a leg found in another tile than the cluster was seen
        from other antennas, and its amplitude is moved to the cluster's by
        the spreading loss (module notes); linear arrays ignore it.
    wavelength : float, optional
        The carrier's wavelength, m: the shape tolerance of the repeat test
        (:func:`repeats`, :data:`REPEAT_SHAPE`); None: no repeat test.

    Returns
    -------
    ndarray of bool, shape (M,)
        True for the points of clusters a double bounce explains, or that
        repeat a nearer cluster's echo (:func:`repeats`).
    """
    m_pts = len(image.points)
    flags = np.zeros(m_pts, bool)
    if m_pts == 0:
        return flags
    positions = _xyz(positions)
    centre_xyz = 0.5 * (positions.min(axis=0) + positions.max(axis=0))
    pts3 = _xyz(image.points)
    cl_img = np.asarray(image.cluster)
    cl_rp = np.asarray(rps.cluster)
    order = sorted(np.unique(cl_img), key=lambda c: float(np.median(rps.range[cl_rp == c])))
    strength, reach, seen_by, seen = [], [], [], []
    # planar arrays only (module notes)
    parts = None if parts is None or rps.z is None else np.asarray(parts)
    objects = _Objects()
    legs = _Legs(medium)
    for c in order:
        ant = _spread(positions[np.unique(np.asarray(rps.antenna)[cl_rp == c])], MAX_OBJECT_POINTS)
        mine = pts3[cl_img == c]
        amp = float(np.median(np.asarray(rps.amp)[cl_rp == c]))
        # one RP of the cluster (its median range) for the level pre-test
        rr = np.asarray(rps.range, float)[cl_rp == c]
        k = int(np.argsort(rr)[len(rr) // 2])
        one = positions[np.asarray(rps.antenna)[cl_rp == c][k]][None]
        part = None if parts is None else parts[cl_rp == c][0]
        # a cluster whose points lie on surfaces already found images those
        # surfaces (more of a sphere seen by a large array), not the empty
        # space a double bounce is imaged in
        ghost = False
        on_found = objects.covered(mine) > 0.5
        pairs = []
        mine_rp = _nearest_per_antenna(np.asarray(rps.antenna)[cl_rp == c], rr)
        if not on_found and wavelength is not None and seen:
            # the antennas' own re-reflection of an echo found already
            leg_amp = np.asarray(strength)
            ghost = any(
                _repeats(mine_rp, seen[i], resolution, wavelength)
                for i in np.flatnonzero(amp <= GHOST_AMP * leg_amp)
            )
        if not ghost and not on_found and len(legs.clusters) > 1:
            # a leg found in another tile was seen from other antennas,
            # nearer or farther: its amplitude is moved to the cluster's
            # antennas by the spreading (module notes)
            if parts is None:
                scale = 1.0
            else:
                apart = np.asarray(seen_by) != part
                # two-way spherical spreading: amplitude as 1 / R^2
                scale = np.where(apart, np.asarray(reach) / legs.nearest(one), 1.0) ** 2
            # both legs stronger than the cluster by GHOST_AMP, and two
            # objects, not two parts of one
            strong = amp <= GHOST_AMP * np.asarray(strength) * scale
            roots = np.array([objects.root(i) for i in range(len(legs.clusters))])
            keep = strong[:, None] & strong[None, :] & (roots[:, None] != roots[None, :])
            pairs = legs.candidates(one, rr[k], LEVEL_TOL * resolution, keep)
        for i, j in pairs:
            g = ghost_points(ant, legs.clusters[i], legs.clusters[j], medium)
            if len(g) == 0:
                continue
            centre = np.median(g, axis=0)
            gap = min(
                float(np.linalg.norm(centre - legs.medians[i])),
                float(np.linalg.norm(centre - legs.medians[j])),
            )
            if _median_gap(mine, g, centre_xyz) < GHOST_TOL * gap:
                ghost = True
                break
        if ghost:
            flags[cl_img == c] = True
        else:
            strength.append(amp)
            seen.append(mine_rp)
            reach.append(float(np.median(rr)))
            seen_by.append(part)
            objects.add(mine)
            legs.add(_spread(mine, MAX_OBJECT_POINTS))
    return flags


class _Legs:
    """The accepted clusters as legs of double bounces, stacked so that the
    level test of every pair runs at once.

    :meth:`candidates` returns, in the order the test takes them (i < j,
    lexicographic), the pairs whose double-bounce range at an antenna lies
    within the tolerance of the cluster's (:func:`double_bounce` over the
    stacked points).  Pairs whose range cannot: the exact range ``R_AB``
    lies between ``(d_i + D_ij + d_j) / 2`` (the least of each part, ``D``
    the least distance between two clusters' points) and the path through
    the two points nearest the antenna, so only pairs within those bounds
    are formed.  Testing pair by pair made the filter cubic in the clusters:
    110 s for the 518 clusters of a 200-antenna line over eighteen bars.
    """

    #: Pairs whose ranges are formed at once (each a (32, 32) table).
    CHUNK = 2048

    def __init__(self, medium=None):
        self.medium = medium
        self.scale = 1.0 if medium is None else medium.n
        #: each accepted cluster's points (at most MAX_OBJECT_POINTS), their
        #: median, and the points stacked (NaN-padded) for the level test
        self.clusters: list[np.ndarray] = []
        self.medians: list[np.ndarray] = []
        self.points = np.full((0, MAX_OBJECT_POINTS, 3), np.nan)
        self.gap = np.zeros((0, 0))

    def _one_way(self, one: np.ndarray) -> np.ndarray:
        """Leg lengths (clusters, MAX_OBJECT_POINTS) from ``one`` (1, 3) to
        every stacked point (inf at the padding)."""
        p = self.points
        if self.medium is None:
            d = np.linalg.norm(p - one[0], axis=2)
        else:
            from ..io.medium import one_way

            d = one_way(self.medium, one[None], np.nan_to_num(p))
        return np.where(np.isnan(p[..., 0]), np.inf, d)

    def add(self, points: np.ndarray) -> None:
        n = len(self.points)
        row = np.zeros((1, MAX_OBJECT_POINTS, 3))
        row[0, : len(points)] = points
        row[0, len(points) :] = np.nan
        d = np.linalg.norm(self.points[:, :, None, :] - points[None, None], axis=3)
        gap = np.zeros((n + 1, n + 1))
        gap[:n, :n] = self.gap
        gap[n, :n] = gap[:n, n] = self.scale * np.nanmin(d, axis=(1, 2)) if n else []
        self.gap = gap
        self.points = np.concatenate([self.points, row])
        self.clusters.append(points)
        self.medians.append(np.median(points, axis=0))

    def nearest(self, one: np.ndarray) -> np.ndarray:
        """Per accepted cluster, the one-way range from ``one`` (1, 3) to
        its nearest point, m (air-equivalent in a half-space)."""
        return np.maximum(self._one_way(one).min(axis=1), 1e-12)

    def candidates(self, one: np.ndarray, r: float, tol: float, keep) -> list:
        """Pairs (i, j), i < j, that ``keep`` (a (n, n) bool table) allows,
        whose double bounce seen from ``one`` (1, 3) lies within ``tol`` of
        range ``r``."""
        n = len(self.points)
        if n < 2:
            return []
        legs = self._one_way(one)  # (n, P)
        near = np.argmin(legs, axis=1)
        d = legs[np.arange(n), near]
        best = self.points[np.arange(n), near]
        through = self.scale * np.linalg.norm(best[:, None] - best[None], axis=2)
        low = 0.5 * (d[:, None] + self.gap + d[None, :])
        high = 0.5 * (d[:, None] + through + d[None, :])
        ok = (low <= r + tol) & (high >= r - tol) & keep
        i, j = np.nonzero(np.triu(ok, 1))
        out = []
        for c0 in range(0, len(i), self.CHUNK):
            a, b = i[c0 : c0 + self.CHUNK], j[c0 : c0 + self.CHUNK]
            ab = self.scale * np.linalg.norm(
                self.points[a][:, :, None, :] - self.points[b][:, None, :, :], axis=3
            )
            total = legs[a][:, :, None] + ab + legs[b][:, None, :]
            total = np.where(np.isnan(total), np.inf, total)
            rab = 0.5 * total.reshape(len(a), -1).min(axis=1)
            hit = np.abs(r - rab) <= tol
            out.extend(zip(a[hit].tolist(), b[hit].tolist()))
        return out


#: A TOUCH cell's offsets to itself and its 26 neighbours, shape (27, 3).
_BESIDE = np.stack(np.meshgrid(*[np.arange(-1, 2)] * 3, indexing="ij"), -1).reshape(-1, 3)


#: Cells are packed into one int64, :data:`_CELL_BITS` bits an axis, counted
#: from the cell of the first point accepted; where a point lies farther
#: than :data:`_CELL_REACH` cells from it on an axis (10.5 km at 10 mm), the
#: cells are held as tuples in a dict instead (the same answers, slower).
_CELL_BITS = 21
_CELL_REACH = (1 << (_CELL_BITS - 1)) - 2
#: The packed offsets of :data:`_BESIDE`: a cell's and its neighbours' codes
#: are its code plus these (within the reach no axis leaves its bits).
_BESIDE_CODES = (_BESIDE[:, 0] << (2 * _CELL_BITS)) + (_BESIDE[:, 1] << _CELL_BITS) + _BESIDE[:, 2]


class _Objects:
    """Accepted clusters grouped into objects by touching points (union-find
    over the :data:`TOUCH` cells their points occupy; the cells held as
    sorted packed codes, each with the first cluster that occupied it, or
    as a dict of tuples where the points spread beyond the packing's
    reach)."""

    def __init__(self):
        self.parent: list[int] = []
        self.origin = None
        self.codes = np.zeros(0, np.int64)
        self.owner = np.zeros(0, np.int64)
        self.cells: dict | None = None  # the tuple cells, once beyond the reach

    def _root(self, i: int) -> int:
        while self.parent[i] != i:
            self.parent[i] = self.parent[self.parent[i]]
            i = self.parent[i]
        return i

    def _keys(self, points: np.ndarray) -> np.ndarray:
        """The cells of ``points`` (M, 3), shape (M, 3), int64; switches to
        the tuple cells where one lies beyond the packing's reach."""
        keys = np.floor(np.asarray(points, np.float64) / TOUCH).astype(np.int64)
        if self.origin is None:
            self.origin = keys[0].copy()
        if self.cells is None and np.any(np.abs(keys - self.origin) > _CELL_REACH):
            half = 1 << (_CELL_BITS - 1)
            mask = (1 << _CELL_BITS) - 1
            rel = (
                np.stack(
                    [
                        (self.codes >> (2 * _CELL_BITS)) & mask,
                        (self.codes >> _CELL_BITS) & mask,
                        self.codes & mask,
                    ],
                    axis=1,
                )
                - half
            )
            self.cells = {
                tuple(k): int(o) for k, o in zip((rel + self.origin).tolist(), self.owner.tolist())
            }
        return keys

    def _pack(self, keys: np.ndarray) -> np.ndarray:
        """Packed codes of cells within the reach, shape (M,)."""
        k = keys - self.origin + (1 << (_CELL_BITS - 1))
        return (k[:, 0] << (2 * _CELL_BITS)) | (k[:, 1] << _CELL_BITS) | k[:, 2]

    def _held(self, codes: np.ndarray) -> np.ndarray:
        """Per code (any shape), the index of its cell in ``self.codes``, -1
        where no accepted cluster occupies it."""
        if not self.codes.size:
            return np.full(np.shape(codes), -1, np.intp)
        at = np.minimum(np.searchsorted(self.codes, codes), self.codes.size - 1)
        return np.where(self.codes[at] == codes, at, -1)

    def add(self, points: np.ndarray) -> None:
        """The next accepted cluster, by its image points (M, 3): joined to
        every accepted cluster with a point in the same or a neighbouring
        cell (points closer than :data:`TOUCH` always are, wherever the
        cells' edges fall)."""
        me = len(self.parent)
        self.parent.append(me)
        if len(points) == 0:
            return
        keys = self._keys(points)
        if self.cells is not None:
            keys = np.unique(keys, axis=0)
            near = {
                tuple(k) for k in np.unique((keys[:, None, :] + _BESIDE).reshape(-1, 3), axis=0)
            }
            for key in near:
                other = self.cells.get(key)
                if other is not None:
                    self.parent[self._root(other)] = self._root(me)
            for key in map(tuple, keys.tolist()):
                self.cells.setdefault(key, me)
            return
        codes = np.unique(self._pack(keys))
        if self.codes.size:
            near = self._held(np.unique(codes[:, None] + _BESIDE_CODES))
            for other in np.unique(self.owner[near[near >= 0]]).tolist():
                self.parent[self._root(other)] = self._root(me)
            codes = codes[self._held(codes) < 0]  # a cell keeps its first cluster
        order = np.argsort(np.concatenate([self.codes, codes]), kind="stable")
        self.codes = np.concatenate([self.codes, codes])[order]
        self.owner = np.concatenate([self.owner, np.full(codes.size, me, np.int64)])[order]

    def covered(self, points: np.ndarray) -> float:
        """The share of ``points`` (M, 3) in a cell of an accepted cluster or
        a neighbouring one (0 with none accepted)."""
        if not self.parent or len(points) == 0:
            return 0.0
        keys = self._keys(points)
        if self.cells is not None:
            keys, inv = np.unique(keys, axis=0, return_inverse=True)
            hit = np.array(
                [any(tuple(k) in self.cells for k in (key + _BESIDE).tolist()) for key in keys]
            )
        else:
            codes, inv = np.unique(self._pack(keys), return_inverse=True)
            hit = np.any(self._held(codes[:, None] + _BESIDE_CODES) >= 0, axis=1)
        return float(np.mean(hit[inv.ravel()]))

    def same(self, i: int, j: int) -> bool:
        return self._root(i) == self._root(j)

    def root(self, i: int) -> int:
        """The object of accepted cluster ``i``."""
        return self._root(i)


def _median_gap(p: np.ndarray, q: np.ndarray, centre: np.ndarray) -> float:
    """Median over ``p`` of the distance to the nearest point of ``q``, m,
    with the part along the line of sight from ``centre`` (the array's
    centre) weighted by :data:`RADIAL_WEIGHT`."""
    d = p[:, None, :] - q[None]
    u = p - centre
    u = u / np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-12)
    along = np.sum(d * u[:, None, :], axis=2)
    across2 = np.maximum(np.sum(d * d, axis=2) - along**2, 0.0)
    gap = np.sqrt(across2 + (RADIAL_WEIGHT * along) ** 2)
    return float(np.median(np.min(gap, axis=1)))


def ghost_points(antennas: np.ndarray, a: np.ndarray, b: np.ndarray, medium=None) -> np.ndarray:
    """Where RPM images the double bounce A-B seen from ``antennas``: the
    envelope point of each antenna's range sphere (module notes).

    Parameters
    ----------
    antennas : ndarray, shape (N, 3)
        m (y = 0).
    a, b : ndarray, shape (Ma, 3), (Mb, 3)
        m.
    medium : rpm_cl.io.medium.Medium, optional
        A half-space (refracted paths and rays); None: air.

    Returns
    -------
    ndarray, shape (N', 3)
        The points of the antennas where the predicted range walk is a
        direction (|grad R| < 1), m.
    """
    # everything in the plane z = 0 (a linear array's scene): the range is
    # even in z there, its z slope exactly 0
    flat = not (antennas[:, 2].any() or a[:, 2].any() or b[:, 2].any())
    if medium is None:
        r, grad = _bounce_gradient(antennas, a, b)
        if flat:
            grad[:, 2] = 0.0
        return _envelope(antennas, r, grad)
    r = double_bounce(antennas, a, b, medium)
    grad = np.zeros((len(antennas), 3))
    for axis in (0,) if flat else (0, 2):
        e = np.zeros(3)
        e[axis] = GRADIENT_STEP
        grad[:, axis] = (
            double_bounce(antennas + e, a, b, medium) - double_bounce(antennas - e, a, b, medium)
        ) / (2 * GRADIENT_STEP)
    across = 1.0 - grad[:, 0] ** 2 - grad[:, 2] ** 2
    ok = across > 0
    from ..io.medium import point_on_ray

    p = np.sqrt(np.maximum(1.0 - across, 0.0))
    h = -grad[:, [0, 2]]
    e = np.where(p[:, None] > 0, h / np.where(p > 0, p, 1.0)[:, None], [1.0, 0.0])
    pt, _ = point_on_ray(medium, antennas, np.where(ok, p, 0.0), e, r)
    return pt[ok]


def _bounce_gradient(antennas: np.ndarray, a: np.ndarray, b: np.ndarray):
    """In air: :func:`double_bounce`'s range (N,) and its gradient in the
    antenna's position (N, 3), exact: the path through the points A_i, B_j
    that give the least range moves with the antenna as half the sum of the
    unit vectors from them to it (the choice of points is fixed where the
    least is unique, i.e. almost everywhere)."""
    da = np.linalg.norm(antennas[:, None, :] - a[None], axis=2)  # (N, Ma)
    db = np.linalg.norm(antennas[:, None, :] - b[None], axis=2)  # (N, Mb)
    ab = np.linalg.norm(a[:, None, :] - b[None], axis=2)  # (Ma, Mb)
    total = (da[:, :, None] + ab[None] + db[:, None, :]).reshape(len(antennas), -1)
    best = np.argmin(total, axis=1)
    i, j = np.divmod(best, b.shape[0])
    n = np.arange(len(antennas))
    ua = (antennas - a[i]) / np.maximum(da[n, i], 1e-300)[:, None]
    ub = (antennas - b[j]) / np.maximum(db[n, j], 1e-300)[:, None]
    return 0.5 * total[n, best], 0.5 * (ua + ub)


def _envelope(antennas: np.ndarray, r: np.ndarray, grad: np.ndarray) -> np.ndarray:
    """The envelope point of each antenna's range sphere ``r`` with range
    gradient ``grad`` (air): ``a - r grad``, at ``y = r sqrt(1 - |grad_xz|^2)``;
    the antennas where that is real."""
    across = 1.0 - grad[:, 0] ** 2 - grad[:, 2] ** 2
    ok = across > 0
    out = antennas - r[:, None] * grad
    out[:, 1] = r * np.sqrt(np.where(ok, across, 0.0))
    return out[ok]


def repeats(cluster, leg, resolution: float, wavelength: float) -> bool:
    """Whether a cluster's echo is its leg's sent back by the antennas
    (module notes, "Repeats"): at the antennas both hold (each antenna's
    nearest RP of each), its ranges are
    ``n`` times the leg's (``n`` in :data:`REPEAT_ORDERS`) to within
    :data:`REPEAT_LEVEL` range resolutions in the median and
    :data:`REPEAT_SHAPE` wavelengths RMS about that median.

    Parameters
    ----------
    cluster, leg : tuple of ndarray
        (flat antenna indices, ranges in m) of the RPs of each.
    resolution, wavelength : float
        m.
    """
    return _repeats(
        _nearest_per_antenna(*cluster), _nearest_per_antenna(*leg), resolution, wavelength
    )


def _repeats(cluster, leg, resolution: float, wavelength: float) -> bool:
    """:func:`repeats` of the (antennas, ranges) of :func:`_nearest_per_antenna`."""
    (ant_c, r_c), (ant_l, r_l) = cluster, leg
    if ant_c.size == 0 or ant_l.size == 0:
        return False
    pos = np.searchsorted(ant_l, ant_c)
    pos = np.minimum(pos, ant_l.size - 1)
    both = ant_l[pos] == ant_c
    if np.count_nonzero(both) < max(3, REPEAT_SHARED * ant_c.size):
        return False
    rc, rl = r_c[both], r_l[pos[both]]
    for n in REPEAT_ORDERS:
        d = rc - n * rl
        mid = float(np.median(d))
        if (
            abs(mid) <= REPEAT_LEVEL * resolution
            and float(np.sqrt(np.mean((d - mid) ** 2))) <= REPEAT_SHAPE * wavelength
        ):
            return True
    return False


def _nearest_per_antenna(antenna, rng):
    """(antennas, ranges) with each antenna's nearest RP only (a cluster may
    hold two at one antenna), sorted by antenna."""
    ant, r = np.asarray(antenna), np.asarray(rng, np.float64)
    order = np.lexsort((r, ant))
    ant, r = ant[order], r[order]
    first = np.r_[True, ant[1:] != ant[:-1]] if ant.size else np.zeros(0, bool)
    return ant[first], r[first]
