"""Mean-shift and density kernels of the RPM OpenCL engine
(:mod:`rpm_cl.rpm.device`): each main RP's point moved to the mode of the
3-D intersection density of its cluster, and that density at given points.

The methods have the signatures of their float64 references in
:mod:`rpm_cl.rpm.reference` (``meanshift_spheres``, ``density_spheres``).
"""

from __future__ import annotations

import numpy as np

from ..io.data import InputError
from .device_buffers import _check_chunk, _check_clusters, _stride
from .reference import EPS_DET, MS_CUTOFF, MS_DENSITY_T, MS_NEAR_K, MS_PAIR_CUTOFF, MS_TOL

#: Reals of the mean shift's candidate store in one launch (3 per pair of
#: sub RPs a main RP sweeps, at most 3 x stride^2 each; 128 MiB in float32):
#: the kernel intersects each main RP's pairs once, in its first pass, and
#: reads them back in the later passes and in the density that follows;
#: :meth:`_MeanShift.meanshift_chunk` bounds the chunks so that they fit.
MS_STORE_SLOTS = 1 << 25


class _MeanShift:
    """Mean shift over the intersection density on the device.

    A mixin of :class:`rpm_cl.rpm.device.DeviceRPM`, which provides the
    kernels (``_k``), the precision (``dtype``) and the buffer handling
    (:class:`rpm_cl.rpm.device_buffers._DeviceBuffers`).
    """

    def _cluster_args(self, x, z, r, amp, cstart, ccount, i0, n):
        """Checked chunk and the device arguments shared by the mean-shift
        kernels: (n, x, z, r, amp, cstart, ccount buffers, i0, n, stride)."""
        x = np.asarray(x, np.float64)
        z = np.asarray(z, np.float64)
        total = x.size
        n = total - i0 if n is None else int(n)
        _check_chunk(total, int(i0), n)
        _check_clusters("x, z, r, amp, cstart, ccount", total, cstart, ccount, z, r, amp)
        stride = _stride(int(np.asarray(ccount)[i0 : i0 + n].max()) if n else 1)
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

    @staticmethod
    def meanshift_chunk(largest: int) -> int:
        """Most main RPs of one :meth:`meanshift_spheres` call whose
        candidates fit the store (:data:`MS_STORE_SLOTS`), for clusters of up
        to ``largest`` RPs."""
        s = _stride(max(1, int(largest)))
        return max(1, MS_STORE_SLOTS // (3 * s * s))

    def meanshift_spheres(
        self, x, z, r, amp, cstart, ccount, point, sigma_d, sigma_r, iters, i0=0, n=None
    ):
        """Device twin of :func:`rpm_cl.rpm.reference.meanshift_spheres`.

        One work-item per main RP; its scratch (5 rows of the largest cluster
        of the chunk, padded to 8) and, where the chunk fits
        :data:`MS_STORE_SLOTS`, its candidate store (3 x stride^2 reals) are
        the only memory that grows with the clusters, so chunks bound it.
        With the store the candidates are intersected once, and a
        :meth:`density_spheres` call with ``reuse`` on the same chunk reads
        them too.
        """
        if int(iters) < 0:
            raise InputError(f"iters must be >= 0, got {iters}")
        n, args = self._cluster_args(x, z, r, amp, cstart, ccount, i0, n)
        pt = np.asarray(point, np.float64).reshape(3, n)
        mode = self._out((3, n), role="ms_mode")
        dens = self._out((n,), role="ms_density")
        near = self._out((3, MS_NEAR_K, n), role="ms_nearest")
        count = self._out((n,), np.int32, role="ms_count")
        stride = int(args[-1])
        scratch = self._out((5, n, stride), role="ms_scratch")
        sstride = stride * stride
        use = 0 < int(iters) and 3 * n * sstride <= MS_STORE_SLOTS
        store = self._out((3, n, sstride) if use else (1,), role="ms_store")
        qcount = self._out((2, n), np.int32, role="ms_qcount")
        self._ms_stored = (int(i0), n, stride) if use else None
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
            store,
            np.int64(sstride),
            np.int32(use),
            qcount,
            stage="meanshift",
        )
        return (
            self._read(mode, (3, n)),
            self._read(dens, (n,)),
            self._read(near, (3, MS_NEAR_K, n)),
            self._read(count, (n,), np.int32),
        )

    def density_spheres(
        self, x, z, r, amp, cstart, ccount, point, sigma_d, sigma_r, i0=0, n=None, reuse=False
    ):
        """Device twin of :func:`rpm_cl.rpm.reference.density_spheres`.

        ``reuse``: the last :meth:`meanshift_spheres` call ran on the same
        RPs, widths and chunk; its stored candidates are read instead of
        intersected again (where it stored them).
        """
        n, args = self._cluster_args(x, z, r, amp, cstart, ccount, i0, n)
        pt = np.asarray(point, np.float64).reshape(3, -1, n)
        nt = pt.shape[1]
        if not 1 <= nt <= MS_DENSITY_T:
            raise InputError(
                f"density_spheres takes 1..{MS_DENSITY_T} points per main RP, got {nt}"
            )
        dens = self._out((nt, n), role="ms_density_at")
        stride = int(args[-1])
        scratch = self._out((5, n, stride), role="ms_scratch")
        use = bool(reuse) and self._ms_stored == (int(i0), n, stride)
        sstride = stride * stride
        store = self._out((3, n, sstride) if use else (1,), role="ms_store")
        qcount = self._out((2, n), np.int32, role="ms_qcount")
        self._run(
            self._k["density_spheres"],
            n,
            *args,
            *self._density_args(sigma_d, sigma_r),
            np.int32(nt),
            self._buf(pt, role="ms_point"),
            dens,
            scratch,
            store,
            np.int64(sstride),
            np.int32(use),
            qcount,
            stage="density",
        )
        return self._read(dens, (nt, n))
