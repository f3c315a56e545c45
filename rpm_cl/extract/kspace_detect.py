"""Detection of the k-space decomposition's cluster centres
(:mod:`rpm_cl.extract.kspace`, step 2): local maxima of the detection map
over (k, R), and the runs and regimes of range gates it is computed on.

The steps named in the docstrings below ("module notes, step N") are those
of the notes of :mod:`rpm_cl.extract.kspace`.
"""

from __future__ import annotations

import numpy as np

from ..filters import maximum_filter
from ..io.data import RadarData

#: Non-maximum suppression of the centre search: a quarter of the window
#: period in k (two centres closer share most of one window).
NMS_K_PERIODS = 0.25


def _runs(mask: np.ndarray):
    """Contiguous runs of True in a 1-D mask, as (start, stop) pairs."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.nonzero(d == 1)[0], np.nonzero(d == -1)[0]))


def _regimes(dechirp, nr: int) -> list:
    """The gates whose detection maxima are compared with each other: all of
    them, or the dechirped and the plain ones apart (dechirping raises a
    focused target's peak, by 9 dB on the tapered map of a 64 x 64 array, so
    one relative threshold over both would drop targets at plain gates).
    Boolean masks over the range gates, none empty."""
    if dechirp is None:
        return [np.ones(nr, bool)]
    return [m for m in (np.asarray(dechirp, bool), ~np.asarray(dechirp, bool)) if m.any()]


def _centres(det: np.ndarray, size: list, n_k: int, threshold, g0: int, nr: int):
    """Local maxima of ``det`` (one run of range gates starting at gate g0)
    at or above ``threshold`` (a scalar, or one value per gate of the run):
    (indices with global gates, values)."""
    mode = ["wrap"] * n_k + ["nearest"]
    # a window wider than its axis sees the whole axis, as the axis's own
    # length (wrapped) or twice it (edges repeated) does: the same maxima,
    # at a cost bounded by the data, not by the resolution
    size = [min(int(s), n if m == "wrap" else 2 * n + 1) for s, n, m in zip(size, det.shape, mode)]
    # a strict maximum along R (a flat run of equal values, e.g. a constant
    # signal, is not a peak: every gate of it would pass the window test)
    local = np.zeros(det.shape, bool)
    local[..., 1:-1] = (det[..., 1:-1] > det[..., :-2]) & (det[..., 1:-1] >= det[..., 2:])
    local &= (det >= threshold) & (det > 0)
    cand = np.argwhere(local)
    if len(cand) * int(np.prod(size)) <= SPARSE_SHARE * det.size:
        # few candidates (a 187 x 144 array's map of 35 million samples held
        # 1746): each one's window is read on its own, the same comparison as
        # the whole map's filter at a fraction of its passes
        local[tuple(cand.T)] = det[tuple(cand.T)] >= _window_max(det, cand, size, mode)
    else:
        local &= det == maximum_filter(det, size, mode)
    idx = np.argwhere(local)
    vals = det[tuple(idx.T)]
    idx[:, -1] += g0
    # a peak on the first or last range gate is the edge of the axis, not a maximum
    keep = (idx[:, -1] > 0) & (idx[:, -1] < nr - 1)
    return idx[keep], vals[keep]


#: The centre test reads each candidate's window on its own
#: (:func:`_window_max`) where the candidates' windows hold at most this
#: share of the map's samples, else filters the whole map (about log2 of
#: the window's length passes over it per axis).
SPARSE_SHARE = 1.0
#: Candidates whose windows :func:`_window_max` reads at once (memory: this
#: times the window's samples, 8 bytes each).
WINDOW_CHUNK = 512


def _window_max(a: np.ndarray, at: np.ndarray, size, mode) -> np.ndarray:
    """``maximum_filter(a, size, mode)`` at the points ``at`` only (shape
    (C, a.ndim)): each point's window read directly, modes "wrap" and
    "nearest" per axis (origin 0, as the filter's)."""
    out = np.empty(len(at), a.dtype)
    offsets = [np.arange(s) - s // 2 for s in size]
    for c0 in range(0, len(at), WINDOW_CHUNK):
        pts = at[c0 : c0 + WINDOW_CHUNK]
        index = []
        for ax, (off, m) in enumerate(zip(offsets, mode)):
            i = pts[:, ax, None] + off[None, :]
            i = i % a.shape[ax] if m == "wrap" else np.clip(i, 0, a.shape[ax] - 1)
            shape = [len(pts)] + [1] * a.ndim
            shape[ax + 1] = len(off)
            index.append(i.reshape(shape))
        out[c0 : c0 + len(pts)] = a[tuple(index)].reshape(len(pts), -1).max(axis=1)
    return out


def _nms_size(data: RadarData, periods, k_axes, close: bool = False):
    """The non-maximum suppression neighbourhood of the centres (module
    notes, step 2): a quarter window period in k, half a range resolution
    in R.  ``close`` (``KSpaceParams.close_centres``, linear arrays): in k
    at most one aperture resolution cell ``2 pi / L``, the closest two
    directions the aperture tells apart.

    Returns
    -------
    size : list of int
        Points per k axis, then range gates (odd).
    half_r : int
        Half its length along R, range gates.
    """
    n_k = data.array.dim - 1
    dr = data.dr
    # non-maximum suppression neighbourhood: a quarter window period in k,
    # half a range resolution in R; k axes periodic, R not.
    size = [
        2 * int(np.ceil(NMS_K_PERIODS * periods[a] / abs(k_axes[a][1] - k_axes[a][0]))) + 1
        for a in range(n_k)
    ]
    if close and n_k == 1:
        cell = 2 * np.pi / max(float(np.ptp(data.array.x)), 1e-12)
        size[0] = min(size[0], 2 * int(np.ceil(cell / abs(k_axes[0][1] - k_axes[0][0]))) + 1)
    size = [min(s_, len(k)) for s_, k in zip(size, k_axes)]
    half_r = int(np.ceil(0.5 * data.waveform.range_resolution / dr))
    size.append(2 * half_r + 1)
    return size, half_r


def _ranked_centres(found, size, n_k: int, threshold, nr: int) -> np.ndarray:
    """The centres of every run of gates searched (:func:`_centres`), largest
    first: indices (k indices, gate), shape (n_centres, n_k + 1).

    ``found`` holds (detection map of the run, its first gate) pairs;
    ``threshold`` is one value per range gate."""
    peaks = [_centres(d, size, n_k, threshold[g0 : g0 + d.shape[-1]], g0, nr) for d, g0 in found]
    idx = np.concatenate([p[0] for p in peaks])
    vals = np.concatenate([p[1] for p in peaks])
    return idx[np.argsort(-vals, kind="stable")]
