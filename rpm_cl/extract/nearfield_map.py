"""Candidate generation of the near-field search (:mod:`rpm_cl.extract.nearfield`):
the focused map and its peaks.

:class:`_FocusMap` is the search's stage that proposes centres: the
near-field beamformer map ``|sum_X w(X) s(X, R) conj(a_p(X))|`` over
(sin theta, R), its size bound (``MAP_TERMS_MAX``), the table of focusing
phases kept across calls per geometry (``_TABLES``) and the strongest peaks
of the map of what the centres so far leave (:func:`_peaks`).
"""

from __future__ import annotations

import threading

import numpy as np

from ..io.data import InputError

#: Peaks of the residual map tried for each new centre.
CANDIDATES = 3
#: Largest |sin theta| searched.
U_MAX = 0.985
#: Largest table of focusing phases kept for the detection map, bytes.
MAP_TABLE_BYTES = 128 << 20
#: Most terms (directions x antennas x range samples) of one focused map:
#: as many as the kept table holds (complex64), so that every map allowed
#: is built once; a larger search is refused (see :mod:`rpm_cl.extract.nearfield`).
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


class MapTooLarge(InputError):
    """The near-field search's focused map would exceed MAP_TERMS_MAX terms:
    an error where the search was asked for, the plane-wave path where it
    was the automatic choice (:func:`rpm_cl.extract.kspace.decompose`)."""


class _FocusMap:
    """The focused map of the search's data and the candidate centres it gives.

    A mixin of :class:`rpm_cl.extract.nearfield._Search`, which provides the
    array (``x``, ``n``, ``k0``, ``aperture``, ``du``), the range sampling
    (``dr``, ``res_r``), the gates searched (``gates``), the threshold
    (``thr``) and the model (``model``).
    """

    def _init_map(self, data, pad):
        """The map's directions, range samples and weights, and its global
        maximum ``gmax`` (every candidate is thresholded against it)."""
        sig = data.signal
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
        self.nms = [
            2 * int(np.ceil(self.du * 2 * self.k0 / dk)) + 1,
            2 * int(np.ceil(0.5 * self.res_r / (step * self.dr))) + 1,
        ]
        self.gmax = float(self.focus_map(self.s_det).max())

    def _check_size(self, data, n_dirs: int) -> None:
        """MapTooLarge when one focused map of ``n_dirs`` directions exceeds
        MAP_TERMS_MAX terms (checked before the directions are allocated)."""
        terms = n_dirs * self.n * self.r_det.size
        if terms > MAP_TERMS_MAX:
            raise MapTooLarge(
                f"the near-field search of this sparse array is too large: a focused map of "
                f"{terms:.3g} terms ({n_dirs} directions x {self.n} antennas x "
                f"{self.r_det.size} range samples; at most {MAP_TERMS_MAX:.3g}), as the "
                f"{self.aperture:g} m aperture spans {self.aperture / data.waveform.wavelength:.0f}"
                f" wavelengths and {self.gates.size} range gates hold echoes; crop the range "
                f"axis to the scene, or use the plane-wave decomposition (near_field = false, "
                f"--near-field false)"
            )

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
