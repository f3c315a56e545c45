"""Recorded arrays -> the input schema by a key mapping.

Reads named arrays from MATLAB ``.mat`` files (v4 to v7.2 through
``scipy.io.loadmat``, v7.3 through h5py), ``.npz`` archives, ``.npy`` files
(the key of each is its file name without ``.npy``) and HDF5 files, and
renames them to the input schema's names (docs/input-format.md, "Input schema")::

    KeyMap.parse("spectrum=F,frequency=f,x=da")

maps the file's ``F`` to ``spectrum``, ``f`` to ``frequency`` and ``da`` to
``x``.  Frequency domain: ``spectrum``, ``frequency``, ``x`` (``z`` for a
planar array; ``fc`` and ``bandwidth`` optional).  Time domain: ``signal``,
``range``, ``fc``, ``bandwidth``, ``x`` (``z``).

Shapes
------
Arrays come out with the shape MATLAB shows (``size(F)``), whichever version
wrote them: a v7.3 file stores every array with its axes reversed (HDF5 is
row-major, MATLAB column-major), and the reader reverses them back.  The
data array (``spectrum`` or ``signal``) must then be ``(nx[, nz], n)`` (or a
stack ``(frames, nx[, nz], n)``); ``transpose=True`` (``--transpose``)
reverses all its axes first, as MATLAB's ``F(nf, nx)`` needs.  Axes
(``x``, ``z``, ``frequency``, ``range``) may be MATLAB row or column vectors
(a ``1 x n`` or ``n x 1`` matrix); ``fc`` and ``bandwidth`` ``1 x 1``.
Complex arrays: MATLAB v7.3 stores them as an HDF5 compound of ``real`` and
``imag``; MATLAB saves an array whose imaginary part is all zero as real,
so a real data array is taken as complex.

Nothing about the sign is changed: the file must hold an echo of range R as
``a exp(-j 4 pi f R / c)``, a profile's carrier phase as ``exp(-j 2 k_c R)``
(``conjugate=True`` takes the conjugate of data recorded as ``exp(+j ...)``).  ``scale_x`` multiplies ``x`` and
``z`` (1e-3 for millimetres), ``scale_f`` ``frequency``, ``fc`` and
``bandwidth`` (1e9 for GHz).

Safety: the shape and type of every array are read from its header (the
``.mat`` variable directory, the ``.npy`` header, the HDF5 dataset) and
checked before its data are; HDF5 external links, soft links, external raw
storage and virtual datasets are refused; MATLAB cells, structs of v4-v7.2
files, strings and sparse matrices are refused.

Where the code lives: :mod:`.mapped_keymap` (:class:`KeyMap`) and
:mod:`.mapped_sources` (the files' arrays, one interface per format); their
names are importable from here too.  This module reads the mapped arrays
from several files (with the size limit :data:`MAX_ELEMENTS`) and checks
them against the schema (:func:`convert`, :func:`list_keys`).
"""

from __future__ import annotations

import math
import os

import numpy as np

from .checks import InputError, _finite_scalar, _uniform_axis, uniform_steps
from .mapped_keymap import DATA_NAMES, SCHEMA_NAMES, KeyMap
from .mapped_sources import MAPPED_EXTENSIONS, _H5Source, _open_source
from .model import Array, Waveform

__all__ = [
    "DATA_NAMES",
    "MAPPED_EXTENSIONS",
    "MAX_ELEMENTS",
    "SCHEMA_NAMES",
    "KeyMap",
    "convert",
    "list_keys",
]

_AXES = ("x", "z", "frequency", "range")
_SCALARS = ("fc", "bandwidth")
#: Most elements read from one array (1 GB of float64).
MAX_ELEMENTS = 1 << 27


