"""Scoring kernels of the RPM OpenCL engine (:mod:`rpm_cl.rpm.device`): the
kernel-density score of every candidate point and each main RP's best one,
in 2-D and 3-D.

The methods have the signatures of their float64 references in
:mod:`rpm_cl.rpm.reference` (``score_candidates``, ``argmax_candidates``).
Device rows are padded to ``_stride(maxc)`` slots
(:mod:`rpm_cl.rpm.device_buffers`); the public twins return the
reference's ``(.., maxc)`` shapes.
"""

from __future__ import annotations

import numpy as np

from .device_buffers import _pad_rows, _stride


class _Scoring:
    """Candidate scores and their argmax on the device.

    A mixin of :class:`rpm_cl.rpm.device.DeviceRPM`, which provides the
    kernels (``_k``), the precision (``dtype``) and the buffer handling
    (:class:`rpm_cl.rpm.device_buffers._DeviceBuffers`); with ``timing``,
    the Gaussian evaluations are counted in ``kernel_evals``.
    """

    def _score(self, dim, n, maxc, cand, w, valid, sigma_r):
        score = self._out((n, maxc), role="score")
        self._run2(
            self._k[f"score{dim}"],
            maxc,
            n,
            cand,
            w,
            valid,
            np.int32(n),
            np.int32(maxc),
            self.dtype.type(np.log2(np.e) / (2.0 * sigma_r**2)),
            score,
        )
        if self.timing:  # valid candidates each sum over their whole row
            self.kernel_evals += int(np.count_nonzero(self._read(valid, (n, maxc), np.int8))) * maxc
        return score

    def _argmax(self, dim, n, maxc, score, cand):
        best = self._out((n,), np.int32, role="best")
        best_score = self._out((n,), role="best_score")
        point = self._out((dim, n), role="point")
        self._run(
            self._k[f"argmax{dim}"],
            n,
            score,
            cand,
            np.int32(n),
            np.int32(maxc),
            best,
            best_score,
            point,
            stage="argmax",
        )
        return (
            self._read(best, (n,), np.int32),
            self._read(best_score, (n,)),
            self._read(point, (dim, n)),
        )

    def score_candidates(self, cand, w, valid, sigma_r):
        """Device twin of :func:`rpm_cl.rpm.reference.score_candidates`."""
        cand = np.asarray(cand)
        dim, n, maxc = cand.shape
        st = _stride(maxc)
        score = self._score(
            dim,
            n,
            st,
            self._buf(_pad_rows(cand, st)),
            self._buf(_pad_rows(w, st)),
            self._buf(_pad_rows(np.asarray(valid, np.int8), st), np.int8),
            sigma_r,
        )
        return self._read(score, (n, st))[:, :maxc]

    def argmax_candidates(self, score, cand):
        """Device twin of :func:`rpm_cl.rpm.reference.argmax_candidates`."""
        cand = np.asarray(cand)
        dim, n, maxc = cand.shape
        st = _stride(maxc)
        return self._argmax(
            dim,
            n,
            st,
            self._buf(_pad_rows(np.asarray(score), st, -1)),
            self._buf(_pad_rows(cand, st)),
        )
