"""The ``rpm-cl`` console script and ``python -m rpm_cl``.

Ctrl-C ends the command with one line (exit 130) from the first statement
of :func:`run`, before :mod:`rpm_cl.cli` is even imported (its import takes
some 50 ms) until :func:`rpm_cl.cli.main` replaces the handler with its own,
which cleans up, and puts it back on return.  Only Python's start-up and the
import of this small module lie before.
"""

import os
import signal

__all__ = ["run"]


def _interrupted(signum, frame):
    os.write(2, b"rpm-cl: interrupted\n")
    os._exit(130)


def run() -> int:
    """Run :func:`rpm_cl.cli.main` on ``sys.argv``; its exit code.  A SIGINT
    the caller ignores (a background job) stays ignored."""
    early = signal.getsignal(signal.SIGINT) is signal.default_int_handler
    if early:  # main() replaces it with its own and puts it back on return
        signal.signal(signal.SIGINT, _interrupted)
    from .cli.commands import main

    code = main()
    if early:  # done: a Ctrl-C during the interpreter's shutdown changes nothing
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    return code
