"""``fogbench check``: scenario files, map files and device files validated whole, nothing
simulated or written; a folder stands for every ``*.toml`` in it and in its ``maps/`` and
``devices/`` subfolders."""

from __future__ import annotations

from pathlib import Path
from typing import Iterator

from fogbench.scenario.device_file import is_device_file, load_device_file
from fogbench.scenario.load import RUNNER_SECTIONS, claim_name, load_scenario
from fogbench.scenario.maps import map_file_scenario
from fogbench.scenario.plan import load_map_file, load_plan
from fogbench.scenario.tables import ScenarioError

__all__ = ["check_files"]


def _expand(paths: list[str]) -> Iterator[tuple[str | None, str | None]]:
    """(file, None) for every file to check, or (None, error) for a folder with none."""
    for path in paths:  # a folder: every scenario file in it (as fogbench suite reads)
        if Path(path).is_dir():
            # its scenario files, and the claim maps and device files of the layout
            # scenarios/ has (maps/, devices/); not every folder below (a .venv, outputs)
            found = sorted(Path(path).glob("*.toml")) + sorted(
                f for sub in ("maps", "devices") for f in (Path(path) / sub).glob("*.toml"))
            if not found:
                yield None, f"{path}: no scenario file (*.toml) in this folder"
            for f in found:
                yield str(f), None
        else:
            yield path, None


def _check_one(path: str, first_file: dict) -> str:
    """The line that says what ``path`` is and that it is valid; raises ScenarioError."""
    target = map_file_scenario(path)
    if target is not None:   # a map file: its scenario and its [map], every point
        sc = load_scenario(target, extra_sections=RUNNER_SECTIONS)
        spec = load_map_file(path, sc, load_plan(sc))
        return (f"{path}: ok: claim map of {target} ({sc.name!r}), {len(spec.points)} "
                f"point(s) over {', '.join(a.name for a in spec.axes)}")
    if is_device_file(path):   # a device file ([fog] device = "..." names it)
        try:
            vals = load_device_file(path)
        except ScenarioError as exc:
            raise ScenarioError(f"{exc} (checked as a device file: it has none of a "
                                "scenario's tables, [scenario], [[runs]], [fog], ...)") from None
        from fogbench.scenario.device_triad import TRIAD_AXES, is_triad

        if is_triad(vals):
            return (f"{path}: ok: triad device file, " + ", ".join(
                f"[{a}] {len(vals[a])} key(s)" for a in TRIAD_AXES) + ", top level "
                f"{len(set(vals) - {'source', *TRIAD_AXES})} key(s)")
        return f"{path}: ok: device file, {len(set(vals) - {'source'})} key(s)"
    sc = load_scenario(path, extra_sections=RUNNER_SECTIONS)
    plan = load_plan(sc)
    claim_name(first_file, sc, path)  # as fogbench suite refuses two with one name
    n = sum(r.duration for r in sc.runs) * sc.fs
    return (f"{path}: ok: scenario {sc.name!r}, {len(sc.runs)} run(s), {n:.0f} samples, "
            f"{len(plan.protocols)} protocol(s), {len(plan.methods)} method(s), "
            f"{plan.replicates} replicate(s)"
            + (f"; a claim map of {len(plan.map.points)} point(s)" if plan.map else ""))


def check_files(paths: list[str]) -> Iterator[tuple[bool, str]]:
    """(ok, line) for every file of ``paths`` (folders expanded), in order: every file is
    checked and reported, not only up to the first bad one."""
    first_file: dict = {}
    for path, problem in _expand(paths):
        if path is None:
            yield False, problem
            continue
        try:
            yield True, _check_one(path, first_file)
        except ScenarioError as exc:
            yield False, str(exc)
