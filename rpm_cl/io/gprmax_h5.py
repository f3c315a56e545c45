"""HDF5 access to gprMax output: only objects stored in the file itself,
reached through hard links (:func:`_get`, :func:`_dataset`), attributes of a
given shape checked before they are read, the positions and the source
waveform a file records."""

from __future__ import annotations

import os

import numpy as np

from .checks import InputError
from .gprmax_waveform import WAVEFORMS, SourceWaveform
from .guard import h5_inside


def _h5py():
    import h5py

    return h5py


def _guarded(path: str, read):
    """``read()``; any failure but an InputError (a truncated dataset, a bad
    filter) becomes one InputError line naming ``path``."""
    from .sources import _guarded as guarded

    return guarded(path, read)


def _open_h5(path: str):
    if not os.path.isfile(path):
        raise InputError(f"{path}: no such file")
    h5py = _h5py()
    try:
        return h5py.File(path, "r")
    except OSError as exc:
        text = " ".join(str(exc).split())
        raise InputError(f"{path}: not a readable HDF5 file ({text})") from None


def _get(f, path: str, what: str):
    """The object at ``path``, reached through hard links only (an external
    link would open another file, a soft link may lead to one)."""
    h5py = _h5py()
    obj = f
    for name in path.strip("/").split("/"):
        if not isinstance(obj, h5py.Group) or name not in obj:
            raise InputError(f"{f.filename}: no {what} ({path!r} is missing)")
        link = obj.get(name, getlink=True)
        if isinstance(link, h5py.ExternalLink):
            raise InputError(
                f"{f.filename}: {path!r} is an external link (to "
                f"{link.filename}); only data stored in the file are read"
            )
        if not isinstance(link, h5py.HardLink):
            raise InputError(
                f"{f.filename}: {path!r} is a soft link; only data stored in the file are read"
            )
        obj = obj[name]
    return obj


def _dataset(f, path: str, what: str):
    """A real, numeric dataset stored in the file (no external raw storage,
    no virtual dataset mapping other files); its data are not read."""
    ds = _get(f, path, what)
    if not isinstance(ds, _h5py().Dataset):
        raise InputError(f"{f.filename}: {path!r} is not a dataset")
    h5_inside(f, ds, f"{f.filename}: {path!r}")
    if ds.dtype.kind not in "fiu":
        raise InputError(f"{f.filename}: {path!r} must hold real numbers, got dtype {ds.dtype}")
    return ds


def _attr(obj, name: str, shape: tuple, what: str) -> np.ndarray:
    """Attribute ``name`` of the given shape (checked before it is read), as float64."""
    if name not in obj.attrs:
        raise InputError(f"{obj.file.filename}: {obj.name} has no {name!r} attribute ({what})")
    got = obj.attrs.get_id(name).shape
    if tuple(got) != shape:
        raise InputError(
            f"{obj.file.filename}: attribute {obj.name}:{name} must have shape "
            f"{shape}, got {tuple(got)}"
        )
    v = np.asarray(obj.attrs[name])
    if v.dtype.kind not in "fiu" or not np.all(np.isfinite(v)):
        raise InputError(f"{obj.file.filename}: attribute {obj.name}:{name} must be finite numbers")
    return v.astype(np.float64)


def _text_attr(obj, name: str) -> str | None:
    if name not in obj.attrs or obj.attrs.get_id(name).shape not in ((), None):
        return None
    v = obj.attrs[name]
    return v.decode("utf-8", "replace") if isinstance(v, bytes) else str(v)


def _position(obj):
    if obj is None or "Position" not in obj.attrs:
        return None
    return _attr(obj, "Position", (3,), "a position")


def _file_waveform(f) -> SourceWaveform | None:
    """The waveform a gprMax 4 trace file records for its one source, if any;
    refuses what the converter cannot model."""
    if "srcs" not in f:
        return None
    src = _get(f, "srcs/src1", "source 1")
    kind = _text_attr(src, "Type")
    if kind is not None and kind != "HertzianDipole":
        raise InputError(
            f"{f.filename}: source 1 is a {kind}; the converter takes a Hertzian "
            f"dipole (line current)"
        )
    if "excitation" not in src:
        return None
    ex = _get(f, "srcs/src1/excitation", "the source excitation")
    start = float(_attr(ex, "SourceStartTime", (), "")) if "SourceStartTime" in ex.attrs else 0.0
    if start != 0:
        raise InputError(
            f"{f.filename}: the source starts at {start:g} s; the converter takes "
            f"sources that start at 0"
        )
    wtype = _text_attr(ex, "WaveformType")
    if wtype is None or "WaveformFrequency" not in ex.attrs:
        return None
    if wtype not in WAVEFORMS:
        raise InputError(
            f"{f.filename}: waveform {wtype!r} cannot be deconvolved; use one of "
            f"{', '.join(WAVEFORMS)}"
        )
    amp = float(_attr(ex, "WaveformAmplitude", (), "")) if "WaveformAmplitude" in ex.attrs else 1.0
    return SourceWaveform(wtype, float(_attr(ex, "WaveformFrequency", (), "")), amp)
