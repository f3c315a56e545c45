"""The ``rpm-cl`` console script and ``python -m rpm_cl``.

Ctrl-C and SIGTERM end the command with one line (exit 130, 143) from the
first statement of :func:`run`, before :mod:`rpm_cl.cli` is even imported
(its import takes some 50 ms), until :func:`rpm_cl.cli.main` replaces the
handlers with its own, which clean up, and puts them back on return.  Only
Python's start-up and the import of this small module lie before.
"""

import signal

from .ending import end_process

__all__ = ["run"]


def _interrupted(signum, frame):
    end_process("rpm-cl: interrupted", 130)


def _terminated(signum, frame):
    end_process("rpm-cl: terminated", 143)


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
        _interrupted(None, None)
    except BaseException as exc:
        if type(exc).__name__ != "_Terminated":  # rpm_cl.cli.errors' SIGTERM
            raise
        _terminated(None, None)
    # done: a Ctrl-C during the interpreter's shutdown changes nothing
    if early:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    return code
