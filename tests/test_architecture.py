"""The package's layering (docs/architecture.md): every import of
rpm_cl's own modules, at module level or inside a function, goes to the
same floor or a lower one, and no modules import each other in a cycle."""

import ast
from collections import defaultdict
from pathlib import Path

import rpm_cl

ROOT = Path(rpm_cl.__file__).parent

#: Floors, lowest first: a module may import its own floor's and lower
#: floors' modules.  Keys are the first name under rpm_cl (a package or a
#: top-level module); "" is the package itself (__init__: version, names);
#: "kernels" the OpenCL sources (a package of data once installed).
FLOORS = [
    {"", "lazy", "progress", "ending", "cl", "filters", "heap", "transforms", "kernels"},
    {"io"},
    {"extract", "simulate", "metrics"},
    {"result"},
    {"rpm", "baselines"},
    {"imaging"},
    {"viz"},
    {"cli"},
    {"_entry", "__main__"},
]
FLOOR = {name: i for i, names in enumerate(FLOORS) for name in names}
#: Entry points (run, never imported): the command's start-up.
ENTRY = {"rpm_cl.__main__", "rpm_cl.cli.__main__", "rpm_cl._entry"}


def _modules():
    mods = {}
    for p in ROOT.rglob("*.py"):
        parts = p.relative_to(ROOT.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        mods[name] = p
    return mods


def _imports(mods):
    deps = defaultdict(set)
    for name, path in mods.items():
        pkg = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = pkg.split(".")[: len(pkg.split(".")) - (node.level - 1)]
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                found = {target} if target in mods else set()
                found |= {f"{target}.{a.name}" for a in node.names} & set(mods)
                deps[name] |= found
            elif isinstance(node, ast.Import):
                deps[name] |= {a.name for a in node.names if a.name in mods}
        deps[name].discard(name)
    return deps


def _group(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def test_every_module_has_a_floor():
    missing = sorted({_group(m) for m in _modules()} - set(FLOOR))
    assert not missing, f"rpm_cl modules on no floor of docs/architecture.md: {missing}"


def test_imports_go_down_or_sideways_within_a_floor():
    mods = _modules()
    up = []
    for a, targets in _imports(mods).items():
        if a in ENTRY:
            continue
        for b in targets:
            if FLOOR[_group(b)] > FLOOR[_group(a)]:
                up.append(f"{a} -> {b}")
    assert not up, "imports of a higher floor:\n" + "\n".join(sorted(up))


def test_floors_do_not_import_each_other_sideways():
    """Packages on one floor stay apart (rpm and baselines; extract,
    simulate and metrics)."""
    bad = [
        f"{a} -> {b}"
        for a, targets in _imports(_modules()).items()
        if a not in ENTRY
        for b in targets
        if _group(a) != _group(b) and FLOOR[_group(a)] == FLOOR[_group(b)] and _group(b)
    ]
    assert not bad, "\n".join(sorted(bad))


def test_no_import_cycles():
    mods = _modules()
    deps = {
        a: {b for b in t if b not in ENTRY} for a, t in _imports(mods).items() if a not in ENTRY
    }
    index, low, stack, on, cycles = {}, {}, [], set(), []

    def visit(v):  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in deps.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on.discard(w)
                comp.add(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in sorted(mods):
        if v not in index and v not in ENTRY:
            visit(v)
    assert not cycles, f"modules that import each other: {cycles}"
