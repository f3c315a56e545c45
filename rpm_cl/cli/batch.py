"""Batch imaging: many frames with one parameter set, on a Dask cluster.

``rpm-cl batch IN -o OUT`` images every frame of ``IN`` (a folder of ``.npz`` /
``.h5`` files, or one HDF5 stack whose ``signal`` has a leading frame axis) and
writes, per frame, ``OUT/<name>.npz`` (the result of :func:`rpm_cl.io.formats.save_result`)
and, with a DAS grid, ``OUT/<name>_das.npz`` (the format of ``rpm-cl das``);
then ``OUT/summary.json``.

Work is spread by :mod:`dask.distributed`: an embedded ``LocalCluster`` (one
single-threaded worker process per ``--workers``), or an existing cluster
(``--scheduler tcp://host:port``).  Each worker process holds one
:class:`_WorkerEngine` (a ``distributed.WorkerPlugin``): its OpenCL context,
the :class:`rpm_cl.rpm.DeviceRPM` (compiled programs and kernels) and, when
DAS is asked for, the :class:`rpm_cl.baselines.das.DeviceDAS` and the
:class:`rpm_cl.baselines.das.DASPlan` of the frames' geometry, built on the worker's
first frame and reused for every later one.  Nothing is held at module level.

Failures lose nothing:

- a frame that raises (corrupt file, bad shape, OpenCL error) is recorded in
  the summary with its one-line error and the other frames go on;
- outputs are written atomically, so an existing output is complete and a
  restarted batch skips its frame;
- a frame whose worker process dies is rescheduled by the Dask scheduler on
  another (or the restarted) worker, up to
  ``distributed.scheduler.allowed-failures`` times (default 3), after which it
  is recorded as failed;
- a frame that runs longer than ``frame_timeout`` or takes the worker's
  resident memory above ``frame_memory`` (:class:`BatchConfig`) is stopped by
  killing its worker process (:mod:`rpm_cl.cli.watchdog`), recorded as failed with
  the limit it exceeded, and its partial outputs are removed; the nanny
  restarts the worker and the other frames go on.  Workers without a nanny
  (``dask worker --no-nanny``) are not killed: there the limits are not
  enforced.

Exit status of the CLI: 0 when every frame is done or skipped, 1 when some
frames failed (the summary names them), 2 for a user error (one line).
"""

from __future__ import annotations

import os
import threading
import time
import warnings
from dataclasses import asdict, dataclass
from typing import NamedTuple

import numpy as np

from ..io.data import DataWarning, InputError, RadarData
from .watchdog import DEFAULT_FRAME_MEMORY_FRACTION, DEFAULT_FRAME_TIMEOUT

__all__ = [
    "PLUGIN_NAME",
    "BatchConfig",
    "BatchSummary",
    "FrameSource",
    "frame_sources",
    "prepare_output",
    "run_batch",
]

#: Name under which the per-worker engine plugin is registered.
PLUGIN_NAME = "rpm-cl-batch-engine"
#: File suffixes taken as frames in an input folder.
NPZ_SUFFIXES = (".npz",)
H5_SUFFIXES = (".h5", ".hdf5")
#: DAS variants of a batch (see :class:`BatchConfig`).
DAS_REUSE = ("auto", "plan", "direct")


class FrameSource(NamedTuple):
    """One frame: its output name, the file holding it, its index in a stack."""

    name: str
    path: str
    frame: int | None


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
        :data:`DEFAULT_FRAME_MEMORY_FRACTION` of the worker's memory limit).
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
        from ..rpm.params import ImagingParams, RPMParams

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
            Medium(**by_section.get("medium", {}))
            ImagingParams(**by_section.get("imaging", {}))
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


