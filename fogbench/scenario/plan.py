"""The compensation part of a scenario file: ``[[protocols]]`` (which samples fit the methods
and which score them), ``[[methods]]`` (fogcomp methods, built-in or plug-ins, with their
hyperparameters and sweeps), ``[[bounds]]`` (the interval a metric must stay in for ``fogbench
suite --check``), ``[[paper]]`` (a paper's published figure to show beside ours),
``[[claims]]``, ``[montecarlo]``, ``[lab]`` and ``[map]``, read into a :class:`Plan`."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace

from fogbench.scenario.environment import DEFAULT_FIT_TIMEOUT_S, FIT_TIMEOUT_ENV
from fogbench.scenario.load import RUNNER_SECTIONS, Scenario, load_scenario
from fogbench.scenario.maps import MapSpec, _load_map
from fogbench.scenario.names import METRIC_NAMES, name_problem
from fogbench.scenario.protocols import Protocol, _check_overlap, _selection
from fogbench.scenario.rig import _ARCSEC
from fogbench.scenario.sweeps import SWEEP_DEFAULT, _sweep_members
from fogbench.scenario.tables import MAX_REPLICATES, ScenarioError, _read_toml, _Table
from fogcomp import units as U
from sim.lab import LabKnowledge

__all__ = ["MethodSpec", "Bound", "PaperValue", "Claim", "Plan", "load_plan"]


@dataclass(frozen=True)
class MethodSpec:
    name: str
    label: str
    params: dict
    group: str | None = None        # the [[methods]] label a sweep member belongs to
    setting: dict = field(default_factory=dict)   # the swept values of this member
    paper_setting: bool = False     # this member has the paper's (or the default) values
    failed: str | None = None       # a plug-in that cannot run: why (reported, the run goes on)


@dataclass(frozen=True)
class Bound:
    protocol: str
    method: str
    metric: str
    run: str | None
    lo: float | None
    hi: float | None
    note: str
    relative_to: str | None = None  # min/max are ratios to this row's value (e.g. "raw")


@dataclass(frozen=True)
class PaperValue:
    method: str
    metric: str
    run: str | None
    value: float
    source: str
    segment: str | None = None


@dataclass(frozen=True)
class Claim:
    """A paper's claim as a number: ``better`` improves ``metric`` over ``than`` by a percentage
    100 (1 - better / than) inside [min_pct, max_pct] (mean over the scored runs, or ``run``)."""

    text: str
    source: str
    metric: str
    better: str
    than: str
    min_pct: float | None
    max_pct: float | None
    run: str | None = None


@dataclass(frozen=True)
class Plan:
    """A scenario's compensation plan (protocols, methods, bounds, claims, replicates)."""

    protocols: tuple[Protocol, ...]
    methods: tuple[MethodSpec, ...]
    bounds: tuple[Bound, ...]
    paper: tuple[PaperValue, ...]
    axis: str
    ci: bool = False
    notes: tuple[str, ...] = field(default=())
    claims: tuple[Claim, ...] = field(default=())
    replicates: int = 1            # [montecarlo] replicates: power-ons drawn anew per replicate
    method_seeds: int = 1          # [montecarlo] method_seeds: random starts per fit
    mc_seed: int | None = None     # [montecarlo] seed (default: a hash of the scenario name)
    map: "MapSpec | None" = None   # [map]: the claims at other values of open keys
    fit_timeout_s: float = DEFAULT_FIT_TIMEOUT_S   # [compensation]: per fit and per compensate
    lab: "LabKnowledge | None" = None   # [lab]: what the lab believes (protocols reference = "lab")


_WARNED: set = set()


def _warn_once(file, text: str) -> None:
    """One ``fogbench: warning:`` line, once per process (load_plan runs per replicate)."""
    from fogbench.console import warn

    if (str(file), text) in _WARNED:
        return
    _WARNED.add((str(file), text))
    warn(f"{file}: {text}")


def _plugin_warning(file, label: str, why: str) -> None:
    from fogbench.console import warn

    if (str(file), label) in _WARNED:       # once per process (load_plan runs per replicate)
        return
    _WARNED.add((str(file), label))
    warn(f"{file}: method {label!r} will be reported as failed: {why}")


