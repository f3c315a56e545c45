"""Near-field focusing and autofocus of the k-space decomposition's clusters
(:mod:`rpm_cl.extract.kspace`, steps 5 and 6).

The focus term of the range walk of a point at a cluster's range
(:func:`_focus_range`, exact, with the Fresnel part of each array axis
scaled by a factor where the autofocus fitted one), and the autofocus that
picks those factors for the largest whole-aperture coherent peak
(:func:`_autofocus`).

The steps named in the docstrings below ("module notes, step N") are those
of the notes of :mod:`rpm_cl.extract.kspace`.
"""

from __future__ import annotations

import numpy as np

from .kspace_geometry import _centred_grids

#: Factors of the Fresnel (quadratic) part of the wavefront tried along each
#: array axis by the autofocus (module notes, step 6): ``r_c / (r_c + rho)``
#: for a convex surface of curvature radius ``rho`` at range ``r_c`` (1: a
#: point, 0: flat along that axis), a little beyond 1 for concave ones.  The
#: best of these is then refined by AUTOFOCUS_REFINE on each side.
AUTOFOCUS_FACTORS = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0, 1.2)
AUTOFOCUS_REFINE = 0.1
#: The refinement then halves its step while a step still moves the
#: Fresnel phase at the aperture's edge by more than a quarter cycle, down
#: to this factor step at most.
AUTOFOCUS_FINEST = 1e-3
#: Range gates on each side of the coherent peak's gate that the autofocus
#: compares the wavefronts on.
AUTOFOCUS_GATES = 2
#: The fitted wavefront replaces the point's only where it raises the
#: coherent peak by this factor.  Measured on the human body at 20 dB: 2.4-6.5
#: for the torso, arms and thighs seen by 64 x 64 (where it finds 97.4 % of
#: the echoes instead of 91.3 %), 1.005-1.14 on 32 x 32 (where it found 0.4 %
#: more echoes but cost about a point of RPM <= 10 mm, in the forearms); an
#: any-gain rule also took factors from noise-only clusters (9 of 10 on a
#: 48 x 48 array).
AUTOFOCUS_MARGIN = 1.25


def _autofocus(whole_peak, lin, coherent, u, axes_x, r_c, lo, k_c):
    """Per-axis factors of the Fresnel part of the focus wavefront that
    maximise a cluster's whole-aperture coherent peak (module notes, step 6),
    or None where the point focus (all 1) stays best.

    ``whole_peak(delta, q, gates)`` is :func:`_align`'s: the whole-aperture
    coherent peak at the cluster's k of the profiles shifted by ``delta``
    and focused by ``q`` over ``gates``.  ``lin`` is the cluster's linear range walk u . dX (m,
    the alignment without the focus term), ``coherent`` its signal aligned
    and focused as a point at ``r_c``, times the conjugate plane wave of its
    k, over gates ``lo:lo + n``.  Each candidate wavefront re-aligns the
    profiles (the focus term is part of the range offset) over the
    ``2 AUTOFOCUS_GATES + 1`` gates around the point focus's coherent peak
    only.  One axis at a time, the
    others held: :data:`AUTOFOCUS_FACTORS`, then AUTOFOCUS_REFINE either side
    of the best (within the factors' range); two sweeps over the axes at
    most.  The result is kept only where its peak is AUTOFOCUS_MARGIN times
    the point focus's; it is then refined by halving the step while a step
    moves the Fresnel phase at the aperture's edge by more than a quarter
    cycle at the carrier wavenumber ``k_c`` (rad/m), down to
    :data:`AUTOFOCUS_FINEST`.
    """
    n = coherent.shape[-1]
    g = int(np.argmax(np.abs(coherent.reshape(-1, n).sum(axis=0))))
    gates = (lo + max(0, g - AUTOFOCUS_GATES), lo + min(n, g + AUTOFOCUS_GATES + 1))
    terms = _focus_terms(u, axes_x, r_c)
    memo = {}

    def peak(f):
        key = tuple(np.round(f, 6))
        if key not in memo:
            q = _surface_term(u, axes_x, r_c, f, *terms)
            memo[key] = whole_peak(lin + q, q, gates)
        return memo[key]

    # the finest step the refinement halves down to: a factor step whose
    # Fresnel phase at the aperture's edge, 2 k_c df max|quad|, is a quarter
    # of a cycle (0.003 for a 0.56 m scan 0.1 m over a surface at 24 GHz;
    # the grid's 0.1 there is 13 rad)
    edge = max(float(np.abs(q).max()) for q in terms[1]) if terms[1] else 0.0
    fine = max(AUTOFOCUS_FINEST, 0.25 * np.pi / (2.0 * k_c * edge)) if edge > 0 else np.inf

    f = np.ones(len(axes_x))
    best = point = peak(f)
    lo_f, hi_f = min(AUTOFOCUS_FACTORS), max(AUTOFOCUS_FACTORS)

    def sweeps(f, best, levels):
        """One axis at a time, the others held: each level (a tuple of
        factors, or a step either side of the best so far), two sweeps over
        the axes at most."""
        for _ in range(2):
            start = f.copy()
            for a in range(len(axes_x)):
                for values in levels:
                    if not isinstance(values, tuple):  # refine around the best so far
                        values = [v for v in (f[a] - values, f[a] + values) if lo_f <= v <= hi_f]
                    for v in values:
                        trial = f.copy()
                        trial[a] = v
                        p = peak(trial)
                        if p > best:
                            best, f = p, trial
            if np.array_equal(f, start):
                break
        return f, best

    f, best = sweeps(f, best, [AUTOFOCUS_FACTORS, AUTOFOCUS_REFINE])
    if np.all(f == 1.0) or not best >= AUTOFOCUS_MARGIN * point:
        return None
    # only a surface the coarse fit found is refined: from a point focus
    # whose direction is a little off, the fine steps climb a side lobe of
    # the coherent peak (a point 0.46 m from a 1 m linear array: 0.9375 at
    # 1.9 times the point's peak, and a tenth of its RPs then off it)
    steps, step = [], AUTOFOCUS_REFINE / 2
    while step >= fine:
        steps.append(step)
        step /= 2
    return sweeps(f, best, steps)[0]


