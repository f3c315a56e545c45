"""3-D (sphere) kernels of the RPM OpenCL engine (:mod:`rpm_cl.rpm.device`):
the intersections of each main RP's sphere with every pair of its
neighbours', and the whole 3-D RPM (intersections, scores and argmax back
to back).

The methods have the signatures of their float64 references in
:mod:`rpm_cl.rpm.reference` (``intersect_spheres``, ``rpm_spheres``).
Device rows are padded to ``_stride(maxc)`` slots
(:mod:`rpm_cl.rpm.device_buffers`); the public twins return the
reference's ``(.., maxc)`` shapes.
"""

from __future__ import annotations

import numpy as np

from ..io.data import InputError
from .device_buffers import _check_chunk, _pad_rows, _stride
from .reference import EPS_DET, pair_table


class _Spheres:
    """Sphere intersections of a planar array's RPs on the device.

    A mixin of :class:`rpm_cl.rpm.device.DeviceRPM`, which provides the
    kernels (``_k``), the precision (``dtype``), the buffer handling
    (:class:`rpm_cl.rpm.device_buffers._DeviceBuffers`), the pair tables
    kept per neighbour count (``_pairs``) and the scoring
    (:class:`rpm_cl.rpm.device_score._Scoring`).
    """

    def _pair_bufs(self, kmax):
        if kmax not in self._pairs:
            pa, pb = pair_table(kmax)
            stride = _stride(pa.size)
            # padding slots pair position kmax, never < nnbr: invalid
            self._pairs[kmax] = (
                self._buf(_pad_rows(pa, stride, 0), np.int32),
                self._buf(_pad_rows(pb, stride, kmax), np.int32),
            )
        return self._pairs[kmax]

    def _intersect3(self, x, z, r, amp, nbr, nnbr, sigma_d, i0=0, n=None):
        x = np.asarray(x, np.float64)
        z = np.asarray(z, np.float64)
        n = x.size - i0 if n is None else int(n)
        _check_chunk(x.size, int(i0), n)
        nbr = np.asarray(nbr)
        nnbr = np.asarray(nnbr)
        if nbr.ndim != 2 or nbr.shape[0] != x.size or nnbr.shape != (x.size,):
            raise InputError(f"nbr must be (N, kmax) and nnbr (N,) for N = {x.size} RPs")
        kmax = nbr.shape[1]
        used = np.arange(kmax)[None, :] < nnbr[:, None]
        if x.size and (
            nnbr.min() < 0
            or nnbr.max() > kmax
            or (used.any() and (nbr[used].min() < 0 or nbr[used].max() >= x.size))
            or any(np.size(v) != x.size for v in (z, r, amp))
        ):
            raise InputError("nnbr must be in 0..kmax and the listed neighbours valid RP indices")
        maxc = _stride(kmax * (kmax - 1) // 2)
        # common origin removed in float64 (outputs are in each main antenna's frame)
        x0 = float(np.mean(x)) if x.size else 0.0
        z0 = float(np.mean(z)) if z.size else 0.0
        cand = self._out((3, n, maxc), role="cand")
        w = self._out((n, maxc), role="w")
        valid = self._out((n, maxc), np.int8, role="valid")
        pa, pb = self._pair_bufs(kmax)
        self._run(
            self._k["intersect_spheres"],
            n * maxc,
            self._buf(x - x0, role="x"),
            self._buf(z - z0, role="z"),
            self._buf(r, role="r"),
            self._buf(amp, role="amp"),
            self._buf(nbr, np.int32, role="nbr"),
            self._buf(nnbr, np.int32, role="nnbr"),
            pa,
            pb,
            np.int32(i0),
            np.int32(n),
            np.int32(kmax),
            np.int32(maxc),
            self.dtype.type(1.0 / (2.0 * sigma_d**2)),
            self.dtype.type(EPS_DET),
            cand,
            w,
            valid,
        )
        return cand, w, valid, n, maxc

    def intersect_spheres(self, x, z, r, amp, nbr, nnbr, sigma_d, i0=0, n=None):
        """Device twin of :func:`rpm_cl.rpm.reference.intersect_spheres`."""
        cand, w, valid, n, stride = self._intersect3(x, z, r, amp, nbr, nnbr, sigma_d, i0, n)
        kmax = np.asarray(nbr).reshape(np.size(x), -1).shape[1]
        maxc = kmax * (kmax - 1) // 2
        return (
            self._read(cand, (3, n, stride))[..., :maxc],
            self._read(w, (n, stride))[:, :maxc],
            self._read(valid, (n, stride), np.int8)[:, :maxc],
        )

    def rpm_spheres(self, x, z, r, amp, nbr, nnbr, sigma_d, sigma_r, i0=0, n=None):
        """Device twin of :func:`rpm_cl.rpm.reference.rpm_spheres`.

        The three kernels run back to back on the device; only the per-main-RP
        results are read back.
        """
        cand, w, valid, n, st = self._intersect3(x, z, r, amp, nbr, nnbr, sigma_d, i0, n)
        score = self._score(3, n, st, cand, w, valid, sigma_r)
        return self._argmax(3, n, st, score, cand)