def _compensation(extra: _Table, sc: Scenario) -> tuple[str, bool, tuple, float]:
    """``[compensation]``: (axis, ci, notes, fit_timeout_s), ``--fit-timeout-s`` winning."""
    opts = _Table(extra.get("compensation", "table", {}), "[compensation]", sc.path)
    axis = opts.get("axis", "str", sc.axes[0], choices=set(sc.axes))
    ci = opts.get("ci", "bool", False)
    notes = tuple(opts.get("notes", "strs", []))
    fit_timeout_s = opts.get("fit_timeout_s", "float", DEFAULT_FIT_TIMEOUT_S, lo=0.0,
                             hi=86_400.0, lo_open=True)
    if os.environ.get(FIT_TIMEOUT_ENV):
        try:
            fit_timeout_s = float(os.environ[FIT_TIMEOUT_ENV])
        except ValueError:
            fit_timeout_s = math.nan
        if not 0.0 < fit_timeout_s <= 86_400.0:
            raise ScenarioError(f"environment variable {FIT_TIMEOUT_ENV} (--fit-timeout-s): "
                                "expected seconds in (0, 86400], got "
                                f"{os.environ[FIT_TIMEOUT_ENV]!r}")
    opts.done()
    return axis, ci, notes, fit_timeout_s


def _protocols(extra: _Table, sc: Scenario) -> list[Protocol]:
    """``[[protocols]]``: each one's fit and score selections, refused where a held-out
    protocol scores samples it was fitted on."""
    file = sc.path
    runs = {r.name: r for r in sc.runs}
    names = set(runs)
    protocols = []
    ptabs = extra.get("protocols", "tables")
    if not ptabs:
        raise extra.err("protocols", "expected at least one [[protocols]] table")
    for i, pt in enumerate(ptabs):
        t = _Table(pt, f"[[protocols]][{i}]", file)
        pname = t.get("name", "name")
        t.where = f"[[protocols]] '{pname}'"
        fit_raw = t.get("fit", "any")
        score_raw = t.get("score", "any")
        for key, val in (("fit", fit_raw), ("score", score_raw)):
            if not isinstance(val, list) or not val:
                raise t.err(key, "expected a non-empty list of selections (run names or tables)")
        star = [(s == "*" or (isinstance(s, dict) and s.get("run") == "*"))
                for s in fit_raw + score_raw]
        per_run = all(star)
        fit = tuple(_selection(s, f"{t.where} fit[{j}]", file, names, runs, per_run)
                    for j, s in enumerate(fit_raw))
        score = tuple(_selection(s, f"{t.where} score[{j}]", file, names, runs, per_run)
                      for j, s in enumerate(score_raw))
        prot_runs = tuple(t.get("runs", "strs", sorted(names) if per_run else [], choices=names))
        if prot_runs and not per_run:
            raise t.err("runs", "only a per-run protocol (run = '*') takes 'runs'")
        prot = Protocol(
            name=pname, description=t.get("description", "str", ""), fit=fit, score=score,
            per_run=per_run, runs=tuple(r for r in [x.name for x in sc.runs] if r in prot_runs),
            in_sample=t.get("in_sample", "bool", False),
            skip_s=t.get("skip_s", "float", 0.0, lo=0.0),
            smooth_s=t.get("smooth_s", "float", None, lo=0.0, lo_open=True),
            reference=t.get("reference", "str", None, choices={"truth", "lab"}),
        )
        if prot.smooth_s is not None:
            k = prot.smooth_s * sc.fs
            if abs(k - round(k)) > 1e-9 or round(k) < 1:
                raise t.err("smooth_s", f"expected a whole number of samples at "
                            f"{sc.fs:g} Hz, got {prot.smooth_s:g} s")
        t.done()
        _check_overlap(prot, sc, file)
        protocols.append(prot)
    if any(p.in_sample for p in protocols) and all(p.in_sample for p in protocols):
        raise extra.err("protocols", "an in_sample protocol must stand beside a held-out one "
                        "(in_sample = false) in the same scenario")
    return protocols


