"""Detection of the k-space decomposition's cluster centres
(:mod:`rpm_cl.extract.kspace`, step 2): local maxima of the detection map
over (k, R), the runs and regimes of range gates it is computed on, and
the centres at the peaks of the coherent image that the map's leave out
(:func:`coherent_centres`).

The steps named in the docstrings below ("module notes, step N") are those
of the notes of :mod:`rpm_cl.extract.kspace`.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..filters import maximum_filter
from ..io.data import RadarData

#: Non-maximum suppression of the centre search: a quarter of the window
#: period in k (two centres closer share most of one window).
NMS_K_PERIODS = 0.25


def _taper(shape: tuple) -> np.ndarray:
    """Hann taper across the array axes, shape ``shape + (1,)``."""
    w = np.ones(tuple(shape) + (1,))
    for a, n in enumerate(shape):
        shp = [1] * (len(shape) + 1)
        shp[a] = n
        w = w * np.hanning(n + 2)[1:-1].reshape(shp)
    return w


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


#: A centre of a compressed spectrum must stand this many times above the
#: range sidelobes that the stronger echoes at its k put at its gate
#: (:func:`above_leakage`): two echoes' sidelobes may add, and a dechirped
#: gate's peak differs from a plain one's.
LEAK_MARGIN = 2.0


def sidelobe_envelope(data: RadarData) -> np.ndarray | None:
    """The range sidelobes of the data's compression, as a bound by gate
    offset: ``env[m]`` is the largest response of a unit echo at ``m`` gates
    or more away round the compressed axis's ``N`` gates (0 within the main
    lobe, out to its first null), ``m = 0 .. N // 2``.  None where the
    profiles are no compression's of known window (range profiles given
    without their samples, or after a gain: ``RadarData.compression``).
    """
    from ..io.compress import _window

    comp = data.compression
    if comp is None:
        return None
    w = _window(comp.window, comp.samples)
    resp = np.abs(np.fft.ifft(w / w.sum(), n=comp.gates)) * comp.gates
    half = resp[: comp.gates // 2 + 1]
    rising = np.flatnonzero(np.diff(half) > 0)
    null = int(rising[0]) if rising.size else half.size  # the main lobe's first null
    env = np.maximum.accumulate(half[::-1])[::-1]  # the largest at this offset or beyond
    env[:null] = 0.0
    return env


def above_leakage(idx: np.ndarray, det: np.ndarray, det0: int, data: RadarData) -> np.ndarray:
    """The centres ``idx`` (k indices, gate) that stand :data:`LEAK_MARGIN`
    times above the range sidelobes of the echoes at their k (module
    notes, step 2).

    A strong echo's compression leaks into every gate at the echo's own k,
    down by the window's sidelobe at that offset (Hann: -31 dB at the first,
    -54 dB five resolutions away); in data with the noise far below that
    (a flat plate at 60 dB S/N, or none), a plain regime's relative
    threshold (``REGIME_GAIN_DB`` below the strongest) took those sidelobes
    for centres, at the first sidelobe or wrapped to the end of the axis.
    The bound at a centre's gate is the largest over the map's gates at its
    k of ``|S(k, R')|`` times the sidelobe envelope at the offset round the
    compressed axis (:func:`sidelobe_envelope`).  Profiles of no known
    compression keep every centre.
    """
    idx = np.asarray(idx, np.intp)
    env = sidelobe_envelope(data) if idx.size else None
    if env is None:
        return idx
    period = data.compression.gates  # the compressed axis, whatever part is kept
    gates = det0 + np.arange(det.shape[-1])
    keep = np.ones(len(idx), bool)
    for i, c in enumerate(idx):
        row = det[tuple(c[:-1])]
        d = np.abs(gates - c[-1]) % period
        d = np.minimum(d, period - d)
        leak = env[np.minimum(d, env.size - 1)] * row
        keep[i] = row[c[-1] - det0] > LEAK_MARGIN * float(leak.max())
    return idx[keep]


#: The coherent centres (``KSpaceParams.coherent_centres``) need a band of
#: at least this fraction of the carrier: with a narrower one the
#: delay-and-sum image is close to a one-frequency hologram, whose side
#: lobes are peaks of their own (the coherence test of points,
#: :mod:`rpm_cl.rpm.coherence`, has the same bound for the same reason).
COHERENT_MIN_FRACTION = 0.2
#: A peak of the coherent image proposes a centre only where it stands this
#: many dB above the image's median over the searched region (its side
#: lobes and its noise; the map's own noise floor, ``noise_pfa``, is not
#: applied to the image): at 14 dB the rebar fixture's share within 20 mm
#: fell from 88.8 % to 85.1 %, at 26 dB the gprMax fixture's c4 was lost at
#: 1.5-5 GHz (docs/decisions.md).
COHERENT_FLOOR_DB = 20.0
#: The coherent image's nodes in sin(theta): steps of this fraction of the
#: aperture's resolution cell ``lambda_c / (2 L)``.
COHERENT_STEP_U = 0.5
#: The coherent image's nodes in range: steps of this fraction of the range
#: resolution.
COHERENT_STEP_R = 0.25
#: A peak of the coherent image is the largest of this many nodes across:
#: +-1 node, half a resolution cell in sin(theta) and a quarter range
#: resolution.
COHERENT_PEAK_SIZE = 3
#: The coherent image spans sin(theta) within +-this (80 degrees).
COHERENT_U_MAX = 0.985
#: Most terms (nodes x antennas, at least 16 antennas counted) of the
#: coherent image; a larger one is not formed and the map's centres stand
#: alone (2^24: about 0.3 s here and at most 2^20 nodes; the wide-band
#: random scenes of 64 antennas over 3 m take 7.3e6).
COHERENT_MAX_TERMS = 1 << 24


def wants_coherent_centres(data: RadarData, params) -> bool:
    """True where the decomposition adds coherent centres.

    Parameters
    ----------
    data : RadarData
        The data decomposed.
    params : KSpaceParams
        ``coherent_centres`` must be on.

    Returns
    -------
    bool
        The setting on, a linear array of two antennas or more, and a band of
        at least :data:`COHERENT_MIN_FRACTION` of the carrier.
    """
    w = data.waveform
    return (
        bool(params.coherent_centres)
        and not data.array.planar
        and data.array.n >= 2
        and w.bandwidth >= COHERENT_MIN_FRACTION * w.fc
    )


def coherent_centres(
    data: RadarData,
    idx: np.ndarray,
    runs,
    k_axis: np.ndarray,
    rel: float,
    window: float,
    gate: float,
    sums=None,
) -> np.ndarray:
    """Centres at the peaks of the coherent image that no centre holds
    (module notes, step 2).

    The image is the delay-and-sum value (:func:`rpm_cl.extract.backprojection.at_points`,
    straight rays) of the data tapered across the array (Hann, as the map's),
    on nodes (sin theta, R) seen from the array's middle, over the gates of
    ``runs``.  Above a half-space the data are the paraxial scene the map
    also decomposes, so a proposal far off the normal is approximate; in a
    homogeneous medium they are its air-equivalent scene.  A peak is the
    largest of :data:`COHERENT_PEAK_SIZE` nodes across, not on an edge of
    the runs or of the directions, at least ``rel`` of the largest value off
    those edges and :data:`COHERENT_FLOOR_DB` above the image's median.  Its
    centre is the k of its direction, ``2 k_c sin(theta)`` wrapped onto
    ``k_axis``, at the gate of its range.  It is kept where no centre of
    ``idx`` (or kept before it) holds it already: within a quarter of the
    window period ``window`` (where the raised cosine passes half or more;
    wider than phase-rpm's one-cell spacing of the map's centres) and
    ``gate`` of its range.

    Parameters
    ----------
    data : RadarData
        A linear array's range profiles (uniform antenna and range axes).
    idx : ndarray of int, shape (n, 2)
        The map's centres: (k index, gate).
    runs : list of (int, int)
        The searched gates, half-open runs ``[g0, g1)``.
    k_axis : ndarray, shape (nk,)
        The map's k axis, rad/m.
    rel : float
        The relative threshold, ``10^(peak_threshold_db / 20)``.
    window : float
        The window period along k, rad/m.
    gate : float
        Half-width of a cluster's range interval, m.
    sums : callable, optional
        ``sums(data, points)``: the image at points (M, 2), complex, shape
        (M,) (an OpenCL device's
        :meth:`rpm_cl.extract.backprojection_cl.PointSums.at_points`);
        None: :func:`rpm_cl.extract.backprojection.at_points`.

    Returns
    -------
    ndarray of int, shape (m, 2)
        The new centres (k index, gate), strongest first.
    """
    from .backprojection import at_points

    none = np.zeros((0, 2), np.intp)
    if not runs:
        return none
    w, x = data.waveform, np.asarray(data.array.x, np.float64)
    aperture = float(x[-1] - x[0])
    if not aperture > 0:
        return none
    r = data.range
    counted = max(x.size, 16)
    du = COHERENT_STEP_U * w.wavelength / (2 * aperture)
    if not 2 * COHERENT_U_MAX / du * counted < COHERENT_MAX_TERMS:  # an aperture of kilometres
        return none
    u = np.linspace(-COHERENT_U_MAX, COHERENT_U_MAX, int(np.ceil(2 * COHERENT_U_MAX / du)) + 1)
    dr = COHERENT_STEP_R * w.range_resolution
    parts = [np.arange(max(float(r[g0]), dr), float(r[g1 - 1]), dr) for g0, g1 in runs]
    rr = np.concatenate(parts)
    if rr.size == 0 or u.size * rr.size * counted > COHERENT_MAX_TERMS:
        return none
    # a node on the edge of a run or of the directions is no maximum: the
    # image may rise beyond it (the end of the range axis held a coupling
    # echo's wrapped tail on the rebar fixture converted without background)
    sizes = np.array([q.size for q in parts])
    ends = np.cumsum(sizes)
    inner = np.ones((u.size, rr.size), bool)
    inner[[0, -1], :] = False
    inner[:, np.concatenate([(ends - sizes)[sizes > 0], (ends - 1)[sizes > 0]])] = False
    if not inner.any():
        return none
    uu, rg = np.meshgrid(u, rr, indexing="ij")
    xm = 0.5 * (x[0] + x[-1])
    pts = np.stack([xm + rg.ravel() * uu.ravel(), rg.ravel() * np.sqrt(1 - uu.ravel() ** 2)], 1)
    # tapered across the array as the map is (step 2): a plain sum's
    # cross-range side lobes (-13 dB) would each be proposed
    tapered = replace(
        data, signal=data.signal * _taper(data.array.shape), spectrum=None, truth=None
    )
    img = np.abs((sums or at_points)(tapered, pts)).reshape(uu.shape)
    top = float(img[inner].max())
    if not top > 0:
        return none
    level = max(rel * top, float(np.median(img)) * 10.0 ** (COHERENT_FLOOR_DB / 20.0))
    peak = (img == maximum_filter(img, [COHERENT_PEAK_SIZE] * 2, "nearest")) & (img >= level)
    peak &= inner
    iu, ir = np.nonzero(peak)
    order = np.argsort(-img[iu, ir], kind="stable")
    period = 2 * np.pi / data.array.dx
    k = 2 * w.kc * u[iu[order]]
    dk = (k_axis[None, :] - k[:, None] + 0.5 * period) % period - 0.5 * period
    kk = np.argmin(np.abs(dk), axis=1)
    gates = np.clip(np.rint((rr[ir[order]] - r[0]) / data.dr).astype(np.intp), 0, r.size - 1)
    held_k = list(k_axis[np.asarray(idx, np.intp).reshape(-1, 2)[:, 0]])
    held_g = list(np.asarray(idx, np.intp).reshape(-1, 2)[:, 1])
    out = []
    for a, b in zip(kk, gates):
        if held_k:
            dka = (k_axis[a] - np.asarray(held_k) + 0.5 * period) % period - 0.5 * period
            near = (np.abs(dka) < 0.25 * window) & (
                np.abs(b - np.asarray(held_g)) * data.dr <= gate
            )
            if near.any():
                continue
        held_k.append(k_axis[a])
        held_g.append(b)
        out.append((int(a), int(b)))
    return np.array(out, np.intp).reshape(-1, 2)
