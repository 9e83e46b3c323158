"""A protocol: which samples fit the methods and which score them (:class:`Protocol`).

A selection is a run name, or a table ``{run = "name", segments = [i, ...], start_s = a, end_s
= b, stride = k, offset = j, static_only = true, settle_s = s}`` (settle_s: the first s seconds
of each selected segment left out, a rate table's transients); ``run = "*"`` makes the protocol
per-run: each run is fitted on its own fit selection and scored on its own score selection
(re-calibration at every switch-on). Scoring on samples a method was fitted on is refused,
unless the protocol says ``in_sample = true`` (reproducing a paper's own protocol), and then the
scenario must also have a held-out protocol, and every report flags the in-sample one.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from fogbench.scenario.load import Scenario
from fogbench.scenario.tables import ScenarioError, _Table
from sim.rig import Run

__all__ = ["Selection", "Protocol", "select_indices", "expand"]


@dataclass(frozen=True)
class Selection:
    run: str                      # a run name, or "*" (the run being scored)
    segments: tuple[int, ...] = ()
    start_s: float | None = None
    end_s: float | None = None
    stride: int = 1
    offset: int = 0
    static_only: bool = False
    settle_s: float = 0.0         # left out at the start of each selected segment (transients)

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
        if self.settle_s:
            parts.append(f"the first {self.settle_s:g} s of each segment left out")
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
    reference: str = "truth"       # what the fit is handed: "truth" (an ideal lab) or "lab"
    twin_of: str | None = None     # the lab protocol this one is the ideal-lab reading of

    @property
    def seed_name(self) -> str:
        """The name random starts derive from: an ideal-lab twin draws its lab protocol's, so
        that the two readings differ by the reference alone."""
        return self.twin_of or self.name


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
            mask[min(b, a + int(round(sel.settle_s * fs))):b] = True
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
    segs = tuple(t.get("segments", "ints", [], lo=0))
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
        settle_s=t.get("settle_s", "float", 0.0, lo=0.0, hi=1e6),
    )
    if sel.settle_s and not sel.segments:
        raise t.err("settle_s", "leaves out the start of each selected segment: give "
                    "'segments' too")
    if sel.offset >= sel.stride and sel.stride > 1:
        raise t.err("offset", f"expected 0 <= offset < stride = {sel.stride}, got {sel.offset}")
    t.done()
    return sel


def expand(prot: Protocol, sc: Scenario) -> list[tuple[list[Selection], list[Selection]]]:
    """(fit selections, score selections) pairs with '*' resolved to run names."""
    if not prot.per_run:
        return [(list(prot.fit), list(prot.score))]
    out = []
    for rname in prot.runs:
        sub = lambda s: replace(s, run=rname)
        out.append(([sub(s) for s in prot.fit], [sub(s) for s in prot.score]))
    return out


def _selected_samples(s: Selection, prot: Protocol, run: Run, fs: float) -> np.ndarray:
    """Raw sample indices a selection touches (a stride over smoothed blocks keeps whole
    blocks). static_only can only shrink a selection, so it is left out (conservative)."""
    k = stride_blocks(prot.smooth_s, fs)
    if k == 1:
        return select_indices(replace(s, static_only=False), run, fs, prot.skip_s)
    idx = select_indices(replace(s, static_only=False, stride=1, offset=0), run, fs,
                         prot.skip_s)
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
