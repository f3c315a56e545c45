"""OpenCL twins of the near-field search's hot scans (:mod:`rpm_cl.nearfield`).

:class:`NearFieldDevice` runs ``kernels/nearfield.cl`` in float64 on one
OpenCL device; each method has the signature of its NumPy reference in
:mod:`rpm_cl.nearfield`, which the search uses where no device is given or
the device has no float64 (:func:`device_for`).
"""

from __future__ import annotations

import numpy as np

from .cl import CLEnv, get_kernels

__all__ = ["NearFieldDevice", "device_for"]


def device_for(env: CLEnv | None) -> NearFieldDevice | None:
    """The near-field kernels on ``env``; None without an environment or
    where its device has no float64 (the search then stays in NumPy)."""
    if env is None or not env.has_double:
        return None
    return NearFieldDevice(env)


class NearFieldDevice:
    """Near-field scan kernels on one OpenCL device, float64.

    Parameters
    ----------
    env : CLEnv
        The OpenCL environment; its device must support float64.
    """

    def __init__(self, env: CLEnv):
        if not env.has_double:
            raise ValueError(f"device {env.name} has no float64 support")
        self.env = env
        self._k = get_kernels(env, "nearfield.cl", ["pair_energy"])
        self._pool = {}

    def _pooled(self, role: str, nbytes: int):
        """The device buffer of ``role``, at least ``nbytes`` long (reused:
        the queue is in order and every call reads its result back)."""
        import pyopencl as cl

        buf = self._pool.get(role)
        if buf is None or buf.size < nbytes:
            buf = cl.Buffer(self.env.context, cl.mem_flags.READ_WRITE, max(1, nbytes))
            self._pool[role] = buf
        return buf

    def _put(self, role: str, array, dtype):
        import pyopencl as cl

        a = np.ascontiguousarray(array, dtype=dtype)
        buf = self._pooled(role, a.nbytes)
        if a.size:
            cl.enqueue_copy(self.env.queue, buf, a, is_blocking=True)
        return buf

    def pair_algebra(self, c, x, pm, pn, em):
        """Joint explained energy of every pair, shape (ni, nj): the
        ``pair_energy`` kernel; arguments and result as
        :func:`rpm_cl.nearfield._pair_algebra` (its float64 reference)."""
        import pyopencl as cl

        ni, nj = int(np.shape(pm)[0]), int(np.shape(pn)[0])
        out = np.empty((ni, nj))
        if out.size == 0:
            return out
        cplx = np.complex128
        args = (self._put("c", c, cplx), self._put("x", x, cplx), self._put("pm", pm, cplx),
                self._put("pn", pn, cplx), self._put("em", em, np.float64))
        dst = self._pooled("out", out.nbytes)
        self._k["pair_energy"](self.env.queue, (nj, ni), None, *args, dst,
                               np.int32(ni), np.int32(nj))
        cl.enqueue_copy(self.env.queue, out, dst)
        return out

