"""Buffer handling and launches of the RPM OpenCL engine (:mod:`rpm_cl.rpm.device`).

:class:`_DeviceBuffers` copies arrays into device buffers kept per role and
grown when a call needs more, reads results back, and launches kernels
(timed where asked).  Below it, the checks and paddings every kernel
wrapper shares: the chunk of main RPs, and rows padded to the score
kernel's vector width.
"""

from __future__ import annotations

import numpy as np

from ..io.data import InputError


def _check_chunk(total: int, i0: int, n: int) -> None:
    """The kernels index main RPs i0 .. i0+n-1 without bounds checks: refuse a
    chunk outside the arrays (the reference would raise IndexError)."""
    if i0 < 0 or n < 0 or i0 + n > total:
        raise InputError(f"main RPs {i0}..{i0 + n - 1} are outside the {total} RPs given")


def _check_clusters(names: str, total: int, cstart, ccount, *per_rp) -> None:
    """Refuse per-RP arrays (``per_rp``, ``cstart``, ``ccount``) of other
    lengths than ``total``, or a cluster reaching outside the RPs (the
    kernels read ``cstart[i] .. cstart[i] + ccount[i]`` unchecked); ``names``
    lists them for the message."""
    cs, cc = np.asarray(cstart), np.asarray(ccount)
    if any(np.size(v) != total for v in (*per_rp, cs, cc)) or (
        total and (cs.min() < 0 or cc.min() < 0 or (cs + cc).max() > total)
    ):
        raise InputError(
            f"{names} must have one entry per RP, and every cluster must lie within the RPs"
        )


def _round_up(n: int, m: int = 64) -> int:
    return max(m, ((n + m - 1) // m) * m)


def _stride(maxc: int) -> int:
    """Device row length: maxc padded to the score kernel's vector width (8)."""
    return max(8, ((int(maxc) + 7) // 8) * 8)


def _pad_rows(a, stride: int, fill=0):
    """Pad the last axis of ``a`` to ``stride`` with ``fill``."""
    a = np.asarray(a)
    if a.shape[-1] == stride:
        return a
    out = np.full(a.shape[:-1] + (stride,), fill, a.dtype)
    out[..., : a.shape[-1]] = a
    return out


class _DeviceBuffers:
    """Device buffers, reads and kernel launches of one engine.

    A mixin of :class:`rpm_cl.rpm.device.DeviceRPM`, which provides the
    environment (``env``), the precision (``dtype``), the buffers kept per
    role (``_pool``) and the timing switch and totals (``timing``,
    ``kernel_times``).
    """

    def _pooled(self, role: str, nbytes: int):
        """The device buffer of ``role``, at least ``nbytes`` long."""
        import pyopencl as cl

        buf = self._pool.get(role)
        if buf is None or buf.size < nbytes:
            buf = cl.Buffer(self.env.context, cl.mem_flags.READ_WRITE, max(1, nbytes))
            self._pool[role] = buf
        return buf

    def _buf(self, array, dtype=None, role=None):
        """``array`` copied into the (reused) device buffer of ``role``."""
        import pyopencl as cl

        a = np.ascontiguousarray(array, dtype=dtype or self.dtype)
        if a.size == 0:
            a = np.zeros(1, a.dtype)
        if role is None:
            return cl.Buffer(
                self.env.context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=a
            )
        buf = self._pooled(role, a.nbytes)
        cl.enqueue_copy(self.env.queue, buf, a, is_blocking=True)
        return buf

    def _out(self, shape, dtype=None, role=None):
        import pyopencl as cl

        nbytes = max(1, int(np.prod(shape))) * np.dtype(dtype or self.dtype).itemsize
        if role is not None:
            return self._pooled(role, nbytes)
        return cl.Buffer(self.env.context, cl.mem_flags.READ_WRITE, nbytes)

    def _read(self, buf, shape, dtype=None):
        import pyopencl as cl

        out = np.empty(shape, dtype or self.dtype)
        if out.size:
            cl.enqueue_copy(self.env.queue, out, buf)
        return out

    def _timed(self, stage, launch):
        if not self.timing:
            launch()
            return
        import time

        self.env.queue.finish()
        t0 = time.perf_counter()
        launch()
        self.env.queue.finish()
        self.kernel_times[stage] += time.perf_counter() - t0

    def _run(self, kernel, nitems, *args, stage="intersect"):
        if self.timing:
            self.kernel_work[stage] += int(nitems)
        if nitems > 0:
            self._timed(stage, lambda: kernel(self.env.queue, (_round_up(nitems),), None, *args))

    def _run2(self, kernel, n0, n1, *args, stage="score"):
        if n0 > 0 and n1 > 0:
            self._timed(stage, lambda: kernel(self.env.queue, (n0, n1), None, *args))
