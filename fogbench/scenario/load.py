"""A scenario file's rig part loaded into a :class:`Scenario`: ``[scenario]``, ``[table]``,
``[fog]``, ``[thermal]`` and ``[[runs]]``; the other tables (``RUNNER_SECTIONS``) are kept for
:func:`fogbench.scenario.plan.load_plan`. The file's text goes with it, with what the command
line added (``--with-method``, ``--reference``) written into it."""

from __future__ import annotations

import hashlib
import json
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from fogbench.scenario.device_file import _fog
from fogbench.scenario.environment import reference_override, with_methods
from fogbench.scenario.overrides import apply_overrides
from fogbench.scenario.rig import _check_size, _check_whole_samples, _motion, _table_cfg, _thermal
from fogbench.scenario.tables import ScenarioError, _Table, read_text
from sim.fog import FogParams
from sim.motion import Positions, positions_move_fits
from sim.rate_table import TableConfig
from sim.rig import Rig, Run
from sim.thermal import (
    ThermalModel,
)

__all__ = ["Scenario", "load_scenario", "claim_name"]

# Top-level tables of the compensation part (validated by load_plan below); others are refused.
RUNNER_SECTIONS = ("compensation", "protocols", "methods", "bounds", "paper", "claims",
                   "montecarlo", "map", "lab")


# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Scenario:
    """A validated scenario, SI units inside."""

    path: str
    name: str
    description: str
    fs: float
    table: TableConfig
    fog: FogParams
    fog_preset: str | None
    fog_source: str
    axes: tuple[str, ...]
    runs: tuple[Run, ...]
    ambient_c: float = 20.0
    extra: dict = field(default_factory=dict, compare=False)  # sections later stages read
    text: str = ""
    thermal_model: ThermalModel = ThermalModel()
    fog_changed: dict = field(default_factory=dict, compare=False)  # [fog] keys over the preset
    overrides: dict = field(default_factory=dict, compare=False)    # a claim-map point's values

    @property
    def device(self) -> str:
        """The device this scenario runs, as a report names it: the preset and its source, the
        keys the file sets over it and the values a claim-map point sets (never the preset's
        label alone)."""
        if self.fog_preset is None:
            out = "given in the scenario file"
        elif self.fog_preset.startswith("device file "):
            out = f"{self.fog_preset} ({self.fog_source})"
        else:
            out = f"preset `{self.fog_preset}` ({self.fog_source})"
        by_file = {k: v for k, v in self.fog_changed.items()
                   if f"fog.{k}" not in self.overrides}
        if self.fog_preset is not None and by_file:
            out += "; set over it by the scenario file: " + ", ".join(
                f"{k} = {_short(v)}" for k, v in by_file.items())
        if self.overrides:
            out += "; claim-map point: " + ", ".join(
                f"{k} = {_short(v)}" for k, v in self.overrides.items())
        return out

    @property
    def rig(self) -> Rig:
        """The rig part: what ``sim.simulate_run`` needs besides a run."""
        return Rig(fs=self.fs, table=self.table, fog=self.fog, axes=self.axes,
                   ambient_c=self.ambient_c, thermal=self.thermal_model)

    def run(self, name: str) -> Run:
        for r in self.runs:
            if r.name == name:
                return r
        raise KeyError(f"{self.path}: no run named {name!r}; runs: {[r.name for r in self.runs]}")


def _short(v) -> str:
    t = json.dumps(v)
    return t if len(t) <= 80 else t[:77] + "..."


_PROTOCOLS_HEADER = re.compile(r"[ \t]*\[\[[ \t]*protocols[ \t]*\]\][ \t]*(#.*)?")


def _same_doc(a, b) -> bool:
    """Two parsed TOML documents hold the same values (NaN equal to NaN)."""
    return json.dumps(a, sort_keys=True, default=str) == json.dumps(b, sort_keys=True, default=str)


