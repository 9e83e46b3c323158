"""Scenario files (TOML) loaded into frozen, validated objects in SI units: the whole file, here.

Every key a person writes carries its unit in its name (``rate_dps``, ``arw_deg_rt_h``); the
loader converts once, here. An unknown key, a missing required key, a wrong type or a value out
of range is refused with a :class:`ScenarioError` naming the file, the key and what was expected.

The modules, in the order a file is read: :mod:`.tables` (a TOML table read key by key, each
read recorded as the schema), :mod:`.load` (``[scenario]``, ``[table]``, ``[fog]``,
``[thermal]``, ``[[runs]]`` into a :class:`Scenario`), :mod:`.rig` (the table, the thermal
programs and the motion segments), :mod:`.device_file` (``[fog]`` and device files),
:mod:`.plan` (protocols, methods, bounds, claims, Monte Carlo, the lab: a :class:`Plan`),
:mod:`.protocols` (which samples a protocol fits and scores), :mod:`.sweeps`, :mod:`.maps` and
:mod:`.overrides` (claim maps: the scenario at other values of its keys), :mod:`.environment`
(what the command line sets for every scenario a process loads)."""

from __future__ import annotations

from fogbench.scenario.load import Scenario, claim_name, load_scenario
from fogbench.scenario.maps import MapAxis, MapPoint, MapSpec
from fogbench.scenario.overrides import apply_overrides
from fogbench.scenario.plan import Bound, Claim, MethodSpec, PaperValue, Plan, load_plan
from fogbench.scenario.protocols import Protocol, Selection, expand, select_indices
from fogbench.scenario.tables import ScenarioError
from sim.rig import PRESETS_PATH, Run, load_presets

__all__ = ["ScenarioError", "Scenario", "Run", "load_scenario", "load_presets", "PRESETS_PATH", "Selection", "Protocol", "MethodSpec", "Bound", "PaperValue", "Claim", "Plan", "load_plan", "select_indices", "expand", "claim_name", "apply_overrides", "MapAxis", "MapPoint", "MapSpec"]