class _Sources:
    """The keys of several files; a key held by two of them is refused."""

    def __init__(self, paths):
        from .sources import _guarded

        self.srcs = []
        self.where = {}
        try:
            for p in paths:
                src = _guarded(p, lambda p=p: _open_source(p))
                self.srcs.append(src)
                for k in _guarded(p, src.keys):
                    if k in self.where:
                        raise InputError(f"{k!r} is in both {self.where[k].path} and {p}")
                    self.where[k] = src
        except BaseException:
            self.close()  # the files opened so far
            raise

    def _source(self, key: str, name: str):
        """The file that holds ``key``; one line naming what they hold if none."""
        src = self._find(key)
        if src is None:
            held = ", ".join(sorted(self.where)[:20]) or "nothing"
            raise InputError(f"no {key!r} (for {name}) in {self._files()}; it holds: {held}")
        return src

    def read(self, key: str, name: str):
        from .sources import _guarded

        src = self._source(key, name)

        def get():
            shape, _ = src.header(key)
            n = math.prod(shape)
            if n > MAX_ELEMENTS:
                raise InputError(f"{key} holds {n} values, more than {MAX_ELEMENTS}")
            if n == 0:
                raise InputError(f"{key} is empty (shape {shape})")
            v = np.asarray(src.read(key))
            if tuple(v.shape) != tuple(shape):  # what the header promised
                raise InputError(f"{key}: shape {v.shape} read, {shape} declared")
            return v

        return _guarded(src.path, get)

    def shape(self, key: str, name: str) -> tuple:
        """The shape ``key``'s header declares (no data read)."""
        from .sources import _guarded

        src = self._source(key, name)
        return tuple(_guarded(src.path, lambda: src.header(key))[0])

    def _find(self, key):
        if key in self.where:
            return self.where[key]
        # a member of an HDF5 group or MATLAB v7.3 struct need not be listed
        for src in self.srcs:
            if isinstance(src, _H5Source):
                path = key.replace(".", "/") if src.matlab else key
                if path.strip("/") and path.strip("/").split("/")[0] in src.f:
                    return src
        return None

    def _files(self):
        return ", ".join(s.path for s in self.srcs)

    def close(self):
        for s in self.srcs:
            s.close()


def list_keys(paths) -> list:
    """The keys a mapping may name in these files (HDF5: the first 50 datasets)."""
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    srcs = _Sources([os.fspath(p) for p in paths])
    try:
        return sorted(srcs.where)
    finally:
        srcs.close()


def _vector(name: str, key: str, v: np.ndarray) -> np.ndarray:
    if v.ndim > 1 and sum(s != 1 for s in v.shape) <= 1:
        v = v.reshape(-1)  # MATLAB 1 x n or n x 1
    if v.ndim == 2 and name in ("x", "z") and v.dtype.kind in "iuf":
        v = _grid_axis(name, key, v)
    if v.ndim != 1:
        raise InputError(f"{name} ({key}) must be a vector, got shape {v.shape}")
    if v.dtype.kind == "c":
        if np.any(v.imag != 0):
            raise InputError(f"{name} ({key}) must be real, got complex values")
        v = v.real
    return v


def _grid_axis(name: str, key: str, v: np.ndarray) -> np.ndarray:
    """The axis of a coordinate grid (MATLAB's ``meshgrid``: a matrix whose
    rows, or columns, all hold the same positions): its first row or
    column.  A grid whose values change along both axes (a rotated or
    sheared scan) is refused."""
    a = v.astype(np.float64)
    if np.array_equal(a, np.broadcast_to(a[:1, :], a.shape)):
        return v[0, :]
    if np.array_equal(a, np.broadcast_to(a[:, :1], a.shape)):
        return v[:, 0]
    raise InputError(
        f"{name} ({key}) is a {v.shape[0]} x {v.shape[1]} grid whose values change along "
        f"both axes (a rotated or irregular scan); give the scan's positions along {name} "
        f"as a vector"
    )


#: Positions (``x``, ``z``) that lie within this fraction of their mean step
#: of a uniform grid are put on it (with a warning naming the largest
#: offset); farther, the axis is refused as not uniform.  A recorded scan's
#: positions carry its stage's jitter, while the engine's decomposition and
#: back-projection sample the aperture on a uniform grid: an offset of a
#: tenth of a 3 mm step turns a 24 GHz echo's phase by at most 0.30 rad
#: (2 k times the offset).
SNAP_FRACTION = 0.1
#: ... and without a warning within this fraction (a float32 axis's
#: rounding, 1e-7 of its largest value, is a few 1e-5 of a 3 mm step at 0.5 m).
SNAP_QUIET = 1e-3
#: A frequency or range axis is put on its uniform grid within this fraction
#: of a step (float32 storage, values rounded on export, e.g. GHz to four
#: decimals): a frequency off by a hundredth of a step turns an echo at the
#: far end of the unambiguous range by 0.06 rad.
SNAP_AXIS_FRACTION = 0.01
#: (fraction, quiet fraction) of :func:`_snapped` for an axis of samples
#: (False) and for the antenna positions (True).
SNAP = {False: (SNAP_AXIS_FRACTION, SNAP_QUIET), True: (SNAP_FRACTION, SNAP_QUIET)}