def _toml_value(v) -> str:
    """A parsed TOML value written back as TOML (inline: tables as { }, on one line)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) \
            else repr(v)
    if isinstance(v, str):   # JSON's escapes are TOML's, but for DEL, which TOML escapes too
        return json.dumps(v, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_toml_value(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    return v.isoformat()     # a date or a time


def _toml_document(doc: dict) -> str:
    """A parsed TOML document written back as TOML: its top-level tables and arrays of tables
    as headers, every value under them inline."""
    def keys(t):
        return "".join(f"{_toml_value(k)} = {_toml_value(v)}\n" for k, v in t.items())

    out = [keys({k: v for k, v in doc.items() if not isinstance(v, dict)
                 and not (isinstance(v, list) and v and all(isinstance(x, dict) for x in v))})]
    for k, v in doc.items():
        if isinstance(v, dict):
            out.append(f"\n[{_toml_value(k)}]\n{keys(v)}")
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            out += [f"\n[[{_toml_value(k)}]]\n{keys(x)}" for x in v]
    return "".join(out)


def _with_references(text: str, which: list[int], names: list[str], value: str) -> str:
    """The scenario's text with ``reference = VALUE`` in its protocols numbered ``which``
    (``--reference VALUE``), so that the text, the run folder's scenario.toml, runs again as it
    ran: a line after each one's ``[[protocols]]`` header. A file whose protocols are not
    written under such headers (inline tables) is written out whole, its own text kept below
    as comments. Either is read back and checked to hold the values the run ran."""
    note = f"  # --reference {value}\n"
    try:
        want = tomllib.loads(text)
        for i in which:
            want["protocols"][i]["reference"] = value
    except (tomllib.TOMLDecodeError, KeyError, IndexError, TypeError):
        # the text's protocols are not the run's (not a file as read): say so in a comment
        return text + (f'\n# --reference {value}: reference = "{value}" set in protocols '
                       + ", ".join(json.dumps(n) for n in names) + "\n")

    def holds(new: str) -> bool:
        try:
            return _same_doc(tomllib.loads(new), want)
        except tomllib.TOMLDecodeError:
            return False

    lines = text.splitlines(keepends=True)
    heads = [i for i, ln in enumerate(lines) if _PROTOCOLS_HEADER.fullmatch(ln.rstrip("\r\n"))]
    if len(heads) == len(want["protocols"]):
        for i in sorted(which, reverse=True):
            h = heads[i]
            lines.insert(h + 1, ("" if lines[h].endswith("\n") else "\n")
                         + f'reference = "{value}"' + note)
        new = "".join(lines)
        if holds(new):
            return new
    new = (f"# --reference {value}: reference = \"{value}\" set in protocols "
           + ", ".join(json.dumps(n) for n in names) + "; the file written out whole (its "
           "own text, as given, is below as comments)\n" + _toml_document(want)
           + "\n# the file as given:\n" + "".join(f"# {ln}\n" for ln in text.splitlines()))
    if not holds(new):
        raise ScenarioError(f"--reference {value}: cannot write the scenario with reference = "
                            f"\"{value}\" set in its protocols (please report this file)")
    return new


def _read_doc(path: Path) -> tuple[str, dict]:
    """(text, parsed document) of a scenario file; a ScenarioError names what is wrong."""
    file = str(path)
    text = read_text(path)
    try:
        return text, tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{file}: not valid TOML ({exc})") from None


def _set_over(doc: dict, text: str, file: str, overrides: dict | None) -> str:
    """Values set over the file's, in ``doc`` and written into the text (so that digests,
    ``--resume`` and the run folder's scenario.toml see them): a claim-map point's, the methods
    of ``--with-method``, the reference of ``--reference``. Returns the text."""
    if overrides is not None:  # a point of the claim map (its own [map] left out)
        doc.pop("map", None)
        apply_overrides(doc, overrides, file)
    if overrides:
        text = text + "\n# claim-map point: these values set over the file's\n" + "".join(
            f"# {k} = {json.dumps(v)}\n" for k, v in overrides.items())
    added = [n for n in with_methods() if isinstance(doc.get("methods"), list)
             and n not in {m.get("name") for m in doc["methods"] if isinstance(m, dict)}]
    if added:
        doc["methods"].extend({"name": n} for n in added)
        text = text + "\n# --with-method: methods added to the file's\n" + "".join(
            f"[[methods]]\nname = {json.dumps(n)}\n" for n in added)
    ref = reference_override()
    if ref in ("lab", "truth") and isinstance(doc.get("protocols"), list):
        # --reference lab | truth: every protocol that does not say its reference is fitted on
        # the lab's (beside its ideal-lab twin) or on the truth alone
        set_ = [i for i, p in enumerate(doc["protocols"])
                if isinstance(p, dict) and "reference" not in p]
        for i in set_:
            doc["protocols"][i]["reference"] = ref
        if set_:
            text = _with_references(text, set_, [str(doc["protocols"][i].get("name"))
                                                 for i in set_], ref)
    return text


def _with_device_text(text: str, path: Path, device) -> str:
    """The text with the device file's own (``[fog] device = "..."``) as comments: a digest
    (--resume), the copy in a run's folder and the report hold what the run ran."""
    if not isinstance(device, str):
        return text
    dpath = path.parent / device
    draw = read_text(dpath, "device file")
    return text + (f"\n# [fog] device = {json.dumps(device)}: that file's text, as this run "
                   f"read it (sha256 {hashlib.sha256(draw.encode()).hexdigest()}):\n"
                   + "".join(f"#   {ln}\n" for ln in draw.splitlines()))


