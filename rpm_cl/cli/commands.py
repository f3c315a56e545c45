"""Command line: ``rpm-cl {info,simulate,convert,image,params,das,rma,view,figure,reproduce,
demo,bench,batch}``.

Every error the user can cause (bad input file, bad option, no OpenCL) is
reported as one line ``rpm-cl: error: ...`` on stderr with exit code 2.
Every subcommand takes ``-v/--verbose`` (resolved parameters and stage
timings on stderr, through the ``rpm_cl`` logger) and ``-q/--quiet`` (nothing
but errors); those that image take ``--config FILE.toml`` and a flag per
parameter (:mod:`rpm_cl.cli.config`).

This module holds :func:`main` and :func:`build_parser`, which binds each
subcommand's parser (:mod:`rpm_cl.cli.parser`) to its handler, a ``cmd_*``
function of :mod:`rpm_cl.cli.cmd_data`, :mod:`rpm_cl.cli.cmd_imaging`,
:mod:`rpm_cl.cli.cmd_baselines` or :mod:`rpm_cl.cli.cmd_runs`, looked up
here when the parser is built.  How a command ends (errors, signals,
warnings) is :mod:`rpm_cl.cli.errors`.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import logging
import sys
import warnings

from .cmd_baselines import cmd_das, cmd_rma
from .cmd_data import cmd_convert, cmd_info, cmd_simulate
from .cmd_imaging import cmd_figure, cmd_image, cmd_params, cmd_view
from .cmd_runs import cmd_batch, cmd_bench, cmd_demo, cmd_reproduce
from .common import _load_config
from .errors import (
    _SIGNALS_SEEN,
    CLIError,  # noqa: F401 - importable from here
    _catch_signals,
    _declared_too_large,
    _end_interrupted,
    _end_signalled,
    _end_terminated,
    _error_exit,
    _refuse_overwriting_inputs,
    _release_signals,
    _show_warning,
    _Terminated,
)
from .options import (  # noqa: F401 - importable from here
    common_opts,
    convert_opts,
    medium_opts,
    param_opts,
)
from .parser import _bind_negative_values, build

__all__ = ["main"]

log = logging.getLogger("rpm_cl")


def build_parser() -> argparse.ArgumentParser:
    """The ``rpm-cl`` parser (:func:`rpm_cl.cli.parser.build`), each command's
    ``func`` the ``cmd_*`` handler of this module's namespace."""
    return build(
        {
            "info": cmd_info,
            "simulate": cmd_simulate,
            "convert": cmd_convert,
            "image": cmd_image,
            "params": cmd_params,
            "reproduce": cmd_reproduce,
            "demo": cmd_demo,
            "view": cmd_view,
            "figure": cmd_figure,
            "das": cmd_das,
            "rma": cmd_rma,
            "bench": cmd_bench,
            "batch": cmd_batch,
        }
    )


def _run(args) -> int:
    """Run the handler of parsed ``args``: under ``-q`` with neither progress
    bars nor standard output, DataWarnings as one line, after the check that
    no output overwrites an input and with ``--config`` read."""
    with contextlib.ExitStack() as stack:
        if args.quiet:
            from ..progress import bars_off

            stack.enter_context(bars_off())
            stack.enter_context(contextlib.redirect_stdout(io.StringIO()))
        stack.enter_context(warnings.catch_warnings())
        warnings.showwarning = _show_warning(warnings.showwarning)
        _refuse_overwriting_inputs(args)
        if hasattr(args, "config"):
            _load_config(args)
        return args.func(args)


def main(argv=None) -> int:
    """Entry point of the ``rpm-cl`` command; returns the exit code.

    Ctrl-C (exit 130) and SIGTERM (143) end it with one line from the moment
    it is called: ``rpm_cl`` and this module import nothing heavy, so that
    the NumPy, SciPy and OpenCL imports happen inside its handlers."""
    args = None
    argv_given = argv is not None
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("rpm-cl: %(message)s"))
    held = {}
    try:
        _catch_signals(argv_given, held)
        argv = _bind_negative_values(list(sys.argv[1:] if argv is None else argv))
        args = build_parser().parse_args(argv)
        log.addHandler(handler)
        log.propagate = False
        log.setLevel(
            logging.ERROR if args.quiet else logging.INFO if args.verbose else logging.WARNING
        )
        code = _run(args)
        if _SIGNALS_SEEN:  # a signal's exception that a library caught and dropped
            return _end_signalled(argv_given)
        return code
    except KeyboardInterrupt:
        return _end_interrupted(argv_given)
    except _Terminated:
        return _end_terminated(argv_given)
    except BrokenPipeError:  # output piped into e.g. head: not an error
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except MemoryError:
        if _SIGNALS_SEEN:
            return _end_signalled(argv_given)
        line = _declared_too_large(args) if args is not None else None
        print(
            f"rpm-cl: error: {line or 'out of memory; lower the problem size or the RPM chunk size'}",
            file=sys.stderr,
        )
        return 2
    except Exception as exc:
        code = _error_exit(exc, argv_given)
        if code is None:
            raise
        return code
    finally:
        log.removeHandler(handler)
        _release_signals(held)