def _snapped(
    name: str,
    key: str,
    v: np.ndarray,
    fraction: float = SNAP_FRACTION,
    quiet: float = SNAP_QUIET,
    stored: float = 0.0,
) -> np.ndarray:
    """An axis ``v`` (float64, >= 2 values, increasing) on the uniform grid
    that fits it best (least squares), when every value lies within
    ``fraction`` of a step of it (with a warning beyond ``quiet``); ``v``
    unchanged when the schema's check takes it as uniform already, or when
    it lies farther from uniform (the check then refuses it).  ``stored``:
    the relative rounding of the type the values were stored in (float32's
    eps), whose ``8 eps max|v|`` is allowed on top of both bounds, silently,
    as the schema's check allows it."""
    import warnings

    from .checks import DataWarning

    if v.size < 3 or not np.all(np.isfinite(v)):
        return v
    if uniform_steps(v, np.finfo(np.float64).eps):
        return v  # uniform as the schema's check takes it: kept as given
    i = np.arange(v.size, dtype=np.float64)
    step, start = np.polyfit(i, v, 1)
    fit = start + step * i
    off = float(np.max(np.abs(v - fit)))
    rounding = 8 * stored * float(np.max(np.abs(v)))
    if step == 0 or off > fraction * abs(step) + rounding:
        return v
    if off <= quiet * abs(step) + rounding:  # the rounding of stored values
        return fit
    unit = "Hz" if name == "frequency" else "m"
    warnings.warn(
        f"{name} ({key}) is not uniformly spaced: its values lie up to {off:.3g} {unit} "
        f"({100 * off / abs(step):.2g} % of the {abs(step):.4g} {unit} step) from a "
        f"uniform grid; they are put on that grid",
        DataWarning,
        stacklevel=4,
    )
    return fit


def _scalar(name: str, key: str, v: np.ndarray) -> float:
    if v.size != 1:
        raise InputError(f"{name} ({key}) must be one number, got shape {v.shape}")
    v = v.reshape(())
    if v.dtype.kind == "c":
        if v.imag != 0:
            raise InputError(f"{name} ({key}) must be real")
        v = v.real
    return _finite_scalar(f"{name} ({key})", v)


def _data(kind: str, key: str, v: np.ndarray, keymap: KeyMap) -> np.ndarray:
    order = keymap.order(v.ndim)
    if order is not None:
        v = v.transpose(order)
    if v.dtype.kind == "c":
        v = v.astype(np.complex64 if v.dtype == np.complex64 else np.complex128, copy=False)
    else:  # MATLAB saves an all-real complex array as real
        _warn_real(kind, key)
        v = v.astype(np.complex64 if v.dtype == np.float32 else np.complex128)
    if not np.all(np.isfinite(v)):
        raise InputError(f"{kind} ({key}) contains NaN or Inf")
    return np.conj(v) if keymap.conjugate else v


def _warn_real(kind: str, key: str) -> None:
    """A real data array is taken as complex with a zero imaginary part
    (what MATLAB saves for an all-real complex array); say what that means
    for the image, since real data are more often samples without their
    quadrature part, or magnitudes."""
    import warnings

    from .checks import DataWarning

    if kind == "spectrum":
        what = (
            "real samples (the in-phase part alone) hold each echo's mirror image too, "
            "at the unambiguous range c/(2 df) minus its range: give I + jQ where the "
            "radar records both"
        )
    else:
        what = (
            "the engine places points by the profiles' carrier phase, which real or "
            "magnitude-only profiles do not hold: give complex baseband profiles"
        )
    warnings.warn(
        f"{kind} ({key}) is real: taken as complex with a zero imaginary part; {what}",
        DataWarning,
        stacklevel=5,
    )


def _fits(shape: tuple, core: tuple) -> bool:
    return shape == core or (len(shape) == len(core) + 1 and shape[1:] == core and shape[0] > 0)


def _check_shape(
    kind: str, key: str, shape: tuple, core: tuple, what: str, keymap: KeyMap, raw: tuple
) -> None:
    """``shape`` (the data array's, as permuted) fits ``core`` or a stack of
    it; else one line naming the expected shape and, where the file's array
    (of shape ``raw``) fits another order of its axes, the ``--axes`` that
    gives it."""
    import itertools

    if _fits(tuple(shape), core):
        return
    hint = ""
    own = "f" if kind == "spectrum" else "r"
    names = ["x"] + (["z"] if len(core) == 3 else []) + [own]
    for stack in (False, True):
        if len(raw) != len(names) + stack:
            continue
        target = ((None,) if stack else ()) + core
        labels = (["frame"] if stack else []) + names
        for perm in itertools.permutations(range(len(raw))):
            if stack and raw[perm[0]] <= 0:
                continue
            if all(t is None or raw[p] == t for p, t in zip(perm, target)):
                file_order = [""] * len(raw)
                for p, lab in zip(perm, labels):
                    file_order[p] = lab
                hint = f"; its axes fit as --axes {','.join(file_order)} (axes=...)"
                break
        if hint:
            break
    ordered = keymap.axes is not None or keymap.transpose
    if ordered and _fits(tuple(raw), core):
        hint = "; it fits in the file's own order (without --transpose or --axes)"
    elif not ordered and _fits(tuple(raw[::-1]), core):
        hint = "; --transpose (transpose=True) reverses its axes to that"
    raise InputError(
        f"{kind} ({key}) has shape {tuple(raw)}; expected {core} ({what}) or a stack "
        f"(frames, {', '.join(map(str, core))}){hint}"
    )


