"""2-D (circle) kernels of the RPM OpenCL engine (:mod:`rpm_cl.rpm.device`):
the intersections of each main RP's circle with its cluster's, and the
whole 2-D RPM (intersections, scores and argmax back to back).

The methods have the signatures of their float64 references in
:mod:`rpm_cl.rpm.reference` (``intersect_circles``, ``rpm_circles``).
Device rows are padded to ``_stride(maxc)`` slots
(:mod:`rpm_cl.rpm.device_buffers`); the public twins return the
reference's ``(.., maxc)`` shapes.
"""

from __future__ import annotations

import numpy as np

from .device_buffers import _check_chunk, _check_clusters, _stride


class _Circles:
    """Circle intersections of a linear array's RPs on the device.

    A mixin of :class:`rpm_cl.rpm.device.DeviceRPM`, which provides the
    kernels (``_k``), the precision (``dtype``), the buffer handling
    (:class:`rpm_cl.rpm.device_buffers._DeviceBuffers`) and the scoring
    (:class:`rpm_cl.rpm.device_score._Scoring`).
    """

    def _intersect(self, x, r, amp, cstart, ccount, maxc, sigma_x, i0=0, n=None):
        total = int(np.size(x))
        n = total - i0 if n is None else int(n)
        _check_chunk(total, int(i0), n)
        _check_clusters("x, r, amp, cstart, ccount", total, cstart, ccount, r, amp)
        # Subtract a common origin on the host in float64 so that float32
        # kernels see small coordinates; the outputs are in each main
        # antenna's frame, so they do not depend on it.
        x = np.asarray(x, np.float64)
        x0 = float(np.mean(x)) if x.size else 0.0
        maxc = _stride(maxc)  # slots >= the cluster size are invalid in the kernel
        cand = self._out((2, n, maxc), role="cand")
        w = self._out((n, maxc), role="w")
        valid = self._out((n, maxc), np.int8, role="valid")
        self._run(
            self._k["intersect_circles"],
            n * maxc,
            self._buf(x - x0, role="x"),
            self._buf(r, role="r"),
            self._buf(amp, role="amp"),
            self._buf(cstart, np.int32, role="cstart"),
            self._buf(ccount, np.int32, role="ccount"),
            np.int32(i0),
            np.int32(n),
            np.int32(maxc),
            self.dtype.type(1.0 / (2.0 * sigma_x**2)),
            cand,
            w,
            valid,
        )
        return cand, w, valid, n, maxc

    def intersect_circles(self, x, r, amp, cstart, ccount, maxc, sigma_x, i0=0, n=None):
        """Device twin of :func:`rpm_cl.rpm.reference.intersect_circles`."""
        maxc = int(maxc)
        cand, w, valid, n, stride = self._intersect(x, r, amp, cstart, ccount, maxc, sigma_x, i0, n)
        return (
            self._read(cand, (2, n, stride))[..., :maxc],
            self._read(w, (n, stride))[:, :maxc],
            self._read(valid, (n, stride), np.int8)[:, :maxc],
        )

    def rpm_circles(self, x, r, amp, cstart, ccount, maxc, sigma_x, sigma_r, i0=0, n=None):
        """Device twin of :func:`rpm_cl.rpm.reference.rpm_circles`.

        The three kernels run back to back on the device; only the per-main-RP
        results are read back.
        """
        cand, w, valid, n, st = self._intersect(
            x, r, amp, cstart, ccount, int(maxc), sigma_x, i0, n
        )
        score = self._score(2, n, st, cand, w, valid, sigma_r)
        return self._argmax(2, n, st, score, cand)
