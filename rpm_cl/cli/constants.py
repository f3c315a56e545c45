"""The engine's fixed numeric constants, as ``rpm-cl params`` lists them.

Every number that shapes a result is either a settable parameter (a field
of the dataclasses behind ``[kspace]``, ``[rpm]``, ``[medium]``,
``[imaging]``, ``[engine]``: :mod:`rpm_cl.cli.config`) or a module-level
constant named in capitals with a ``#:`` comment saying its unit and why it
has its value.  :func:`constants` finds the latter in every module of the
package by reading its source, so that a constant added with its comment is
listed without being registered anywhere.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import pkgutil
from dataclasses import dataclass

__all__ = ["Constant", "constants", "format_constants"]

#: Modules not imported to list constants: entry points (importing runs them).
_SKIP = ("__main__",)


@dataclass(frozen=True)
class Constant:
    """One documented module constant.

    Attributes
    ----------
    module : str
        Dotted module name.
    name : str
    value : object
        A number, or a tuple / dict of numbers.
    doc : str
        Its ``#:`` comment, joined into one paragraph.
    """

    module: str
    name: str
    value: object
    doc: str


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _numeric(v) -> bool:
    """A number, or a flat tuple / list / dict of numbers (not a table)."""
    if _number(v):
        return True
    if isinstance(v, (tuple, list)) and v:
        return all(_number(x) for x in v)
    if isinstance(v, dict) and v:
        return all(_number(x) for x in v.values())
    return False


def _documented(module) -> list[Constant]:
    try:
        src = inspect.getsource(module)
    except (OSError, TypeError):
        return []
    lines = src.splitlines()
    out = []
    group_doc, group_end = "", -1
    for node in ast.parse(src).body:
        targets = (
            node.targets
            if isinstance(node, ast.Assign)
            else [node.target]
            if isinstance(node, ast.AnnAssign)
            else []
        )
        if len(targets) != 1 or not isinstance(targets[0], ast.Name):
            continue
        doc, i = [], node.lineno - 2
        while i >= 0 and lines[i].lstrip().startswith("#:"):
            doc.insert(0, lines[i].lstrip()[2:].strip())
            i -= 1
        # a constant right below another shares its comment (a group such
        # as the grids of one search)
        text = " ".join(doc) if doc else (group_doc if node.lineno - 1 == group_end else "")
        group_doc, group_end = text, node.end_lineno
        name = targets[0].id
        if not (name.isupper() and not name.startswith("_")):
            continue
        value = getattr(module, name, None)
        if _numeric(value) and text:
            out.append(Constant(module.__name__, name, value, text))
    return out


def constants(package: str = "rpm_cl") -> list[Constant]:
    """Every documented numeric constant of ``package``'s modules, by module
    and then in source order."""
    pkg = importlib.import_module(package)
    names = [package] + sorted(
        m.name
        for m in pkgutil.walk_packages(pkg.__path__, package + ".")
        if not m.name.rsplit(".", 1)[-1] in _SKIP and ".kernels" not in m.name
    )
    found = []
    for name in names:
        found += _documented(importlib.import_module(name))
    return found


def format_constants(items: list[Constant], width: int = 88) -> str:
    """The constants as TOML comments (a ``params`` file stays valid TOML:
    they are fixed, not settable)."""
    import textwrap

    out = [
        "# Fixed constants (not settable; each is a named constant in its module,",
        "# with the reason for its value):",
    ]
    module = None
    for c in items:
        if c.module != module:
            module = c.module
            out.append(f"#\n# {module}")
        out += textwrap.wrap(c.doc, width, initial_indent="#   ", subsequent_indent="#   ")
        out.append(f"#   {c.name} = {c.value!r}")
    return "\n".join(out)
