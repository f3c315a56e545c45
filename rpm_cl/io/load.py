"""Reading the input schema from an ``.npz`` or HDF5 file
(:func:`load_data`, :func:`frame_count`): the data array and its frame of a
stack, every array beside it checked from its header and the run's memory
from the headers before any data are read, then the validated
:class:`~rpm_cl.io.radar.RadarData` (a spectrum range-compressed).  The
schema: :mod:`rpm_cl.io.formats`."""

from __future__ import annotations

import numpy as np

from .checks import InputError
from .compress import (
    RANGE_OVERSAMPLE,
    _check_conjugated,
    _frequency_axis,
    _window_name,
    spectrum_data,
)
from .guard import check_budget, memory_limit, run_bytes
from .model import Array, Truth, Waveform
from .plausible import check_plausible
from .radar import RadarData
from .sources import _guarded, _nbytes, _open
from .spikes import drop_spikes


def _frames(src, key: str, n_axes: int) -> int | None:
    """Frames in ``key``: None for a single frame, else the stack's length."""
    shape, dtype = src.shape_dtype(key)
    if not np.issubdtype(dtype, np.complexfloating):
        raise InputError(f"{key} must be complex (complex64/complex128), got dtype {dtype}")
    if len(shape) == n_axes:
        return None
    if len(shape) == n_axes + 1:
        if shape[0] == 0:
            raise InputError(f"{key} holds no frames (a stack of length 0, shape {shape})")
        return int(shape[0])
    raise InputError(
        f"{key} must have {n_axes} axes (or {n_axes + 1} for a stack of frames), got shape {shape}"
    )


def _data_key(src) -> str:
    if "signal" in src and "spectrum" in src:
        raise InputError("holds both signal and spectrum; keep one")
    if "signal" in src:
        return "signal"
    if "spectrum" in src:
        return "spectrum"
    raise InputError("missing key 'signal' (time domain) or 'spectrum' (frequency domain)")


def _n_axes(src) -> int:
    return 3 if "z" in src else 2


def _need(src, key):
    if key not in src:
        raise InputError(f"missing key {key!r}")
    return src.read(key)


def frame_count(path) -> int:
    """Frames in an input file: the stack's length, 1 for a single frame.

    Parameters
    ----------
    path : str or path-like
        An ``.npz`` or HDF5 input (see :func:`load_data`).

    Raises
    ------
    InputError
        The file is unreadable, or has no complex ``signal``/``spectrum`` of a
        valid number of axes, or a stack of no frames.
    """
    path, src = _open(path)
    try:
        n = _guarded(path, lambda: _frames(src, _data_key(src), _n_axes(src)))
    finally:
        src.close()
    return 1 if n is None else n


def _select(src, key: str, n_axes: int, frame):
    n = _frames(src, key, n_axes)
    if frame is not None and (isinstance(frame, bool) or not isinstance(frame, (int, np.integer))):
        raise InputError(f"frame must be an integer, got {frame!r}")
    if n is None:
        if frame not in (None, 0):
            raise InputError(f"frame {frame} out of range: the file holds a single frame")
        return src.read(key)
    if frame is None:
        raise InputError(
            f"{key} is a stack of {n} frames; choose one with frame= (--frame N, 0..{n - 1})"
        )
    if not 0 <= frame < n:
        raise InputError(f"frame {frame} out of range: the stack holds {n} frames (0..{n - 1})")
    return src.read_frame(key, int(frame))


#: The arrays beside the data and the shapes they must have, from the data
#: header's core shape (nx[, nz], n): a callable of (core, n_axes).
_BESIDE = {
    "x": lambda key, core, n_axes: (core[0],),
    "z": lambda key, core, n_axes: (core[1],) if n_axes == 3 else None,
    "range": lambda key, core, n_axes: (core[-1],) if key == "signal" else None,
    "frequency": lambda key, core, n_axes: (core[-1],) if key == "spectrum" else None,
    "fc": lambda key, core, n_axes: (),
    "bandwidth": lambda key, core, n_axes: (),
    "record_range": lambda key, core, n_axes: (),
}
_TRUTH = ("truth_boundary", "truth_rp_antenna", "truth_rp_range")
#: An array beside the data larger than the data's header allows is refused
#: from its header when it holds more than this, bytes; a smaller one is
#: read and its mismatch reported by the validators in their own words.
BESIDE_READ_BYTES = 1 << 20


