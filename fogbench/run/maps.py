"""Claim maps: each claim's verdict at every point of a scenario's ``[map]``.

A paper leaves device values open that its claims rest on (a raw noise level, the share of the
Shupe term, a misalignment). A scenario's ``[map]`` names one or two axes over such values
(``fogbench.scenario.MapSpec``): every point is the scenario with those values set, validated as a
file of its own, run as a Monte Carlo of its own (``replicates`` per point) on the same executor
as the scenario, with the same seeds (common random numbers: points differ only in what they
set). The point whose values are the file's own is the scenario itself (its replicates are
reused). Each claim is then judged at every point (``fogbench.run.stats.claim_verdict``), and the
map states where it holds: the verdict, the interval and the oracle at each point, a figure, and
a sentence.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["MapRun", "map_sentence", "side"]


class MapRun:
    """The points of a scenario's claim map other than the scenario itself, each a
    ``fogbench.run.montecarlo.ScenarioMC`` whose replicates all run on the executor."""

    def __init__(self, path, out: Path, base, replicates: int | None = None,
                 method_seeds: int | None = None, methods: list[str] | None = None,
                 resume: bool = False):
        from fogbench.run.montecarlo import ScenarioMC

        self.spec = base.plan.map
        self.base = base
        self.R = int(replicates or self.spec.replicates or base.plan.replicates)
        # method starts per fit: the command line's, else the map's, else the scenario's
        method_seeds = method_seeds or self.spec.method_seeds
        self.mcs: dict[int, ScenarioMC] = {}
        try:
            for i, pt in enumerate(self.spec.points):
                if pt.is_base:
                    continue
                self.mcs[i] = ScenarioMC(path, out, replicates=self.R,
                                         method_seeds=method_seeds, methods=methods,
                                         resume=resume, overrides=pt.overrides, tag=f"map{i}",
                                         first_in_process=False)
        except BaseException:
            self.release()
            raise

    @property
    def todo(self) -> int:
        return sum(len(m.todo) for m in self.mcs.values())

    def simulate_truths(self, say=None, cache: dict | None = None) -> None:
        for m in self.mcs.values():
            m.simulate_truths(say, cache=cache)

    def submit(self, executor, on_done=None) -> None:
        for m in self.mcs.values():
            m.submit(executor, on_done=on_done)

    def wait(self) -> None:
        for m in self.mcs.values():
            m.wait()

    @property
    def failures(self) -> list:
        return [f for m in self.mcs.values() for f in m.failures]

    @property
    def done(self) -> int:
        return sum(len(m.done) for m in self.mcs.values())

    def release(self) -> None:
        for m in self.mcs.values():
            m.work.remove_if_empty()

    def remove(self) -> None:
        for m in self.mcs.values():
            m.work.remove()

    def copy_into(self, run_tmp: Path) -> None:
        for i, m in self.mcs.items():
            dest = run_tmp / "map" / f"point{i}"
            dest.mkdir(parents=True)
            m.work.copy_into(dest, keep=list(range(m.R)))

    def finish(self, base_doc: dict, engine: str) -> dict:
        """The map: its axes, its points (what each sets, how many replicates) and, per claim
        and protocol, the verdict at every point with the sentence that says where it holds."""
        aggs = {}
        for i, pt in enumerate(self.spec.points):
            aggs[i] = base_doc if pt.is_base else self.mcs[i].finish(engine)
        points = []
        for i, pt in enumerate(self.spec.points):
            agg = aggs[i]
            points.append({"index": list(pt.index), "labels": list(pt.labels),
                           "label": pt.label, "set": pt.overrides, "base": pt.is_base,
                           "replicates": agg.get("replicates"),
                           "failed_replicates": len(agg.get("failed_replicates") or [])})
        claims = []
        for c in base_doc.get("claims", []):
            per_point = []
            for i in range(len(self.spec.points)):
                hit = next((x for x in aggs[i].get("claims", [])
                            if x["text"] == c["text"] and x["protocol"] == c["protocol"]), None)
                sm = (hit or {}).get("summary") or {}
                per_point.append(None if hit is None else {
                    "verdict": hit["verdict"], "mean": sm.get("mean"),
                    "ci_low": sm.get("ci_low"), "ci_high": sm.get("ci_high"),
                    "n": sm.get("n"), "held": hit.get("held"),
                    "oracle_mean": (hit.get("oracle_improvement") or {}).get("mean"),
                    "oracle_ci_low": (hit.get("oracle_improvement") or {}).get("ci_low"),
                    "oracle_ci_high": (hit.get("oracle_improvement") or {}).get("ci_high"),
                    "oracle_bounds": hit.get("oracle_bounds_claim"),
                    "oracle": hit.get("oracle"), "side": side(hit)})
            entry = {k: c[k] for k in ("text", "source", "protocol", "in_sample", "metric",
                                       "better", "than", "min_pct", "max_pct")}
            entry["points"] = per_point
            entry["sentence"] = map_sentence(entry, points)
            claims.append(entry)
        metrics = []
        for prot, meth, metric in self.spec.metrics:
            per_point = []
            for i in range(len(self.spec.points)):
                sm = ((aggs[i].get("over_runs") or {}).get(prot, {}).get(meth, {})
                      .get(metric)) or {}
                per_point.append({k: sm.get(k) for k in ("mean", "ci_low", "ci_high", "n")}
                                 if sm else None)
            metrics.append({"protocol": prot, "method": meth, "metric": metric,
                            "points": per_point})
        return {"axes": [{"name": a.name, "source": a.source, "labels": list(a.labels),
                          "numeric": list(a.numeric) if a.numeric else None}
                         for a in self.spec.axes],
                "replicates_per_point": self.R, "points": points, "claims": claims,
                "metrics": metrics}


def side(claim: dict) -> str | None:
    """Which side of the claimed range a "disagrees" lies on: ``"exceeds"`` (better than the
    range allows) or ``"falls short"``; None for another verdict."""
    if claim.get("verdict") != "disagrees":
        return None
    hi, mean = claim.get("max_pct"), (claim.get("summary") or {}).get("mean")
    if mean is None:
        return None
    if hi is not None and mean > hi:
        return "exceeds"
    return "falls short of"


def _verdict_word(p: dict | None) -> str:
    if p is None:
        return "not run"
    v = p["verdict"]
    if v == "disagrees":
        return f"disagrees ({(p.get('side') or 'falls short of').removesuffix(' of')})"
    return v


def map_sentence(claim: dict, points: list[dict]) -> str:
    """``"holds where A, B; disagrees (falls short) where C; inconclusive where D"``."""
    groups: dict[str, list[str]] = {}
    for p, pt in zip(claim["points"], points):
        word = "holds" if p is not None and p["verdict"] == "agrees" else _verdict_word(p)
        groups.setdefault(word, []).append(pt["label"] + (" (the scenario)" if pt["base"]
                                                          else ""))
    order = ["holds", "disagrees (falls short)", "disagrees (exceeds)", "inconclusive",
             "untestable", "not run"]
    parts = [f"{w} where {'; '.join(groups[w])}" for w in order if w in groups]
    parts += [f"{w} where {'; '.join(v)}" for w, v in groups.items() if w not in order]
    if "holds" not in groups:
        parts.insert(0, "holds nowhere on this map")
    return "; ".join(parts)
