"""OpenCL twin of :func:`rpm_cl.extract.backprojection.at_points`: the
delay-and-sum value at scattered points, for the coherence test of
phase-rpm's points (:mod:`rpm_cl.rpm.coherence`).

:class:`PointSums` runs the ``das_points`` kernel of ``kernels/das.cl`` in
float64 on one OpenCL device: float32 sums differ from the host's by about
2e-4 of the largest (the phases of ranges tens of metres long), enough to
move a point across the test's threshold, float64 ones by about 1e-13
(``tests/test_coherence.py``).  :func:`device_for` gives None where the
device takes no doubles, and the test then sums in NumPy.
"""

from __future__ import annotations

import numpy as np

from ..cl import CLEnv, get_kernels, read_only
from ..io.data import C0, InputError, RadarData
from .backprojection import antennas, phased_pairs, points3

__all__ = ["POINTS_PER_LAUNCH", "PointSums", "device_for", "sums_on"]

#: Most points of one ``das_points`` launch.
POINTS_PER_LAUNCH = 1 << 18
#: Antennas per vector of the float64 kernel (``VW`` of kernels/simd.h):
#: the host pads the antennas by this many.
_VW = 4


def device_for(env: CLEnv | None) -> PointSums | None:
    """The sums on ``env``'s device; None without an environment or where
    its device has no float64."""
    if env is None or not env.has_double:
        return None
    return PointSums(env)


def sums_on(env: CLEnv | None):
    """``sums(data, points)`` on ``env``'s device (:meth:`PointSums.at_points`),
    or None where :func:`device_for` gives none (the callers then sum in
    NumPy)."""
    dev = device_for(env)
    return None if dev is None else dev.at_points


class PointSums:
    """I(p) at scattered points on one OpenCL device, float64.

    Parameters
    ----------
    env : rpm_cl.cl.CLEnv
        Its device must take doubles (``env.has_double``).
    """

    def __init__(self, env: CLEnv):
        if not env.has_double:
            raise ValueError(f"device {env.name} has no float64 support")
        self.env = env
        self._kept = None  # (data, kernel, arguments): the test asks twice per data

    def _buf(self, a, dtype):
        return read_only(self.env, a, dtype)

    def at_points(self, data: RadarData, points: np.ndarray) -> np.ndarray:
        """I(p) at ``points``: :func:`rpm_cl.extract.backprojection.at_points`
        (straight lines), on the device.

        Parameters
        ----------
        data : RadarData
            As recorded (air-equivalent ranges).
        points : ndarray, shape (M, dim)
            (x, y) for linear arrays, (x, y, z) for planar ones, m.

        Returns
        -------
        ndarray, complex128, shape (M,)
            On a linear array each point sums only the antennas within the
            range axis's end of it in x (the others' ranges lie beyond the
            axis, where their weights are 0).
        """
        import pyopencl as cl

        p3 = points3(data, points)
        if data.range.size < 2:
            raise InputError("the sums need at least 2 range samples")
        m = p3.shape[0]
        if m == 0:
            return np.zeros(0, np.complex128)
        ant = antennas(data.array)
        # a common origin taken off in float64, as the DAS kernel's host does
        o = np.array([np.mean(ant[:, 0]), 0.0, np.mean(ant[:, 2])])
        kernel, args = self._input(data, ant, o)
        if data.array.planar:
            lo, hi = np.zeros(m, np.int32), np.full(m, len(ant), np.int32)
        else:  # x strictly increasing (rpm_cl.io.data.Array)
            r_max = float(data.range[-1])
            lo = np.searchsorted(ant[:, 0], p3[:, 0] - r_max, "left").astype(np.int32)
            hi = np.searchsorted(ant[:, 0], p3[:, 0] + r_max, "right").astype(np.int32)
        out = np.empty(m, np.complex128)
        buf = cl.Buffer(self.env.context, cl.mem_flags.WRITE_ONLY, 16 * min(m, POINTS_PER_LAUNCH))
        for a in range(0, m, POINTS_PER_LAUNCH):
            b = min(m, a + POINTS_PER_LAUNCH)
            kernel(
                self.env.queue,
                (b - a,),
                None,
                *args,
                self._buf(p3[a:b, 0] - o[0], np.float64),
                self._buf(p3[a:b, 1], np.float64),
                self._buf(p3[a:b, 2] - o[2], np.float64),
                self._buf(lo[a:b], np.int32),
                self._buf(hi[a:b], np.int32),
                np.int32(b - a),
                buf,
            )
            cl.enqueue_copy(self.env.queue, out[a:b], buf)
        return out

    def _input(self, data: RadarData, ant: np.ndarray, o: np.ndarray):
        """The kernel and its arguments before the points', kept for the
        last ``data``."""
        if self._kept is not None and self._kept[0] is data:
            return self._kept[1], self._kept[2]
        k2 = 4 * np.pi * data.waveform.fc / C0
        # sincos, never the Taylor polynomial (-DPOLY): in float64 its
        # truncation reaches 1.6e-10 of the largest sum near k_c dr = 1.1,
        # sincos stays at 1e-13 (tests/test_coherence.py)
        defines = {"REAL": "double", "REAL_IS_DOUBLE": 1}
        kernel = get_kernels(self.env, "das.cl", ["das_points"], defines)["das_points"]
        # _VW more antennas: zero rows, and the last antenna's place again
        # (the kernel's lanes past a point's last antenna read inside them)
        pairs = phased_pairs(data)
        pairs = np.concatenate([pairs, np.zeros((_VW,) + pairs.shape[1:], pairs.dtype)])
        pad = np.concatenate([ant - o, np.repeat(ant[-1:] - o, _VW, axis=0)])
        args = [
            self._buf(pairs, np.complex128),
            np.int32(data.range.size),
            self._buf(pad[:, 0], np.float64),
            self._buf(pad[:, 2], np.float64),
            np.float64(data.range[0]),
            np.float64(1.0 / data.dr),
            np.float64(k2 * data.dr),
        ]
        self._kept = (data, kernel, args)
        return kernel, args
