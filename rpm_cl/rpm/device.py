"""Host wrappers of the RPM OpenCL kernels.

:class:`DeviceRPM` methods have exactly the signatures of the float64
references in :mod:`rpm_cl.rpm.reference`, and return NumPy arrays in the
kernel precision (``float32`` by default, ``float64`` where the device allows).
Programs are built once per (context, file, options) and kernels fetched once,
when the object is made.
"""

from __future__ import annotations

import numpy as np

from ..cl import CLEnv, get_kernels
from ..io.data import InputError
from .reference import (
    EPS_DET,
    MS_CUTOFF,
    MS_DENSITY_T,
    MS_NEAR_K,
    MS_NEWTON_PIVOT,
    MS_PAIR_CUTOFF,
    MS_TOL,
    pair_table,
)

__all__ = ["DeviceRPM"]


def _check_chunk(total: int, i0: int, n: int) -> None:
    """The kernels index main RPs i0 .. i0+n-1 without bounds checks: refuse a
    chunk outside the arrays (the reference would raise IndexError)."""
    if i0 < 0 or n < 0 or i0 + n > total:
        raise InputError(f"main RPs {i0}..{i0 + n - 1} are outside the {total} RPs given")


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


class DeviceRPM:
    """RPM kernels on one OpenCL device.

    Parameters
    ----------
    env : CLEnv
        The OpenCL environment (context, queue, device).
    precision : {"float32", "float64"}
        Kernel arithmetic; float64 needs a device with ``double_fp_config``.
    timing : bool
        Wait for each kernel and add its wall time (s) to ``kernel_times``
        (``intersect``, ``score``, ``argmax``, ``meanshift``), and the Gaussian kernel
        evaluations the scoring kernel performed to ``kernel_evals``.  For
        benchmarks: the waits serialise host and device.
    """

    def __init__(self, env: CLEnv, precision: str = "float32", timing: bool = False):
        if precision not in ("float32", "float64"):
            raise ValueError(f"precision must be 'float32' or 'float64', got {precision!r}")
        if precision == "float64" and not env.has_double:
            raise ValueError(f"device {env.name} has no float64 support; use precision='float32'")
        self.env = env
        self.precision = precision
        self.timing = timing
        self.kernel_times = {
            "intersect": 0.0,
            "score": 0.0,
            "argmax": 0.0,
            "meanshift": 0.0,
            "density": 0.0,
        }
        self.kernel_evals = 0
        self.dtype = np.dtype(np.float32 if precision == "float32" else np.float64)
        base = {"REAL": "float" if precision == "float32" else "double"}
        if precision == "float64":
            base["REAL_IS_DOUBLE"] = 1
        self._k = dict(get_kernels(env, "circles.cl", ["intersect_circles"], base))
        self._k.update(get_kernels(env, "spheres.cl", ["intersect_spheres"], base))
        self._k.update(
            get_kernels(
                env,
                "meanshift.cl",
                ["meanshift_spheres", "density_spheres"],
                {
                    **base,
                    "MS_NEAR_K": MS_NEAR_K,
                    "MS_DENSITY_T": MS_DENSITY_T,
                    "MS_NEWTON_PIVOT": MS_NEWTON_PIVOT,
                },
            )
        )
        self._pairs = {}  # kmax -> device pair table
        # device buffers by role, reused from call to call (a batch of frames
        # or the chunks of one image) and grown when a call needs more; the
        # queue is in order and every call reads its results back before it
        # returns, so a later call never overwrites what an earlier one uses
        self._pool = {}
        for dim in (2, 3):
            ks = get_kernels(
                env, "score.cl", ["score_candidates", "argmax_candidates"], {**base, "DIM": dim}
            )
            self._k[f"score{dim}"] = ks["score_candidates"]
            self._k[f"argmax{dim}"] = ks["argmax_candidates"]

    # -- small helpers -----------------------------------------------------
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
        if nitems > 0:
            self._timed(stage, lambda: kernel(self.env.queue, (_round_up(nitems),), None, *args))

    def _run2(self, kernel, n0, n1, *args, stage="score"):
        if n0 > 0 and n1 > 0:
            self._timed(stage, lambda: kernel(self.env.queue, (n0, n1), None, *args))

    # -- kernels on device buffers ----------------------------------------
    def _intersect(self, x, r, amp, cstart, ccount, maxc, sigma_x, i0=0, n=None):
        total = int(np.size(x))
        n = total - i0 if n is None else int(n)
        _check_chunk(total, int(i0), n)
        cs, cc = np.asarray(cstart), np.asarray(ccount)
        if any(np.size(v) != total for v in (r, amp, cs, cc)) or (
            total and (cs.min() < 0 or cc.min() < 0 or (cs + cc).max() > total)
        ):
            raise InputError(
                "x, r, amp, cstart, ccount must have one entry per RP, and every "
                "cluster must lie within the RPs"
            )
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

    # -- public twins of rpm_cl.rpm.reference -------------------------------
    # Device rows are padded to _stride(maxc) slots; the twins return the
    # reference's (.., maxc) shapes.
    def intersect_circles(self, x, r, amp, cstart, ccount, maxc, sigma_x, i0=0, n=None):
        """Device twin of :func:`rpm_cl.rpm.reference.intersect_circles`."""
        maxc = int(maxc)
        cand, w, valid, n, stride = self._intersect(x, r, amp, cstart, ccount, maxc, sigma_x, i0, n)
        return (
            self._read(cand, (2, n, stride))[..., :maxc],
            self._read(w, (n, stride))[:, :maxc],
            self._read(valid, (n, stride), np.int8)[:, :maxc],
        )

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

    def rpm_spheres(self, x, z, r, amp, nbr, nnbr, sigma_d, sigma_r, i0=0, n=None):
        """Device twin of :func:`rpm_cl.rpm.reference.rpm_spheres`.

        The three kernels run back to back on the device; only the per-main-RP
        results are read back.
        """
        cand, w, valid, n, st = self._intersect3(x, z, r, amp, nbr, nnbr, sigma_d, i0, n)
        score = self._score(3, n, st, cand, w, valid, sigma_r)
        return self._argmax(3, n, st, score, cand)

    def _cluster_args(self, x, z, r, amp, cstart, ccount, i0, n):
        """Checked chunk and the device arguments shared by the mean-shift
        kernels: (n, x, z, r, amp, cstart, ccount buffers, i0, n, stride)."""
        x = np.asarray(x, np.float64)
        z = np.asarray(z, np.float64)
        total = x.size
        n = total - i0 if n is None else int(n)
        _check_chunk(total, int(i0), n)
        cs, cc = np.asarray(cstart), np.asarray(ccount)
        if any(np.size(v) != total for v in (z, r, amp, cs, cc)) or (
            total and (cs.min() < 0 or cc.min() < 0 or (cs + cc).max() > total)
        ):
            raise InputError(
                "x, z, r, amp, cstart, ccount must have one entry per RP, and every "
                "cluster must lie within the RPs"
            )
        stride = _stride(int(cc[i0 : i0 + n].max()) if n else 1)
        x0 = float(np.mean(x)) if total else 0.0  # outputs are in the main antennas' frames
        z0 = float(np.mean(z)) if total else 0.0
        return n, (
            self._buf(x - x0, role="x"),
            self._buf(z - z0, role="z"),
            self._buf(r, role="r"),
            self._buf(amp, role="amp"),
            self._buf(cstart, np.int32, role="cstart"),
            self._buf(ccount, np.int32, role="ccount"),
            np.int32(i0),
            np.int32(n),
            np.int32(stride),
        )

    def _density_args(self, sigma_d, sigma_r):
        """The truncations and constants of the density (reference module notes)."""
        t = self.dtype.type
        return (
            t(1.0 / (2.0 * sigma_d**2)),
            t((MS_PAIR_CUTOFF * sigma_d) ** 2),
            t(MS_CUTOFF * sigma_r),
            t(np.log2(np.e) / (2.0 * sigma_r**2)),
            t(EPS_DET),
        )

    def meanshift_spheres(
        self, x, z, r, amp, cstart, ccount, point, sigma_d, sigma_r, iters, i0=0, n=None
    ):
        """Device twin of :func:`rpm_cl.rpm.reference.meanshift_spheres`.

        One work-item per main RP; its scratch (5 rows of the largest cluster
        of the chunk, padded to 8) is the only memory that grows with the
        clusters, so chunks bound it.
        """
        if int(iters) < 0:
            raise InputError(f"iters must be >= 0, got {iters}")
        n, args = self._cluster_args(x, z, r, amp, cstart, ccount, i0, n)
        pt = np.asarray(point, np.float64).reshape(3, n)
        mode = self._out((3, n), role="ms_mode")
        dens = self._out((n,), role="ms_density")
        near = self._out((3, MS_NEAR_K, n), role="ms_nearest")
        count = self._out((n,), np.int32, role="ms_count")
        scratch = self._out((5, n, int(args[-1])), role="ms_scratch")
        self._run(
            self._k["meanshift_spheres"],
            n,
            *args,
            *self._density_args(sigma_d, sigma_r),
            np.int32(iters),
            self.dtype.type((MS_TOL * sigma_r) ** 2),
            self._buf(pt, role="ms_point"),
            mode,
            dens,
            near,
            count,
            scratch,
            stage="meanshift",
        )
        return (
            self._read(mode, (3, n)),
            self._read(dens, (n,)),
            self._read(near, (3, MS_NEAR_K, n)),
            self._read(count, (n,), np.int32),
        )

    def density_spheres(self, x, z, r, amp, cstart, ccount, point, sigma_d, sigma_r, i0=0, n=None):
        """Device twin of :func:`rpm_cl.rpm.reference.density_spheres`."""
        n, args = self._cluster_args(x, z, r, amp, cstart, ccount, i0, n)
        pt = np.asarray(point, np.float64).reshape(3, -1, n)
        nt = pt.shape[1]
        if not 1 <= nt <= MS_DENSITY_T:
            raise InputError(
                f"density_spheres takes 1..{MS_DENSITY_T} points per main RP, got {nt}"
            )
        dens = self._out((nt, n), role="ms_density_at")
        scratch = self._out((5, n, int(args[-1])), role="ms_scratch")
        self._run(
            self._k["density_spheres"],
            n,
            *args,
            *self._density_args(sigma_d, sigma_r),
            np.int32(nt),
            self._buf(pt, role="ms_point"),
            dens,
            scratch,
            stage="density",
        )
        return self._read(dens, (nt, n))
