"""SAR / delay-and-sum (DAS) back-projection: the coherent baseline.

    I(p) = sum_a s_a(|p - a|) exp(+j 2 k_c |p - a|)

over the antennas a = (X_a, 0[, Z_a]), with s_a linearly interpolated along
the range axis (0 outside it): the adjoint of the discretised forward model
(:func:`das_adjoint`), so the dot-product test holds exactly.

Three implementations of the same sum:

- :func:`das_numpy`: float64 NumPy, vectorised over voxel chunks sized so that
  the temporaries stay under ``memory_budget`` bytes (default 2 GB); the
  specification of the kernel.
- :class:`DeviceDAS`: the OpenCL kernel ``kernels/das.cl`` on the same device
  as RPM (the one timed against RPM); images of any size in row chunks.
- :class:`DASPlan`: the paper's reuse variant for repeated frames (Section
  VI-B2): the per-voxel, per-antenna sample index and complex weights are
  computed once, and each frame costs a gather and a multiply-add; it refuses,
  with the memory it would need, grids whose tables exceed the budget.

Images are complex on a :class:`Grid`: shape (nx, ny) in 2-D (linear arrays),
(nx, ny, nz) in 3-D (planar arrays), C order, axes in metres.

In a medium (``medium``, :class:`rpm_cl.io.medium.Medium`) ``|p - a|`` becomes
the air-equivalent travel range: a homogeneous medium is back-projected as
its equivalent air scene (:func:`rpm_cl.io.medium.in_medium`, every
implementation, the kernel included); above a half-space each (voxel,
antenna) range is Fermat's refracted path (:func:`rpm_cl.io.medium.one_way`),
computed on the host: :func:`das_numpy`, :func:`das_adjoint` and
:class:`DASPlan` take it, and :class:`DeviceDAS` hands such images to
:func:`das_numpy` (the kernel computes straight-line distances from its
grid axes).
"""

from __future__ import annotations

import numpy as np

from ..cl import read_only
from ..extract.backprojection import (
    BYTES_PER_TERM,
    BYTES_PER_TERM_REFRACTED,
    antennas,
    phased_pairs,
    summed,
)
from ..extract.backprojection import weights as _weights
from ..io.data import C0, InputError, RadarData
from ..io.images import GRID_COORD_MAX, Grid, check_disk, parse_grid, write_image

__all__ = [
    "GRID_COORD_MAX",
    "MEMORY_BUDGET_DEFAULT",
    "DASPlan",
    "DeviceDAS",
    "Grid",
    "check_disk",
    "check_float32_range",
    "das_adjoint",
    "das_numpy",
    "parse_grid",
    "write_image",
]

#: The DAS kernel evaluates the phasor between two range gates by a Taylor
#: polynomial (-DPOLY) where k_c times the gate spacing is at most this, rad
#: (its truncation error there is below 1e-7, under float32 rounding), else
#: by sincos (kernels/das.cl).
POLY_KC_DR_MAX = 1.1
#: Default bound on the memory a DAS run may hold (temporaries, tables), bytes.
MEMORY_BUDGET_DEFAULT = 2_000_000_000


def _geometry(data: RadarData, grid: Grid):
    if grid.dim != data.array.dim:
        kind = "planar (3-D)" if data.array.planar else "linear (2-D)"
        raise InputError(f"a {kind} array needs a {data.array.dim}-axis grid, got {grid.dim} axes")
    return antennas(data.array)


#: Largest and smallest nonzero signal amplitude a float32 DAS image holds:
#: the sum over the antennas stays below float32's 3.4e38, and the smallest
#: samples stay normal (1.2e-38) with room for the interpolation weights.
F32_MAX_SUM = 1e36
F32_MIN_PEAK = 1e-30


def check_float32_range(data: RadarData) -> None:
    """InputError when ``data``'s amplitudes leave float32's range in a DAS
    image (a sum of ``n`` antennas' samples): all-Inf/NaN above, all-zero
    below.  An all-zero signal is fine (an empty image)."""
    peak = float(np.max(np.abs(data.signal))) if data.signal.size else 0.0
    n = data.array.n
    if peak > 0 and (peak * n > F32_MAX_SUM or peak < F32_MIN_PEAK):
        raise InputError(
            f"signal amplitudes up to {peak:.3g} are outside what a float32 DAS "
            f"image holds ({F32_MIN_PEAK:g} .. {F32_MAX_SUM / n:.3g} for {n} "
            f"antennas); use --precision float64, or scale the signal"
        )


