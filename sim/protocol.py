"""The compensation part of a scenario file: protocols, methods, bounds and the papers' figures.

``[[protocols]]`` say which samples fit the methods and which score them. A selection is a run
name, or a table ``{run = "name", segments = [i, ...], start_s = a, end_s = b, stride = k,
offset = j, static_only = true}``; ``run = "*"`` makes the protocol per-run: each run is fitted on
its own fit selection and scored on its own score selection (re-calibration at every switch-on).
Scoring on samples a method was fitted on is refused, unless the protocol says
``in_sample = true`` (reproducing a paper's own protocol), and then the scenario must also have a
held-out protocol, and every report flags the in-sample one.

``[[methods]]`` name registered fogcomp methods with hyperparameter overrides (``params``).
``[[bounds]]`` give the interval a metric must stay in for ``fogbench suite --check``.
``[[paper]]`` give a paper's published figure to show beside ours.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .motion import Positions
from .scenario import Run, Scenario, ScenarioError, _Table

__all__ = ["Selection", "Protocol", "MethodSpec", "Bound", "PaperValue", "Plan", "load_plan",
           "select_indices"]

METRIC_NAMES = {
    "std_dps", "std_dph", "rmse_dph", "rmse_dps", "bias_stability_100s_dph", "angle_error_final_deg",
    "angle_error_max_deg", "arw_deg_rt_h", "bias_instability_dph", "rrw_dph_rt_h",
    "fit_time_s", "compensate_time_s", "improvement_std_pct", "improvement_rmse_pct",
    "improvement_bias_stability_pct", "coef_rms_error_dph", "drift_rms_dph",
    "improvement_drift_pct", "mean_error_dph",
}


@dataclass(frozen=True)
class Selection:
    run: str                      # a run name, or "*" (the run being scored)
    segments: tuple[int, ...] = ()
    start_s: float | None = None
    end_s: float | None = None
    stride: int = 1
    offset: int = 0
    static_only: bool = False

    def describe(self) -> str:
        parts = [self.run]
        if self.segments:
            parts.append(f"segments {list(self.segments)}")
        if self.start_s is not None or self.end_s is not None:
            parts.append(f"{self.start_s or 0:g}..{'' if self.end_s is None else f'{self.end_s:g}'} s")
        if self.stride > 1:
            parts.append(f"every {self.stride}-th sample from #{self.offset}")
        if self.static_only:
            parts.append("static samples only")
        return ", ".join(parts)


@dataclass(frozen=True)
class Protocol:
    name: str
    description: str
    fit: tuple[Selection, ...]
    score: tuple[Selection, ...]
    per_run: bool
    runs: tuple[str, ...]          # the runs a per-run protocol walks through
    in_sample: bool
    skip_s: float
    smooth_s: float | None


@dataclass(frozen=True)
class MethodSpec:
    name: str
    label: str
    params: dict


@dataclass(frozen=True)
class Bound:
    protocol: str
    method: str
    metric: str
    run: str | None
    lo: float | None
    hi: float | None
    note: str


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
    protocols: tuple[Protocol, ...]
    methods: tuple[MethodSpec, ...]
    bounds: tuple[Bound, ...]
    paper: tuple[PaperValue, ...]
    axis: str
    ci: bool = False
    notes: tuple[str, ...] = field(default=())
    claims: tuple[Claim, ...] = field(default=())


def _segment_bounds(run: Run, fs: float) -> list[tuple[int, int]]:
    out, a = [], 0
    for seg in run.motion:
        n = int(round(seg.duration * fs))
        out.append((a, a + n))
        a += n
    return out


def select_indices(sel: Selection, run: Run, fs: float, skip_s: float,
                   table_rate: np.ndarray | None = None) -> np.ndarray:
    """Sample indices of ``run`` picked by ``sel`` (before smoothing)."""
    n = int(round(run.duration * fs))
    mask = np.zeros(n, dtype=bool)
    if sel.segments:
        bounds = _segment_bounds(run, fs)
        for i in sel.segments:
            a, b = bounds[i]
            mask[a:b] = True
    else:
        mask[:] = True
    t = np.arange(n) / fs
    if sel.start_s is not None:
        mask &= t >= sel.start_s - 1e-9
    if sel.end_s is not None:
        mask &= t < sel.end_s - 1e-9
    mask &= t >= skip_s - 1e-9
    if sel.static_only:
        if table_rate is None:
            raise ValueError("static_only needs the table's rate")
        mask &= np.linalg.norm(table_rate, axis=1) < 1e-4
    idx = np.flatnonzero(mask)
    if sel.stride > 1:
        idx = idx[sel.offset::sel.stride]
    return idx


def stride_blocks(prot_smooth_s, fs):
    """Samples per stride step: with smoothing a stride picks smoothed blocks, not samples."""
    return 1 if not prot_smooth_s else int(round(prot_smooth_s * fs))


def _selection(v, where: str, file: str, run_names: set[str], runs: dict[str, Run],
               allow_star: bool) -> Selection:
    if isinstance(v, str):
        v = {"run": v}
    t = _Table(v, where, file)
    run = t.get("run", "str")
    if run == "*":
        if not allow_star:
            raise t.err("run", "'*' (each run) is allowed only when every selection of the "
                        "protocol uses it")
    elif run not in run_names:
        raise t.err("run", f"expected one of the scenario's runs {sorted(run_names)}, got {run!r}")
    segs = tuple(int(x) for x in t.get("segments", "floats", [], lo=0))
    nseg = min(len(r.motion) for r in runs.values()) if run == "*" else len(runs[run].motion)
    for s in segs:
        if s >= nseg or s != int(s):
            raise t.err("segments", f"expected segment indices 0..{nseg - 1}, got {list(segs)}")
    sel = Selection(
        run=run, segments=segs,
        start_s=t.get("start_s", "float", None, lo=0.0),
        end_s=t.get("end_s", "float", None, lo=0.0, lo_open=True),
        stride=t.get("stride", "int", 1, lo=1),
        offset=t.get("offset", "int", 0, lo=0),
        static_only=t.get("static_only", "bool", False),
    )
    if sel.offset >= sel.stride and sel.stride > 1:
        raise t.err("offset", f"expected 0 <= offset < stride = {sel.stride}, got {sel.offset}")
    t.done()
    return sel


def load_plan(sc: Scenario) -> Plan:
    """Validate the scenario's [[protocols]], [[methods]], [[bounds]] and [[paper]] tables."""
    from fogcomp import get_method, make_method

    file = sc.path
    extra = _Table(dict(sc.extra), "top level", file)
    runs = {r.name: r for r in sc.runs}
    names = set(runs)

    opts = _Table(extra.get("compensation", "table", {}), "[compensation]", file)
    axis = opts.get("axis", "str", sc.axes[0], choices=set(sc.axes))
    ci = opts.get("ci", "bool", False)
    notes = tuple(opts.get("notes", "strs", []))
    opts.done()

    protocols = []
    ptabs = extra.get("protocols", "tables")
    if not ptabs:
        raise extra.err("protocols", "expected at least one [[protocols]] table")
    for i, pt in enumerate(ptabs):
        t = _Table(pt, f"[[protocols]][{i}]", file)
        pname = t.get("name", "str")
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
        )
        if prot.smooth_s is not None:
            k = prot.smooth_s * sc.fs
            if abs(k - round(k)) > 1e-9 or round(k) < 1:
                raise t.err("smooth_s", f"expected a whole number of samples at "
                            f"{sc.fs:g} Hz, got {prot.smooth_s:g} s")
        t.done()
        _check_overlap(prot, sc, file)
        protocols.append(prot)
    if len({p.name for p in protocols}) != len(protocols):
        raise extra.err("protocols", "protocol names must be unique")
    if any(p.in_sample for p in protocols) and all(p.in_sample for p in protocols):
        raise extra.err("protocols", "an in_sample protocol must stand beside a held-out one "
                        "(in_sample = false) in the same scenario")

    methods = []
    for i, mt in enumerate(extra.get("methods", "tables")):
        t = _Table(mt, f"[[methods]][{i}]", file)
        mname = t.get("name", "str")
        try:
            get_method(mname)
        except KeyError as exc:
            raise t.err("name", exc.args[0]) from None
        params = dict(t.get("params", "table", {}))
        try:
            make_method(mname, **params)
        except (TypeError, ValueError) as exc:
            raise t.err("params", str(exc)) from None
        methods.append(MethodSpec(mname, t.get("label", "str", mname), params))
        t.done()
    if not methods:
        raise extra.err("methods", "expected at least one [[methods]] table")
    labels = [m.label for m in methods]
    if len(set(labels)) != len(labels):
        raise extra.err("methods", f"method labels must be unique (give 'label'); got {labels}")

    known_methods = set(labels) | {"raw", "oracle"}
    pnames = {p.name for p in protocols}
    bounds = []
    for i, bt in enumerate(extra.get("bounds", "tables", [])):
        t = _Table(bt, f"[[bounds]][{i}]", file)
        b = Bound(protocol=t.get("protocol", "str", choices=pnames),
                  method=t.get("method", "str", choices=known_methods),
                  metric=t.get("metric", "str", choices=METRIC_NAMES),
                  run=t.get("run", "str", None, choices=names),
                  lo=t.get("min", "float", None), hi=t.get("max", "float", None),
                  note=t.get("note", "str", ""))
        if b.lo is None and b.hi is None:
            raise t.err("max", "a bound needs 'min', 'max' or both")
        if b.lo is not None and b.hi is not None and not b.lo <= b.hi:
            raise t.err("max", f"expected min <= max, got min = {b.lo}, max = {b.hi}")
        t.done()
        bounds.append(b)

    paper = []
    for i, pt in enumerate(extra.get("paper", "tables", [])):
        t = _Table(pt, f"[[paper]][{i}]", file)
        paper.append(PaperValue(method=t.get("method", "str", choices=known_methods),
                                metric=t.get("metric", "str", choices=METRIC_NAMES),
                                run=t.get("run", "str", None, choices=names),
                                value=t.get("value", "float"), source=t.get("source", "str"),
                                segment=t.get("segment", "str", None)))
        t.done()

    claims = []
    for i, ct in enumerate(extra.get("claims", "tables", [])):
        t = _Table(ct, f"[[claims]][{i}]", file)
        c = Claim(text=t.get("text", "str"), source=t.get("source", "str"),
                  metric=t.get("metric", "str", choices=METRIC_NAMES),
                  better=t.get("better", "str", choices=known_methods),
                  than=t.get("than", "str", choices=known_methods),
                  min_pct=t.get("min_pct", "float", None), max_pct=t.get("max_pct", "float", None),
                  run=t.get("run", "str", None, choices=names))
        if c.min_pct is None and c.max_pct is None:
            raise t.err("min_pct", "a claim needs 'min_pct', 'max_pct' or both")
        t.done()
        claims.append(c)
    extra.done()
    return Plan(tuple(protocols), tuple(methods), tuple(bounds), tuple(paper), axis, ci, notes,
                tuple(claims))


