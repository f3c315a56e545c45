"""Imaging parameters from a TOML file and from command-line flags.

The settings, one TOML key and one flag per field of the parameter
dataclasses, are :mod:`rpm_cl.cli.settings`; this module reads and writes
the file (:func:`load_config`, :func:`dump_toml`), adds and reads the flags
(:func:`add_flags`, :func:`flag_values`) and resolves them into parameters
(:func:`resolve`, :func:`resolve_medium`, :func:`resolve_engine`).

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

from ..io.data import InputError
from .settings import EngineParams, Setting, settings

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


def add_flags(parser, sections=("kspace", "rpm", "imaging"), only=None) -> None:
    """Add a flag for every field of ``sections`` to an argparse parser (an
    argument group each); a flag not given leaves no attribute
    (``argparse.SUPPRESS``), so :func:`flag_values` sees what was given.
    ``only``: the field names to add (all where None)."""
    titles = {
        "kspace": "k-space decomposition",
        "rpm": "RPM",
        "imaging": "range points",
        "medium": "medium",
        "engine": "engine",
    }
    groups = {}
    for s in settings():
        if s.section not in sections or (only is not None and s.name not in only):
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
            metavar=None if s.choices else kind + ("|auto" if s.takes_auto else ""),
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
    if explicit.get(("imaging", "time_zero"), 0.0) is None:  # "auto": from the data
        given["time_zero"] = None
        explicit.pop(("imaging", "time_zero"))
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


def resolve_medium(values: dict, sources: dict | None = None, data=None):
    """:class:`rpm_cl.io.medium.Medium` from the ``medium`` entries of ``values``
    (for the commands that take no other imaging parameter: ``das``,
    ``rma``); ``eps_r`` "auto" is read from ``data`` (after the steps before
    imaging; :func:`rpm_cl.extract.hyperbola.read_eps_r`)."""
    from ..io.medium import Medium
    from ..rpm.params import is_auto

    kw = {name: v for (section, name), v in values.items() if section == "medium"}
    if is_auto(kw.get("eps_r")) and data is not None:
        from ..extract.hyperbola import read_eps_r

        kw["eps_r"] = read_eps_r(data, kw.get("antenna_height"))
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
