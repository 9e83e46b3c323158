"""The direction of dependencies is a law: fogbench -> sim, fogbench -> fogcomp, never back.

``fogcomp`` (the library under test) imports nothing of ``sim`` or ``fogbench``; ``sim`` (the rig)
imports nothing of ``fogbench`` and of ``fogcomp`` only ``fogcomp.units``. Read from the source
with ``ast`` (every import, at any depth: a lazy import inside a function counts too).
"""

from __future__ import annotations

import ast
import itertools
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


def import_graph() -> dict[str, set[str]]:
    """Module -> the modules of the three packages it imports (at any depth, lazily too; a
    name imported from a module counts as an import of that module). ``python -m fogbench``
    (``__main__``) is the entry point, not part of the graph."""
    mods = {m: p for top in ("sim", "fogcomp", "fogbench") for m, p in modules_of(top).items()}
    graph = {}
    for me, path in mods.items():
        if me.endswith("__main__"):
            continue
        deps = set()
        for _, mod in imports_of(path):
            parts = mod.split(".")
            target = next((".".join(parts[:k]) for k in range(len(parts), 0, -1)
                           if ".".join(parts[:k]) in mods), None)
            if target is not None:
                deps.add(target)
        graph[me] = deps - {me}
    return graph


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
    loose = [m for m in modules_of("fogbench") if m.count(".") >= 1
             and not m.endswith("__main__") and floor_of(m) is None]
    assert loose == []


def upward(graph: dict[str, set[str]]) -> list[str]:
    """Every import of a bench module from a floor above its own."""
    return [f"{a} imports {b}" for a, deps in graph.items() for b in sorted(deps)
            if floor_of(a) is not None and floor_of(b) is not None and floor_of(b) < floor_of(a)]


def test_the_bench_imports_only_downwards():
    """cli on top, then the benchmarks, devices, logs, run/report/recording, formats, scenario,
    the shared outputs; sim and fogcomp at the bottom (checked above)."""
    assert upward(import_graph()) == []


def test_the_floor_check_can_fail():
    """A scenario module importing the runner, and the report importing a command, are caught;
    run and report importing each other (one floor) and anything importing sim are not."""
    graph = {"fogbench.scenario.plan": {"fogbench.run.runner", "sim.fog"},
             "fogbench.report.rundir": {"fogbench.cli.run", "fogbench.run.runner"},
             "fogbench.run.suite": {"fogbench.report.rundir"}}
    assert upward(graph) == ["fogbench.scenario.plan imports fogbench.run.runner",
                             "fogbench.report.rundir imports fogbench.cli.run"]


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


def modules_of(package: str) -> dict[str, Path]:
    """``{module name: file}`` of ``package`` and its subpackages (a package is its
    ``__init__``)."""
    files = {}
    for path in sorted((ROOT / package).rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        files[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return files


def module_graph(package: str) -> dict[str, dict[str, int]]:
    """``{module: {imported module of the same package: line}}`` for every module of
    ``package``, every import at any depth (a lazy import inside a function counts), relative
    ones resolved. An imported name is charged to the longest module path it starts with:
    ``from .noise import avar_gm`` is an import of ``noise`` (its ``__init__`` when it is a
    package), ``from . import methods`` one of ``methods``."""
    files = modules_of(package)
    graph = {}
    for me, path in files.items():
        graph[me] = {}
        for line, mod in imports_of(path):
            parts = mod.split(".")
            target = next((".".join(parts[:k]) for k in range(len(parts), 0, -1)
                           if ".".join(parts[:k]) in files), None)
            if target is not None and target != me:
                graph[me].setdefault(target, line)
    return graph


def import_cycles(package: str) -> list[str]:
    """Each set of modules of ``package`` that import one another in a ring (a strongly
    connected component of the import graph with more than one module), written as its
    shortest ring through its first module, with the line of each import:
    ``fogcomp.allan (fogcomp/allan.py:616) -> fogcomp.noise (...) -> fogcomp.allan``."""
    graph, files = module_graph(package), modules_of(package)
    index, low, stack, comps = {}, {}, [], []

    def connect(v):                      # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = stack[stack.index(v):]
            del stack[stack.index(v):]
            comps.append(set(comp))

    for v in sorted(graph):
        if v not in index:
            connect(v)
    out = []
    for comp in (c for c in comps if len(c) > 1):
        start = min(comp)
        came = {w: start for w in sorted(graph[start]) if w in comp}
        queue = list(came)               # breadth first, inside the component, back to start
        while start not in came:
            v = queue.pop(0)
            for w in sorted(graph[v]):
                if w in comp and w not in came:
                    came[w] = v
                    queue.append(w)
        ring = [start]
        while ring[-1] != start or len(ring) == 1:
            ring.append(came[ring[-1]])
        ring.reverse()
        hops = [f"{a} ({files[a].relative_to(ROOT)}:{graph[a][b]})"
                for a, b in itertools.pairwise(ring)]
        out.append(" -> ".join(hops + [start]) + f"  [ring of {sorted(comp)}]")
    return sorted(out)


@pytest.mark.parametrize("package", ["fogcomp", "sim", "fogbench"])
def test_no_import_cycles(package):
    """No module of the library (or of the rig, or of the bench) imports, directly or through others, a module
    that imports it back: each module has a place in one order, the lower ones never needing
    the higher. A lazy import inside a function counts: it hides the ring from Python at import
    time, not from a reader."""
    assert import_cycles(package) == []


def test_the_cycle_check_can_fail(tmp_path, monkeypatch):
    """The checker itself: a lazy relative import closing a ring of two, and a ring of three
    through a subpackage's ``__init__`` and a ``from . import``, are each found; a chain that
    does not close is not."""
    pkg = tmp_path / "fogcomp"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("from .a import f\n")
    (pkg / "a.py").write_text("def f():\n    from .b import g\n    return g\n")
    (pkg / "b.py").write_text("import math\n\nfrom fogcomp.a import f\n")
    (pkg / "c.py").write_text("from .sub import h\n")
    (pkg / "sub" / "__init__.py").write_text("from .. import d\nh = 1\n")
    (pkg / "d.py").write_text("def k():\n    import fogcomp.c\n")
    (pkg / "e.py").write_text("from .a import f\nfrom .sub import h\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    assert import_cycles("fogcomp") == [
        ("fogcomp.a (fogcomp/a.py:2) -> fogcomp.b (fogcomp/b.py:3) -> fogcomp.a  "
         "[ring of ['fogcomp.a', 'fogcomp.b']]"),
        ("fogcomp.c (fogcomp/c.py:1) -> fogcomp.sub (fogcomp/sub/__init__.py:1) -> fogcomp.d "
         "(fogcomp/d.py:2) -> fogcomp.c  [ring of ['fogcomp.c', 'fogcomp.d', 'fogcomp.sub']]")]
