"""The scenario file's keys as the validator itself reads them: every scenario, map and device
file given is loaded with each read recorded (:class:`~fogbench.scenario.tables.Read`: the
table, key, kind, range, choices, default), and the reads are gathered by section. The
reference's tables of keys are made from this (``docs/_ext/scenario_keys.py``), so they cannot
drift from what a scenario accepts; a key the files given never reach is not in them, which is
why the reference reads the bundled scenarios with :data:`COVERAGE` beside them.
"""

from __future__ import annotations

import contextlib
import re
from dataclasses import dataclass, field
from pathlib import Path

from fogbench.scenario.tables import Read, _Table

__all__ = ["KeyInfo", "record_reads", "keys_by_section", "section_of", "COVERAGE"]

#: Tables the bundled scenarios do not reach, each a minimal scenario that does (written to a
#: temporary folder and loaded like the others).
COVERAGE = {
    "motion_kinds.toml": """
[scenario]
name = "coverage_motion"
sample_rate_hz = 100.0
[fog]
preset = "tactical"
[[runs]]
name = "a"
seed = 1
[[runs.motion]]
type = "rate"
duration_s = 1.0
rate_dps = 10.0
[[runs.motion]]
type = "rate_steps"
rates_dps = [1.0, 2.0]
step_s = 1.0
[[runs.motion]]
type = "sine"
duration_s = 1.0
amplitude_dps = 1.0
frequency_hz = 1.0
[[runs.motion]]
type = "positions"
tilts_deg = [0.0]
headings_deg = [0.0, 90.0]
move_s = 5.0
dwell_s = 1.0
[runs.thermal]
start_c = 20.0
[[runs.thermal.steps]]
ramp_to_c = 21.0
rate_c_per_min = 1.0
[[protocols]]
name = "p"
fit = [{ run = "a", end_s = 2.0 }]
score = [{ run = "a", start_s = 2.0 }]
[[methods]]
name = "kalman"
[map]
[[map.axes]]
name = "noise"
source = "the keys a bundled map does not use"
key = "fog.arw_deg_rt_h"
values = [0.01, 0.02]
labels = ["low", "high"]
""",
}


@dataclass
class KeyInfo:
    """What the validator accepts for one key of one section, gathered over every read of
    it: its kinds, range, choices, default (``None`` when every read has none, ``...`` when
    required) and whether it is required somewhere."""

    key: str
    kinds: list[str] = field(default_factory=list)
    lo: object = None
    hi: object = None
    lo_open: bool = False
    choices: set | None = None
    defaults: list = field(default_factory=list)
    required: bool = False

    def add(self, r: Read) -> None:
        if r.kind not in self.kinds:
            self.kinds.append(r.kind)
        if r.lo is not None:
            self.lo = r.lo if self.lo is None else min(self.lo, r.lo)
            self.lo_open = r.lo_open
        if r.hi is not None:
            self.hi = r.hi if self.hi is None else max(self.hi, r.hi)
        if r.choices is not None:
            self.choices = set(r.choices) | (self.choices or set())
        if r.default is ...:
            self.required = True
        elif not any(_same(r.default, d) for d in self.defaults):
            self.defaults.append(r.default)


def _same(a, b) -> bool:
    try:
        return bool(a == b) and type(a) is type(b)
    except Exception:  # noqa: BLE001 - arrays and the like: not the same default
        return False


_SECTIONS = [  # (pattern on the table's name with names and indices removed, section)
    (r"^\[\[runs\]\] motion$", "[[runs.motion]]"),
    (r"^\[\[runs\]\] thermal$", "[runs.thermal]"),
    (r"^\[\[runs\]\] thermal steps$", "[[runs.thermal.steps]]"),
    (r"^\[thermal\] steps$", "[[thermal.steps]]"),
    (r"^\[\[protocols\]\] (fit|score)$", "[[protocols]] fit / score selection"),
    (r"^\[\[map\.axes\]\] points$", "[[map.axes.points]]"),
    (r"^device file$", "device file"),
]


def section_of(where: str) -> str:
    """The section a table belongs to, from the name errors give it (``[[runs]] 'test1'
    motion[0]`` is ``[[runs.motion]]``)."""
    w = re.sub(r"'[^']*'", "", where)
    w = re.sub(r"\[\d+\]", "", w)
    w = " ".join(w.split())
    for pat, name in _SECTIONS:
        if re.match(pat, w):
            return name
    return w


@contextlib.contextmanager
def record_reads():
    """Every :class:`Read` the validator makes inside the block, in a list."""
    calls: list = []
    before, _Table.recorder = _Table.recorder, calls
    try:
        yield calls
    finally:
        _Table.recorder = before


def _load_any(path: Path) -> None:
    from fogbench.scenario.device_file import is_device_file, load_device_file
    from fogbench.scenario.load import RUNNER_SECTIONS, load_scenario
    from fogbench.scenario.maps import map_file_scenario
    from fogbench.scenario.plan import load_map_file, load_plan

    target = map_file_scenario(path)
    if target is not None:
        sc = load_scenario(target, extra_sections=RUNNER_SECTIONS)
        load_map_file(path, sc, load_plan(sc))
    elif is_device_file(path):
        load_device_file(path)
    else:
        load_plan(load_scenario(path, extra_sections=RUNNER_SECTIONS))


def keys_by_section(paths) -> dict[str, dict[str, KeyInfo]]:
    """Section -> key -> :class:`KeyInfo`, in the order the validator first reads them, over
    every file of ``paths`` (scenario, map and device files) and :data:`COVERAGE`. A file that
    does not validate raises its :class:`~fogbench.scenario.tables.ScenarioError`."""
    import tempfile

    out: dict[str, dict[str, KeyInfo]] = {}
    with tempfile.TemporaryDirectory() as d, record_reads() as calls:
        extra = []
        for name, text in COVERAGE.items():
            p = Path(d) / name
            p.write_text(text)
            extra.append(p)
        for path in [*map(Path, paths), *extra]:
            _load_any(path)
    for r in calls:
        sec = section_of(r.where)
        out.setdefault(sec, {}).setdefault(r.key, KeyInfo(r.key)).add(r)
    return out