def _method_specs(t: _Table, file: str) -> list[MethodSpec]:
    """One ``[[methods]]`` table: a method, or one member per setting of its sweep; a plug-in
    that cannot run kept with ``failed`` set (the run reports it and goes on)."""
    from fogcomp import PluginError, get_method, make_method

    import warnings

    from fogcomp._registry import PluginShadowWarning

    mname = t.get("name", "str")
    params = dict(t.get("params", "table", {}))
    label = t.get("label", "name", mname.rpartition(":")[2] if ":" in mname else mname)
    try:
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always", PluginShadowWarning)
            cls = get_method(mname)
        for w in said:     # an installed plug-in has this built-in's name: say which runs
            _warn_once(file, str(w.message))
    except PluginError as exc:      # installed but unusable: reported as failed, run goes on
        msg = name_problem(label)
        if msg:
            raise t.err("label", msg) from None
        t.get("sweep", "table", None)
        _plugin_warning(file, label, str(exc))
        return [MethodSpec(mname, label, params, failed=str(exc))]
    except KeyError as exc:
        raise t.err("name", exc.args[0]) from None
    builtin = cls.__module__.startswith("fogcomp.")
    sweep = t.get("sweep", "table", None)
    members = [({}, True)] if sweep is None else _sweep_members(t, mname, params, sweep)
    out = []
    for setting, paper in members:
        # "default" in a sweep: the constructor's default (which TOML cannot write: None)
        full = {**params, **{k: v for k, v in setting.items() if v != SWEEP_DEFAULT}}
        failed = None
        try:
            make_method(mname, **full).check_params()
        except (TypeError, ValueError) as exc:
            what = f"method {label!r}" + (f" with {setting}" if setting else "")
            raise t.err("sweep" if setting else "params", f"{what}: {exc}") from None
        except Exception as exc:
            if builtin:
                raise
            failed = (f"method {mname!r}: its constructor or check_params raised "
                      f"{type(exc).__name__}: {exc}")
            _plugin_warning(file, label, failed)
        mlabel = label if not setting else label + "." + ".".join(
            f"{k}-{v}" for k, v in setting.items())
        msg = name_problem(mlabel)
        if msg:
            raise t.err("sweep", f"member label {msg}")
        out.append(MethodSpec(mname, mlabel, full, group=label if sweep else None,
                              setting=setting, paper_setting=paper, failed=failed))
    return out


def _methods(extra: _Table, file: str) -> list[MethodSpec]:
    """``[[methods]]``: every method and sweep member, labels unique."""
    methods = []
    for i, mt in enumerate(extra.get("methods", "tables")):
        t = _Table(mt, f"[[methods]][{i}]", file)
        methods += _method_specs(t, file)
        t.done()
    if not methods:
        raise extra.err("methods", "expected at least one [[methods]] table")
    labels = [m.label for m in methods]
    if len(set(labels)) != len(labels):
        raise extra.err("methods", f"method labels must be unique (give 'label'); got {labels}")
    return methods


def _with_twins(extra: _Table, protocols: list[Protocol], methods: list[MethodSpec]):
    """The protocols with their reference set, and each fitted on the lab's references beside
    its ideal-lab twin ``<name>.ideal`` fitted on the truth.

    A protocol that does not name its reference models a lab's calibration when a method of
    the scenario is supervised (handed a reference rate, and gravity if it wants it): it is
    fitted on what a lab has (reference = "lab", sim/lab.py), never on the truth. Where no
    method is handed a reference, the reference changes nothing and "truth" stands (no twin).
    The paired difference of a protocol and its twin is what the lab's references cost."""
    from fogcomp import get_method

    supervised = any(m.failed is None and get_method(m.name).supervised for m in methods)
    protocols = [p if p.reference is not None else
                 replace(p, reference="lab" if supervised else "truth") for p in protocols]
    for p in protocols:
        if p.reference == "lab" and name_problem(f"{p.name}.ideal"):
            raise extra.err("protocols", f"protocol {p.name!r} has reference = \"lab\": its twin "
                            f"'{p.name}.ideal' must also be a name: {name_problem(p.name + '.ideal')}")
    protocols += [replace(p, name=f"{p.name}.ideal", reference="truth", twin_of=p.name,
                          description=f"{p.description} (ideal lab: fitted on the truth)".strip())
                  for p in protocols if p.reference == "lab"]
    if len({p.name for p in protocols}) != len(protocols):
        raise extra.err("protocols", "protocol names must be unique (a protocol with reference "
                        "= \"lab\" adds <name>.ideal)")
    return protocols


