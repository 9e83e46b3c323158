"""The ``fogbench-scenario-keys`` directive: a table per section of a scenario file, every key
with its kind, range or choices and default, made from the validator's own record of what it
reads (:func:`fogbench.scenario.schema.keys_by_section`) over the bundled scenarios, maps and
device files. Its argument is the annotated example (a TOML file beside the page): a key of the
tables that the example does not name is a build warning, so an undocumented key fails the
``-W`` build.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

from docutils import nodes
from sphinx.util import logging
from sphinx.util.docutils import SphinxDirective

logger = logging.getLogger(__name__)

KINDS = {"float": "number", "int": "integer", "str": "string", "bool": "true / false",
         "floats": "list of numbers", "ints": "list of integers", "strs": "list of strings",
         "name": "name (A-Z a-z 0-9 _ . -)", "table": "table", "tables": "array of tables",
         "any": "see the example"}

#: Sections whose keys are the table names of a scenario (documented by their own tables).
SKIP = {"top level"}


def _number(v) -> str:
    if isinstance(v, float) and v.is_integer() and abs(v) < 1e15:
        return f"{v:g}"
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)


def _range(info) -> str:
    if info.choices:
        return ", ".join(f"`{c}`" for c in sorted(map(str, info.choices)))
    lo = None if info.lo is None else _number(info.lo)
    hi = None if info.hi is None else _number(info.hi)
    if lo is not None and hi is not None:
        return f"{'(' if info.lo_open else '['}{lo}, {hi}]"
    if lo is not None:
        return f"{'>' if info.lo_open else '>='} {lo}"
    if hi is not None:
        return f"<= {hi}"
    return ""


def _default(info, section: str) -> str:
    if info.required and not info.defaults:
        return "required"
    shown = []
    for d in info.defaults:
        if d is None and section in ("[fog]", "device file") and info.key not in (
                "preset", "device"):
            shown.append("the preset's, else the simulator's (0: off)")
        elif d is None:
            shown.append("none")
        elif isinstance(d, float) and not math.isfinite(d):
            shown.append(str(d))
        elif isinstance(d, (bool, int, float, str)):
            shown.append(f"`{str(d).lower() if isinstance(d, bool) else _number(d)}`")
        elif isinstance(d, (list, tuple)) and len(str(d)) < 40:
            shown.append(f"`{list(d)}`")
        else:
            shown.append("(computed)")
    text = " or ".join(dict.fromkeys(shown))
    return ("required here; " + text) if info.required else text


def _table(rows: list[list[str]]) -> nodes.table:
    """A docutils table of literal-marked cells (``code`` between backquotes)."""
    table = nodes.table()
    group = nodes.tgroup(cols=4)
    table += group
    for w in (22, 18, 30, 30):
        group += nodes.colspec(colwidth=w)
    head = nodes.thead()
    body = nodes.tbody()
    group += head
    group += body
    for i, row in enumerate(rows):
        tr = nodes.row()
        for cell in row:
            entry = nodes.entry()
            para = nodes.paragraph()
            for j, part in enumerate(re.split(r"`([^`]*)`", cell)):
                para += nodes.literal(part, part) if j % 2 else nodes.Text(part)
            entry += para
            tr += entry
        (head if i == 0 else body).append(tr)
    return table


class ScenarioKeys(SphinxDirective):
    required_arguments = 1     # the annotated example, relative to the page

    def run(self):
        from fogbench.scenario.schema import keys_by_section

        root = Path(self.env.app.confdir).parent
        paths = sorted((root / "scenarios").glob("*.toml")) + \
            sorted((root / "scenarios" / "maps").glob("*.toml")) + \
            sorted((root / "scenarios" / "devices").glob("*.toml"))
        example_path = Path(self.env.relfn2path(self.arguments[0])[1])
        self.env.note_dependency(str(example_path))
        example = example_path.read_text()
        sections = keys_by_section(paths)
        out = []
        for sec, keys in sections.items():
            if sec in SKIP:
                continue
            out.append(nodes.rubric(text=sec))
            rows = [["key", "kind", "range or choices", "default"]]
            for key, info in keys.items():
                rows.append([f"`{key}`", " or ".join(KINDS.get(k, k) for k in info.kinds),
                             _range(info), _default(info, sec)])
                if sec != "device file" and not re.search(rf"\b{re.escape(key)}\b", example):
                    logger.warning(f"scenario key {sec} {key!r} is not named in the annotated "
                                   f"example {example_path.name}: say what it means there",
                                   location=self.get_location())
            out.append(_table(rows))
        return out


def setup(app):
    app.add_directive("fogbench-scenario-keys", ScenarioKeys)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
