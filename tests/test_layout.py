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
    (fake / "a.py").write_text("import fogbench.runner\n")
    (fake / "b.py").write_text("def f():\n    from fogbench import cli\n")
    (fake / "c.py").write_text("from fogcomp import metrics\nfrom fogcomp.units import DPH\n")
    (tmp_path / "fogcomp").mkdir()
    (tmp_path / "fogcomp" / "d.py").write_text("from ..sim import fog\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    bad = violations("sim") + violations("fogcomp")
    assert bad == ["sim/a.py:1 imports fogbench.runner", "sim/b.py:2 imports fogbench.cli",
                   "sim/c.py:1 imports fogcomp.metrics", "fogcomp/d.py:1 imports sim.fog"]


def test_no_circular_imports_within_fogbench():
    """No two modules of the bench import each other (directly or through a chain)."""
    graph = {}
    for path in sorted((ROOT / "fogbench").glob("*.py")):
        me = f"fogbench.{path.stem}"
        graph[me] = {".".join(m.split(".")[:2]) for _, m in imports_of(path)
                     if m.startswith("fogbench.")} - {me}
    graph = {k: {v for v in vs if v in graph} for k, vs in graph.items()}

    def reach(a, seen=None):
        seen = set() if seen is None else seen
        for b in graph[a]:
            if b not in seen:
                seen.add(b)
                reach(b, seen)
        return seen

    cycles = sorted(a for a in graph if a in reach(a))
    assert cycles == [], f"modules on an import cycle: {cycles}"


def test_every_package_directory_is_installed():
    """``pip install .`` (not editable) installs only the packages pyproject.toml lists: a
    subpackage missing from the list (``fogbench.reallog`` was, after the split of
    ``reallog.py``) imports from a clone and fails for a user who installed the wheel."""
    import tomllib

    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
                 ["packages"])
    found = {".".join(p.parent.relative_to(ROOT).parts)
             for top in ("sim", "fogcomp", "fogbench") for p in (ROOT / top).rglob("__init__.py")}
    assert found == listed