def _one_or_list(t: _Table, key: str, choices) -> list[str]:
    """A key that names one thing, or a list of them (``[[bounds]] protocol``, ``method``)."""
    if isinstance(t.data.get(key), list):
        v = t.get(key, "strs", choices=choices)
        if not v:
            raise t.err(key, "expected a name or a non-empty list of names")
        return v
    return [t.get(key, "str", choices=choices)]


def _bounds(extra: _Table, file: str, pnames: set, bound_methods: set, known: set,
            runs: set) -> list[Bound]:
    """``[[bounds]]``: the interval a metric must stay in for ``fogbench suite --check``. A
    table may name several protocols and methods (``protocol = ["a", "b"]``): one bound for
    each, protocol by protocol, in the order given."""
    bounds = []
    for i, bt in enumerate(extra.get("bounds", "tables", [])):
        t = _Table(bt, f"[[bounds]][{i}]", file)
        protocols = _one_or_list(t, "protocol", pnames)
        methods = _one_or_list(t, "method", bound_methods)
        rest = dict(metric=t.get("metric", "str", choices=METRIC_NAMES),
                    run=t.get("run", "str", None, choices=runs),
                    lo=t.get("min", "float", None), hi=t.get("max", "float", None),
                    note=t.get("note", "str", ""),
                    relative_to=t.get("relative_to", "str", None, choices=known))
        if rest["lo"] is None and rest["hi"] is None:
            raise t.err("max", "a bound needs 'min', 'max' or both")
        if rest["lo"] is not None and rest["hi"] is not None and not rest["lo"] <= rest["hi"]:
            raise t.err("max", f"expected min <= max, got min = {rest['lo']}, max = "
                        f"{rest['hi']}")
        t.done()
        bounds += [Bound(protocol=p, method=m, **rest) for p in protocols for m in methods]
    return bounds


def _paper_table(t: _Table, known: set, runs: set) -> list[tuple[str, str, float]]:
    """A ``[[paper]]`` table of values: ``values = {row = [v, ...]}`` whose rows are methods
    and columns ``runs = [...]`` (expanded method by method), or whose rows are runs and
    columns ``methods = [...]`` (expanded run by run): (method, run, value) in that order."""
    if t.has("runs") == t.has("methods"):
        raise t.err("values", "give 'runs' (then each row of values is a method) or "
                    "'methods' (then each row is a run), not both")
    by_method = t.has("runs")
    cols = t.get("runs", "strs", choices=runs) if by_method else \
        t.get("methods", "strs", choices=known)
    rows = t.get("values", "table")
    out = []
    for row, vals in rows.items():
        if row not in (known if by_method else runs):
            raise t.err("values", f"row {row!r}: expected a "
                        + (f"method of {sorted(known)}" if by_method else
                           f"run of {sorted(runs)}"))
        if not isinstance(vals, list) or len(vals) != len(cols) or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                for v in vals):
            raise t.err("values", f"row {row!r}: expected {len(cols)} finite numbers, one per "
                        f"{'run' if by_method else 'method'} of {cols}, got {vals!r}")
        for col, v in zip(cols, vals):
            out.append((row, col, float(v)) if by_method else (col, row, float(v)))
    return out


def _paper(extra: _Table, file: str, known: set, runs: set) -> list[PaperValue]:
    """``[[paper]]``: a paper's published figures to show beside ours, one value (``method``,
    ``run``, ``value``) or a table of them (:func:`_paper_table`)."""
    paper = []
    for i, pt in enumerate(extra.get("paper", "tables", [])):
        t = _Table(pt, f"[[paper]][{i}]", file)
        if not t.has("values"):
            paper.append(PaperValue(method=t.get("method", "str", choices=known),
                                    metric=t.get("metric", "str", choices=METRIC_NAMES),
                                    run=t.get("run", "str", None, choices=runs),
                                    value=t.get("value", "float"), source=t.get("source", "str"),
                                    segment=t.get("segment", "str", None)))
            t.done()
            continue
        metric = t.get("metric", "str", choices=METRIC_NAMES)
        source = t.get("source", "str")
        segment = t.get("segment", "str", None)
        rows = _paper_table(t, known, runs)
        t.done()
        paper += [PaperValue(method=m, metric=metric, run=r, value=v, source=source,
                             segment=segment) for m, r, v in rows]
    return paper


