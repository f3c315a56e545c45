"""This machine's limits, measured, for the roofline columns of ``rpm-cl bench``.

Two micro-benchmarks on the OpenCL device the engine runs on
(``kernels/limits.cl``): the peak arithmetic rate of vector multiply-adds
as the device's compiler emits them, and the read bandwidth of one pass
over a buffer far larger than the caches.  Each is the best of ``repeats``
timed launches after a warm-up: a limit is what the machine can do, so the
fastest run is the estimate, not the median.

A stage's *rate* divided by a limit is the share of the machine it uses:
FLOP/s over :attr:`MachineLimits.flops` for arithmetic kernels, bytes/s over
:attr:`MachineLimits.bandwidth` for stages that stream data.  The
operations or bytes per unit of work are counted from each kernel's source
(:data:`rpm_cl.cli.bench.STAGE_MODELS`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..cl import CLEnv, get_kernels

__all__ = [
    "LimitKernels",
    "MachineLimits",
    "measure_limits",
    "peak_fma_reference",
    "stream_read_reference",
]

#: Multiply-add iterations per work-item of the peak micro-benchmark (8
#: chains of VW-wide vectors each): about 0.1 s on one 2-core CPU.
PEAK_ITERS = 200_000
#: Work-items of the peak micro-benchmark: many per core, so every core
#: stays busy whatever the device's work-group split.
PEAK_ITEMS = 256
#: Bytes the bandwidth micro-benchmark reads (256 MiB: far above any cache).
STREAM_BYTES = 256 * 2**20
#: Work-items of the bandwidth micro-benchmark.
STREAM_ITEMS = 1024
#: Multiply-add chains per work-item in kernels/limits.cl (NACC).
NACC = 8


@dataclass(frozen=True)
class MachineLimits:
    """Measured limits of one device at one precision.

    Attributes
    ----------
    flops : float
        Peak vector multiply-add rate, floating-point operations per second
        (a multiply-add counts 2).
    bandwidth : float
        Read bandwidth of memory, bytes per second.
    precision : str
        ``"float32"`` or ``"float64"``.
    device : str
    """

    flops: float
    bandwidth: float
    precision: str
    device: str

    def __post_init__(self):
        if not (self.flops > 0 and self.bandwidth > 0):
            raise ValueError(f"limits must be positive, got {self.flops}, {self.bandwidth}")

    def describe(self) -> str:
        """One line: both limits with how they were measured."""
        return (
            f"machine limits ({self.device}, {self.precision}): peak {self.flops / 1e9:.1f} "
            f"GFLOP/s (vector multiply-adds, kernels/limits.cl), memory read "
            f"{self.bandwidth / 1e9:.1f} GB/s (one pass over {STREAM_BYTES >> 20} MiB)"
        )


def _best(launch, repeats: int) -> float:
    launch()  # build, warm caches and threads
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        launch()
        best = min(best, time.perf_counter() - t0)
    return best


def _setup(precision: str):
    if precision not in ("float32", "float64"):
        raise ValueError(f"precision must be float32 or float64, got {precision!r}")
    double = precision == "float64"
    defines = {"REAL": "double" if double else "float"}
    if double:
        defines["REAL_IS_DOUBLE"] = 1
    return np.dtype(np.float64 if double else np.float32), (4 if double else 8), defines


class LimitKernels:
    """The micro-benchmark kernels of ``kernels/limits.cl`` on one device,
    built once; each launch leaves its buffers on the device for timing,
    and :meth:`peak_fma` / :meth:`stream_read` return their outputs for
    checking against :func:`peak_fma_reference` / :func:`stream_read_reference`.

    Parameters
    ----------
    env : CLEnv
    precision : {"float32", "float64"}
    """

    def __init__(self, env: CLEnv, precision: str = "float32"):
        self.env = env
        self.dtype, self.vw, defines = _setup(precision)
        self._k = get_kernels(env, "limits.cl", ("peak_fma", "stream_read"), defines)

    def peak_launcher(self, items: int, iters: int, b: float, c: float):
        """A no-argument callable running ``peak_fma`` once and waiting for
        it, and the device buffer of its ``items`` outputs."""
        import pyopencl as cl

        out = cl.Buffer(self.env.context, cl.mem_flags.WRITE_ONLY, items * self.dtype.itemsize)
        args = (out, np.int32(iters), self.dtype.type(b), self.dtype.type(c))

        def launch():
            self._k["peak_fma"](self.env.queue, (items,), None, *args)
            self.env.queue.finish()

        return launch, out

    def stream_launcher(self, a: np.ndarray, per: int):
        """A no-argument callable running ``stream_read`` over ``a`` (host
        data copied once; an int: that many ones, filled on the device) and
        waiting for it, and the buffer of its sums."""
        import pyopencl as cl

        size = int(a) if np.isscalar(a) else np.size(a)
        items = size // (per * self.vw) if per > 0 else 0
        if per <= 0 or per % 4 or items == 0 or items * per * self.vw != size:
            raise ValueError(
                f"a must hold whole work-items of per = {per} (a multiple of 4) vectors "
                f"of {self.vw}, got {size} values"
            )
        mf = cl.mem_flags
        if np.isscalar(a):
            src = cl.Buffer(self.env.context, mf.READ_ONLY, size * self.dtype.itemsize)
            cl.enqueue_fill_buffer(self.env.queue, src, self.dtype.type(1), 0, src.size).wait()
        else:
            host = np.ascontiguousarray(a, self.dtype)
            src = cl.Buffer(self.env.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=host)
        sums = cl.Buffer(self.env.context, mf.WRITE_ONLY, items * self.dtype.itemsize)

        def launch():
            self._k["stream_read"](self.env.queue, (items,), None, src, np.int64(per), sums)
            self.env.queue.finish()

        return launch, sums

    def _read(self, buf, n):
        import pyopencl as cl

        out = np.empty(n, self.dtype)
        cl.enqueue_copy(self.env.queue, out, buf)
        return out

    def peak_fma(self, items: int, iters: int, b: float, c: float) -> np.ndarray:
        """Device twin of :func:`peak_fma_reference`."""
        launch, out = self.peak_launcher(items, iters, b, c)
        launch()
        return self._read(out, items)

    def stream_read(self, a: np.ndarray, per: int) -> np.ndarray:
        """Device twin of :func:`stream_read_reference`."""
        launch, sums = self.stream_launcher(a, per)
        launch()
        return self._read(sums, np.size(a) // (per * self.vw))


def peak_fma_reference(items: int, iters: int, b: float, c: float, vw: int = 8) -> np.ndarray:
    """float64 reference of ``peak_fma``: per work-item g, NACC chains
    a_j = a_j b + c from g 1e-6 + j / 10, ``iters`` times, summed over the
    chains and the ``vw`` identical lanes.  Shape (items,)."""
    a = np.arange(items, dtype=np.float64)[:, None] * 1e-6 + np.arange(NACC) / 10.0
    for _ in range(iters):
        a = a * b + c
    return vw * a.sum(axis=1)


def stream_read_reference(a: np.ndarray, per: int, vw: int = 8) -> np.ndarray:
    """float64 reference of ``stream_read``: the sum of each work-item's
    ``per`` consecutive vectors of ``vw`` values.  Shape (a.size // (per vw),)."""
    a = np.asarray(a, np.float64)
    return a.reshape(-1, per * vw).sum(axis=1)


def measure_limits(
    env: CLEnv,
    precision: str = "float32",
    repeats: int = 5,
    stream_bytes: int = STREAM_BYTES,
    peak_iters: int = PEAK_ITERS,
) -> MachineLimits:
    """Measure the peak FLOP/s and the memory read bandwidth of ``env``'s device.

    Parameters
    ----------
    env : CLEnv
    precision : {"float32", "float64"}
    repeats : int
        Timed launches of each micro-benchmark after one warm-up; the best counts.
    stream_bytes : int
        Bytes the bandwidth benchmark reads (far above the caches for a
        memory figure).
    peak_iters : int
        Multiply-add iterations per work-item of the peak benchmark.

    Returns
    -------
    MachineLimits
    """
    if repeats < 1:
        raise ValueError(f"repeats must be at least 1, got {repeats}")
    k = LimitKernels(env, precision)
    launch, _ = k.peak_launcher(PEAK_ITEMS, peak_iters, 0.999, 1e-3)
    flops = 2.0 * k.vw * NACC * peak_iters * PEAK_ITEMS / _best(launch, repeats)
    per = max(4, stream_bytes // (k.dtype.itemsize * k.vw * STREAM_ITEMS) // 4 * 4)
    launch, _ = k.stream_launcher(per * STREAM_ITEMS * k.vw, per)
    bandwidth = per * STREAM_ITEMS * k.vw * k.dtype.itemsize / _best(launch, repeats)
    return MachineLimits(flops, bandwidth, precision, env.name)
