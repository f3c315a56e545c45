"""How ``rpm-cl`` reports what ends a command: :class:`CLIError` (a user
error, one line and exit code 2), SIGTERM and Ctrl-C (one line, exit codes
143 and 130), a :class:`rpm_cl.io.data.DataWarning` as one line, and the
inputs' headers named after a MemoryError.  Also the check run before every
command that no output overwrites an input.
"""

from __future__ import annotations

import logging
import sys

from ..ending import end_process

log = logging.getLogger("rpm_cl")


class CLIError(Exception):
    """A user error: printed as one line, exit code 2."""


class _Terminated(BaseException):
    """SIGTERM, raised in the main thread so that every ``finally`` and the
    atomic writers' clean-up run as for Ctrl-C (temporary files removed)."""


def _on_sigterm(signum, frame):
    """SIGTERM on the command line: :class:`_Terminated`, as :func:`_on_sigint`."""
    _SIGNALS_SEEN.append(signum)
    if _in_finalizer(frame) and _deliver_again(_Terminated):
        return
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


#: The signals a handler of :func:`_catch_signals` has raised for, in order:
#: an import interrupted inside a C extension can turn the exception into
#: an ImportError, which is then told by this.
_SIGNALS_SEEN = []


#: Seconds after which a signal whose exception could not leave where it
#: landed is delivered again.
SIGNAL_RETRY_S = 0.05
#: Most times a signal is delivered again in one command (each time it lands
#: where its exception cannot leave); then the exception is reported as
#: Python would.
SIGNAL_RETRIES = 20
_REDELIVERED = [0]


def _interrupt_again(signum) -> None:
    """Deliver ``signum`` to the main thread again, if a handler of
    :func:`_catch_signals` still handles it (not after :func:`_release_signals`)."""
    import _thread
    import signal

    if signal.getsignal(signum) in (_on_sigint, _on_sigterm):
        _thread.interrupt_main(signum)


def _deliver_again(exc_type) -> bool:
    """Whether ``exc_type`` is the exception of one of the handlers of
    :func:`_catch_signals` (KeyboardInterrupt, :class:`_Terminated`) and its
    signal will be delivered again :data:`SIGNAL_RETRY_S` later."""
    import signal
    import threading

    if issubclass(exc_type, KeyboardInterrupt):
        signum = signal.SIGINT
    elif issubclass(exc_type, _Terminated):
        signum = signal.SIGTERM
    else:
        return False
    if signum not in _SIGNALS_SEEN or _REDELIVERED[0] >= SIGNAL_RETRIES:
        return False
    t = threading.Timer(SIGNAL_RETRY_S, _interrupt_again, (signum,))
    t.daemon = True
    try:
        t.start()
    except RuntimeError:  # no new thread at interpreter shutdown
        return False
    _REDELIVERED[0] += 1
    return True


def _unraisable_hook(shown):
    """A ``sys.unraisablehook`` for where a handler's exception cannot
    leave: a finalizer (``__del__``, e.g. a progress bar collected as Ctrl-C
    lands), a weakref callback (importlib's module locks), a generator
    closed by the garbage collector.  Python would print it with a traceback
    as "Exception ignored" and go on; the signal is delivered again instead,
    once that code has returned.  Anything else goes to ``shown``."""

    def hook(unraisable):
        if not _deliver_again(unraisable.exc_type):
            shown(unraisable)

    return hook


def _except_hook(shown):
    """A ``sys.excepthook`` for a handler's exception that a C extension
    prints itself (``PyErr_Print``, e.g. NumPy's ``import_array`` in another
    extension's initialisation, which then raises ImportError): not printed,
    and the signal delivered again in case the extension goes on.  Main()
    catches every exception of its own, so nothing else reaches this but
    what goes to ``shown``."""

    def hook(exc_type, value, tb):
        if not _deliver_again(exc_type):
            shown(exc_type, value, tb)

    return hook


def _in_finalizer(frame) -> bool:
    """Whether ``frame`` or a caller is an object's ``__del__``."""
    while frame is not None:
        if frame.f_code.co_name == "__del__":
            return True
        frame = frame.f_back
    return False


