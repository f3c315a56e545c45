"""Accuracy as the paper reports it (Tables I-V).

- Err_range: per RP, the distance between its range and the nearest true
  range at the same antenna (the paper's "minimum distance between the true and
  estimated ranges for each RP"); unavailable where the truth holds the
  boundary only (``Truth.has_rps`` False).
- Err_RPM: per image point, the distance to the nearest sample of the densely
  sampled true boundary.
- Cumulative fractions: the share of RPs / points with error <= a threshold.
- Echoes found (not in the paper): the true echoes with an RP at their
  antenna within a tolerance, i.e. how much of the scene the RPs cover.
"""

from __future__ import annotations

import numpy as np

from .io.data import InputError, Truth

__all__ = ["cumulative", "echoes_found", "err_range", "err_rpm", "pct", "summary"]


def err_range(antenna, rng, truth: Truth) -> np.ndarray:
    """Err_range of each RP, m (inf where its antenna has no true echo).

    Parameters
    ----------
    antenna : ndarray of int, shape (K,)
        Flat antenna index of each RP.
    rng : ndarray, shape (K,)
        RP ranges, m.
    truth : Truth
        With its true RPs (``truth.has_rps``).

    Raises
    ------
    InputError
        The truth has no true RPs.
    """
    _need_rps(truth)
    antenna = np.asarray(antenna)
    rng = np.asarray(rng, np.float64)
    out = np.full(rng.shape, np.inf)
    if rng.size == 0 or truth.rp_range.size == 0:
        return out
    order = np.argsort(truth.rp_antenna, kind="stable")
    t_ant, t_rng = truth.rp_antenna[order], truth.rp_range[order]
    lo = np.searchsorted(t_ant, antenna, "left")
    hi = np.searchsorted(t_ant, antenna, "right")
    longest = int(np.max(hi - lo))
    for off in range(longest):  # a few true echoes per antenna at most
        k = lo + off
        ok = k < hi
        d = np.abs(rng - t_rng[np.minimum(k, t_rng.size - 1)])
        out = np.where(ok, np.minimum(out, d), out)
    return out


def echoes_found(antenna, rng, truth: Truth, tol: float = 0.010) -> int:
    """Number of true echoes with an RP at the same antenna within ``tol``
    (m) of their range: Err_range with the roles of RPs and truth swapped.

    Parameters
    ----------
    antenna, rng, truth
        The RPs and the truth, as for :func:`err_range`.
    tol : float
        Largest range difference, m.
    """
    _need_rps(truth)
    rps = Truth(np.asarray(antenna, np.int64), rng, truth.boundary)
    return cumulative(err_range(truth.rp_antenna, truth.rp_range, rps), tol)[0]


#: Err_RPM compares every (point, boundary sample) pair up to this many
#: pairs (a paper 2-D scene: about 2e5), else it builds a k-d tree (SciPy,
#: about 0.5 s to import; the human body: 2057 points x 1e5 samples).
BRUTE_FORCE_PAIRS = 20_000_000
#: Pairs per chunk of the brute-force comparison (24 bytes each, x3 dims).
BRUTE_FORCE_CHUNK = 1_000_000


def err_rpm(points, truth: Truth) -> np.ndarray:
    """Err_RPM of each image point, m.

    Parameters
    ----------
    points : ndarray, shape (M, dim)
    truth : Truth
    """
    points = np.asarray(points, np.float64)
    if points.size == 0:
        return np.zeros(0)
    b = np.asarray(truth.boundary, np.float64)
    if points.shape[0] * b.shape[0] > BRUTE_FORCE_PAIRS:
        from scipy.spatial import cKDTree  # on first use: about 0.5 s of import

        d, _ = cKDTree(b).query(points)
        return d
    # a small scene: every pair, in chunks (no SciPy import on a small run)
    step = max(1, BRUTE_FORCE_CHUNK // max(1, b.shape[0]))
    return np.concatenate(
        [
            np.sqrt(np.min(np.sum((p[:, None, :] - b[None]) ** 2, axis=2), axis=1))
            for p in (points[i : i + step] for i in range(0, len(points), step))
        ]
    )


def pct(n: int, d: int) -> str:
    """``"95.2% (60/63)"``, or ``"-"`` when ``d`` is 0."""
    return f"{100.0 * n / d:.1f}% ({n}/{d})" if d else "-"


def cumulative(errors, threshold: float) -> tuple[int, int]:
    """(number with error <= threshold, total)."""
    errors = np.asarray(errors)
    return int(np.sum(errors <= threshold)), int(errors.size)


def _need_rps(truth: Truth) -> None:
    if not truth.has_rps:
        raise InputError(
            "the truth has no true RPs (truth_rp_antenna, truth_rp_range): Err_range is unavailable"
        )


def summary(rps, image, truth: Truth) -> dict:
    """The paper's figures for one result.

    Returns
    -------
    dict
        ``rp_total``, ``rp_within_10mm``, ``rpm_total``, ``rpm_within_10mm``,
        ``rpm_within_50mm``, ``rpm_within_100mm``.  ``rp_within_10mm`` is None
        where the truth has no true RPs (a boundary only: Err_range is
        unavailable, Err_RPM is computed).
    """
    e_p = err_rpm(image.points, truth)
    within = (
        cumulative(err_range(rps.antenna, rps.range, truth), 0.010)[0] if truth.has_rps else None
    )
    out = {"rp_total": len(rps.range), "rp_within_10mm": within, "rpm_total": int(e_p.size)}
    for mm in (10, 50, 100):
        out[f"rpm_within_{mm}mm"] = cumulative(e_p, mm / 1000.0)[0]
    return out
