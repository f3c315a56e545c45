"""The frames of a batch input (``rpm-cl batch``): every ``.npz`` / ``.h5``
file of a folder, or one file, each file one frame or, for a stack, one per
leading index.  The one place of the batch that knows file formats.
"""

from __future__ import annotations

import os
from typing import NamedTuple

from ..io.data import InputError

#: File suffixes taken as frames in an input folder.
NPZ_SUFFIXES = (".npz",)
H5_SUFFIXES = (".h5", ".hdf5")


class FrameSource(NamedTuple):
    """One frame: its output name, the file holding it, its index in a stack."""

    name: str
    path: str
    frame: int | None


def _file_sources(path: str) -> list[FrameSource]:
    """The frames of one file: one per leading index of a stack (named
    ``<stem>_f0007``), else one named ``<stem>``.  A file that cannot be read
    is listed as one frame, so that its error is reported with the results
    and the other frames go on."""
    from ..io.formats import frame_count

    stem = os.path.splitext(os.path.basename(path))[0]
    try:
        n = int(frame_count(path))
    except InputError:
        return [FrameSource(stem, path, None)]
    if n == 1:
        return [FrameSource(stem, path, 0)]
    return [FrameSource(f"{stem}_f{i:04d}", path, i) for i in range(n)]


def frame_sources(source) -> list[FrameSource]:
    """Every frame of ``source``, in name order.

    Parameters
    ----------
    source : str or path-like
        A folder (every ``.npz``, ``.h5``, ``.hdf5`` file in it, hidden files
        left out; an HDF5 stack gives one frame per leading index), or one
        such file.

    Raises
    ------
    InputError
        No such folder or file, no frames, or two frames with one output name.
    """
    source = os.fspath(source)
    suffixes = NPZ_SUFFIXES + H5_SUFFIXES
    if os.path.isdir(source):
        files = sorted(
            os.path.join(source, f)
            for f in os.listdir(source)
            if not f.startswith(".")
            and f.lower().endswith(suffixes)
            and os.path.isfile(os.path.join(source, f))
        )
        if not files:
            raise InputError(f"{source}: no .npz or .h5 frames in this folder")
    elif os.path.isfile(source):
        if not source.lower().endswith(suffixes):
            raise InputError(f"{source}: not a folder, .npz or .h5 file")
        files = [source]
    else:
        raise InputError(f"{source}: no such folder or file")
    out = []
    for f in files:
        out.extend(_file_sources(f))
    names = [s.name for s in out]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError(
            f"{source}: several inputs would write the same result "
            f"({', '.join(dup[:3])}); rename them"
        )
    return out