def expand(prot: Protocol, sc: Scenario) -> list[tuple[list[Selection], list[Selection]]]:
    """(fit selections, score selections) pairs with '*' resolved to run names."""
    if not prot.per_run:
        return [(list(prot.fit), list(prot.score))]
    out = []
    for rname in prot.runs:
        sub = lambda s: Selection(rname, s.segments, s.start_s, s.end_s, s.stride, s.offset,  # noqa: E731
                                  s.static_only)
        out.append(([sub(s) for s in prot.fit], [sub(s) for s in prot.score]))
    return out


def _selected_samples(s: Selection, prot: Protocol, run: Run, fs: float) -> np.ndarray:
    """Raw sample indices a selection touches (a stride over smoothed blocks keeps whole
    blocks). static_only can only shrink a selection, so it is left out (conservative)."""
    k = stride_blocks(prot.smooth_s, fs)
    if k == 1:
        return select_indices(Selection(s.run, s.segments, s.start_s, s.end_s, s.stride,
                                        s.offset), run, fs, prot.skip_s)
    idx = select_indices(Selection(s.run, s.segments, s.start_s, s.end_s), run, fs, prot.skip_s)
    if s.stride == 1:
        return idx
    parts = [p for p in np.split(idx, np.flatnonzero(np.diff(idx) != 1) + 1) if p.size >= k]
    blocks = [p[i * k:(i + 1) * k] for p in parts for i in range(p.size // k)]
    keep = blocks[s.offset::s.stride]
    return np.concatenate(keep) if keep else idx[:0]


def _check_overlap(prot: Protocol, sc: Scenario, file: str):
    runs = {r.name: r for r in sc.runs}
    for fit, score in expand(prot, sc):
        fit_idx: dict[str, set] = {}
        for s in fit:
            idx = _selected_samples(s, prot, runs[s.run], sc.fs)
            if idx.size == 0:
                raise ScenarioError(f"{file}: [[protocols]] '{prot.name}' fit selection "
                                    f"({s.describe()}) selects no samples")
            fit_idx.setdefault(s.run, set()).update(idx.tolist())
        for s in score:
            idx = _selected_samples(s, prot, runs[s.run], sc.fs)
            if idx.size == 0:
                raise ScenarioError(f"{file}: [[protocols]] '{prot.name}' score selection "
                                    f"({s.describe()}) selects no samples")
            shared = fit_idx.get(s.run, set()).intersection(idx.tolist())
            if shared and not prot.in_sample:
                raise ScenarioError(
                    f"{file}: [[protocols]] '{prot.name}' key 'score': run {s.run!r} is scored on "
                    f"{len(shared)} samples it was fitted on; scoring on fitted data is refused "
                    "(set in_sample = true only to reproduce a paper's own protocol, beside a "
                    "held-out one)")


def positions_of(run: Run) -> list[int]:
    """Indices of a run's multi-position segments (used by reports)."""
    return [i for i, s in enumerate(run.motion) if isinstance(s, Positions)]
