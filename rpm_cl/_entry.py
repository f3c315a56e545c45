"""The ``rpm-cl`` console script and ``python -m rpm_cl``.

Ctrl-C and SIGTERM end the command with one line (exit 130, 143) from the
first statement of :func:`run`, before :mod:`rpm_cl.cli` is even imported (its import takes
some 50 ms) until :func:`rpm_cl.cli.main` replaces the handlers with its
own, which clean up, and puts them back on return.  Only Python's start-up and the
import of this small module lie before.
"""

import os
import signal

__all__ = ["run"]


def _end(line: bytes, code: int):
    """Write ``line`` to stderr and end the process with ``code`` at once:
    SIGINT and SIGTERM ignored from here (through ``_signal``, without a
    Python frame that a second signal could interrupt), what the command
    printed flushed, the interpreter's finalisation skipped (see
    :func:`rpm_cl.cli.errors._end_now`)."""
    import _signal
    import sys

    for name in ("SIGINT", "SIGTERM"):
        _signal.signal(getattr(_signal, name), _signal.SIG_IGN)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:  # noqa: BLE001, S110 - a closed or broken pipe: nothing to keep
            pass
    os.write(2, line)
    os._exit(code)


def _interrupted(signum, frame):
    _end(b"rpm-cl: interrupted\n", 130)


def _terminated(signum, frame):
    _end(b"rpm-cl: terminated\n", 143)


def run() -> int:
    """Run :func:`rpm_cl.cli.main` on ``sys.argv``; its exit code.  A SIGINT
    the caller ignores (a background job) stays ignored, and so does a
    SIGTERM a supervisor ignores or handles."""
    early = signal.getsignal(signal.SIGINT) is signal.default_int_handler
    term = signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
    # main() replaces these with its own and puts them back on return
    if early:
        signal.signal(signal.SIGINT, _interrupted)
    if term:
        signal.signal(signal.SIGTERM, _terminated)
    from .cli.commands import main

    try:
        code = main()
    except KeyboardInterrupt:  # a signal landed in main()'s own clean-up
        _end(b"rpm-cl: interrupted\n", 130)
    except BaseException as exc:
        if type(exc).__name__ != "_Terminated":  # rpm_cl.cli.errors' SIGTERM
            raise
        _end(b"rpm-cl: terminated\n", 143)
    # done: a Ctrl-C during the interpreter's shutdown changes nothing
    if early:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    return code
