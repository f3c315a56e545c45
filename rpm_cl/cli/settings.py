"""The settings of ``--config`` files and flags: every field of the parameter
dataclasses, found with :func:`dataclasses.fields` (a field added later is
picked up here without editing this module):

===============  ==========================================================
section          fields of
===============  ==========================================================
``[kspace]``     :class:`rpm_cl.extract.kspace.KSpaceParams` (decomposition)
``[rpm]``        :class:`rpm_cl.rpm.params.RPMParams` (the RPM step)
``[medium]``     :class:`rpm_cl.io.medium.Medium` (the material: eps_r, antenna_height)
``[imaging]``    the plain fields of :class:`rpm_cl.rpm.params.ImagingParams`
``[engine]``     :class:`EngineParams` (OpenCL device, precision)
===============  ==========================================================

(a section is made of every field of ``ImagingParams`` that is itself a
dataclass, under that field's name).  Each field is a TOML key of its section
and a flag ``--field-name`` (underscores as dashes; ``--section-field-name``
where two sections share a field name).  A field whose default may be None
(``T | None``) takes the string ``"auto"`` for None, in the file and after a
flag; the field's docstring says what None means.  :func:`settings` lists
them as :class:`Setting` objects, each of which checks and converts its values.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import math
import re
import types
import typing
from dataclasses import dataclass
from typing import Any, Literal

from ..io.data import InputError

__all__ = ["EngineParams", "Setting", "settings"]

_AUTO = ("auto", "none")
#: Settings whose None is a value picked from the data, written only "auto".
_PICKED = ("time_zero",)
#: Number settings that also take the word "auto": read from the data by
#: :func:`rpm_cl.rpm.params.default_params` (``eps_r``: the echoes' hyperbolas).
_READ = ("eps_r",)


def _read_from_data(value) -> bool:
    """Whether ``value`` is the word that reads a :data:`_READ` setting from
    the data (:func:`rpm_cl.rpm.params.is_auto`, which resolves it)."""
    from ..rpm.params import is_auto  # loaded with the settings (_section_classes)

    return is_auto(value)


@dataclass(frozen=True)
class EngineParams:
    """Where and how the kernels run.

    Attributes
    ----------
    device : str or None
        OpenCL device, 'P:D' indices or a name substring; None: PYOPENCL_CTX,
        else the first CPU device.
    precision : {'float32', 'float64'}
        Kernel arithmetic.
    """

    device: str | None = None
    precision: Literal["float32", "float64"] = "float32"

    def __post_init__(self):
        if self.precision not in ("float32", "float64"):
            raise InputError(f"precision must be 'float32' or 'float64', got {self.precision!r}")


# fields whose class docstring has no Attributes entry
_EXTRA_DOCS = {
    "rp_threshold_db": "RPs below this level relative to their cluster's maximum are "
    "dropped, dB (< 0).",
    "multipath": "phase-rpm: points of clusters that a double bounce between two other "
    "objects explains (rpm_cl.rpm.multipath) are dropped ('drop'), or kept with a "
    "'multipath' column in the result ('flag').",
    "align_traces": "Before imaging, first (rpm_cl.extract.alignment): move each trace by "
    "a fraction of a gate so that its direct wave lines up with the scan's mean, for an "
    "impulse GPR's trigger jitter.",
    "background": "Before imaging (rpm_cl.extract.preprocess): subtract the mean or median range "
    "profile over the antennas per gate ('mean', 'median'), nothing ('none'), or the mean "
    "where a B-scan's strongest echo is the antennas' own coupling ('auto').",
    "time_zero": "Before imaging: this range becomes 0 (the antenna's own pulse, or the "
    "surface echo of a ground-coupled antenna), m; earlier gates are dropped. auto: the "
    "envelope peak of the echo every antenna of a linear scan sees alike, where its "
    "strongest echo is one (rpm_cl.extract.preprocess.pick_time_zero), else 0.",
    "gain_db_per_m": "Before imaging: amplitudes times 10^(g R / 20), a gain of g dB per "
    "metre of range after time_zero.",
    "max_range": "Before imaging: gates beyond this range (after time_zero) are dropped, "
    "m; None keeps all.",
    "reach_deg": "phase-rpm: points seen from their main RP's antenna farther than this "
    "from boresight are dropped, deg (0 < reach_deg <= 90; 90 keeps all).",
    "coherence": "phase-rpm, linear arrays: drop the points that sit beside a peak of the "
    "coherent (DAS) image rather than on it (rpm_cl.rpm.coherence); false keeps all.",
    "segments": "phase-rpm: decompose a long linear scan in overlapping segments and a "
    "large planar array in tiles (rpm_cl.extract.segments); false decomposes "
    "every array whole.",
    "coherence_db": "How far below the largest DAS magnitude within 1.2 cross-range "
    "resolutions a point's own may lie and the point be kept, dB in [-60, 0).",
}


@dataclass(frozen=True)
class Setting:
    """One settable field.

    Attributes
    ----------
    section : str
        TOML section (``kspace``, ``rpm``, ``medium``, ``imaging``, ``engine``).
    name : str
        Field name (the TOML key).
    kind : type
        float, int, bool or str.
    optional : bool
        None is allowed (written ``"auto"``).
    choices : tuple or None
        Allowed values of a ``Literal`` field.
    default : object
        The dataclass default (before derivation from the data).
    doc : str
        The field's docstring text.
    flag : str
        Its command-line flag.
    """

    section: str
    name: str
    kind: type
    optional: bool
    choices: tuple | None
    default: Any
    doc: str
    flag: str = ""

    @property
    def auto_words(self) -> tuple:
        """The texts that stand for None: ``auto`` and ``none``, but only
        ``auto`` where None is a value picked from the data (time zero: "no
        time zero" is 0, not a pick)."""
        return ("auto",) if self.name in _PICKED else _AUTO

    @property
    def takes_auto(self) -> bool:
        """Whether the word ``auto`` is a value (None, or read from the data)."""
        return self.optional or self.name in _READ

    @property
    def dest(self) -> str:
        return f"cfg__{self.section}__{self.name}"

    @property
    def key(self) -> str:
        return f"[{self.section}] {self.name}"

    def describe(self) -> str:
        if self.choices:
            what = " or ".join(repr(c) for c in self.choices)
        else:
            what = {float: "a number", int: "an integer", bool: "true or false", str: "a string"}[
                self.kind
            ]
        return what + (" or 'auto'" if self.takes_auto else "")

    def coerce(self, value):
        """A TOML value checked against the field's type; ValueError if wrong."""
        if self.optional and isinstance(value, str) and value.lower() in self.auto_words:
            return None
        if self.name in _READ and _read_from_data(value):
            return "auto"
        if self.choices is not None:
            if value in self.choices:
                return value
        elif self.kind is bool:
            if isinstance(value, bool):
                return value
        elif self.kind is int:
            if isinstance(value, int) and not isinstance(value, bool):
                return value
        elif self.kind is float:
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                if math.isnan(value):
                    raise ValueError("must not be nan")
                return float(value)
        elif isinstance(value, str):
            return value
        raise ValueError(f"must be {self.describe()}, got {value!r}")

    def parse(self, text: str):
        """A flag's text converted to the field's type (argparse ``type``)."""
        t = text.strip()
        try:
            if self.optional and t.lower() in self.auto_words:
                return None
            if self.name in _READ and _read_from_data(t):
                return "auto"
            if self.choices is None and self.kind is bool:
                low = t.lower()
                if low in ("true", "yes", "on", "1"):
                    return True
                if low in ("false", "no", "off", "0"):
                    return False
                raise ValueError
            if self.choices is None and self.kind in (int, float):
                return self.coerce(self.kind(t))
            return self.coerce(t)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be {self.describe()}, got {text!r}") from None


def _field_docs(cls) -> dict:
    """Attribute descriptions from a numpydoc ``Attributes`` section."""
    doc = cls.__doc__ or ""
    m = re.search(r"\n\s*Attributes\n\s*-+\n(.*?)(?:\n\s*\n\s*\S+\n\s*-+\n|\Z)", doc, re.DOTALL)
    out, name = {}, None
    for line in (m.group(1) if m else "").splitlines():
        head = re.match(r"^\s{0,4}(\w+)\s*:", line)
        if head and len(line) - len(line.lstrip()) <= 4:
            name = head.group(1)
            out[name] = []
        elif name and line.strip():
            out[name].append(line.strip())
    return {k: " ".join(v) for k, v in out.items()}


def _kind(hint):
    """(kind, optional, choices) of a type hint; None if not a setting type."""
    optional = False
    if isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union:
        args = [a for a in typing.get_args(hint) if a is not type(None)]
        optional = len(args) < len(typing.get_args(hint))
        if len(args) != 1:
            return None
        hint = args[0]
    if typing.get_origin(hint) is Literal:
        choices = typing.get_args(hint)
        return type(choices[0]), optional, choices
    if hint in (float, int, bool, str):
        return hint, optional, None
    return None


def _section_classes() -> dict:
    from ..rpm.params import ImagingParams

    hints = typing.get_type_hints(ImagingParams)
    out = {
        f.name: hints[f.name]
        for f in dataclasses.fields(ImagingParams)
        if dataclasses.is_dataclass(hints[f.name])
    }
    out["imaging"] = ImagingParams
    out["engine"] = EngineParams
    return out


def settings() -> list[Setting]:
    """Every settable field, in section order then field order.

    Read once per process: the dataclasses do not change while it runs,
    and the parser asks once per subcommand (18 times; each reading
    introspects every dataclass and its docstring, about 8 ms).

    Raises
    ------
    TypeError
        A field has a type that is neither float, int, bool, str, a
        ``Literal`` of those nor one of them ``| None`` (a programming error,
        found by the tests).
    """
    return list(_settings())


@functools.cache
def _settings() -> tuple[Setting, ...]:
    out = []
    for section, cls in _section_classes().items():
        hints = typing.get_type_hints(cls)
        docs = {**_EXTRA_DOCS, **_field_docs(cls)}
        for f in dataclasses.fields(cls):
            if dataclasses.is_dataclass(hints[f.name]):
                continue  # a section of its own
            kind = _kind(hints[f.name])
            if kind is None:
                raise TypeError(
                    f"{cls.__name__}.{f.name}: type {hints[f.name]} is not a setting type"
                )
            default = (
                f.default
                if f.default is not dataclasses.MISSING
                else f.default_factory()
                if f.default_factory is not dataclasses.MISSING
                else None
            )
            out.append(Setting(section, f.name, *kind, default, docs.get(f.name, "")))
    names = [s.name for s in out]
    return tuple(
        dataclasses.replace(
            s,
            flag="--"
            + (s.name if names.count(s.name) == 1 else f"{s.section}_{s.name}").replace("_", "-"),
        )
        for s in out
    )
