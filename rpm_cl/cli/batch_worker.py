"""What each worker process of a batch keeps between frames
(:class:`_WorkerEngine`, a ``distributed.WorkerPlugin``): its OpenCL context,
the RPM and DAS kernels built for it, the DAS reuse tables of the frames'
geometry, and the watchdog that enforces the frame limits.
"""

from __future__ import annotations

import threading
import time

from ..io.data import InputError, RadarData
from .watchdog import DEFAULT_FRAME_MEMORY_FRACTION

#: Name under which the per-worker engine plugin is registered.
PLUGIN_NAME = "rpm-cl-batch-engine"

try:
    from distributed.diagnostics.plugin import WorkerPlugin as _WorkerPlugin
except ImportError:  # pragma: no cover - dask[distributed] is a core dependency
    _WorkerPlugin = object


class _WorkerEngine(_WorkerPlugin):
    """What a worker process keeps between frames: one OpenCL context, the RPM
    (and DAS) kernels built for it, the DAS reuse tables.

    Registered on every worker (present and future, e.g. one restarted after a
    crash); built on the worker's first frame, under a lock.
    """

    name = PLUGIN_NAME

    def __init__(
        self,
        device: str | None,
        precision: str,
        das: bool,
        memory_budget: float,
        das_reuse: str = "auto",
    ):
        self.device, self.precision, self.das = device, precision, das
        self.memory_budget, self.das_reuse = memory_budget, das_reuse

    def setup(self, worker=None):
        self._lock = threading.Lock()
        self._built = None
        self._plan = None  # (geometry key, "plan" | "direct", DASPlan or None)
        self._watchdog = None
        # killing a worker without a nanny would not restart it (or, in-process, end the client)
        self._can_kill = worker is not None and getattr(worker, "nanny", None) is not None
        limit = getattr(getattr(worker, "memory_manager", None), "memory_limit", None)
        if not limit:
            import psutil

            limit = psutil.virtual_memory().total
        self.default_frame_memory = DEFAULT_FRAME_MEMORY_FRACTION * limit

    def teardown(self, worker=None):
        self._built = self._plan = None
        if self._watchdog is not None:
            self._watchdog.close()
            self._watchdog = None

    def watchdog(self):
        """This worker's :class:`rpm_cl.cli.watchdog.Watchdog` (started on the
        first call, restarted if it died), or None on a worker without a nanny."""
        if not self._can_kill:
            return None
        with self._lock:
            if self._watchdog is None or not self._watchdog.alive():
                from .watchdog import Watchdog

                self._watchdog = Watchdog()
            return self._watchdog

    def get(self):
        """(env, DeviceRPM, DeviceDAS or None, seconds spent building now)."""
        with self._lock:
            if self._built is not None:
                return (*self._built, 0.0)
            from ..cl import create_env
            from ..rpm import DeviceRPM

            t0 = time.perf_counter()
            env = create_env(self.device)
            rpm = DeviceRPM(env, self.precision)
            das = None
            if self.das:
                from ..baselines.das import DeviceDAS

                das = DeviceDAS(env, self.precision, self.memory_budget)
                das._kernel(True), das._kernel(False)  # build both variants now
            self._built = (env, rpm, das)
            return (env, rpm, das, time.perf_counter() - t0)

    def das_image(self, das, data: RadarData, grid, medium=None):
        """DAS image of ``data`` by the variant chosen for its geometry (the
        first frame of a geometry chooses, see
        :class:`rpm_cl.cli.batch_config.BatchConfig`).

        ``medium`` (:class:`rpm_cl.io.medium.Medium`): a homogeneous one's
        equivalent air scene is back-projected; a half-space's refracted
        ranges go into the reuse tables, or the direct back-projection
        computes them on the host (:class:`rpm_cl.baselines.das.DeviceDAS`).

        Returns
        -------
        image : ndarray, complex, shape grid.shape
        mode : str
            "plan" or "direct".
        """
        from ..io.medium import in_medium

        refr = None
        if medium is not None:
            data = in_medium(data, medium)
            refr = medium if medium.half_space else None
        key = (
            data.signal.shape,
            float(data.range[0]),
            data.dr,
            data.waveform.fc,
            data.array.positions().tobytes(),
            grid.shape,
            grid.x[0],
            grid.y[0],
            refr,
        )
        with self._lock:
            if self._plan is None or self._plan[0] != key:
                self._plan = None  # free the old tables first
                mode, plan, img = self._choose(das, data, grid, refr)
                self._plan = (key, mode, plan)
                return img, mode
            _, mode, plan = self._plan
        if mode == "plan":
            return plan.apply(data), mode
        return das.backproject(data, grid, medium=refr), mode

    def _choose(self, das, data, grid, refr=None):
        """(mode, plan or None, this frame's image)."""
        from ..baselines.das import DASPlan

        if self.das_reuse == "direct":
            return "direct", None, das.backproject(data, grid, medium=refr)
        try:
            plan = DASPlan(data, grid, self.memory_budget, refr)
        except InputError:  # the tables exceed the budget
            return "direct", None, das.backproject(data, grid, medium=refr)
        t0 = time.perf_counter()
        img = plan.apply(data)
        t_plan = time.perf_counter() - t0
        if self.das_reuse == "plan" or refr is not None:  # the host's direct one is slower
            return "plan", plan, img
        das.backproject(data, grid)  # warm-up: PoCL compiles at the first launch
        t0 = time.perf_counter()
        direct = das.backproject(data, grid)
        if time.perf_counter() - t0 < t_plan:
            return "direct", None, direct
        return "plan", plan, img
