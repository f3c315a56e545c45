"""OpenCL twins of the near-field search's hot scans (:mod:`rpm_cl.extract.nearfield`).

:class:`NearFieldDevice` runs ``kernels/nearfield.cl`` in float64 on one
OpenCL device; each method has the signature of its NumPy reference in
:mod:`rpm_cl.extract.nearfield`, which the search uses where no device is given or
the device has no float64 (:func:`device_for`).
"""

from __future__ import annotations

import numpy as np

from ..cl import CLEnv, get_kernels

__all__ = ["DEGENERATE_DET", "NearFieldDevice", "device_for"]

#: det(I - C^H C) at or below which a pair of candidates counts as one
#: (dimensionless: the product of the squared sines of the two bases'
#: principal angles).  Two equal candidates leave det at rounding level,
#: 1e-30 either side of zero, and tr at the same level, so tr / det is
#: noise as large as the data's energy; 1e-24 (both angles under ~1e-6 rad)
#: sits a millionfold above that, and a pair degenerate in one direction
#: only keeps det ~1e-12 through the regularisation.  The NumPy reference
#: (:func:`rpm_cl.extract.nearfield_model._pair_algebra`) and the kernel share it.
DEGENERATE_DET = 1e-24


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
        self._k = get_kernels(
            env, "nearfield.cl", ["pair_energy"], {"DEGENERATE_DET": DEGENERATE_DET}
        )

    def pair_algebra(self, c, x, pm, pn, em):
        """Joint explained energy of every pair, shape (ni, nj): the
        ``pair_energy`` kernel; arguments and result as
        :func:`rpm_cl.extract.nearfield_model._pair_algebra` (its float64 reference).

        The arrays are handed to the device in place (``USE_HOST_PTR``) and
        the result is mapped back: on PoCL's CPU device no copy is made
        (a pair scan's two 0.9 MB product matrices copied in and out cost
        as much as the kernel: 0.97 ms a call against 0.53 ms in place,
        measured inside the search)."""
        import pyopencl as cl

        ni, nj = int(np.shape(pm)[0]), int(np.shape(pn)[0])
        out = np.empty((ni, nj))
        if out.size == 0:
            return out
        mf, ctx, queue = cl.mem_flags, self.env.context, self.env.queue
        arrays = [
            np.ascontiguousarray(a, t)
            for a, t in (
                (c, np.complex128),
                (x, np.complex128),
                (pm, np.complex128),
                (pn, np.complex128),
                (em, np.float64),
            )
        ]
        bufs = [cl.Buffer(ctx, mf.READ_ONLY | mf.USE_HOST_PTR, hostbuf=a) for a in arrays]
        dst = cl.Buffer(ctx, mf.WRITE_ONLY | mf.USE_HOST_PTR, hostbuf=out)
        self._k["pair_energy"](queue, (nj, ni), None, *bufs, dst, np.int32(ni), np.int32(nj))
        # mapping a USE_HOST_PTR buffer makes ``out`` hold the result (and
        # waits for the kernel: the inputs stay alive until then)
        mapped, _ = cl.enqueue_map_buffer(
            queue, dst, cl.map_flags.READ, 0, out.shape, out.dtype, is_blocking=True
        )
        result = np.array(mapped)
        mapped.base.release()
        return result
