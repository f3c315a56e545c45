"""Ending the ``rpm-cl`` process at once, with one line: shared by the
console script's start-up handlers (:mod:`rpm_cl._entry`) and the command's
own (:mod:`rpm_cl.cli.errors`).  Imports nothing heavy."""

import os
import sys

__all__ = ["end_process"]


def end_process(line: str, code: int):
    """Write ``line`` to stderr and end the process with ``code``: SIGINT and
    SIGTERM ignored from here (through ``_signal``, without a Python frame
    that a second signal could interrupt), what the command printed flushed,
    and the interpreter's finalisation skipped.  Skipped because a signal's
    exception can leave an object half built (one of pyopencl's cache
    dictionaries cut off in its ``__init__``), whose finalizer would print a
    traceback at exit, and because an interrupt that lands in code run by
    exec() (SciPy's and NumPy's imports use it) marks the interpreter as
    killed by SIGINT however it is caught, so that Python would exit by
    SIGINT after the line."""
    import _signal

    for name in ("SIGINT", "SIGTERM"):
        _signal.signal(getattr(_signal, name), _signal.SIG_IGN)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:  # noqa: BLE001, S110 - a closed or broken pipe: nothing to keep
            pass
    os.write(2, (line + "\n").encode())
    os._exit(code)