def _preflight(src, key: str, n_axes: int, with_truth: bool, max_memory) -> None:
    """Every array the run reads, checked from its header before any data is
    read: numeric, no larger than the data's header allows (``x`` its first
    axis, ``range`` / ``frequency`` its last, ``fc`` one number; see
    :data:`BESIDE_READ_BYTES`), and the whole run within ``max_memory``
    (:func:`rpm_cl.io.guard.run_bytes`)."""
    shape, _ = src.shape_dtype(key)
    core = shape[-n_axes:]
    other = 0
    for name, want in _BESIDE.items():
        if name not in src:
            continue
        got, dtype = src.shape_dtype(name)
        need = want(key, core, n_axes)
        if dtype.kind not in "biuf":
            what = "a real number" if need == () else "real numbers"
            raise InputError(f"{name} must be {what}, got dtype {dtype}")
        size, nbytes = int(np.prod(got, dtype=object)), _nbytes(got, dtype)
        if (
            need is not None
            and size > int(np.prod(need, dtype=object))
            and nbytes > BESIDE_READ_BYTES
        ):
            what = "one number" if need == () else f"{need[0]} values ({key} has shape {shape})"
            raise InputError(f"{name} must hold {what}, its header declares shape {got}")
        other += nbytes
    if with_truth:
        for name in _TRUTH:
            if name in src:
                got, dtype = src.shape_dtype(name)
                other += _nbytes(got, dtype)
    samples = int(np.prod(core[:-1], dtype=object))
    if key == "spectrum":  # range-compressed onto next_fast_len(16 nf) gates, ~16 nf
        samples *= RANGE_OVERSAMPLE * max(int(core[-1]), 1)
    else:
        samples *= int(core[-1])
    check_budget(run_bytes(samples, other, n_axes - 1), memory_limit(max_memory), f"{key} {shape}")


def _truth(src):
    if "truth_boundary" not in src:
        given = [k for k in ("truth_rp_antenna", "truth_rp_range") if k in src]
        if given:
            import warnings

            from .checks import DataWarning

            warnings.warn(
                f"{' and '.join(given)} without truth_boundary: not scored (the truth is "
                f"read with truth_boundary, the targets' boundary samples; give it too)",
                DataWarning,
                stacklevel=5,
            )
        return None
    scene = src.text("truth_scene") if "truth_scene" in src else "{}"
    # the true RPs are optional (a surveyed boundary alone scores Err_RPM)
    rp = [src.read(k) if k in src else None for k in ("truth_rp_antenna", "truth_rp_range")]
    return Truth(rp[0], rp[1], src.read("truth_boundary"), scene)


def cut_to_record(data: RadarData, end) -> RadarData:
    """``data`` without the gates beyond ``end``, the range its record
    covers (m; a file's ``record_range``): what a zero-padded record's
    transform puts there holds nothing recorded (a DZT conversion's second
    half).  The samples and the compression are kept, as for any cut of the
    axis.

    Raises
    ------
    InputError
        ``end`` not a finite number > 0, or fewer than 2 gates left.
    """
    from dataclasses import replace

    from .checks import _finite_scalar

    end = _finite_scalar("record_range", end)
    keep = data.range <= end
    if keep.sum() < 2:
        raise InputError(
            f"record_range {end:g} m leaves fewer than 2 range gates of "
            f"{data.range[0]:g} .. {data.range[-1]:g} m"
        )
    if keep.all():
        return data
    return replace(data, signal=data.signal[..., keep], range=data.range[keep])


def _record_range(src) -> float | None:
    """The file's ``record_range``, checked (a finite number > 0), m; None
    where it gives none."""
    if "record_range" not in src:
        return None
    from .checks import _finite_scalar

    return _finite_scalar("record_range", src.read("record_range"))


def _record_cut(data: RadarData, record: float | None) -> RadarData:
    return data if record is None else cut_to_record(data, record)


