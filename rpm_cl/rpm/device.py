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
from .device_buffers import _DeviceBuffers
from .device_circles import _Circles
from .device_meanshift import _MeanShift
from .device_score import _Scoring
from .device_spheres import _Spheres
from .reference import MS_DENSITY_T, MS_NEAR_K, MS_NEWTON_PIVOT

__all__ = ["DeviceRPM"]


class DeviceRPM(_Circles, _Spheres, _Scoring, _MeanShift, _DeviceBuffers):
    """RPM kernels on one OpenCL device.

    The kernels come by stage, one mixin each: 2-D circles
    (:class:`rpm_cl.rpm.device_circles._Circles`), 3-D spheres
    (:class:`rpm_cl.rpm.device_spheres._Spheres`), scores and argmax
    (:class:`rpm_cl.rpm.device_score._Scoring`), mean shift and density
    (:class:`rpm_cl.rpm.device_meanshift._MeanShift`), on the buffer
    handling of :class:`rpm_cl.rpm.device_buffers._DeviceBuffers`.

    Parameters
    ----------
    env : CLEnv
        The OpenCL environment (context, queue, device).
    precision : {"float32", "float64"}
        Kernel arithmetic; float64 needs a device with ``double_fp_config``.
    timing : bool
        Wait for each kernel and add its wall time (s) to ``kernel_times``
        (``intersect``, ``score``, ``argmax``, ``meanshift``, ``density``), the
        Gaussian kernel evaluations the scoring kernel performed to
        ``kernel_evals`` and each one-dimensional launch's work-items
        (candidate slots of ``intersect``, main RPs of the others) to
        ``kernel_work``.  For benchmarks: the waits serialise host and device.
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
        self.kernel_work = dict.fromkeys(self.kernel_times, 0)
        self._ms_stored = None  # (i0, n, stride) of the last mean shift's candidate store
        self.dtype = np.dtype(np.float32 if precision == "float32" else np.float64)
        base = {"REAL": "float" if precision == "float32" else "double"}
        if precision == "float64":
            base["REAL_IS_DOUBLE"] = 1
        ms = {
            **base,
            "MS_NEAR_K": MS_NEAR_K,
            "MS_DENSITY_T": MS_DENSITY_T,
            "MS_NEWTON_PIVOT": MS_NEWTON_PIVOT,
        }
        # each program is built on its first use: a 2-D image needs two of
        # the five (a build from PoCL's cache takes about 40 ms)
        self._k = _Kernels(
            env,
            {
                "intersect_circles": ("circles.cl", "intersect_circles", base),
                "intersect_spheres": ("spheres.cl", "intersect_spheres", base),
                "meanshift_spheres": ("meanshift.cl", "meanshift_spheres", ms),
                "density_spheres": ("meanshift.cl", "density_spheres", ms),
                **{
                    f"{role}{dim}": ("score.cl", f"{role}_candidates", {**base, "DIM": dim})
                    for dim in (2, 3)
                    for role in ("score", "argmax")
                },
            },
        )
        self._pairs = {}  # kmax -> device pair table
        # device buffers by role, reused from call to call (a batch of frames
        # or the chunks of one image) and grown when a call needs more; the
        # queue is in order and every call reads its results back before it
        # returns, so a later call never overwrites what an earlier one uses
        self._pool = {}


class _Kernels:
    """The engine's kernels by role, each program built on first use
    (:func:`rpm_cl.cl.get_kernels`: once per context and options)."""

    def __init__(self, env: CLEnv, spec: dict):
        self._env, self._spec, self._got = env, spec, {}

    def __getitem__(self, role: str):
        if role not in self._got:  # once: not on every launch
            filename, name, defines = self._spec[role]
            self._got[role] = get_kernels(self._env, filename, [name], defines)[name]
        return self._got[role]
