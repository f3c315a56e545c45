"""Output files: the check of an output path (:func:`output_path`), writes
through a temporary file beside the target renamed over it
(:func:`_atomic_file`, :func:`atomic_savez`, :func:`atomic_write_text`), and
the refusal to write over an input (:func:`refuse_overwrite`)."""

from __future__ import annotations

import os
import tempfile

import numpy as np

from .checks import InputError


def _usual_mode(path) -> None:
    """Give a temporary file (mkstemp: 0600) the mode a plain open() would."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(path, 0o666 & ~umask)


def temp_prefix(path) -> str:
    """Prefix of the temporary files written on the way to ``path``
    (``.tmp-<name>-``): hidden, and telling whose they are."""
    return f".tmp-{os.path.basename(os.fspath(path))}-"


def output_path(path):
    """Check an output path before anything is computed or written.

    Returns
    -------
    path : str
    folder : str
        Its (existing) folder, where temporary files go.

    Raises
    ------
    InputError
        The folder does not exist, or ``path`` is a folder.
    """
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise InputError(f"{path}: output folder {folder} does not exist")
    if os.path.isdir(path):
        raise InputError(f"{path}: is a folder, not a file")
    return path, folder


def _atomic_file(path, write, ext: str | None = None) -> None:
    """Call ``write(tmp_path)`` on a temporary file beside ``path``, then
    rename it over ``path``.

    An interrupted run never leaves a half-written ``path`` (nor the
    temporary file) behind.

    Raises
    ------
    InputError
        The folder does not exist or cannot be written.
    """
    path, folder = output_path(path)
    try:
        fd, tmp = tempfile.mkstemp(
            prefix=temp_prefix(path), suffix=ext or os.path.splitext(path)[1], dir=folder
        )
    except OSError as exc:
        raise InputError(f"{path}: cannot write ({exc.strerror})") from None
    os.close(fd)
    try:
        write(tmp)
        _usual_mode(tmp)
        os.replace(tmp, path)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError):
            text = exc.strerror or " ".join(str(exc).split())
            raise InputError(f"{path}: cannot write ({type(exc).__name__}: {text})") from None
        raise


def _atomic_write(path, write) -> None:
    """Call ``write(fh)`` on a binary file handle, atomically (see
    :func:`_atomic_file`)."""

    def to_file(tmp):
        with open(tmp, "wb") as fh:
            write(fh)

    _atomic_file(path, to_file)


def atomic_savez(path, **arrays) -> None:
    """Write an ``.npz`` atomically (see :func:`_atomic_write`)."""
    _atomic_write(path, lambda fh: np.savez(fh, **arrays))


def atomic_write_text(path, text: str) -> None:
    """Write a UTF-8 text file atomically (see :func:`_atomic_write`)."""
    _atomic_write(path, lambda fh: fh.write(text.encode("utf-8")))


def refuse_overwrite(path, inputs) -> None:
    """Raise :class:`InputError` when ``path`` is (or links to) one of ``inputs``
    (a command never writes over what it reads)."""
    out = os.path.realpath(os.fspath(path))
    for p in inputs:
        p = os.fspath(p)
        same = os.path.realpath(p) == out
        if not same and os.path.exists(path) and os.path.exists(p):
            same = os.path.samefile(p, path)
        if same:
            raise InputError(f"{path}: is also an input ({p}); write the output elsewhere")