# --------------------------------------------------------------------------
# Frames: the one place that knows file formats.
def _file_sources(path: str) -> list[FrameSource]:
    """The frames of one file: one per leading index of a stack (named
    ``<stem>_f0007``), else one named ``<stem>``.  A file that cannot be read
    is listed as one frame, so that its error is reported with the results
    and the other frames go on."""
    from ..io.formats import frame_count

    stem = os.path.splitext(os.path.basename(path))[0]
    try:
        n = int(frame_count(path))
    except InputError:
        return [FrameSource(stem, path, None)]
    if n == 1:
        return [FrameSource(stem, path, 0)]
    return [FrameSource(f"{stem}_f{i:04d}", path, i) for i in range(n)]


def frame_sources(source) -> list[FrameSource]:
    """Every frame of ``source``, in name order.

    Parameters
    ----------
    source : str or path-like
        A folder (every ``.npz``, ``.h5``, ``.hdf5`` file in it, hidden files
        left out; an HDF5 stack gives one frame per leading index), or one
        such file.

    Raises
    ------
    InputError
        No such folder or file, no frames, or two frames with one output name.
    """
    source = os.fspath(source)
    suffixes = NPZ_SUFFIXES + H5_SUFFIXES
    if os.path.isdir(source):
        files = sorted(
            os.path.join(source, f)
            for f in os.listdir(source)
            if not f.startswith(".")
            and f.lower().endswith(suffixes)
            and os.path.isfile(os.path.join(source, f))
        )
        if not files:
            raise InputError(f"{source}: no .npz or .h5 frames in this folder")
    elif os.path.isfile(source):
        if not source.lower().endswith(suffixes):
            raise InputError(f"{source}: not a folder, .npz or .h5 file")
        files = [source]
    else:
        raise InputError(f"{source}: no such folder or file")
    out = []
    for f in files:
        out.extend(_file_sources(f))
    names = [s.name for s in out]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError(
            f"{source}: several inputs would write the same result "
            f"({', '.join(dup[:3])}); rename them"
        )
    return out


def _load_frame(path: str, frame: int | None) -> RadarData:
    """Read one frame (validated; :func:`rpm_cl.io.formats.load_data`)."""
    from ..io.formats import load_data

    return load_data(path, frame=frame)


# --------------------------------------------------------------------------
# Per-worker state
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
        first frame of a geometry chooses, see :class:`BatchConfig`).

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


def _error_line(exc: BaseException) -> str:
    msg = str(exc).strip().splitlines()
    text = msg[0] if msg else ""
    return text if isinstance(exc, InputError) else f"{type(exc).__name__}: {text}".rstrip(": ")


def _marker(out_dir: str, src: FrameSource) -> str:
    """The file where the watchdog leaves the reason it stopped ``src``."""
    return os.path.join(out_dir, f".{src.name}.limit")


def _clear_markers(out_dir: str, sources) -> None:
    """Remove the limit markers (:func:`_marker`) of ``sources``."""
    for s in sources:
        if os.path.exists(_marker(out_dir, s)):
            os.remove(_marker(out_dir, s))


def _limit_failure(out_dir: str, src: FrameSource, config: BatchConfig) -> str | None:
    """The reason ``src`` was stopped by a limit (its marker), or None; the
    frame's outputs and temporary files are removed.  The marker stays until
    the end of the batch, so that a frame computed again (its result was lost
    with a worker) is reported failed again rather than run again."""
    import glob

    from ..io.data import temp_prefix

    try:
        with open(_marker(out_dir, src), encoding="utf-8") as fh:
            reason = fh.read().strip()
    except FileNotFoundError:
        return None
    for path in _outputs(out_dir, src, config):
        partial = glob.glob(
            os.path.join(glob.escape(out_dir), glob.escape(temp_prefix(path)) + "*")
        )
        for p in [path, *partial]:
            if os.path.exists(p):
                os.remove(p)
    return reason