def _run(r: _Table, name: str, fs: float, table: TableConfig, default_thermal) -> Run:
    """One ``[[runs]]`` table: its seed, start tilt, motion segments (each a whole number of
    samples, every positions move within the tilt axis's slew) and thermal program."""
    file = r.file
    seed = r.get("seed", "int", lo=0)
    tilt0 = math.radians(r.get("start_tilt_deg", "float", 0.0, lo=-180.0, hi=180.0))
    segs = []
    for j, mt in enumerate(r.get("motion", "tables")):
        mtab = _Table(mt, f"{r.where} motion[{j}]", file)
        seg = _motion(mtab, fs)
        _check_whole_samples(mtab, seg, fs)
        segs.append(seg)
    if not segs:
        raise r.err("motion", "expected at least one [[runs.motion]] segment")
    tilt = tilt0
    for j, seg in enumerate(segs):
        if isinstance(seg, Positions):
            msg = positions_move_fits(seg, tilt, table.tilt_slew)
            if msg:
                raise ScenarioError(f"{file}: {r.where} motion[{j}] key 'move_s': {msg}")
            tilt = seg.tilts[-1]
        elif seg.tilt is not None:
            tilt = seg.tilt
    thermal = default_thermal
    if r.has("thermal"):
        thermal = _thermal(_Table(r.get("thermal", "table"), f"{r.where} thermal", file))
    r.done()
    return Run(name, seed, tuple(segs), thermal, tilt0)


def _runs(top: _Table, fs: float, table: TableConfig, default_thermal) -> list[Run]:
    """``[[runs]]``: every run, names unique."""
    runs, seen = [], set()
    run_tables = top.get("runs", "tables")
    if not run_tables:
        raise top.err("runs", "expected at least one [[runs]] table")
    for i, rt in enumerate(run_tables):
        r = _Table(rt, f"[[runs]][{i}]", top.file)
        rname = r.get("name", "name")
        if rname in seen:
            raise r.err("name", f"run names must be unique; {rname!r} appears twice")
        seen.add(rname)
        r.where = f"[[runs]] '{rname}'"
        runs.append(_run(r, rname, fs, table, default_thermal))
    return runs


def load_scenario(path: str | Path, extra_sections: tuple[str, ...] = (),
                  overrides: dict | None = None) -> Scenario:
    """Load and validate a scenario file. Raises ScenarioError naming file, key and expectation.

    ``extra_sections`` names further top-level tables that a later stage validates (they are
    kept, unread, in ``Scenario.extra``); any other unknown table is refused. ``overrides``
    (``{dotted path: value}``, :func:`apply_overrides`) change the file's values before it is
    validated: a point of a claim map is the scenario with its axes' values set (its own
    ``[map]`` left out), validated like any file; its text for digests and reports is the file's
    followed by the overrides.
    """
    path = Path(path)
    file = str(path)
    text, doc = _read_doc(path)
    text = _set_over(doc, text, file, overrides)
    top = _Table(doc, "top level", file)
    sc = _Table(top.get("scenario", "table"), "[scenario]", file)
    name = sc.get("name", "name")
    description = sc.get("description", "str", "")
    fs = sc.get("sample_rate_hz", "float", lo=0.0, lo_open=True, hi=10_000.0)
    ambient = sc.get("ambient_c", "float", 20.0, lo=-80.0, hi=150.0)
    sc.done()
    table = _table_cfg(_Table(top.get("table", "table", {}), "[table]", file))
    fog_tbl = _Table(top.get("fog", "table"), "[fog]", file)
    fog, preset, source, axes, thermal_model, changed = _fog(fog_tbl, fs, scenario=True)
    text = _with_device_text(text, path, fog_tbl.data.get("device"))
    default_thermal = None
    if top.has("thermal"):
        default_thermal = _thermal(_Table(top.get("thermal", "table"), "[thermal]", file))
    runs = _runs(top, fs, table, default_thermal)
    _check_size(runs, fs, len(axes), file)
    extra = {}
    for sec in extra_sections:
        if top.has(sec):
            extra[sec] = top.get(sec, "any")
    # every table a scenario may hold is listed when an unknown one is refused, present or not
    top.used |= {"scenario", "table", "fog", "thermal", "runs", *extra_sections}
    top.done()
    return Scenario(path=file, name=name, description=description, fs=fs, table=table, fog=fog,
                    fog_preset=preset, fog_source=source, axes=axes, runs=tuple(runs),
                    ambient_c=ambient, extra=extra, text=text, thermal_model=thermal_model,
                    fog_changed=changed, overrides=dict(overrides or {}))


def claim_name(first_file: dict, sc: Scenario, path) -> None:
    """Record that ``path`` holds scenario ``sc``; refuse a name another file in the same set
    already has (each scenario names its report folder)."""
    if sc.name in first_file:
        raise ScenarioError(f"{path}: [scenario] key 'name': {sc.name!r} is also the name of "
                            f"{first_file[sc.name]}; scenario names must be unique in a suite "
                            "(each names its report folder)")
    first_file[sc.name] = path
