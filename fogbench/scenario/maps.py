"""A scenario's ``[map]`` (or a map file's): one or two axes of values the papers leave open,
every point validated as a scenario of its own before any work."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

from fogbench.scenario.load import Scenario
from fogbench.scenario.names import METRIC_NAMES
from fogbench.scenario.tables import MAX_REPLICATES, ScenarioError, _read_toml, _Table

__all__ = ["MapAxis", "MapPoint", "MapSpec"]


@dataclass(frozen=True)
class MapAxis:
    """One axis of a claim map: its points, each a label and the values it sets."""

    name: str
    source: str
    labels: tuple[str, ...]
    sets: tuple[dict, ...]
    numeric: tuple[float, ...] | None = None   # a value per point, for a numeric x axis


@dataclass(frozen=True)
class MapPoint:
    """A point of the map: one point of each axis, the values they set together."""

    index: tuple[int, ...]
    labels: tuple[str, ...]
    overrides: dict
    is_base: bool

    @property
    def label(self) -> str:
        return ", ".join(self.labels)


@dataclass(frozen=True)
class MapSpec:
    """A scenario's ``[map]``: one or two axes, the replicates (and method starts) per point,
    the metrics shown at every point beside the claims."""

    axes: tuple[MapAxis, ...]
    replicates: int | None
    points: tuple[MapPoint, ...]
    method_seeds: int | None = None
    metrics: tuple[tuple[str, str, str], ...] = ()   # (protocol, method label, metric)


MAX_MAP_POINTS = 25


def map_file_scenario(path) -> Path | None:
    """The scenario a map file names (``scenario = "../paper004_flnn.toml"``, relative to the
    map file), or None when ``path`` is a scenario file (its ``[scenario]`` is a table)."""
    if Path(path).is_dir():
        return None
    try:
        doc = _read_toml(path)
    except ScenarioError:
        return None      # load_scenario names the problem
    v = doc.get("scenario")
    if not isinstance(v, str):
        return None
    target = Path(os.path.normpath(Path(path).parent / v))
    if not target.is_file():
        raise ScenarioError(f"{path}: key 'scenario': {v!r} ({target}) is not a file; a map "
                            "file names its scenario relative to itself")
    if target.resolve() == Path(path).resolve():
        raise ScenarioError(f"{path}: key 'scenario': {v!r} is this map file itself; a map file "
                            "names a scenario file (with [scenario], [fog], [[runs]], ...)")
    try:
        named = _read_toml(target)
    except ScenarioError:
        return target                      # load_scenario names the problem
    if isinstance(named.get("scenario"), str):
        raise ScenarioError(f"{path}: key 'scenario': {v!r} ({target}) is a map file too (its "
                            "own 'scenario' names another file); a map file names a scenario "
                            "file, not another map")
    return target


def _map_metrics(mt: _Table, plan) -> list[tuple[str, str, str]]:
    """``metrics = ["protocol.method.metric", ...]``: shown at every point beside the claims."""
    metrics = []
    for m in mt.get("metrics", "strs", []):
        bits = m.split(".")
        if len(bits) != 3 or not all(bits):
            raise mt.err("metrics", f"{m!r}: expected 'protocol.method.metric', e.g. "
                         "'held_out.kalman.std_dps'")
        metrics.append(tuple(bits))
    protocols = {p.name for p in plan.protocols}
    labels_ = {m.label for m in plan.methods} | {"raw", "oracle", "oracle_filter"}
    for prot, meth, metric in metrics:
        what = f"{prot}.{meth}.{metric}"
        if prot not in protocols:
            raise mt.err("metrics", f"{what!r}: no protocol {prot!r}; protocols: "
                         f"{sorted(protocols)}")
        if meth not in labels_:
            raise mt.err("metrics", f"{what!r}: no method labelled {meth!r}; methods: "
                         f"{sorted(labels_)}")
        if metric not in METRIC_NAMES:
            raise mt.err("metrics", f"{what!r}: {metric!r} is not a metric; metrics: "
                         f"{sorted(METRIC_NAMES)}")
    return metrics


def _axis(t: _Table, where: str) -> MapAxis:
    """One ``[[map.axes]]``: ``key`` with ``values`` (and ``labels``), or ``points``."""
    name = t.get("name", "str")
    t.where = f"[[map.axes]] '{name}'"
    source = t.get("source", "str")
    if t.has("key") == t.has("points"):
        raise t.err("key", "give either key and values, or points")
    labels, sets, numeric = [], [], None
    if t.has("key"):
        key = t.get("key", "str")
        values = t.get("values", "any")
        if not isinstance(values, list) or not values:
            raise t.err("values", f"expected a non-empty list of values, got {values!r}")
        given = t.get("labels", "strs", None)
        if given is not None and len(given) != len(values):
            raise t.err("labels", f"expected {len(values)} labels, one per value")
        for j, v in enumerate(values):
            labels.append(given[j] if given else f"{key.split('.')[-1]} = {v}")
            sets.append({key: v})
        if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
            numeric = tuple(float(v) for v in values)
    else:
        for j, pt in enumerate(t.get("points", "tables")):
            p = _Table(pt, f"{t.where} points[{j}]", where)
            labels.append(p.get("label", "str"))
            st = dict(p.get("set", "table", {}))
            for path in p.get("unset", "strs", []):   # keys the point removes
                if path in st:
                    raise p.err("unset", f"{path!r} is also in set")
                st[path] = None
            sets.append(st)
            p.done()
    t.done()
    if len(set(labels)) != len(labels):
        raise ScenarioError(f"{where}: {t.where}: point labels must be unique, got {labels}")
    return MapAxis(name, source, tuple(labels), tuple(sets), numeric)


def _combinations(axes: list[MapAxis], mt: _Table, where: str) -> list[tuple[tuple, dict]]:
    """Every point of the map: (index on each axis, the values set together)."""
    import itertools
    import math

    n = math.prod(len(a.labels) for a in axes)   # counted before any point is built
    if n > MAX_MAP_POINTS:
        raise mt.err("axes", f"{n} points; at most {MAX_MAP_POINTS}")
    points = []
    for combo in itertools.product(*(range(len(a.labels)) for a in axes)):
        over: dict = {}
        for a, k in zip(axes, combo):
            for path, v in a.sets[k].items():
                if path in over and over[path] != v:
                    raise ScenarioError(f"{where}: [map]: axes set {path!r} twice, to "
                                        f"{over[path]!r} and {v!r}")
                over[path] = v
        points.append((combo, over))
    return points


def _load_map(extra: _Table, sc: Scenario, plan, check_point,
              where: str | None = None) -> MapSpec | None:
    """``[map]``: ``replicates`` (per point; default the scenario's), ``method_seeds``,
    ``metrics`` (``"protocol.method.metric"`` shown at every point) and one or two
    ``[[map.axes]]``, each ``name``, ``source`` (where its range comes from) and either ``key``
    with ``values`` (and optional ``labels``) or ``points``, an array of tables ``{label, set =
    {"dotted.path" = value, ...}, unset = ["dotted.path", ...]}`` (``unset``: keys the point
    removes, e.g. ``fog.preset`` where it names a device file). Every point is validated as a
    scenario of its own by ``check_point(file, overrides)``, which returns the point's
    :class:`Scenario` (:func:`fogbench.scenario.plan.load_plan` passes one that loads its plan
    too: a point's plan may hold another map's points only through this callable, so the map
    reader does not import the plan's).
    ``where``: the file errors name (a map file; default the scenario)."""
    if not extra.has("map"):
        return None
    file = sc.path
    where = where or file
    mt = _Table(extra.get("map", "table"), "[map]", where)
    replicates = mt.get("replicates", "int", None, lo=1, hi=MAX_REPLICATES)
    method_seeds = mt.get("method_seeds", "int", None, lo=1, hi=1000)
    metrics = _map_metrics(mt, plan)
    axes = [_axis(_Table(at, f"[[map.axes]][{i}]", where), where)
            for i, at in enumerate(mt.get("axes", "tables"))]
    if not 1 <= len(axes) <= 2:
        raise mt.err("axes", f"expected one or two [[map.axes]], got {len(axes)}")
    mt.done()
    out = []
    own = _fingerprint(sc)
    for combo, over in _combinations(axes, mt, where):
        # every point is a scenario: validated now, before any work
        labels = tuple(a.labels[k] for a, k in zip(axes, combo))
        try:
            psc = check_point(file, over)
        except ScenarioError as exc:
            msg = str(exc).removeprefix(f"{file}: ")
            raise ScenarioError(f"{where}: [map] point {', '.join(labels)!r}: {msg}") from None
        # the point that runs the file as written (its values set to what the file, or its
        # preset, already has) is the scenario itself
        out.append(MapPoint(tuple(combo), labels, over, _fingerprint(psc) == own))
    return MapSpec(tuple(axes), replicates, tuple(out), method_seeds, tuple(metrics))


def _fingerprint(sc: Scenario) -> str:
    """Everything a run of ``sc`` depends on (not its text): equal for two files that run
    the same."""
    extra = {k: v for k, v in sc.extra.items() if k != "map"}
    return repr((sc.fs, sc.table, sc.fog, sc.fog_preset, sc.axes, sc.runs, sc.ambient_c,
                 sc.thermal_model)) + json.dumps(extra, sort_keys=True, default=repr)