def _image_frame(src: FrameSource, out_dir: str, config: BatchConfig) -> dict:
    """Task run on a worker: image one frame and write its outputs, under the
    frame's limits (see :class:`BatchConfig`).

    Returns a record (never raises for the frame's own errors): ``status``
    "done" with ``timings`` (s) or "failed" with ``error`` (one line), and
    ``warnings``, the frame's DataWarnings (one line each).  A
    frame that its worker's watchdog stopped comes back here (the scheduler
    resubmits it) and is reported failed with the watchdog's reason.
    """
    from distributed import get_worker

    from .. import __version__
    from ..imaging import run_method
    from ..io.formats import save_result
    from .config import resolve

    t_start = time.perf_counter()
    worker = get_worker()
    rec = {"frame": src.name, "input": src.path, "index": src.frame, "worker": worker.address}
    reason = _limit_failure(out_dir, src, config)
    if reason is not None:
        return {**rec, "status": "failed", "error": reason}
    engine = worker.plugins[PLUGIN_NAME]
    watchdog = engine.watchdog()
    # the frame's DataWarnings come back with its record, for the driver to
    # print (a worker's own stderr is no place for them); one thread per worker
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", DataWarning)
        try:
            env, rpm, das, setup_s = engine.get()
            rec.update(device=env.name, setup_s=setup_s)
            if watchdog is not None:
                memory = config.frame_memory
                watchdog.arm(
                    _marker(out_dir, src),
                    config.frame_timeout,
                    engine.default_frame_memory if memory is None else memory,
                )
            t0 = time.perf_counter()
            data = _load_frame(src.path, src.frame)
            timings = {"load": time.perf_counter() - t0}
            params = resolve(data, dict(config.overrides))
            grid = config.grid()
            if grid is not None and grid.dim != data.array.dim:
                raise InputError(
                    f"{src.path}: --das-grid has {grid.dim} axes; this array needs {data.array.dim}"
                )
            result = run_method(config.method, data, params, rpm)
            timings.update({k: v for k, v in result.timings.items() if k != "total"})
            meta = {
                "version": __version__,
                "device": env.name,
                "precision": config.precision,
                "input": src.path,
                "frame": src.frame,
                "params": asdict(params),
            }
            if data.truth is not None and data.truth.scene not in ("", "{}"):
                import json

                meta["scene"] = json.loads(data.truth.scene)
            if grid is not None:
                from ..baselines.das import write_image

                t0 = time.perf_counter()
                img, mode = engine.das_image(das, data, grid, params.medium)
                timings["das"] = time.perf_counter() - t0
                rec["das_mode"] = mode

                def fill(out):
                    out[...] = img

                t0 = time.perf_counter()
                write_image(
                    os.path.join(out_dir, f"{src.name}_das.npz"),
                    grid,
                    fill,
                    img.dtype,
                    {**meta, "method": "das", "das_mode": mode, "grid": config.das_grid},
                )
                timings["save"] = time.perf_counter() - t0
            t0 = time.perf_counter()
            # written last: its presence marks the frame done (see _outputs)
            save_result(os.path.join(out_dir, f"{src.name}.npz"), result, meta)
            timings["save"] = timings.get("save", 0.0) + time.perf_counter() - t0
            timings["total"] = time.perf_counter() - t_start - setup_s
            rec.update(status="done", timings=timings, points=len(result.image.points))
        except Exception as exc:  # noqa: BLE001 - the frame's failure is recorded; the batch goes on
            rec.update(status="failed", error=_error_line(exc))
        finally:
            if watchdog is not None:
                watchdog.disarm()
    rec["warnings"] = [
        " ".join(str(w.message).split()) for w in caught if issubclass(w.category, DataWarning)
    ]
    for w in caught:  # the others go where they went without the capture
        if not issubclass(w.category, DataWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return rec


# --------------------------------------------------------------------------
# Driver
@dataclass(frozen=True)
class BatchSummary:
    """What :func:`run_batch` did (also written as ``summary.json``).

    Attributes
    ----------
    frames, done, skipped : int
    failed : list of dict
        ``{"frame", "input", "error"}`` per failed frame.
    frames_per_s : float
        Frames done per second of wall time from submission to the last result.
    stage_median_s : dict
        Median time of each stage over the frames done, s (``load``,
        ``decompose`` / ``range_points``, ``rpm``, ``das``, ``save``, ``total``:
        one frame inside its worker, worker setup excluded).
    worker_setup_s : list of float
        Time each worker spent creating its OpenCL context and building its
        programs (once per worker process), s.
    workers : int
    device : list of str
    """

    frames: int
    done: int
    skipped: int
    failed: list
    frames_per_s: float
    wall_s: float
    stage_median_s: dict
    worker_setup_s: list
    workers: int
    device: list
    scheduler: str
    method: str
    precision: str
    das_modes: list

    @property
    def exit_code(self) -> int:
        """0 when nothing failed, else 1."""
        return 1 if self.failed else 0


def _outputs(out_dir: str, src: FrameSource, config: BatchConfig) -> list[str]:
    paths = [os.path.join(out_dir, f"{src.name}.npz")]
    if config.das_grid is not None:
        paths.append(os.path.join(out_dir, f"{src.name}_das.npz"))
    return paths


def prepare_output(out_dir, sources: list[FrameSource]) -> str:
    """Check (and create, one level) the output folder before any work.

    Raises
    ------
    InputError
        Its parent is missing, it is a file or not writable, or it holds the
        inputs (results would be taken for frames on the next run).
    """
    out_dir = os.fspath(out_dir)
    if os.path.exists(out_dir) and not os.path.isdir(out_dir):
        raise InputError(f"{out_dir}: output exists and is not a folder")
    if not os.path.isdir(out_dir):
        parent = os.path.dirname(os.path.abspath(out_dir))
        if not os.path.isdir(parent):
            raise InputError(f"{out_dir}: its parent folder {parent} does not exist")
        try:
            os.mkdir(out_dir)
        except OSError as exc:
            raise InputError(f"{out_dir}: cannot create ({exc.strerror})") from None
    if not os.access(out_dir, os.W_OK | os.X_OK):
        raise InputError(f"{out_dir}: output folder is not writable")
    for s in sources:
        if os.path.samefile(os.path.dirname(os.path.abspath(s.path)), out_dir):
            raise InputError(f"{out_dir}: the output folder holds the inputs; choose another")
    return out_dir


def _connect(workers: int, scheduler: str | None):
    """(client, cluster or None): the embedded LocalCluster or an existing scheduler."""
    from distributed import Client, LocalCluster

    if scheduler is None:
        import signal
        import threading

        # the worker processes start with SIGINT ignored (an ignored signal
        # stays ignored across exec, and Python then leaves it so): a
        # terminal's Ctrl-C reaches the whole process group, and the driver,
        # not each worker, ends the batch (workers caught in their start-up
        # printed tracebacks).  The driver ignores it only while the cluster
        # starts.
        main = threading.current_thread() is threading.main_thread()
        old = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
        try:
            with warnings.catch_warnings():  # "Port 8787 is already in use": another port is taken
                warnings.filterwarnings("ignore", message="Port .* is already in use")
                cluster = LocalCluster(
                    n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
                )
        finally:
            if main:
                signal.signal(signal.SIGINT, old)
        return Client(cluster), cluster
    try:
        return Client(scheduler, timeout="10s"), None
    except (OSError, ValueError, TypeError) as exc:
        line = str(exc).strip().splitlines()
        raise InputError(
            f"cannot connect to the Dask scheduler {scheduler!r}{': ' + line[0] if line else ''}"
        ) from None


def _median_stages(records: list[dict]) -> dict:
    stages: dict[str, list] = {}
    for r in records:
        for k, v in r["timings"].items():
            stages.setdefault(k, []).append(v)
    return {k: float(np.median(v)) for k, v in stages.items()}


def run_batch(
    source,
    out_dir,
    config: BatchConfig = BatchConfig(),
    workers: int = 1,
    scheduler: str | None = None,
    client=None,
    progress=None,
) -> BatchSummary:
    """Image every frame of ``source`` into ``out_dir`` on a Dask cluster.

    Parameters
    ----------
    source : str or path-like
        Folder of frames or an HDF5 stack (see :func:`frame_sources`).
    out_dir : str or path-like
        Output folder (created if its parent exists).
    config : BatchConfig
    workers : int
        Worker processes of the embedded ``LocalCluster`` (one thread each).
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://host:port``) instead;
        its workers need rpm-cl installed.
    client : distributed.Client, optional
        An existing client instead of both (kept open).
    progress : callable, optional
        Called with each frame's record as it completes.

    Returns
    -------
    BatchSummary
        Also written atomically to ``out_dir/summary.json``.
    """
    import json

    from distributed import as_completed

    from ..io.data import atomic_write_text

    if workers < 1:
        raise InputError(f"workers must be >= 1, got {workers}")
    sources = frame_sources(source)
    out_dir = prepare_output(out_dir, sources)
    todo = [s for s in sources if not all(os.path.isfile(p) for p in _outputs(out_dir, s, config))]
    skipped = len(sources) - len(todo)
    _clear_markers(out_dir, sources)  # a run stopped while a limit's report was on its way
    cluster = None
    own = client is None and bool(todo)  # nothing to do: no cluster started
    if own:
        client, cluster = _connect(workers, scheduler)
    records, n_workers, address, wall = [], 0, None, 0.0
    try:
        if todo:
            n_workers = len(client.scheduler_info().get("workers", {}))
            address = client.scheduler.address
            t0 = time.perf_counter()
            client.register_plugin(
                _WorkerEngine(
                    config.device,
                    config.precision,
                    config.das_grid is not None,
                    config.memory_budget,
                    config.das_reuse,
                ),
                name=PLUGIN_NAME,
            )
            futures = client.map(
                _image_frame, todo, out_dir=out_dir, config=config, pure=False, retries=1
            )
            by_key = {f.key: s for f, s in zip(futures, todo)}
            pending = as_completed(futures)
            del futures
            for fut in pending:
                try:
                    rec = fut.result()
                except Exception as exc:  # noqa: BLE001 - e.g. KilledWorker: recorded
                    s = by_key[fut.key]
                    reason = _limit_failure(out_dir, s, config)
                    rec = {
                        "frame": s.name,
                        "input": s.path,
                        "index": s.frame,
                        "status": "failed",
                        "error": reason or _error_line(exc),
                    }
                # released at once: a result left on a worker that a limit then kills
                # would be computed again
                fut.release()
                records.append(rec)
                if progress is not None:
                    progress(rec)
            wall = time.perf_counter() - t0
            if cluster is None:  # a cluster not ours: free the workers' OpenCL state
                client.unregister_worker_plugin(PLUGIN_NAME)
    finally:
        if own:
            client.close()
            if cluster is not None:
                cluster.close()
    _clear_markers(out_dir, todo)  # the limits' reports, read into the records
    done = [r for r in records if r["status"] == "done"]
    failed = sorted(
        ({k: r[k] for k in ("frame", "input", "error")} for r in records if r["status"] != "done"),
        key=lambda r: r["frame"],
    )
    summary = BatchSummary(
        frames=len(sources),
        done=len(done),
        skipped=skipped,
        failed=failed,
        frames_per_s=len(done) / wall if done and wall > 0 else 0.0,
        wall_s=wall,
        stage_median_s=_median_stages(done),
        worker_setup_s=[r["setup_s"] for r in records if r.get("setup_s")],
        workers=n_workers,
        device=sorted({r["device"] for r in records if "device" in r}),
        scheduler=address,
        method=config.method,
        precision=config.precision,
        das_modes=sorted({r["das_mode"] for r in done if "das_mode" in r}),
    )
    atomic_write_text(
        os.path.join(out_dir, "summary.json"), json.dumps(asdict(summary), indent=2) + "\n"
    )
    return summary
