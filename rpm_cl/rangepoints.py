"""Range points (RPs): local maxima of |s(X[,Z], R)| along R (paper eq. 5).

Each RP is a local maximum of the envelope along R at one antenna, refined to
sub-sample precision by a parabola through the three samples around it; its
amplitude is the parabola's peak value.  RPs carry the cluster they came from.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .data import InputError, RadarData
from .kspace import Decomposition

__all__ = ["RangePoints", "profile_peaks", "rps_from_decomposition", "rps_from_profiles"]


@dataclass(frozen=True)
class RangePoints:
    """A set of RPs sorted by cluster.

    Attributes
    ----------
    antenna : ndarray of int, shape (K,)
        Flat antenna index (C order of the array).
    x : ndarray, shape (K,)
        Antenna x, m.
    z : ndarray, shape (K,) or None
        Antenna z for planar arrays, m.
    range : ndarray, shape (K,)
        Refined range, m.
    amp : ndarray, shape (K,)
        |s| at the refined peak.
    cluster : ndarray of int, shape (K,)
        Cluster index, non-decreasing.
    """

    antenna: np.ndarray
    x: np.ndarray
    z: np.ndarray | None
    range: np.ndarray
    amp: np.ndarray
    cluster: np.ndarray

    def __post_init__(self):
        n = np.size(self.range)
        for name in ("antenna", "x", "amp", "cluster"):
            if np.size(getattr(self, name)) != n:
                raise InputError(f"RangePoints.{name} has {np.size(getattr(self, name))} values, "
                                 f"range has {n}")
        if self.z is not None and np.size(self.z) != n:
            raise InputError("RangePoints.z length differs from range")
        if n and np.any(np.diff(self.cluster) < 0):
            raise InputError("RangePoints must be sorted by cluster")

    def __len__(self) -> int:
        return int(np.size(self.range))

    @property
    def dim(self) -> int:
        return 2 if self.z is None else 3

    def cluster_bounds(self):
        """Start index and size of each RP's cluster, shape (K,) each."""
        c = np.asarray(self.cluster)
        if c.size == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        _, first, counts = np.unique(c, return_index=True, return_counts=True)
        which = np.searchsorted(np.unique(c), c)
        return first[which], counts[which]


def profile_peaks(env: np.ndarray, rel_threshold: float):
    """Local maxima along the last axis with parabolic refinement.

    Parameters
    ----------
    env : ndarray, shape (n_profiles, nr)
        Envelopes |s|, >= 0.
    rel_threshold : float
        Keep peaks >= this fraction of each ``env``'s global maximum.

    Returns
    -------
    profile : ndarray of int, shape (K,)
        Row of each peak.
    pos : ndarray, shape (K,)
        Fractional sample index of the refined peak.
    value : ndarray, shape (K,)
        Refined peak value.
    """
    if env.shape[-1] < 3 or env.size == 0:
        return np.zeros(0, int), np.zeros(0), np.zeros(0)
    a, b, c = env[:, :-2], env[:, 1:-1], env[:, 2:]
    gmax = float(env.max())
    peak = (b > a) & (b >= c) & (b > 0) & (b >= rel_threshold * gmax)
    row, col = np.nonzero(peak)
    a, b, c = a[row, col], b[row, col], c[row, col]
    den = a - 2 * b + c  # < 0 at a strict maximum
    with np.errstate(divide="ignore", invalid="ignore"):
        delta = np.where(den < 0, 0.5 * (a - c) / den, 0.0)
    delta = np.clip(delta, -0.5, 0.5)
    value = b - 0.25 * (a - c) * delta
    return row, col + 1 + delta, value


def _make(data: RadarData, flat_ant, r, amp, cluster) -> RangePoints:
    arr = data.array
    order = np.argsort(cluster, kind="stable")
    flat_ant, r, amp, cluster = flat_ant[order], r[order], amp[order], cluster[order]
    if arr.planar:
        ix, iz = np.unravel_index(flat_ant, arr.shape)
        x, z = arr.x[ix], arr.z[iz]
    else:
        x, z = arr.x[flat_ant], None
    return RangePoints(flat_ant.astype(np.int64), x, z, r, amp, cluster.astype(np.int64))


def rps_from_decomposition(data: RadarData, dec: Decomposition,
                           rp_threshold_db: float) -> RangePoints:
    """RPs of every decomposed signal (eq. 5), each carrying its cluster.

    Parameters
    ----------
    data : RadarData
    dec : Decomposition
    rp_threshold_db : float
        Peaks below this level relative to the cluster's maximum are dropped, dB.
    """
    rel = 10.0 ** (rp_threshold_db / 20.0)
    ants, rs, amps, cl = [], [], [], []
    for m, c in enumerate(dec.clusters):
        env = np.abs(c.signal).reshape(-1, c.signal.shape[-1])
        row, pos, val = profile_peaks(env, rel)
        ants.append(row)
        rs.append(data.range[c.r_slice.start] + pos * data.dr + np.ravel(c.offset)[row])
        amps.append(val)
        cl.append(np.full(row.size, m))
    if not ants:
        z = np.zeros(0)
        return _make(data, z.astype(int), z, z, z.astype(int))
    return _make(data, np.concatenate(ants), np.concatenate(rs), np.concatenate(amps),
                 np.concatenate(cl))


def rps_from_profiles(data: RadarData, rp_threshold_db: float) -> RangePoints:
    """RPs of the plain matched-filter output (no decomposition): one cluster.

    Parameters
    ----------
    data : RadarData
    rp_threshold_db : float
        Peaks below this level relative to the global maximum are dropped, dB.
    """
    env = np.abs(data.signal).reshape(-1, data.range.size)
    row, pos, val = profile_peaks(env, 10.0 ** (rp_threshold_db / 20.0))
    return _make(data, row, data.range[0] + pos * data.dr, val, np.zeros(row.size, int))
