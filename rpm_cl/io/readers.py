"""Readers of recorded and simulated data, by name: the input formats of
``rpm-cl convert``.

Each reader turns its files into the frequency-domain input schema
(``spectrum``, ``frequency``, ``x``; docs/input-format.md, "Input schema"), or for the
``arrays`` reader into whichever form the mapping names:

=========  ===============================  ===================================
name       inputs                           module
=========  ===============================  ===================================
gprmax     ``.out``, ``.h5``                :mod:`rpm_cl.io.gprmax`
arrays     ``.mat .npz .npy .h5``           :mod:`rpm_cl.io.mapped` (``map`` given)
dzt        ``.dzt``                         :mod:`rpm_cl.io.dzt`
dt1        ``.dt1`` (its ``.hd`` beside)    :mod:`rpm_cl.io.dt1`
mala       ``.rd3 .rd7`` (``.rad`` beside)  :mod:`rpm_cl.io.mala`
dca1000    ``.bin``                         :mod:`rpm_cl.io.dca1000`
=========  ===============================  ===================================

:func:`convert` picks the reader from the inputs' extension (an HDF5 file
with a ``map`` is read as arrays, without one as gprMax output) unless
``fmt`` names it, and refuses an option that belongs to another reader.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

from .data import InputError

__all__ = ["FORMATS", "Format", "convert", "detect_format", "save"]


@dataclass(frozen=True)
class Format:
    """One reader: its extensions, the options it takes (keyword names of
    :func:`convert`, the CLI's ``--`` flags with ``_`` for ``-``) and those
    it requires."""

    extensions: tuple
    options: tuple
    required: tuple = ()
    description: str = ""


FORMATS = {
    "gprmax": Format(
        (".out", ".h5", ".hdf5"),
        ("background", "band", "waveform", "sidecar", "df", "rx"),
        ("band",),
        "gprMax 2-D TM output",
    ),
    "arrays": Format(
        (".mat", ".npz", ".npy", ".h5", ".hdf5"),
        ("map", "transpose", "axes", "scale_x", "scale_f", "conjugate"),
        ("map",),
        "named arrays (MATLAB, NumPy, HDF5) by a key mapping",
    ),
    "dzt": Format(
        (".dzt",),
        ("band", "dx", "time_zero", "channel", "subtract_mean"),
        (),
        "GSSI DZT (impulse GPR)",
    ),
    "dt1": Format(
        (".dt1",),
        ("band", "dx", "time_zero", "subtract_mean"),
        (),
        "Sensors & Software pulseEKKO DT1 + HD (impulse GPR)",
    ),
    "mala": Format(
        (".rd3", ".rd7"),
        ("band", "dx", "time_zero", "subtract_mean"),
        (),
        "MALÅ RAMAC/ProEx rd3/rd7 + rad (impulse GPR)",
    ),
    "dca1000": Format(
        (".bin",),
        (
            "slope",
            "adc_rate",
            "samples",
            "start_freq",
            "adc_start_time",
            "chirps",
            "rx",
            "layout",
            "dx",
            "rx_spacing",
            "receiver",
        ),
        ("slope", "adc_rate", "samples", "start_freq"),
        "TI mmWave + DCA1000 raw ADC capture",
    ),
}


def _flag(name: str) -> str:
    return "--" + name.replace("_", "-")


def detect_format(inputs, mapped: bool = False) -> str:
    """The reader for these files: by extension (all alike); with ``mapped``
    (a key mapping is given) any mix of ``.mat .npz .npy .h5 .hdf5`` is
    arrays, without it ``.h5`` / ``.hdf5`` are gprMax output."""
    exts = {os.path.splitext(os.fspath(p))[1].lower() for p in inputs}
    if mapped and exts <= set(FORMATS["arrays"].extensions):
        return "arrays"
    if len(exts) != 1:
        raise InputError(
            f"inputs of several kinds ({', '.join(sorted(exts))}); convert one "
            f"kind at a time, or name it with --format"
        )
    ext = exts.pop()
    if ext in (".h5", ".hdf5"):
        return "arrays" if mapped else "gprmax"
    for name, fmt in FORMATS.items():
        if ext in fmt.extensions:
            return name
    known = sorted({e for f in FORMATS.values() for e in f.extensions})
    raise InputError(
        f"unknown input extension {ext or '(none)'!r}; known: {', '.join(known)} "
        f"(or name the reader with --format {'|'.join(FORMATS)})"
    )


def convert(inputs, fmt: str | None = None, **options) -> tuple:
    """Read ``inputs`` with the reader ``fmt`` (default: :func:`detect_format`).

    Parameters
    ----------
    inputs : path or list of paths
    fmt : str, optional
        A key of :data:`FORMATS`.
    **options
        The reader's options (:data:`FORMATS`; None means not given):
        gprmax ``background, band, waveform`` (a
        :class:`rpm_cl.io.gprmax.SourceWaveform`) ``, sidecar, df, rx``;
        arrays ``map`` (``"spectrum=F,..."``) ``, transpose, axes`` (``"f,x"``)
        ``, scale_x, scale_f, conjugate``; dzt ``band, dx, time_zero, channel,
        subtract_mean``; dt1 and mala ``band, dx, time_zero, subtract_mean``;
        dca1000 ``slope, adc_rate, samples, start_freq, adc_start_time,
        chirps, rx`` (receivers) ``, layout, dx, rx_spacing, receiver``.

    Returns
    -------
    (str, dict)
        The reader's name and the schema's arrays.

    Raises
    ------
    InputError
        An unknown reader or extension, an option of another reader, a
        required option missing, and the reader's own errors.
    """
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    inputs = [os.fspath(p) for p in inputs]
    if not inputs:
        raise InputError("no input given")
    given = {k: v for k, v in options.items() if v is not None and v is not False}
    if fmt is None:
        fmt = detect_format(inputs, "map" in given)
    if fmt not in FORMATS:
        raise InputError(f"unknown format {fmt!r}; known: {', '.join(FORMATS)}")
    spec = FORMATS[fmt]
    alien = [k for k in given if k not in spec.options]
    if alien:
        owners = ", ".join(n for n, f in FORMATS.items() if alien[0] in f.options)
        raise InputError(
            f"{_flag(alien[0])} does not apply to {fmt} input"
            f"{f' (it is for {owners})' if owners else ''}"
        )
    missing = [k for k in spec.required if k not in given]
    if missing:
        raise InputError(f"{fmt} input needs {', '.join(_flag(k) for k in missing)}")
    from .guard import regular_file

    extra = [
        given[k] for k in ("background", "sidecar") if isinstance(given.get(k), (str, os.PathLike))
    ]
    for p in inputs + extra:
        regular_file(p)  # a FIFO would block the reader, /dev/zero never end
    return fmt, _READ[fmt](inputs, given)


def _gprmax(inputs, o):
    from .gprmax import convert

    return convert(
        inputs,
        o.get("background"),
        o["band"],
        o.get("waveform"),
        o.get("sidecar"),
        o.get("df"),
        o.get("rx", 1),
    )


def _arrays(inputs, o):
    from .mapped import KeyMap, convert

    km = KeyMap.parse(
        o["map"],
        transpose=bool(o.get("transpose")),
        axes=o.get("axes"),
        scale_x=o.get("scale_x", 1.0),
        scale_f=o.get("scale_f", 1.0),
        conjugate=bool(o.get("conjugate")),
    )
    return convert(inputs, km)


def _dzt(inputs, o):
    from .dzt import convert

    if len(inputs) != 1:
        raise InputError(f"{len(inputs)} DZT files; convert one at a time")
    return convert(
        inputs[0],
        o.get("band"),
        o.get("dx"),
        o.get("time_zero", 0.0),
        o.get("channel", 0),
        bool(o.get("subtract_mean")),
    )


def _line(convert, name: str, inputs, o):
    """A one-file impulse-GPR reader's ``convert(path, band, dx, time_zero,
    subtract_mean)`` on ``inputs``."""
    if len(inputs) != 1:
        raise InputError(f"{len(inputs)} {name} files; convert one at a time")
    return convert(
        inputs[0], o.get("band"), o.get("dx"), o.get("time_zero", 0.0), bool(o.get("subtract_mean"))
    )


def _dt1(inputs, o):
    from .dt1 import convert

    return _line(convert, "DT1", inputs, o)


def _mala(inputs, o):
    from .mala import convert

    return _line(convert, "MALÅ", inputs, o)


def _dca1000(inputs, o):
    from .dca1000 import Chirp, convert

    chirp = Chirp(
        o["slope"],
        o["adc_rate"],
        o["samples"],
        o["start_freq"],
        o.get("adc_start_time", 0.0),
        o.get("chirps", 1),
        o.get("rx", 4),
        o.get("layout", "complex-2lane"),
    )
    return convert(inputs, chirp, o.get("dx"), o.get("rx_spacing"), o.get("receiver", 0))


_READ = {
    "gprmax": _gprmax,
    "arrays": _arrays,
    "dzt": _dzt,
    "dt1": _dt1,
    "mala": _mala,
    "dca1000": _dca1000,
}


def save(path, arrays: dict, inputs=()) -> None:
    """Write the arrays as ``.npz`` or HDF5 through a temporary file renamed
    over ``path``, which may not be one of ``inputs``
    (:func:`rpm_cl.io.gprmax.save_spectrum`)."""
    from .gprmax import save_spectrum

    save_spectrum(path, arrays, inputs)