def _on_sigint(signum, frame):
    """SIGINT on the command line: KeyboardInterrupt, remembered in
    :data:`_SIGNALS_SEEN`.  In a finalizer (``__del__``), where it could not
    leave, it is not raised but delivered again once the finalizer has had
    :data:`SIGNAL_RETRY_S` to finish its clean-up; wherever else it cannot
    leave, the hooks of :func:`_catch_signals` deliver it again."""
    _SIGNALS_SEEN.append(signum)
    if _in_finalizer(frame) and _deliver_again(KeyboardInterrupt):
        return
    raise KeyboardInterrupt


def _end_signalled(argv_given: bool) -> int:
    """The end of a command that a handler's signal interrupted, whatever
    exception it became: :func:`_end_terminated` or :func:`_end_interrupted`."""
    import signal

    if _SIGNALS_SEEN[0] == signal.SIGTERM:
        return _end_terminated(argv_given)
    return _end_interrupted(argv_given)


def _end_terminated(argv_given: bool) -> int:
    """Print "rpm-cl: terminated"; exit code 143 (on the command line: ends
    the process)."""
    return _end_now("rpm-cl: terminated", 143, argv_given)


def _end_interrupted(argv_given: bool) -> int:
    """Print "rpm-cl: interrupted"; exit code 130 (on the command line: ends
    the process)."""
    return _end_now("rpm-cl: interrupted", 130, argv_given)


def _end_now(line: str, code: int, argv_given: bool) -> int:
    """``line`` on stderr; ``code`` for a call with ``argv``.  The command
    line ends here, the handlers having cleaned up by now
    (:func:`rpm_cl.ending.end_process`)."""
    if argv_given:
        print(line, file=sys.stderr)
        return code
    end_process(line, code)


def _catch_signals(argv_given: bool, held: dict) -> None:
    """Install :func:`_on_sigterm` and :func:`_on_sigint` where they apply,
    and with either the hooks :func:`_unraisable_hook` and
    :func:`_except_hook`.  Each handler (signal number -> handler) or hook
    (its ``sys`` attribute name -> hook) replaced is noted in ``held``
    before it is replaced, so that :func:`_release_signals` puts back what
    was installed even when a signal interrupts this."""
    import signal
    import threading

    main_thread = threading.current_thread() is threading.main_thread()
    _SIGNALS_SEEN.clear()  # a call's own signals only
    _REDELIVERED[0] = 0
    hooks = (("unraisablehook", _unraisable_hook), ("excepthook", _except_hook))
    for name, make in hooks if main_thread else ():
        held[name] = getattr(sys, name)
        setattr(sys, name, make(held[name]))

    # the console script's start-up handlers (rpm_cl._entry, a floor above)
    # stay in place until these replace them: no moment without either
    def early(handler) -> bool:
        return getattr(handler, "__module__", None) == "rpm_cl._entry"

    # only where SIGTERM would kill us anyway (not when a supervisor set it
    # to be ignored, nor over a handler of the embedding program)
    before = signal.getsignal(signal.SIGTERM)
    if main_thread and (before is signal.SIG_DFL or early(before)):
        held[signal.SIGTERM] = before
        signal.signal(signal.SIGTERM, _on_sigterm)
    before = signal.getsignal(signal.SIGINT)
    if not argv_given and main_thread and (before is signal.default_int_handler or early(before)):
        held[signal.SIGINT] = before
        signal.signal(signal.SIGINT, _on_sigint)


def _release_signals(held: dict) -> None:
    """Put back the handlers and hooks that :func:`_catch_signals` noted in
    ``held``."""
    import signal

    for key, handler in reversed(held.items()):
        if isinstance(key, str):
            setattr(sys, key, handler)
        else:
            signal.signal(key, handler)


def _error_exit(exc: Exception, argv_given: bool) -> int | None:
    """The exit code of an exception a command raised, after its one line on
    stderr; None for a programming error (raised on, with its traceback)."""
    if _SIGNALS_SEEN:  # an interrupted import's ImportError, and the like
        return _end_signalled(argv_given)
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
