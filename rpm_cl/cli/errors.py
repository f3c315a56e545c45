"""How ``rpm-cl`` reports what ends a command: :class:`CLIError` (a user
error, one line and exit code 2), SIGTERM and Ctrl-C (one line, exit codes
143 and 130), a :class:`rpm_cl.io.data.DataWarning` as one line, and the
inputs' headers named after a MemoryError.  Also the check run before every
command that no output overwrites an input.
"""

from __future__ import annotations

import logging
import sys

log = logging.getLogger("rpm_cl")


class CLIError(Exception):
    """A user error: printed as one line, exit code 2."""


class _Terminated(BaseException):
    """SIGTERM, raised in the main thread so that every ``finally`` and the
    atomic writers' clean-up run as for Ctrl-C (temporary files removed)."""


def _on_sigterm(signum, frame):
    raise _Terminated()


def _show_warning(shown):
    """A ``warnings.showwarning`` that prints a :class:`rpm_cl.io.data.DataWarning`
    as one line ``rpm-cl: warning: ...`` through the ``rpm_cl`` logger (so
    ``-q`` silences it) and hands every other warning to ``shown``."""
    from ..io.data import DataWarning

    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, DataWarning):
            log.warning("warning: %s", " ".join(str(message).split()))
        else:
            shown(message, category, filename, lineno, file, line)

    return show


#: Arguments that name files a command reads, and files it writes.
_READS = ("input", "inputs", "background", "config", "sidecar")
_WRITES = ("output", "png", "json")


def _refuse_overwriting_inputs(args) -> None:
    """No command writes over a file it reads (the same path, or the same
    file through a link): one error line, before anything is computed."""
    from ..io.data import refuse_overwrite

    reads = []
    for name in _READS:
        v = getattr(args, name, None)
        reads += [v] if isinstance(v, str) else list(v or [])
    for name in _WRITES:
        v = getattr(args, name, None)
        if isinstance(v, str):
            refuse_overwrite(v, reads)


def _declared_too_large(args) -> str | None:
    """After a MemoryError: a member of an ``.npz`` or HDF5 file the command
    reads whose header declares more than the file holds for it
    (:func:`rpm_cl.io.formats.check_members`), as one line; None where there is
    none (the problem is too large)."""
    from ..io.data import InputError
    from ..io.formats import check_members

    for name in _READS:
        v = getattr(args, name, None)
        for path in [v] if isinstance(v, str) else list(v or []):
            try:
                check_members(path, budget=False)
            except InputError as exc:
                return str(exc)
            except Exception:  # noqa: BLE001, S110 - unreadable: the plain out-of-memory line
                pass
    return None


def _user_error(exc: Exception) -> bool:
    """Whether ``exc`` is an error of the user's input (printed as one line)."""
    from ..cl import NoOpenCLError
    from ..io.data import InputError

    return isinstance(exc, (CLIError, InputError, NoOpenCLError))


_SIGINT_SEEN = []


#: Seconds after which a SIGINT that landed in a finalizer is delivered again.
SIGINT_RETRY_S = 0.05
#: Most times in a row a SIGINT is put off because it landed in a finalizer;
#: then it is raised there all the same (a finalizer that hangs stays
#: interruptible).
SIGINT_RETRIES = 20
_SIGINT_PUT_OFF = [0]


def _in_finalizer(frame) -> bool:
    """Whether ``frame`` or a caller is an object's ``__del__``."""
    while frame is not None:
        if frame.f_code.co_name == "__del__":
            return True
        frame = frame.f_back
    return False


def _interrupt_again(signum) -> None:
    """Deliver ``signum`` to the main thread again, if :func:`_on_sigint`
    still handles it (not after :func:`_release_signals`)."""
    import _thread
    import signal

    if signal.getsignal(signum) is _on_sigint:
        _thread.interrupt_main(signum)


def _on_sigint(signum, frame):
    """SIGINT on the command line: KeyboardInterrupt, remembered (an import
    interrupted inside a C extension can turn it into an ImportError).

    An exception raised in a finalizer (``__del__``, e.g. a progress bar
    collected while it runs) cannot leave it: Python prints it with its
    traceback as "Exception ignored" and goes on.  There the signal is
    delivered again :data:`SIGINT_RETRY_S` later instead, when the finalizer
    has returned, at most :data:`SIGINT_RETRIES` times in a row."""
    if _in_finalizer(frame) and _SIGINT_PUT_OFF[0] < SIGINT_RETRIES:
        import threading

        t = threading.Timer(SIGINT_RETRY_S, _interrupt_again, (signum,))
        t.daemon = True
        try:
            t.start()
        except RuntimeError:  # no new thread at interpreter shutdown
            pass
        else:
            _SIGINT_PUT_OFF[0] += 1
            return
    _SIGINT_PUT_OFF[0] = 0
    _SIGINT_SEEN.append(True)
    raise KeyboardInterrupt


def _end_interrupted(argv_given: bool) -> int:
    print("rpm-cl: interrupted", file=sys.stderr)
    if argv_given:
        return 130
    # the command line: end here.  An interrupt that lands in code run by
    # exec() (SciPy's and NumPy's imports use it) marks the interpreter as
    # killed by SIGINT however it is caught, and Python would then exit by
    # SIGINT after this line; the handlers have cleaned up by now.
    import os

    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(130)


def _catch_signals(argv_given: bool) -> tuple:
    """Install :func:`_on_sigterm` and :func:`_on_sigint` where they apply;
    ``(term, sigint)``: whether each was installed (see :func:`_release_signals`)."""
    import signal
    import threading

    # only where SIGTERM would kill us anyway (not when a supervisor set it
    # to be ignored, nor over a handler of the embedding program)
    term = (
        threading.current_thread() is threading.main_thread()
        and signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
    )
    if term:
        signal.signal(signal.SIGTERM, _on_sigterm)
    sigint = (
        not argv_given
        and threading.current_thread() is threading.main_thread()
        and signal.getsignal(signal.SIGINT) is signal.default_int_handler
    )
    _SIGINT_SEEN.clear()  # a call's own interrupts only
    if sigint:
        signal.signal(signal.SIGINT, _on_sigint)
    return term, sigint


def _release_signals(term: bool, sigint: bool) -> None:
    """Put back the default handlers that :func:`_catch_signals` replaced."""
    import signal

    if term:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if sigint:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def _error_exit(exc: Exception, argv_given: bool) -> int | None:
    """The exit code of an exception a command raised, after its one line on
    stderr; None for a programming error (raised on, with its traceback)."""
    if _SIGINT_SEEN:  # an interrupted import's ImportError, and the like
        return _end_interrupted(argv_given)
    if _user_error(exc):  # one line, whatever a library put in the message
        print(f"rpm-cl: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    if type(exc).__module__.startswith("pyopencl"):  # not the user's input
        print(
            f"rpm-cl: error: OpenCL: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}",
            file=sys.stderr,
        )
        return 2
    return None