def _chunk_voxels(n_ant: int, budget: float, per: int = BYTES_PER_TERM) -> int:
    """Voxels per chunk so that ``per`` bytes per (voxel, antenna) fit the budget."""
    return max(1, int(budget // (per * max(1, n_ant))))


def _per(medium) -> int:
    return BYTES_PER_TERM_REFRACTED if medium is not None and medium.half_space else BYTES_PER_TERM


def _seen(data: RadarData, medium):
    """The data a back-projection works on: a homogeneous medium's
    equivalent air scene, else ``data``; and the medium left for the
    ranges (a half-space, else None)."""
    if medium is None or medium.air:
        return data, None
    from ..io.medium import in_medium

    return in_medium(data, medium), (medium if medium.half_space else None)


def das_numpy(
    data: RadarData,
    grid: Grid,
    memory_budget: float = MEMORY_BUDGET_DEFAULT,
    out: np.ndarray | None = None,
    progress=None,
    medium=None,
) -> np.ndarray:
    """DAS image, float64 NumPy (the specification of the kernel).

    Parameters
    ----------
    data : RadarData
    grid : Grid
        2 axes for linear arrays, 3 for planar ones.
    memory_budget : float
        Bound on the temporaries, bytes (160 bytes per voxel and antenna of a
        chunk, the measured peak of :func:`_weights` and the gather); the image
        itself is ``out``.
    out : ndarray, complex, shape grid.shape, optional
        Where to write (e.g. a ``numpy.lib.format.open_memmap`` for volumes
        larger than memory); default a new complex128 array.
    progress : callable, optional
        Called with (voxels done, voxels total) after each chunk.
    medium : rpm_cl.io.medium.Medium, optional
        The material (module notes); None: air.  The grid is in true metres.

    Returns
    -------
    ndarray, complex, shape grid.shape
    """
    data, refr = _seen(data, medium)
    ant = _geometry(data, grid)
    sig = np.ascontiguousarray(data.signal.reshape(-1, data.range.size), np.complex128)
    k2 = 4 * np.pi * data.waveform.fc / C0
    if out is None:
        out = np.empty(grid.shape, np.complex128)
    flat = out.reshape(-1)
    step = _chunk_voxels(len(ant), memory_budget, _per(refr))
    for lo in range(0, grid.size, step):
        hi = min(grid.size, lo + step)
        flat[lo:hi] = summed(grid.points(lo, hi), ant, sig, float(data.range[0]), data.dr, k2, refr)
        if progress:
            progress(hi, grid.size)
    return out


def das_adjoint(image: np.ndarray, data: RadarData, grid: Grid, medium=None) -> np.ndarray:
    """The adjoint of :func:`das_numpy`: a discretised forward model.

    Each voxel's reflectivity is spread onto the two range samples around its
    distance to each antenna (linear-interpolation weights) with the phase
    exp(-j 2 k_c d).  ``<das_adjoint(x), s> = <x, das_numpy(s)>`` (with the
    same ``medium``; a homogeneous one's range axis is the equivalent air
    scene's).

    Returns
    -------
    ndarray, complex, shape data.signal.shape
    """
    data, refr = _seen(data, medium)
    ant = _geometry(data, grid)
    nr = data.range.size
    k2 = 4 * np.pi * data.waveform.fc / C0
    x = np.asarray(image, np.complex128).reshape(-1)
    out = np.zeros((len(ant), nr), np.complex128)
    step = _chunk_voxels(len(ant), MEMORY_BUDGET_DEFAULT, _per(refr))
    a_idx = np.broadcast_to(np.arange(len(ant))[None, :], (min(step, x.size), len(ant)))
    for lo in range(0, x.size, step):
        hi = min(x.size, lo + step)
        i, w0, w1 = _weights(grid.points(lo, hi), ant, float(data.range[0]), data.dr, nr, k2, refr)
        xa = x[lo:hi, None]
        np.add.at(out, (a_idx[: hi - lo], i), np.conj(w0) * xa)
        np.add.at(out, (a_idx[: hi - lo], i + 1), np.conj(w1) * xa)
    return out.reshape(data.signal.shape)


class DASPlan:
    """The reuse variant: per-voxel transfer terms computed once, for many frames.

    Holds, per voxel and antenna, the sample index (int32) and the two complex
    weights (complex64): 20 bytes each.  Each frame then costs one gather and
    one multiply-add per (voxel, antenna), no square root or phase.

    Parameters
    ----------
    data : RadarData
        Any frame of the sequence (its geometry: array, range axis, fc).
    grid : Grid
    memory_budget : float
        Bytes the tables may take; a larger grid raises :class:`InputError`
        saying how much it would need.
    medium : rpm_cl.io.medium.Medium, optional
        The material (module notes); each frame is then that of the same
        medium.
    """

    BYTES_PER_TERM = 20

    def __init__(
        self, data: RadarData, grid: Grid, memory_budget: float = MEMORY_BUDGET_DEFAULT, medium=None
    ):
        self.medium = medium
        data, refr = _seen(data, medium)
        ant = _geometry(data, grid)
        need = float(grid.size) * len(ant) * self.BYTES_PER_TERM
        if need > memory_budget:
            raise InputError(
                f"the DAS reuse tables for {grid.size} voxels x {len(ant)} antennas "
                f"need {need / 1e9:.1f} GB, more than the {memory_budget / 1e9:.1f} GB "
                "budget; use the direct back-projection"
            )
        self.grid, self.shape = grid, data.signal.shape
        self.range0, self.dr = float(data.range[0]), data.dr
        self.fc, self.positions = data.waveform.fc, data.array.positions()
        nr = data.range.size
        k2 = 4 * np.pi * data.waveform.fc / C0
        self.index = np.empty((grid.size, len(ant)), np.int32)
        self.w0 = np.empty((grid.size, len(ant)), np.complex64)
        self.w1 = np.empty((grid.size, len(ant)), np.complex64)
        step = _chunk_voxels(len(ant), memory_budget / 4, _per(refr))
        offset = (np.arange(len(ant)) * nr)[None, :]
        for lo in range(0, grid.size, step):
            hi = min(grid.size, lo + step)
            i, w0, w1 = _weights(grid.points(lo, hi), ant, self.range0, self.dr, nr, k2, refr)
            self.index[lo:hi] = i + offset  # flat index into (antenna, range)
            self.w0[lo:hi], self.w1[lo:hi] = w0, w1
        self.nbytes = self.index.nbytes + self.w0.nbytes + self.w1.nbytes

    def apply(self, data: RadarData) -> np.ndarray:
        """DAS image of one frame with the same geometry, shape grid.shape."""
        data, _ = _seen(data, self.medium)
        if (
            data.signal.shape != self.shape
            or float(data.range[0]) != self.range0
            or data.dr != self.dr
            or data.waveform.fc != self.fc
            or not np.array_equal(data.array.positions(), self.positions)
        ):
            raise InputError("this frame's array, range axis or carrier differs from the plan's")
        check_float32_range(data)
        s = np.ascontiguousarray(data.signal.reshape(-1), np.complex64)
        out = np.empty(self.grid.size, np.complex64)
        step = max(1, 2_000_000 // self.index.shape[1])
        for lo in range(0, self.grid.size, step):
            i = self.index[lo : lo + step]
            out[lo : lo + step] = (
                s[i] * self.w0[lo : lo + step] + s[i + 1] * self.w1[lo : lo + step]
            ).sum(axis=1)
        return out.reshape(self.grid.shape)


class DeviceDAS:
    """The DAS kernel (``kernels/das.cl``) on one OpenCL device.

    Parameters
    ----------
    env : rpm_cl.cl.CLEnv
    precision : {"float32", "float64"}
    memory_budget : float
        Bound on the device output buffer of one chunk, bytes.
    """

    def __init__(
        self, env, precision: str = "float32", memory_budget: float = MEMORY_BUDGET_DEFAULT
    ):
        from ..cl import get_kernels

        if precision not in ("float32", "float64"):
            raise ValueError(f"precision must be 'float32' or 'float64', got {precision!r}")
        if precision == "float64" and not env.has_double:
            raise ValueError(f"device {env.name} has no float64 support; use precision='float32'")
        self.env, self.precision = env, precision
        self.real = np.dtype(np.float32 if precision == "float32" else np.float64)
        self.cplx = np.dtype(np.complex64 if precision == "float32" else np.complex128)
        self.vw = 8 if precision == "float32" else 4
        self.memory_budget = memory_budget
        self._defines = {"REAL": "float" if precision == "float32" else "double"}
        if precision == "float64":
            self._defines["REAL_IS_DOUBLE"] = 1
        self._get = get_kernels

    def _kernel(self, poly: bool):
        d = dict(self._defines, **({"POLY": 1} if poly else {}))
        return self._get(self.env, "das.cl", ["das_backproject"], d)["das_backproject"]

    #: The kernel's input (:func:`rpm_cl.extract.backprojection.phased_pairs`).
    phased_pairs = staticmethod(phased_pairs)

    def _buf(self, a, dtype):
        return read_only(self.env, a, dtype)

    def backproject(
        self,
        data: RadarData,
        grid: Grid,
        out: np.ndarray | None = None,
        reduce=None,
        progress=None,
        medium=None,
    ):
        """DAS image on the device, row chunk by row chunk.

        Parameters
        ----------
        data : RadarData
        grid : Grid
        out : ndarray, complex, shape grid.shape, optional
            Destination (e.g. a memmap); default a new array in the kernel's
            complex precision.  Ignored when ``reduce`` is given.
        reduce : callable, optional
            Called with (row0, chunk) for each chunk, chunk of shape
            (rows, last axis); nothing is kept (for volumes that only need a
            summary, e.g. a projection).
        progress : callable, optional
            Called with (voxels done, voxels total).
        medium : rpm_cl.io.medium.Medium, optional
            The material (module notes).  A half-space's refracted ranges
            are not the kernel's straight lines: that image is
            :func:`das_numpy`'s (float64, on the host), rounded to this
            precision.

        Returns
        -------
        ndarray or None
            The image, or None with ``reduce``.
        """
        import pyopencl as cl

        data, refr = _seen(data, medium)
        if refr is not None:
            return self._host(data, grid, out, reduce, progress, refr)
        ant = _geometry(data, grid)
        nr = data.range.size
        # common origin removed in float64 so float32 sees small coordinates
        o = np.array([np.mean(ant[:, 0]), 0.0, np.mean(ant[:, 2])])
        if nr < 2:
            raise InputError("DAS needs at least 2 range samples")
        if self.cplx == np.complex64:
            check_float32_range(data)
        sig = self._buf(self.phased_pairs(data), self.cplx)
        kc_dr = 2 * np.pi * data.waveform.fc / C0 * data.dr
        kernel = self._kernel(poly=kc_dr <= POLY_KC_DR_MAX)
        ax, az = self._buf(ant[:, 0] - o[0], self.real), self._buf(ant[:, 2] - o[2], self.real)
        gx = self._buf(grid.x - o[0], self.real)
        gy = self._buf(grid.y, self.real)
        gz = self._buf((grid.z if grid.z is not None else np.zeros(1)) - o[2], self.real)
        nlast = grid.shape[-1]
        rows = grid.size // nlast
        ny = grid.shape[1] if grid.dim == 3 else 1
        row_bytes = nlast * self.cplx.itemsize
        step = int(max(1, min(rows, self.memory_budget // max(1, row_bytes), 1 << 16)))
        if out is None and reduce is None:
            out = np.empty(grid.shape, self.cplx)
        flat = None if out is None else out.reshape(rows, nlast)
        buf = cl.Buffer(self.env.context, cl.mem_flags.WRITE_ONLY, step * row_bytes)
        host = np.empty((step, nlast), self.cplx)
        nq = -(-nlast // self.vw)
        k2 = 4 * np.pi * data.waveform.fc / C0
        for r0 in range(0, rows, step):
            n = min(step, rows - r0)
            kernel(
                self.env.queue,
                (nq, n),
                None,
                sig,
                np.int32(len(ant)),
                np.int32(nr),
                ax,
                az,
                self.real.type(data.range[0]),
                self.real.type(1.0 / data.dr),
                self.real.type(k2 * data.dr),
                gx,
                gy,
                gz,
                np.int32(ny),
                np.int32(nlast),
                np.int32(grid.dim),
                np.int64(r0),
                np.int32(n),
                buf,
            )
            cl.enqueue_copy(self.env.queue, host[:n], buf)
            if reduce is not None:
                reduce(r0, host[:n])
            else:
                flat[r0 : r0 + n] = host[:n]
            if progress:
                progress((r0 + n) * nlast, grid.size)
        return None if reduce is not None else out

    def _host(self, data, grid, out, reduce, progress, medium):
        """:meth:`backproject` by :func:`das_numpy` (a half-space)."""
        if out is None or reduce is not None:
            out = np.empty(grid.shape, self.cplx)
        das_numpy(data, grid, self.memory_budget, out=out, progress=progress, medium=medium)
        if reduce is None:
            return out
        nlast = grid.shape[-1]
        flat = out.reshape(-1, nlast)
        reduce(0, flat)
        return None
