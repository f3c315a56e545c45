"""Every number that shapes a result is named once and documented: the
module constants (capitals, a ``#:`` comment with unit and reason) are all
found by rpm_cl.cli.constants and printed by ``rpm-cl params``."""

import ast
import importlib
import inspect
import pkgutil

import tomllib

import rpm_cl
from rpm_cl.cli import main
from rpm_cl.cli.constants import _numeric, constants, format_constants


def _all_numeric_constants():
    names = ["rpm_cl"] + sorted(
        m.name
        for m in pkgutil.walk_packages(rpm_cl.__path__, "rpm_cl.")
        if not m.name.endswith("__main__") and ".kernels" not in m.name
    )
    found = set()
    for n in names:
        mod = importlib.import_module(n)
        for node in ast.parse(inspect.getsource(mod)).body:
            t = (
                node.targets
                if isinstance(node, ast.Assign)
                else ([node.target] if isinstance(node, ast.AnnAssign) else [])
            )
            if len(t) == 1 and isinstance(t[0], ast.Name):
                name = t[0].id
                public = name.isupper() and not name.startswith("_")
                if public and _numeric(getattr(mod, name, None)):
                    found.add((n, name))
    return found


def test_every_numeric_constant_is_documented():
    listed = {(c.module, c.name) for c in constants()}
    undocumented = sorted(_all_numeric_constants() - listed)
    assert not undocumented, f"constants without a #: comment: {undocumented}"
    assert len(listed) >= 100
    assert all(len(c.doc) > 10 for c in constants())


def test_params_lists_them_and_stays_toml(p2, capsys):
    assert main(["params", str(p2)]) == 0
    out = capsys.readouterr().out
    tomllib.loads(out)  # the constants are comments: the file reads back
    for c in constants():
        assert f"#   {c.name} = " in out, c.name
    assert format_constants(constants()) in out