def _claims(extra: _Table, file: str, known: set, runs: set) -> list[Claim]:
    """``[[claims]]``: a paper's claims as numbers (:class:`Claim`)."""
    claims = []
    for i, ct in enumerate(extra.get("claims", "tables", [])):
        t = _Table(ct, f"[[claims]][{i}]", file)
        c = Claim(text=t.get("text", "str"), source=t.get("source", "str"),
                  metric=t.get("metric", "str", choices=METRIC_NAMES),
                  better=t.get("better", "str", choices=known),
                  than=t.get("than", "str", choices=known),
                  min_pct=t.get("min_pct", "float", None), max_pct=t.get("max_pct", "float", None),
                  run=t.get("run", "str", None, choices=runs))
        if c.min_pct is None and c.max_pct is None:
            raise t.err("min_pct", "a claim needs 'min_pct', 'max_pct' or both")
        t.done()
        claims.append(c)
    return claims


def _montecarlo(extra: _Table, file: str) -> tuple[int, int, int | None]:
    """``[montecarlo]``: (replicates, method_seeds, seed)."""
    mc = _Table(extra.get("montecarlo", "table", {}), "[montecarlo]", file)
    replicates = mc.get("replicates", "int", 1, lo=1, hi=MAX_REPLICATES)
    method_seeds = mc.get("method_seeds", "int", 1, lo=1, hi=1000)
    mc_seed = mc.get("seed", "int", None, lo=0, hi=2**63 - 1)
    mc.done()
    return replicates, method_seeds, mc_seed


def load_plan(sc: Scenario) -> Plan:
    """Validate the scenario's compensation part into a :class:`Plan`.

    A method name is a built-in, an entry point of the group ``fogcomp.methods`` or
    ``module:Class`` of an installed module (its code runs: the scenario names it). Unknown
    names and bad hyperparameters are refused naming the key; a plug-in that is installed but
    does not import, is no usable method, or whose constructor raises is kept with ``failed``
    set (the run reports it as failed and goes on)."""
    file = sc.path
    extra = _Table(dict(sc.extra), "top level", file)
    names = {r.name for r in sc.runs}
    axis, ci, notes, fit_timeout_s = _compensation(extra, sc)
    protocols = _protocols(extra, sc)
    methods = _methods(extra, file)
    protocols = _with_twins(extra, protocols, methods)
    known = {m.label for m in methods} | {"raw", "oracle"}
    bound_methods = known | {m.group for m in methods if m.group}  # a group: each member
    bounds = _bounds(extra, file, {p.name for p in protocols}, bound_methods, known, names)
    paper = _paper(extra, file, known, names)
    claims = _claims(extra, file, known, names)
    replicates, method_seeds, mc_seed = _montecarlo(extra, file)
    lab = _lab_knowledge(_Table(extra.get("lab", "table", {}), "[lab]", file))
    if lab is not None and abs(sc.table.latitude + lab.latitude_error) > math.pi / 2 + 1e-12:
        raise ScenarioError(
            f"{file}: [lab] key 'latitude_error_deg': the lab would believe a latitude of "
            f"{math.degrees(sc.table.latitude + lab.latitude_error):g} deg ([table] "
            f"latitude_deg {math.degrees(sc.table.latitude):g} plus this error); a latitude is "
            "within -90 to 90")
    if lab is not None and not any(p.reference == "lab" for p in protocols):
        raise extra.err("lab", "no protocol has reference = \"lab\": the [lab] keys would "
                        "change nothing")
    extra.used.add("map")
    extra.done()
    plan = Plan(tuple(protocols), tuple(methods), tuple(bounds), tuple(paper), axis, ci, notes,
                tuple(claims), replicates, method_seeds, mc_seed, fit_timeout_s=fit_timeout_s,
                lab=lab)
    spec = _load_map(extra, sc, plan, _point_scenario)
    return replace(plan, map=spec) if spec is not None else plan


