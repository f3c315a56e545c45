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

This module holds the driver (:func:`run_batch`) and the task run per frame
on a worker (:func:`_image_frame`); the parameter set is
:mod:`rpm_cl.cli.batch_config`, the frames of the input
:mod:`rpm_cl.cli.batch_frames`, the worker's state
:mod:`rpm_cl.cli.batch_worker`, and the output folder and summary
:mod:`rpm_cl.cli.batch_output`.

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
import time
import warnings
from dataclasses import asdict

from ..io.data import DataWarning, InputError, RadarData
from .batch_config import DAS_REUSE, BatchConfig  # noqa: F401 - importable from here
from .batch_frames import (  # noqa: F401 - importable from here
    H5_SUFFIXES,
    NPZ_SUFFIXES,
    FrameSource,
    _file_sources,
    frame_sources,
)
from .batch_output import (  # noqa: F401 - importable from here
    BatchSummary,
    _clear_markers,
    _limit_failure,
    _marker,
    _median_stages,
    _outputs,
    _summarise,
    prepare_output,
)
from .batch_worker import PLUGIN_NAME, _WorkerEngine

__all__ = [
    "PLUGIN_NAME",
    "BatchConfig",
    "BatchSummary",
    "FrameSource",
    "frame_sources",
    "prepare_output",
    "run_batch",
]


def _load_frame(path: str, frame: int | None) -> RadarData:
    """Read one frame (validated; :func:`rpm_cl.io.formats.load_data`)."""
    from ..io.formats import load_data

    return load_data(path, frame=frame)


def _error_line(exc: BaseException) -> str:
    msg = str(exc).strip().splitlines()
    text = msg[0] if msg else ""
    return text if isinstance(exc, InputError) else f"{type(exc).__name__}: {text}".rstrip(": ")


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
            meta = _frame_meta(src, config, env.name, data, params)
            if grid is not None:
                _das_output(
                    engine, das, data, grid, params, meta, out_dir, src, config, timings, rec
                )
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


def _frame_meta(src: FrameSource, config: BatchConfig, device: str, data, params) -> dict:
    """The ``meta`` of a frame's result (and of its DAS image)."""
    from .. import __version__

    meta = {
        "version": __version__,
        "device": device,
        "precision": config.precision,
        "input": src.path,
        "frame": src.frame,
        "params": asdict(params),
    }
    if data.truth is not None and data.truth.scene not in ("", "{}"):
        import json

        meta["scene"] = json.loads(data.truth.scene)
    return meta


def _das_output(engine, das, data, grid, params, meta, out_dir, src, config, timings, rec):
    """Write the DAS image of a frame (``<name>_das.npz``) by the variant its
    worker chose; its ``das`` and ``save`` seconds go into ``timings``, the
    variant into ``rec["das_mode"]``."""
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


def run_batch(
    source,
    out_dir,
    config: BatchConfig = BatchConfig(),  # noqa: B008 - frozen: one shared default is safe
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
            records, n_workers, address, wall = _run_frames(
                client, cluster, todo, out_dir, config, progress
            )
    finally:
        if own:
            client.close()
            if cluster is not None:
                cluster.close()
    _clear_markers(out_dir, todo)  # the limits' reports, read into the records
    summary = _summarise(sources, skipped, records, n_workers, address, wall, config)
    atomic_write_text(
        os.path.join(out_dir, "summary.json"), json.dumps(asdict(summary), indent=2) + "\n"
    )
    return summary


def _run_frames(client, cluster, todo: list, out_dir: str, config: BatchConfig, progress):
    """Image the frames ``todo`` on the workers of ``client`` (``cluster``:
    the embedded one, or None), each record handed to ``progress`` as it
    comes.

    Returns
    -------
    records : list of dict
    workers : int
    scheduler : str
        The scheduler's address.
    wall : float
        Seconds from the submission to the last record.
    """
    from distributed import as_completed

    records = []
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
    futures = client.map(_image_frame, todo, out_dir=out_dir, config=config, pure=False, retries=1)
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
    return records, n_workers, address, wall
