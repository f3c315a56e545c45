"""Per-frame limits of a batch worker, enforced from a separate process.

A batch worker (:mod:`rpm_cl.cli.batch`) starts one watchdog process beside it
(:class:`Watchdog`), then arms it at the start of each frame with the frame's
wall-time and memory limits and disarms it at the end.  The watchdog polls the
worker's resident memory (RSS, every :data:`POLL_S`) and the clock; when an
armed frame exceeds either limit it writes the one-line reason to the frame's
marker file and kills the worker process.  The Dask nanny restarts the worker,
the scheduler resubmits the frame, and the frame's task finds the marker and
reports the frame failed with that reason instead of running it again.

Being a process of its own, the watchdog acts even while the worker is stuck
in C code that holds the GIL or in an OpenCL call.  It measures RSS rather
than capping address space (``RLIMIT_AS``): PoCL and LLVM reserve far more
virtual memory than they use (a batch worker after one frame: 0.85 GB virtual,
0.25 GB resident), and a capped reservation fails inside the OpenCL runtime
instead of stopping the frame with a reason.

This module is also the watchdog's program (``python watchdog.py PID``): it
imports only the standard library and :mod:`psutil` (a dependency of
``distributed``), so that the process stays small and starts quickly.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import threading
import time

__all__ = [
    "DEFAULT_FRAME_MEMORY_FRACTION",
    "DEFAULT_FRAME_TIMEOUT",
    "POLL_S",
    "Watchdog",
    "limit_reason",
    "main",
]

#: Default wall-time limit of one frame, s: far above any sound frame's
#: (tens of ms to seconds), low enough that a stuck one costs an hour at most.
DEFAULT_FRAME_TIMEOUT = 3600.0
#: Default memory limit of one frame, as a fraction of its worker's Dask
#: ``memory_limit`` (the embedded cluster: the machine's RAM shared equally
#: among the workers; without one, the machine's RAM): below Dask's own
#: ``terminate`` fraction (0.95), which kills without saying why.
DEFAULT_FRAME_MEMORY_FRACTION = 0.8
#: Seconds between two looks at the worker's clock and memory.
POLL_S = 0.05


def _fmt_seconds(s: float) -> str:
    return f"{s:g} s"


def _fmt_bytes(n: float) -> str:
    for unit, size in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n:.0f} B"


def limit_reason(kind: str, limit: float, seen: float | None = None) -> str:
    """The one line that reports a frame stopped by a limit.

    Parameters
    ----------
    kind : {"time", "memory"}
    limit : float
        The limit, s (time) or bytes (memory).
    seen : float, optional
        The worker's resident memory when it was stopped, bytes.
    """
    if kind == "time":
        return f"exceeded the {_fmt_seconds(limit)} per-frame time limit (--frame-timeout)"
    extra = "" if seen is None else f"; worker resident memory {_fmt_bytes(seen)}"
    return f"exceeded the {_fmt_bytes(limit)} per-frame memory limit (--frame-memory{extra})"


class Watchdog:
    """The worker's side: starts the watchdog process and arms it per frame.

    Parameters
    ----------
    pid : int, optional
        The process to watch and kill; default this one.
    """

    def __init__(self, pid: int | None = None):
        from importlib.resources import as_file, files

        self.pid = os.getpid() if pid is None else int(pid)
        with as_file(files("rpm_cl.cli").joinpath("watchdog.py")) as script:
            self._proc = subprocess.Popen(
                [sys.executable, "-I", str(script), str(self.pid)],
                stdin=subprocess.PIPE,
                close_fds=True,
            )

    def _send(self, line: str) -> None:
        self._proc.stdin.write(line.encode() + b"\n")
        self._proc.stdin.flush()

    def arm(self, marker: str, timeout_s: float, memory_bytes: float) -> None:
        """Watch one frame from now.

        Parameters
        ----------
        marker : str
            File that receives the reason (one line) if the frame is stopped.
        timeout_s : float
            Wall-clock limit of the frame, s (``inf``: none).
        memory_bytes : float
            Limit of the worker's resident memory during the frame, bytes
            (``inf``: none).
        """
        self._send(f"arm {float(timeout_s)!r} {float(memory_bytes)!r} {marker}")

    def disarm(self) -> None:
        """The frame is over: stop watching it."""
        self._send("disarm")

    def alive(self) -> bool:
        return self._proc.poll() is None

    def close(self) -> None:
        """End the watchdog process (it also ends by itself when this one does)."""
        try:
            self._proc.stdin.close()
        except OSError:
            pass
        try:
            self._proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self._proc.kill()


# --------------------------------------------------------------------------
# The watchdog process
class _Armed:
    """What the reader thread hands the polling loop, under a lock."""

    def __init__(self):
        self.lock = threading.Lock()
        self.frame = None  # (deadline, limit_s, memory_bytes, marker)
        self.closed = False

    def read(self, stream) -> None:
        for raw in stream:
            words = raw.decode().rstrip("\n").split(" ", 3)
            with self.lock:
                if words[0] == "arm" and len(words) == 4:
                    limit_s, memory = float(words[1]), float(words[2])
                    self.frame = (time.monotonic() + limit_s, limit_s, memory, words[3])
                elif words[0] == "disarm":
                    self.frame = None
        with self.lock:
            self.closed = True


def _stop(proc, marker: str, reason: str) -> None:
    tmp = f"{marker}.tmp"
    with open(tmp, "w", encoding="utf-8") as fh:
        fh.write(reason + "\n")
    os.replace(tmp, marker)
    proc.kill()


def main(argv=None) -> int:
    """Watch the process whose id is ``argv[0]`` until its commands end."""
    import psutil

    pid = int((sys.argv[1:] if argv is None else argv)[0])
    try:
        proc = psutil.Process(pid)
    except psutil.NoSuchProcess:
        return 0
    state = _Armed()
    threading.Thread(target=state.read, args=(sys.stdin.buffer,), daemon=True).start()
    while True:
        time.sleep(POLL_S)
        with state.lock:  # held while deciding: a frame disarmed meanwhile is not stopped
            if state.closed:
                return 0
            if state.frame is None:
                continue
            deadline, limit_s, memory, marker = state.frame
            try:
                rss = proc.memory_info().rss if math.isfinite(memory) else 0
                if rss > memory:
                    _stop(proc, marker, limit_reason("memory", memory, rss))
                elif time.monotonic() > deadline:
                    _stop(proc, marker, limit_reason("time", limit_s))
                else:
                    continue
            except psutil.NoSuchProcess:
                pass
            return 0


if __name__ == "__main__":
    # os._exit: the reader thread may be blocked in stdin, which a normal exit waits for
    os._exit(main())