def _point_scenario(file: str, overrides: dict) -> Scenario:
    """A claim map's point validated as a scenario of its own, its plan included."""
    psc = load_scenario(file, extra_sections=RUNNER_SECTIONS, overrides=overrides)
    load_plan(psc)
    return psc


def _lab_knowledge(t: _Table):
    """[lab]: what the lab believes of its table and site (``sim.lab.LabKnowledge``), as errors
    against the truth; None when the section is absent (protocols with reference = "lab" then
    use a lab that knows its site and table exactly, but still only their commands)."""
    if not t.data:
        t.done()
        return None
    arcsec = _ARCSEC
    lab = LabKnowledge(
        latitude_error=math.radians(t.get("latitude_error_deg", "float", 0.0, lo=-10.0, hi=10.0)),
        heading_error=math.radians(t.get("heading_error_deg", "float", 0.0, lo=-10.0, hi=10.0)),
        tilt_zero_error=t.get("tilt_zero_error_arcsec", "float", 0.0, lo=-3600.0,
                              hi=3600.0) * arcsec,
        radius_error=t.get("radius_error_mm", "float", 0.0, lo=-100.0, hi=100.0) * 1e-3,
        encoder_resolution=t.get("encoder_resolution_arcsec", "float", 0.0, lo=0.0,
                                 hi=3600.0) * arcsec,
        rate_source=t.get("rate_source", "str", "command", choices={"command", "encoder"}),
        # the accelerometer triad (gravity_source = "accelerometer"), defaults 0; class values
        # and sources in sim.lab.CLASS_VALUES (tactical MEMS: Xsens MTi-1, 0.03 mg bias
        # instability, 120 ug/sqrt(Hz)). Limits: 1e5 ug (0.1 g, beyond a MEMS part's raw
        # offset, BMI160 +-60 mg), 1e5 ppm (10 %), 1e4 ug/sqrt(Hz) (MEMS parts: 75-160).
        gravity_source=t.get("gravity_source", "str", "command",
                             choices={"command", "accelerometer"}),
        acc_bias=tuple(v * 1e-6 * U.G0 for v in _triple(t, "acc_bias_ug", 1e5)),
        acc_scale_factor=tuple(v * 1e-6 for v in _triple(t, "acc_scale_factor_ppm", 1e5)),
        acc_noise_density=t.get("acc_noise_ug_rt_hz", "float", 0.0, lo=0.0, hi=1e4)
        * 1e-6 * U.G0)
    if lab.encoder_resolution and lab.rate_source != "encoder":
        raise t.err("encoder_resolution_arcsec", "applies only with rate_source = \"encoder\" "
                    "(the commanded rate has no encoder steps)")
    if lab.gravity_source != "accelerometer":
        for key in ("acc_bias_ug", "acc_scale_factor_ppm", "acc_noise_ug_rt_hz"):
            if t.has(key):
                raise t.err(key, "applies only with gravity_source = \"accelerometer\" (the "
                            "commanded attitude has no accelerometer)")
    t.done()
    return lab


def _triple(t: _Table, key: str, limit: float) -> tuple[float, float, float]:
    """A per-axis key: one number (every axis) or [x, y, z], each within +-limit."""
    if isinstance(t.data.get(key), list):
        v = t.get(key, "floats", lo=-limit, hi=limit)
        if len(v) != 3:
            raise t.err(key, f"expected one number or [x, y, z], got {len(v)} values")
        return v[0], v[1], v[2]
    v = t.get(key, "float", 0.0, lo=-limit, hi=limit)
    return v, v, v


def load_map_file(path, sc: Scenario, plan: Plan) -> MapSpec:
    """A map file: ``scenario = "<its scenario file, relative to the map file>"`` and one
    ``[map]`` table, as a scenario's, that replaces the scenario's own (a denser map of the same
    scenario: ``fogbench run scenarios/maps/paper004_flnn.toml``)."""
    file = str(path)
    top = _Table(_read_toml(path), "top level", file)
    top.get("scenario", "str")
    if not top.has("map"):
        raise ScenarioError(f"{file}: a map file holds its scenario's path and one [map] "
                            "table (with its [[map.axes]]); this one has no [map]")
    top.used.add("map")
    top.done()
    return _load_map(top, sc, plan, _point_scenario, where=file)