def _build(
    src, frame, range_window: str, conjugate: bool, with_truth: bool = True, max_memory=None
) -> RadarData:
    key = _data_key(src)
    n_axes = _n_axes(src)
    _frames(src, key, n_axes)
    _preflight(src, key, n_axes, with_truth, max_memory)
    z = src.read("z") if "z" in src else None
    array = Array(_need(src, "x"), z)
    values = drop_spikes(_select(src, key, n_axes, frame), key)
    truth = _truth(src) if with_truth else None
    if key == "signal":
        if "frequency" in src:
            raise InputError("'frequency' goes with 'spectrum', not with 'signal'")
        if conjugate:  # profiles recorded with the carrier phase exp(+j 2 k_c R)
            values = np.conj(values)
        waveform = Waveform(_need(src, "fc"), _need(src, "bandwidth"))
        data = RadarData(values, array, _need(src, "range"), waveform, truth)
        data = _record_cut(data, _record_range(src))
        check_plausible(data)
        return data
    if "range" in src:
        raise InputError(
            "'range' goes with 'signal'; a spectrum's range axis comes from 'frequency'"
        )
    freq = _frequency_axis(_need(src, "frequency"))
    fc = src.read("fc") if "fc" in src else None
    bw = src.read("bandwidth") if "bandwidth" in src else None
    if conjugate:
        values = np.conj(values)
    data = spectrum_data(values, freq, array, fc, bw, range_window, truth)
    record = _record_range(src)
    if not conjugate:
        _check_conjugated(data.signal, data.range, record)
    data = _record_cut(data, record)
    check_plausible(data)
    return data


def load_data(
    path,
    *,
    frame: int | None = None,
    range_window: str = "hann",
    conjugate: bool = False,
    with_truth: bool = True,
    max_memory=None,
) -> RadarData:
    """Read and validate radar data from an ``.npz`` or HDF5 file.

    Parameters
    ----------
    path : str or path-like
        ``.npz``, ``.h5`` or ``.hdf5`` following the input schema (docs/input-format.md,
        "Input schema"): time domain (``signal``, ``range``) or frequency
        domain (``spectrum``, ``frequency``).
    frame : int, optional
        Frame of a stack (``signal``/``spectrum`` with a leading frame axis);
        required for a stack, 0 or None for a single-frame file.
    range_window : str
        Window of the range compression of a ``spectrum``, one of
        :data:`~rpm_cl.io.compress.RANGE_WINDOWS` (ignored for time-domain data).
    conjugate : bool
        Conjugate a ``spectrum`` before compressing it: for samples recorded
        as ``a exp(+j 4 pi f R / c)`` (whose echoes otherwise land at the
        unambiguous range minus their range; a warning says when the data
        look so).  Time-domain profiles recorded with the carrier phase
        ``exp(+j 2 k_c R)`` are conjugated as they are (their envelope is
        the same; the phase's sign mirrors every direction across the array).
    with_truth : bool
        Read the ``truth_*`` members (scoring); False leaves them unread.
    max_memory : int or str, optional
        Bytes a run on the data may take (:func:`rpm_cl.io.guard.memory_limit`:
        default ``RPM_CL_MAX_MEMORY`` or half the machine's memory); checked
        from the headers before any data is read.

    Warns
    -----
    DataWarning
        One line with its fix: a spectrum that looks conjugated, units that
        look wrong (:func:`rpm_cl.io.data.check_plausible`).

    Returns
    -------
    RadarData
        Validated; a spectrum comes back range-compressed (see
        :func:`~rpm_cl.io.compress.range_compress`).

    Raises
    ------
    InputError
        One line naming the file and the problem: unknown extension, not a
        regular file, unreadable or truncated file, a header declaring more
        than the file holds or the run more memory than ``max_memory``,
        data outside the file (HDF5 external links or storage, virtual
        datasets), missing key, wrong shape or dtype,
        non-uniform axis, NaN/Inf, a stack of no frames, a stack without
        ``frame``, ``frame`` out of range, an unknown window.
    """
    _window_name(range_window)
    path, src = _open(path)
    try:
        return _guarded(
            path,
            lambda: _build(src, frame, range_window, bool(conjugate), bool(with_truth), max_memory),
        )
    finally:
        src.close()
