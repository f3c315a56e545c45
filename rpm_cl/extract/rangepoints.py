"""Range points (RPs): local maxima of |s(X[,Z], R)| along R (paper eq. 5).

Each RP is a local maximum of the envelope along R at one antenna, refined to
sub-sample precision by a parabola through the three samples around it; its
amplitude is the parabola's peak value.  RPs carry the cluster they came from
and, from a decomposition, the complex sample of their decomposed signal at
the refined peak: its phase is the echo's carrier phase ``-2 k_c R_t``
(:mod:`rpm_cl.extract.phase` uses it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..io.data import InputError, RadarData
from .types import Decomposition

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
    sample : ndarray, complex, shape (K,), or None
        The decomposed signal at the refined peak (linear interpolation
        between its two range gates, any focusing phase of the
        decomposition put back), so that its phase is the echo's carrier
        phase ``-2 k_c R_t`` up to the scatterer's own constant; None where
        the RPs carry no phase (matched filter, Capon).
    """

    antenna: np.ndarray
    x: np.ndarray
    z: np.ndarray | None
    range: np.ndarray
    amp: np.ndarray
    cluster: np.ndarray
    sample: np.ndarray | None = None

    def __post_init__(self):
        n = np.size(self.range)
        for name in ("antenna", "x", "amp", "cluster"):
            if np.size(getattr(self, name)) != n:
                raise InputError(
                    f"RangePoints.{name} has {np.size(getattr(self, name))} values, range has {n}"
                )
        if self.z is not None and np.size(self.z) != n:
            raise InputError("RangePoints.z length differs from range")
        if self.sample is not None and np.size(self.sample) != n:
            raise InputError("RangePoints.sample length differs from range")
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


def _make(data: RadarData, flat_ant, r, amp, cluster, sample=None) -> RangePoints:
    arr = data.array
    order = np.argsort(cluster, kind="stable")
    flat_ant, r, amp, cluster = flat_ant[order], r[order], amp[order], cluster[order]
    sample = None if sample is None else sample[order]
    if arr.planar:
        ix, iz = np.unravel_index(flat_ant, arr.shape)
        x, z = arr.x[ix], arr.z[iz]
    else:
        x, z = arr.x[flat_ant], None
    return RangePoints(flat_ant.astype(np.int64), x, z, r, amp, cluster.astype(np.int64), sample)


def _carrier(data: RadarData, c, row, pos) -> np.ndarray:
    """The decomposed signal of cluster ``c`` at fractional gates ``pos`` of
    its flattened antennas ``row``, with the focusing phase
    ``exp(2j k_c q(X))`` of the decomposition (:mod:`rpm_cl.extract.kspace`, step 5)
    taken off again, so that its phase is the echo's ``-2 k_c R_t``.

    The profiles' phase is constant near a peak (a real envelope around the
    carrier), so linear interpolation between the two gates keeps it.
    """
    sig = c.signal.reshape(-1, c.signal.shape[-1])
    g0 = np.clip(np.floor(pos).astype(np.int64), 0, max(0, sig.shape[1] - 2))
    t = np.clip(pos - g0, 0.0, 1.0)
    g1 = np.minimum(g0 + 1, sig.shape[1] - 1)
    z = (1.0 - t) * sig[row, g0] + t * sig[row, g1]
    if c.focus is not None:
        from .kspace_geometry import _array_axes, _centred_grids

        grids = _centred_grids(_array_axes(data.array))
        q = np.ravel(c.offset - sum(c.direction[a] * grids[a] for a in range(len(grids))))
        z = z * np.exp(-2j * data.waveform.kc * q[row])
    return z


def rps_from_decomposition(
    data: RadarData, dec: Decomposition, rp_threshold_db: float
) -> RangePoints:
    """RPs of every decomposed signal (eq. 5), each carrying its cluster.

    Parameters
    ----------
    data : RadarData
    dec : Decomposition
    rp_threshold_db : float
        Peaks below this level relative to the cluster's maximum are dropped, dB.
    """
    rel = 10.0 ** (rp_threshold_db / 20.0)
    ants, rs, amps, cl, zs = [], [], [], [], []
    lo, hi = float(data.range[0]), float(data.range[-1])
    for m, c in enumerate(dec.clusters):
        env = np.abs(c.signal).reshape(-1, c.signal.shape[-1])
        row, pos, val = profile_peaks(env, rel)
        r = data.range[c.r_slice.start] + pos * data.dr + np.ravel(c.offset)[row]
        # an aligned profile holds range[g] + offset[X]: a peak the
        # alignment put beyond the data's axis was read where it holds
        # nothing (a steep walk over a long line reaches tens of m)
        inside = (r >= lo) & (r <= hi)
        row, pos, val, r = row[inside], pos[inside], val[inside], r[inside]
        ants.append(row)
        rs.append(r)
        amps.append(val)
        cl.append(np.full(row.size, m))
        zs.append(_carrier(data, c, row, pos))
    if not ants:
        z = np.zeros(0)
        return _make(data, z.astype(int), z, z, z.astype(int), z.astype(complex))
    return _make(
        data,
        np.concatenate(ants),
        np.concatenate(rs),
        np.concatenate(amps),
        np.concatenate(cl),
        np.concatenate(zs),
    )


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
