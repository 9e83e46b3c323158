"""The direction of dependencies is a law: fogbench -> sim, fogbench -> fogcomp, never back.

``fogcomp`` (the library under test) imports nothing of ``sim`` or ``fogbench``; ``sim`` (the rig)
imports nothing of ``fogbench`` and of ``fogcomp`` only ``fogcomp.units``. Read from the source
with ``ast`` (every import, at any depth: a lazy import inside a function counts too).
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# package -> (forbidden top-level packages, allowed exceptions "pkg.module")
RULES = {
    "fogcomp": ({"sim", "fogbench"}, set()),
    "sim": ({"fogbench", "fogcomp"}, {"fogcomp.units"}),
}


def imports_of(path: Path) -> list[tuple[int, str]]:
    """(line, absolute module name) of every import in ``path``; relative ones resolved."""
    tree = ast.parse(path.read_text(), filename=str(path))
    pkg_parts = path.relative_to(ROOT).with_suffix("").parts[:-1]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = list(pkg_parts[: len(pkg_parts) - node.level + 1])
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            # "from fogcomp import units" imports the module fogcomp.units
            out += [(node.lineno, f"{mod}.{a.name}") for a in node.names]
    return out


def violations(package: str) -> list[str]:
    forbidden, allowed = RULES[package]
    bad = []
    for path in sorted((ROOT / package).rglob("*.py")):
        for line, mod in imports_of(path):
            top = mod.split(".")[0]
            if top in forbidden and not any(mod == a or mod.startswith(a + ".") for a in allowed):
                bad.append(f"{path.relative_to(ROOT)}:{line} imports {mod}")
    return bad


@pytest.mark.parametrize("package", sorted(RULES))
def test_dependencies_point_one_way(package):
    assert violations(package) == []


def test_the_law_can_fail(tmp_path, monkeypatch):
    """The checker itself: a module of sim importing fogbench (directly, relatively or lazily)
    and a fogcomp module importing sim are each caught, with file and import named."""
    fake = tmp_path / "sim"
    fake.mkdir()
    (fake / "a.py").write_text("import fogbench.run.runner\n")
    (fake / "b.py").write_text("def f():\n    from fogbench import cli\n")
    (fake / "c.py").write_text("from fogcomp import metrics\nfrom fogcomp.units import DPH\n")
    (tmp_path / "fogcomp").mkdir()
    (tmp_path / "fogcomp" / "d.py").write_text("from ..sim import fog\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    bad = violations("sim") + violations("fogcomp")
    assert bad == ["sim/a.py:1 imports fogbench.run.runner", "sim/b.py:2 imports fogbench.cli",
                   "sim/c.py:1 imports fogcomp.metrics", "fogcomp/d.py:1 imports sim.fog"]


def modules(root: Path = None) -> dict[str, Path]:
    """Every module of the three packages by its dotted name (a package by its own name)."""
    root = ROOT if root is None else root
    out = {}
    for top in ("sim", "fogcomp", "fogbench"):
        for path in sorted((root / top).rglob("*.py")):
            parts = path.relative_to(root).with_suffix("").parts
            out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


def import_graph(root: Path = None) -> dict[str, set[str]]:
    """Module -> the modules of the three packages it imports (at any depth, lazily too); a
    name imported from a module (``from a.b import c``) counts as an import of ``a.b`` unless
    ``a.b.c`` is itself a module. ``python -m fogbench`` (``__main__``) is the entry point,
    not part of the graph."""
    mods = modules(root)
    graph = {}
    for me, path in mods.items():
        if me.endswith("__main__"):
            continue
        deps = set()
        for _, mod in imports_of(path) if root is None else _imports_under(path, root):
            parts = mod.split(".")
            for k in range(len(parts), 0, -1):
                cand = ".".join(parts[:k])
                if cand in mods:
                    deps.add(cand)
                    break
        graph[me] = deps - {me}
    return graph


def _imports_under(path: Path, root: Path):
    global ROOT
    keep, ROOT = ROOT, root
    try:
        return imports_of(path)
    finally:
        ROOT = keep


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm): each a
    set of modules that import one another through a chain."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in graph:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10_000))
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_cycle_anywhere():
    """No module of sim, fogcomp or fogbench imports itself through a chain of imports, a
    package's ``__init__`` included (lazy imports inside functions count)."""
    assert cycles(import_graph()) == []


def test_the_cycle_check_can_fail(tmp_path, monkeypatch):
    """The checker itself: a chain a -> b -> c -> a through a lazy and a relative import, and a
    package whose __init__ imports a module that imports the package back, are caught."""
    pkg = tmp_path / "fogcomp"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from fogcomp.b import x\n")
    (pkg / "b.py").write_text("def f():\n    from . import c\n")
    (pkg / "c.py").write_text("import fogcomp.a\n")
    (pkg / "sub" / "__init__.py").write_text("from fogcomp.sub.d import y\n")
    (pkg / "sub" / "d.py").write_text("from fogcomp.sub import z\n")
    (pkg / "e.py").write_text("from fogcomp.a import x\n")
    for top in ("sim", "fogbench"):
        (tmp_path / top).mkdir()
    assert cycles(import_graph(tmp_path)) == [["fogcomp.a", "fogcomp.b", "fogcomp.c"],
                                              ["fogcomp.sub", "fogcomp.sub.d"]]


#: The bench's floors, top to bottom: a module imports modules of its own floor or below, never
#: above. The command line on top; the benchmarks; devices and real logs; running, reporting and
#: recording (one floor: a run writes its report, a report shows a run's results); the log formats;
#: scenario files; what every floor shares (files, output folders, interruptions, the console).
FLOORS = (("cli",), ("bench",), ("device",), ("logs",), ("run", "report", "recording"),
          ("formats",), ("scenario",), ("outputs", "console"))


def floor_of(module: str) -> int | None:
    parts = module.split(".")
    if parts[0] != "fogbench" or len(parts) < 2:
        return None
    return next((i for i, names in enumerate(FLOORS) if parts[1] in names), None)


def test_every_bench_module_is_on_a_floor():
    """A new subpackage of fogbench is placed on a floor (else its imports go unchecked)."""
    loose = [m for m in modules() if m.count(".") >= 1 and m.startswith("fogbench.")
             and not m.endswith("__main__") and floor_of(m) is None]
    assert loose == []


def test_the_bench_imports_only_downwards():
    """cli on top, then the benchmarks, devices, logs, run/report/recording, formats, scenario,
    the shared outputs; sim and fogcomp at the bottom (checked above)."""
    up = [f"{a} imports {b}" for a, deps in import_graph().items() for b in sorted(deps)
          if floor_of(a) is not None and floor_of(b) is not None and floor_of(b) < floor_of(a)]
    assert up == []


def test_every_package_directory_is_installed():
    """``pip install .`` (not editable) installs only the packages pyproject.toml lists: a
    subpackage missing from the list (``fogbench.logs`` was, after the split of
    ``reallog.py``) imports from a clone and fails for a user who installed the wheel."""
    import tomllib

    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
                 ["packages"])
    found = {".".join(p.parent.relative_to(ROOT).parts)
             for top in ("sim", "fogcomp", "fogbench") for p in (ROOT / top).rglob("__init__.py")}
    assert found == listed
