"""The parameter set of a batch (:class:`BatchConfig`, ``rpm-cl batch``):
the method, the imaging parameters given explicitly, the OpenCL device and
precision, the DAS image per frame, and each frame's limits, checked once
when it is made.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..io.data import InputError
from .watchdog import DEFAULT_FRAME_TIMEOUT

#: DAS variants of a batch (see :class:`BatchConfig`).
DAS_REUSE = ("auto", "plan", "direct")


@dataclass(frozen=True)
class BatchConfig:
    """One parameter set for every frame of a batch.

    Attributes
    ----------
    method : str or None
        A key of :data:`rpm_cl.imaging.METHODS`; None:
        :data:`rpm_cl.imaging.DEFAULT_METHOD`.
    overrides : tuple of ((section, name), value)
        Imaging parameters given explicitly (``--config`` and flags, as
        :func:`rpm_cl.cli.config.resolve` takes them, e.g.
        ``(("rpm", "sigma_r"), 0.05)``); the rest is derived from each
        frame's data.
    device : str or None
        OpenCL device spec (see :func:`rpm_cl.cl.choose_device`), on every worker.
    precision : {"float32", "float64"}
    das_grid : str or None
        Also write a DAS image per frame on this grid
        (``"x0:x1:dx,y0:y1:dy[,z0:z1:dz]"``, m).
    memory_budget : float
        Bytes the DAS reuse tables may take per worker; beyond it each frame
        is back-projected directly on the device.
    das_reuse : {"auto", "plan", "direct"}
        DAS per frame with the reuse tables (:class:`rpm_cl.baselines.das.DASPlan`,
        built once per worker and geometry), with the direct OpenCL
        back-projection, or (``auto``) whichever of the two was faster on the
        worker's first frame of that geometry (the tables are built there and
        dropped if the kernel wins).
    frame_timeout : float
        Wall-clock limit of one frame on its worker, s (``inf``: none); from
        its worker's OpenCL setup done to its outputs written.
    frame_memory : float or None
        Limit of the worker process's resident memory (RSS) while it runs a
        frame, bytes (``inf``: none; None:
        :data:`rpm_cl.cli.watchdog.DEFAULT_FRAME_MEMORY_FRACTION` of the worker's memory
        limit).
        It includes what the worker holds between frames (the interpreter,
        Dask, the OpenCL runtime and programs, the DAS reuse tables: about
        0.25 GB without DAS).
    """

    method: str | None = None
    overrides: tuple = ()
    device: str | None = None
    precision: str = "float32"
    das_grid: str | None = None
    memory_budget: float = 2e9
    das_reuse: str = "auto"
    frame_timeout: float = DEFAULT_FRAME_TIMEOUT
    frame_memory: float | None = None

    def __post_init__(self):
        from ..extract.kspace import KSpaceParams
        from ..imaging import DEFAULT_METHOD, METHODS
        from ..io.medium import Medium
        from ..rpm.params import ImagingParams, RPMParams, is_auto

        if self.method is None:
            object.__setattr__(self, "method", DEFAULT_METHOD)
        if self.method not in METHODS:
            raise InputError(f"unknown method {self.method!r}; choose from {', '.join(METHODS)}")
        # the overrides checked once here (as each frame would), not once per frame
        by_section = {}
        for key, value in self.overrides:
            if not (isinstance(key, tuple) and len(key) == 2):
                raise InputError(f"imaging parameter keys are (section, name), got {key!r}")
            by_section.setdefault(key[0], {})[key[1]] = value
        unknown = set(by_section) - {"kspace", "rpm", "medium", "imaging"}
        if unknown:
            raise InputError(f"unknown parameter section(s): {', '.join(sorted(unknown))}")
        try:
            KSpaceParams(**by_section.get("kspace", {}))
            RPMParams(**by_section.get("rpm", {}))
            medium = dict(by_section.get("medium", {}))
            if is_auto(medium.get("eps_r")):  # read per frame
                medium["eps_r"] = 1.0
            Medium(**medium)
            imaging = dict(by_section.get("imaging", {}))
            if imaging.get("time_zero", 0.0) is None:  # "auto": picked per frame
                imaging["time_zero"] = 0.0
            ImagingParams(**imaging)
        except TypeError as exc:
            raise InputError(f"unknown imaging parameter: {exc}") from None
        if self.precision not in ("float32", "float64"):
            raise InputError(f"precision must be 'float32' or 'float64', got {self.precision!r}")
        if self.das_grid is not None:
            self.grid()  # validates
        if not (np.isfinite(self.memory_budget) and self.memory_budget > 0):
            raise InputError(f"memory_budget must be > 0 bytes, got {self.memory_budget}")
        if self.das_reuse not in DAS_REUSE:
            raise InputError(
                f"das_reuse must be one of {', '.join(DAS_REUSE)}, got {self.das_reuse!r}"
            )
        if not float(self.frame_timeout) > 0:  # NaN fails too
            raise InputError(f"frame_timeout must be > 0 s, got {self.frame_timeout}")
        if self.frame_memory is not None and not float(self.frame_memory) > 0:
            raise InputError(f"frame_memory must be > 0 bytes, got {self.frame_memory}")

    def grid(self):
        """The DAS :class:`rpm_cl.baselines.das.Grid`, or None."""
        from ..baselines.das import parse_grid

        return None if self.das_grid is None else parse_grid(self.das_grid)
