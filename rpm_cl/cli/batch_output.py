"""The output folder of a batch (``rpm-cl batch``): checked and created
before any work, each frame's outputs (their presence marks it done), the
markers a frame limit leaves, and the summary (:class:`BatchSummary`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ..io.data import InputError
from .batch_config import BatchConfig
from .batch_frames import FrameSource


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


def _median_stages(records: list[dict]) -> dict:
    stages: dict[str, list] = {}
    for r in records:
        for k, v in r["timings"].items():
            stages.setdefault(k, []).append(v)
    return {k: float(np.median(v)) for k, v in stages.items()}


def _summarise(
    sources: list, skipped: int, records: list, workers: int, scheduler, wall: float, config
) -> BatchSummary:
    """The :class:`BatchSummary` of a batch from its frames' records."""
    done = [r for r in records if r["status"] == "done"]
    failed = sorted(
        ({k: r[k] for k in ("frame", "input", "error")} for r in records if r["status"] != "done"),
        key=lambda r: r["frame"],
    )
    return BatchSummary(
        frames=len(sources),
        done=len(done),
        skipped=skipped,
        failed=failed,
        frames_per_s=len(done) / wall if done and wall > 0 else 0.0,
        wall_s=wall,
        stage_median_s=_median_stages(done),
        worker_setup_s=[r["setup_s"] for r in records if r.get("setup_s")],
        workers=workers,
        device=sorted({r["device"] for r in records if "device" in r}),
        scheduler=scheduler,
        method=config.method,
        precision=config.precision,
        das_modes=sorted({r["das_mode"] for r in done if "das_mode" in r}),
    )
