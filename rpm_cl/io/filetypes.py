"""File types by extension: the extensions of radar data, image results and
DAS images, the check of an output path against them (:func:`check_output`),
and h5py, imported where HDF5 is read or written."""

from __future__ import annotations

import os

from .atomic import output_path
from .checks import InputError

#: Input / radar-data extensions.
DATA_EXTENSIONS = (".npz", ".h5", ".hdf5")
#: Image-result extensions of :func:`rpm_cl.io.formats.save_result`.
RESULT_EXTENSIONS = (".npz", ".h5", ".hdf5", ".ply", ".vtp")
#: DAS image extensions of :func:`rpm_cl.io.volumes.write_volume`.
VOLUME_EXTENSIONS = (".npz", ".h5", ".hdf5", ".vti")


_H5_EXT = (".h5", ".hdf5")


def _ext(path: str) -> str:
    return os.path.splitext(path)[1].lower()


def _need_ext(path: str, allowed: tuple, what: str) -> str:
    ext = _ext(path)
    if ext not in allowed:
        raise InputError(
            f"{path}: unknown {what} extension {ext or '(none)'!r}; supported: {', '.join(allowed)}"
        )
    return ext


def check_output(path, extensions: tuple, what: str = "output") -> str:
    """Check an output path before anything is computed: a known extension
    (one of ``extensions``) and an existing folder.

    Returns
    -------
    str
        The extension, lower case.

    Raises
    ------
    InputError
        Unknown extension (the message lists ``extensions``), missing folder,
        or ``path`` is a folder.
    """
    path, _ = output_path(path)  # a missing folder or a folder first: the plainer message
    return _need_ext(path, tuple(extensions), what)


def _h5py():
    try:
        import h5py
    except ImportError:  # a core dependency; only a broken install lands here
        raise InputError("HDF5 files need h5py: pip install h5py") from None
    return h5py