def convert(inputs, keymap: KeyMap) -> dict:
    """Read the mapped arrays and return them under the schema's names.

    Parameters
    ----------
    inputs : path or list of paths
        ``.mat``, ``.npz``, ``.npy`` (key: the file name without ``.npy``),
        ``.h5`` / ``.hdf5``; a key held by two files is refused.
    keymap : KeyMap
        Names, transpose, scales, conjugation.

    Returns
    -------
    dict
        Frequency domain: ``spectrum`` complex ``(nx[, nz], nf)`` (or a stack
        with a leading frame axis), ``frequency`` ``(nf,)`` Hz, ``x`` ``(nx,)``
        m, ``z`` ``(nz,)`` m, ``fc`` and ``bandwidth`` Hz where mapped.  Time
        domain: ``signal`` ``(nx[, nz], nr)``, ``range`` ``(nr,)`` m, ``fc``,
        ``bandwidth``, ``x`` (``z``).  Axes float64, validated as
        :func:`rpm_cl.load_data` does (uniform, increasing, > 0 Hz ...).

    Raises
    ------
    InputError
        One line: a key not in the files (naming what they hold), a name
        outside the schema, a name missing or one that does not go with the
        data array, a wrong shape (naming the expected one, and
        ``--transpose`` where it would fit), a non-numeric or oversized
        array, an unreadable file.
    """
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    paths = [os.fspath(p) for p in inputs]
    if not paths:
        raise InputError("no input given")
    srcs = _Sources(paths)
    try:
        return _convert(srcs, keymap)
    finally:
        srcs.close()


def _convert(srcs: _Sources, keymap: KeyMap) -> dict:
    """:func:`convert` on open sources: the axes and scalars are read
    first, and the data array's shape (from its header) is checked against
    them before its data are."""
    from .compress import _frequency_axis

    kind = keymap.kind
    raw = {name: srcs.read(key, name) for name, key in keymap.pairs if name != kind}
    keys = dict(keymap.pairs)
    out = {}
    flip = []  # axes given in decreasing order: reversed, with the data
    for name in _AXES:
        if name in raw:
            v = _vector(name, keys[name], raw[name])
            # the rounding of the stored type (float32, MATLAB's single)
            stored = np.finfo(v.dtype).eps if v.dtype.kind == "f" else 0.0
            v = v.astype(np.float64)
            if name in ("x", "z"):
                v = v * keymap.scale_x
            elif name == "frequency":
                v = v * keymap.scale_f
            if v.size >= 2 and np.all(np.diff(v) < 0):
                v = v[::-1]
                flip.append(name)
            out[name] = _snapped(name, keys[name], v, *SNAP[name in ("x", "z")], stored)
    for name in _SCALARS:
        if name in raw:
            out[name] = _scalar(name, keys[name], raw[name]) * keymap.scale_f
    array = Array(out["x"], out.get("z"))
    if kind == "spectrum":
        freq = _frequency_axis(out["frequency"])
        n_axis, what = freq.size, "frequency"
        if "fc" in out and not freq[0] <= out["fc"] <= freq[-1]:
            raise InputError(
                f"fc ({out['fc']:g} Hz) must lie within the frequency band "
                f"({freq[0]:g} .. {freq[-1]:g} Hz)"
            )
        if "bandwidth" in out or "fc" in out:
            Waveform(out.get("fc", (freq[0] + freq[-1]) / 2), out.get("bandwidth", 1.0))
    else:
        rng = _uniform_axis("range", out["range"], 2)
        n_axis, what = rng.size, "range"
        Waveform(out["fc"], out["bandwidth"])
    axes = " x ".join(f"{a} {s}" for a, s in zip(("x", "z"), array.shape))
    core = array.shape + (n_axis,)
    shape_in = srcs.shape(keys[kind], kind)
    order = keymap.order(len(shape_in))
    shape = shape_in if order is None else tuple(shape_in[i] for i in order)
    _check_shape(kind, keys[kind], shape, core, f"{axes} x {what} {n_axis}", keymap, shape_in)
    values = _data(kind, keys[kind], srcs.read(keys[kind], kind), keymap)
    lead = values.ndim - len(core)  # a stack's frame axis
    where = {"x": lead, "z": lead + 1, "frequency": values.ndim - 1, "range": values.ndim - 1}
    for name in flip:
        values = np.flip(values, axis=where[name])
    out[kind] = np.ascontiguousarray(values)
    return out