def _focus_terms(u, axes_x, r_c: float):
    """The exact focus term of :func:`_focus_range` and the Fresnel part of
    each axis, ``(1 - u_a^2) dX_a^2 / (2 r_c)``, m (arrays of the array's
    shape)."""
    grids = _centred_grids(axes_x)
    r_c = max(float(r_c), 1e-9)
    u = np.asarray(u, float)
    ud = sum(u[a] * grids[a] for a in range(len(grids)))
    d2 = sum(g * g for g in grids)
    # |X - p| - r_c = (|dX|^2 + 2 r_c u.dX) / (|X - p| + r_c), without cancellation
    dist = np.sqrt(np.maximum(d2 + 2 * r_c * ud + r_c * r_c, 0.0))
    exact = (d2 + 2 * r_c * ud) / (dist + r_c) - ud
    return exact, [(1.0 - u[a] ** 2) * grids[a] ** 2 / (2.0 * r_c) for a in range(len(grids))]


def _focus_range(u, axes_x, r_c: float, f=None) -> np.ndarray:
    """Focus term of the range walk, m (module notes, steps 5-6): the range
    of a point at range ``r_c`` from the array's centre with range slope
    ``u`` (direction cosines ``-u``), minus ``r_c`` and the linear term
    ``u . dX``, exactly (not only the Fresnel term of :func:`_curvature`:
    at ``|u| = 0.5`` across a 0.47 m aperture at 1.2 m the next term is
    1.5 rad of phase).  ``f`` (one factor per array axis) scales the Fresnel
    part along each axis, ``(1 - u_a^2) dX_a^2 / (2 r_c)``: the wavefront of
    a surface curved more gently than a point (:func:`_surface_term`).

    Returns
    -------
    ndarray, shape of the array
    """
    exact, quads = _focus_terms(u, axes_x, r_c)
    return exact if f is None else _surface_term(u, axes_x, r_c, f, exact, quads)


def _surface_term(u, axes_x, r_c: float, f, exact, quads) -> np.ndarray:
    """The focus term of a surface whose Fresnel part along axis a is
    ``f[a]`` times a point's at ``r_c``.

    A sphere of radius rho whose nearest point lies at range r_c returns
    the wavefront of a point at ``r_c + rho`` (its centre's range less rho),
    and ``f = r_c / (r_c + rho)``: so where every factor is below 1 the
    exact term is a point's at ``r_c / max(f)``, the other axes' Fresnel
    parts scaled down from there.  Only the Fresnel parts are scaled where a
    factor reaches 1 or more (concave or point-like along that axis).  The
    exact term matters where the aperture is not small against the range:
    a 0.56 m scan 0.1 m over a surface of 2.9 m curvature radius (``f`` =
    0.034) has a point's higher terms at 0.1 m of 0.19 m at its corners,
    which Fresnel scaling alone keeps.
    """
    f = np.asarray(f, float)
    top = float(f.max())
    if top >= 1.0:
        return _with_factors(exact, quads, f)
    if top <= 0.0:  # flat along every axis
        return np.zeros_like(exact)
    base = _focus_terms(u, axes_x, r_c / top)[0]
    return base + sum((f[a] - top) * quads[a] for a in range(len(quads)))


def _with_factors(exact, quads, f) -> np.ndarray:
    """The focus term with the Fresnel part of axis a scaled by ``f[a]``."""
    return exact + sum((f[a] - 1.0) * quads[a] for a in range(len(quads)))
