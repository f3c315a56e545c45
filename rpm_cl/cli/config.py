"""Imaging parameters from a TOML file and from command-line flags.

Every field of the parameter dataclasses is a setting, found with
:func:`dataclasses.fields` (a field added later is picked up here without
editing this module):

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
flag; the field's docstring says what None means.

Precedence: flags override the file, which overrides the defaults derived from
the data (:func:`rpm_cl.rpm.params.default_params`) and, for the preset scenes of
``demo``, the paper's values.  Every error (unknown section or key, wrong
type, value out of range) is an :class:`rpm_cl.io.data.InputError` of one line
naming the key and the file or flag it came from.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import re
import types
import typing
from dataclasses import dataclass
from typing import Any, Literal

from ..io.data import InputError

__all__ = [
    "EngineParams",
    "Setting",
    "add_flags",
    "dump_toml",
    "flag_values",
    "load_config",
    "merge",
    "resolve",
    "resolve_engine",
    "resolve_medium",
    "settings",
]

_AUTO = ("auto", "none")


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
    "background": "Before imaging (rpm_cl.extract.preprocess): subtract the mean or median range "
    "profile over the antennas per gate ('none', 'mean', 'median').",
    "time_zero": "Before imaging: this range becomes 0 (the antenna's own pulse, or the "
    "surface echo of a ground-coupled antenna), m; earlier gates are dropped.",
    "gain_db_per_m": "Before imaging: amplitudes times 10^(g R / 20), a gain of g dB per "
    "metre of range after time_zero.",
    "max_range": "Before imaging: gates beyond this range (after time_zero) are dropped, "
    "m; None keeps all.",
    "reach_deg": "phase-rpm: points seen from their main RP's antenna farther than this "
    "from boresight are dropped, deg (0 < reach_deg <= 90; 90 keeps all).",
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
        return what + (" or 'auto'" if self.optional else "")

    def coerce(self, value):
        """A TOML value checked against the field's type; ValueError if wrong."""
        if self.optional and isinstance(value, str) and value.lower() in _AUTO:
            return None
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
            if self.optional and t.lower() in _AUTO:
                return None
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

    Raises
    ------
    TypeError
        A field has a type that is neither float, int, bool, str, a
        ``Literal`` of those nor one of them ``| None`` (a programming error,
        found by the tests).
    """
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
    return [
        dataclasses.replace(
            s,
            flag="--"
            + (s.name if names.count(s.name) == 1 else f"{s.section}_{s.name}").replace("_", "-"),
        )
        for s in out
    ]


# --------------------------------------------------------------------------
# the file
#: Largest ``--config`` file read, bytes: a parameter file is a few kB.
CONFIG_MAX_BYTES = 1 << 20


def load_config(path) -> dict:
    """Read and type-check a TOML parameter file.

    Returns
    -------
    dict
        ``{(section, name): value}`` for the keys the file sets.

    Raises
    ------
    InputError
        Unreadable file, invalid TOML, unknown section or key, wrong type.
    """
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib

    from ..io.guard import regular_file

    path = regular_file(path, "config")
    if os.path.getsize(path) > CONFIG_MAX_BYTES:
        raise InputError(
            f"{path}: a config of {os.path.getsize(path)} bytes is not a "
            f"parameter file (at most {CONFIG_MAX_BYTES} bytes)"
        )
    try:
        with open(path, "rb") as fh:
            doc = tomllib.load(fh)
    except OSError as exc:
        raise InputError(f"cannot read config {path}: {exc.strerror or exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML: {exc}") from None
    except UnicodeDecodeError:
        raise InputError(f"{path}: not valid TOML: not UTF-8 text") from None
    except RecursionError:  # tomllib parses nested arrays and tables recursively
        raise InputError(
            f"{path}: not a parameter file: arrays or tables nested too deep to parse"
        ) from None
    by_section = {}
    for s in settings():
        by_section.setdefault(s.section, {})[s.name] = s
    out = {}
    for section, table in doc.items():
        if section not in by_section:
            raise InputError(
                f"{path}: unknown section [{section}]"
                if isinstance(table, dict)
                else f"{path}: unknown key {section!r} outside a section; "
                f"sections: {', '.join(by_section)}"
            )
        if not isinstance(table, dict):
            raise InputError(f"{path}: {section} must be a section [{section}], not a value")
        for name, value in table.items():
            spec = by_section[section].get(name)
            if spec is None:
                raise InputError(
                    f"{path}: unknown key [{section}] {name}; known: "
                    f"{', '.join(by_section[section])}"
                )
            try:
                out[(section, name)] = spec.coerce(value)
            except ValueError as exc:
                raise InputError(f"{path}: [{section}] {name} {exc}") from None
    return out


def _toml_value(v) -> str:
    import json

    if v is None:
        return '"auto"'
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(int(v))
    if isinstance(v, float) or hasattr(v, "dtype"):
        f = float(v)
        return "inf" if f == math.inf else "-inf" if f == -math.inf else repr(f)
    return json.dumps(str(v))


def dump_toml(
    params, engine: EngineParams | None = None, header: str = "", comments: bool = True
) -> str:
    """The parameters as TOML text that :func:`load_config` reads back to
    the same values (every field written; None as ``"auto"``).

    Parameters
    ----------
    params : rpm_cl.rpm.params.ImagingParams
    engine : EngineParams, optional
        Adds an ``[engine]`` section.
    header : str
        Comment lines put first.
    comments : bool
        Each key preceded by its field's docstring as a comment.
    """
    import textwrap

    values = _values(params, engine)
    lines = [f"# {h}" for h in header.splitlines()]
    section = None
    for s in settings():
        if (s.section, s.name) not in values:
            continue
        if s.section != section:
            lines += ["", f"[{s.section}]"]
            section = s.section
        if s.doc and comments:
            lines += textwrap.wrap(s.doc, 88, initial_indent="# ", subsequent_indent="# ")
        lines.append(f"{s.name} = {_toml_value(values[(s.section, s.name)])}")
    return "\n".join(lines).lstrip("\n") + "\n"


def _values(params, engine=None) -> dict:
    """``{(section, name): value}`` of a parameter object."""
    out = {}
    for s in settings():
        if s.section == "engine":
            if engine is not None:
                out[(s.section, s.name)] = getattr(engine, s.name)
        elif s.section == "imaging":
            out[(s.section, s.name)] = getattr(params, s.name)
        else:
            out[(s.section, s.name)] = getattr(getattr(params, s.section), s.name)
    return out


# --------------------------------------------------------------------------
# flags
def add_flags(parser, sections=("kspace", "rpm", "imaging")) -> None:
    """Add a flag for every field of ``sections`` to an argparse parser (an
    argument group each); a flag not given leaves no attribute
    (``argparse.SUPPRESS``), so :func:`flag_values` sees what was given."""
    titles = {
        "kspace": "k-space decomposition",
        "rpm": "RPM",
        "imaging": "range points",
        "medium": "medium",
        "engine": "engine",
    }
    groups = {}
    for s in settings():
        if s.section not in sections:
            continue
        if s.section not in groups:
            groups[s.section] = parser.add_argument_group(
                f"{titles.get(s.section, s.section)} parameters ([{s.section}] of --config)"
            )
        doc = s.doc.replace("%", "%%")
        default = "auto" if s.default is None else s.default
        kind = {float: "X", int: "N", bool: "BOOL", str: "TEXT"}[s.kind]
        groups[s.section].add_argument(
            s.flag,
            dest=s.dest,
            type=s.parse,
            default=argparse.SUPPRESS,
            choices=s.choices,
            metavar=None if s.choices else kind + ("|auto" if s.optional else ""),
            help=f"{doc} (default {default}; `rpm-cl params IN` shows the value for IN)",
        )


def flag_values(args) -> dict:
    """``{(section, name): value}`` of the flags given on the command line."""
    out = {}
    for s in settings():
        if hasattr(args, s.dest):
            out[(s.section, s.name)] = getattr(args, s.dest)
    return out


def merge(*layers: dict) -> dict:
    """Later layers override earlier ones (file, then flags)."""
    out = {}
    for layer in layers:
        out.update(layer or {})
    return out


def resolve(data, values: dict, base: dict | None = None, sources: dict | None = None):
    """The imaging parameters for ``data``.

    Parameters
    ----------
    data : RadarData
    values : dict
        ``{(section, name): value}`` given explicitly (the merged file and
        flags, :func:`merge`); None values mean None (e.g. ``"auto"``), not
        "the default".
    base : dict, optional
        Flat defaults below ``values`` (a preset's paper values).
    sources : dict, optional
        ``{(section, name): 'file.toml' or '--flag'}``, named in errors.

    Returns
    -------
    rpm_cl.rpm.params.ImagingParams
        Every explicit value as given, the rest derived.

    Raises
    ------
    InputError
        A value out of range: one line naming the key and where it came from.
    """
    from ..rpm.params import default_params

    sources = sources or {}
    explicit = {k: v for k, v in values.items() if k[0] != "engine"}
    given = {name: v for (_, name), v in explicit.items() if v is not None}
    try:
        params = default_params(data, **{**(base or {}), **given})
        for (section, name), v in explicit.items():
            if v is None:
                if section == "imaging":
                    params = dataclasses.replace(params, **{name: None})
                else:
                    sub = dataclasses.replace(getattr(params, section), **{name: None})
                    params = dataclasses.replace(params, **{section: sub})
    except InputError as exc:
        msg = str(exc)
        named = [k for k in explicit if re.search(rf"\b{k[1]}\b", msg)]
        if named:
            k = named[0]
            where = sources.get(k, "")
            raise InputError(f"{where + ': ' if where else ''}[{k[0]}] {k[1]}: {msg}") from None
        raise
    return params


def resolve_medium(values: dict, sources: dict | None = None):
    """:class:`rpm_cl.io.medium.Medium` from the ``medium`` entries of ``values``
    (for the commands that take no other imaging parameter: ``das``,
    ``rma``)."""
    from ..io.medium import Medium

    kw = {name: v for (section, name), v in values.items() if section == "medium"}
    try:
        return Medium(**kw)
    except InputError as exc:
        key = next((k for k in values if k[0] == "medium" and k[1] in str(exc)), None)
        where = (sources or {}).get(key, "")
        raise InputError(f"{where + ': ' if where else ''}{exc}") from None


def resolve_engine(values: dict, sources: dict | None = None) -> EngineParams:
    """:class:`EngineParams` from the ``engine`` entries of ``values``."""
    kw = {name: v for (section, name), v in values.items() if section == "engine"}
    try:
        return EngineParams(**kw)
    except InputError as exc:
        key = next((k for k in values if k[0] == "engine" and k[1] in str(exc)), None)
        where = (sources or {}).get(key, "")
        raise InputError(f"{where + ': ' if where else ''}{exc}") from None
