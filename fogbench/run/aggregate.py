"""Every number of a scenario as a distribution over replicates: per metric its summary and
interval, the paired improvements over raw and between methods, the spread over method seeds,
the claims' verdicts and what a lab's references cost (``metrics.json``'s ``montecarlo``)."""

from __future__ import annotations

import math

import numpy as np

from fogbench.run import stats as S

__all__ = ["aggregate", "TIMING_METRICS", "one_line"]

TIMING_METRICS = ("fit_time_s", "compensate_time_s", "compensate_samples_per_s")
# per-replicate values kept for the distribution figure and the recording (mean over scored runs)
SERIES_METRICS = ("rmse_dph", "std_dps", "bias_stability_100s_dph", "drift_rms_dph",
                  "coef_rms_error_dph", "coef_rms_stderr_dph", "coef_z_rms", "arw_deg_rt_h", "bias_instability_dph", "rrw_dph_rt_h",
                  "gm_sigma_dph", "gm_tau_s",
                  "improvement_rmse_pct", "improvement_bias_stability_pct",
                  "improvement_drift_pct", "improvement_std_pct")


# ---------------------------------------------------------------------------------------------
# Aggregation
def _is_num(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _value(by_label: dict, label: str, metric: str) -> float:
    m = by_label.get(label)
    if not isinstance(m, dict) or m.get("status") == "failed":
        return math.nan
    v = m.get(metric)
    return float(v) if _is_num(v) else math.nan


def _series(docs: list[dict], prot: str, run: str, label: str, metric: str) -> np.ndarray:
    """One value per replicate (mean over method seeds when there are several); NaN: failed
    or not computed."""
    out = []
    for d in docs:
        p = d["protocols"].get(prot, {})
        seeds = p.get("seeds", {}).get(run, {}).get(label)
        if seeds:
            vals = [float(m[metric]) for m in seeds
                    if isinstance(m, dict) and m.get("status") != "failed" and _is_num(m.get(metric))]
            out.append(float(np.mean(vals)) if len(vals) == len(seeds) else math.nan)
        else:
            out.append(_value(p.get("runs", {}).get(run, {}), label, metric))
    return np.asarray(out, dtype=float)


def _computed(docs, prot: str, run: str, label: str, metric: str) -> bool:
    """Whether ``metric`` exists for this run and label in some replicate, or the method
    failed there (then its failures count)."""
    for d in docs:
        m = d["protocols"].get(prot, {}).get("runs", {}).get(run, {}).get(label)
        if isinstance(m, dict) and (metric in m or m.get("status") == "failed"):
            if metric in m or label not in ("raw", "oracle"):
                return True
    return False


def _over_runs(docs, prot: str, runs: list[str], label: str, metric: str) -> np.ndarray:
    """Per replicate, the mean over ``runs`` (NaN when any is missing)."""
    cols = [_series(docs, prot, r, label, metric) for r in runs]
    return np.mean(cols, axis=0) if cols else np.full(len(docs), math.nan)


def _improvement(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per replicate: 100 (1 - a / b), of two methods' means over the scored runs."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return 100.0 * (1.0 - a / b)


def _seed_values(doc: dict, prot: str, runs: list[str], label: str, metric: str):
    """Per method seed k of one replicate: the metric's mean over ``runs`` (the K fits of a
    protocol are the same K models on every scored run), shape (K,); None without seeds."""
    seeds = doc["protocols"].get(prot, {}).get("seeds", {})
    per_run = []
    for r in runs:
        ms = seeds.get(r, {}).get(label)
        if not ms:
            return None
        per_run.append([m.get(metric) if isinstance(m, dict) and _is_num(m.get(metric))
                        else math.nan for m in ms])
    if len({len(v) for v in per_run}) != 1:
        return None
    return np.mean(np.asarray(per_run, dtype=float), axis=0)


def p_better(a: np.ndarray, b: np.ndarray, better: str = "lower") -> float:
    """Probability that a start of A beats a start of B drawn independently (ties count half):
    the mean over all K_a x K_b pairs of 1[a_i better than b_j] (the Mann-Whitney statistic
    over K_a K_b). NaN (failed fits) are left out; NaN when either side has none."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    a, b = a[np.isfinite(a)], b[np.isfinite(b)]
    if not a.size or not b.size:
        return math.nan
    d = a[:, None] - b[None, :]
    if better == "higher":
        d = -d
    return float(np.mean((d < 0) + 0.5 * (d == 0)))


def _over_seeds(docs, prot: str, runs: list[str], better: str, than: str, metric: str):
    """A claim between two seeded methods over their method starts: the pooled distribution
    of each (median, 5 and 95 % quantiles over replicates x seeds) and P(a start of ``better``
    beats a start of ``than`` in the same replicate), summarised over replicates; None when
    either method has no seeds. A start that failed (no value) is left out of both and
    counted in ``failed_starts``."""
    direction = "higher" if metric.endswith("_pct") else "lower"
    ps, pooled, ks = [], {better: [], than: []}, set()
    per_rep: dict = {better: [], than: []}
    for d in docs:
        a = _seed_values(d, prot, runs, better, metric)
        b = _seed_values(d, prot, runs, than, metric)
        if a is None or b is None:
            return None
        ks.add(len(a))
        ps.append(p_better(a, b, direction))
        for lab, v in ((better, a), (than, b)):
            per_rep[lab].append([None if not math.isfinite(x) else float(x) for x in v])
        pooled[better].extend(a.tolist())
        pooled[than].extend(b.tolist())
    out = {"p_better_start": S.summarize(ps).as_dict(), "seeds_per_replicate": None,
           "failed_starts": {lab: int(np.sum(~np.isfinite(np.asarray(v, dtype=float))))
                             for lab, v in pooled.items()},
           "starts": {lab: len(v) for lab, v in pooled.items()},
           # every start, replicate by replicate (the claim figure's paired starts)
           "per_replicate": per_rep}
    for lab, vals in pooled.items():
        v = np.asarray(vals, dtype=float)
        v = v[np.isfinite(v)]
        out[lab] = ({"median": float(np.median(v)), "q05": float(np.quantile(v, 0.05)),
                     "q95": float(np.quantile(v, 0.95)), "n": int(v.size)} if v.size else None)
    out["seeds_per_replicate"] = ks.pop() if len(ks) == 1 else None
    return out


def _claim_values(docs, a, b, o, vals, ovals) -> dict:
    """A claim's numbers replicate by replicate (None: failed), for its figure: the metric of
    the method (``better``), the comparator (``than``) and the oracle, and the improvements
    the verdict and the oracle's interval are taken over."""
    def col(v):
        return [None if not math.isfinite(x) else float(x) for x in np.asarray(v, dtype=float)]

    return {"replicate": [int(d["replicate"]) for d in docs], "better": col(a), "than": col(b),
            "oracle": col(o), "improvement_pct": col(vals), "oracle_improvement_pct": col(ovals)}


#: The metrics whose lab-minus-ideal difference the report gives: lower is better in each, and
#: the signed mean error (what a bias fitted on a wrong reference absorbs), judged by its size.
LAB_COST_METRICS = ("mean_error_dph", "rmse_dph", "drift_rms_dph", "coef_rms_error_dph",
                    "bias_stability_100s_dph")
_SIGNED = ("mean_error_dph",)


def _labels(docs: list[dict], plan) -> list[str]:
    """The rows of every table: raw, the oracle(s) (the filter's when computed), the methods."""
    labels = ["raw", "oracle"] + [m.label for m in plan.methods]
    if any(isinstance(by.get("oracle_filter"), dict)
           and by["oracle_filter"].get("status") != "not computed"
           for d in docs for p in d["protocols"].values() for by in p.get("runs", {}).values()):
        labels.insert(2, "oracle_filter")
    return labels


def oracle_filter_withheld(docs: list[dict]) -> dict:
    """protocol -> run -> why the filter oracle has no value there, where its noise model does
    not hold (``fogbench.run.runner.oracle_filter_reason``; the reasons of every replicate)."""
    out: dict = {}
    for d in docs:
        for prot, p in d["protocols"].items():
            for run, by in p.get("runs", {}).items():
                m = by.get("oracle_filter")
                if isinstance(m, dict) and m.get("status") == "not computed":
                    have = out.setdefault(prot, {}).setdefault(run, [])
                    if m.get("reason") not in have:
                        have.append(m.get("reason"))
    return {prot: {run: "; ".join(r for r in reasons if r) for run, reasons in by.items()}
            for prot, by in out.items()}


def _scored_runs(docs: list[dict], prot: str) -> list[str]:
    """The runs a protocol scored in any replicate, in the order they first appear."""
    runs: list[str] = []
    for d in docs:
        for r in d["protocols"].get(prot, {}).get("runs", {}):
            if r not in runs:
                runs.append(r)
    return runs


def _metric_names(docs: list[dict], prot: str, runs: list[str],
                  labels: list[str]) -> dict[str, set]:
    """Per label, every numeric metric some replicate has on some run (timings left out)."""
    metrics: dict[str, set] = {lab: set() for lab in labels}
    for d in docs:
        for r in runs:
            for lab, m in d["protocols"].get(prot, {}).get("runs", {}).get(r, {}).items():
                if isinstance(m, dict) and lab in metrics:
                    metrics[lab] |= {k for k, v in m.items()
                                     if _is_num(v) and k not in TIMING_METRICS}
    return metrics


def one_line(error, limit: int = 160) -> str:
    """An error message as one line of a table: its first line, at most ``limit`` characters."""
    text = str(error or "").strip().splitlines()
    line = text[0].strip() if text else "no message recorded"
    return line if len(line) <= limit else line[:limit - 3].rstrip() + "..."


def _failed_methods(docs: list[dict], prot: str, methods: list[str]) -> dict:
    """Per method that failed on some scored run of ``prot`` in some replicate: in how many
    replicates (``failed``) of ``replicates``, and the first error (the lowest replicate's,
    on one line) with its replicate."""
    out: dict = {}
    for lab in methods:
        failed, first = [], None
        for d in docs:
            errs = [m.get("error") for by in d["protocols"].get(prot, {}).get("runs", {}).values()
                    if isinstance(m := by.get(lab), dict) and m.get("status") == "failed"]
            if errs:
                failed.append(int(d["replicate"]))
                first = errs[0] if first is None else first
        if failed:
            out[lab] = {"failed": len(failed), "replicates": len(docs),
                        "first_error": one_line(first), "first_replicate": failed[0]}
    return out


def _protocol_summaries(docs: list[dict], prot: str, runs: list[str], labels: list[str],
                        metrics: dict[str, set]) -> tuple[dict, dict]:
    """One protocol's summaries: per run, and of the mean over its scored runs."""
    ps: dict = {}
    po: dict = {}
    for lab in labels:
        for metric in sorted(metrics[lab]):
            # a metric some runs cannot have (drift needs dwells, Allan terms long records)
            # is "not computed" there, not failed: those runs are left out of its summary
            have = [r for r in runs if _computed(docs, prot, r, lab, metric)]
            for r in have:
                ps.setdefault(r, {}).setdefault(lab, {})[metric] = \
                    S.summarize(_series(docs, prot, r, lab, metric)).as_dict()
            if have:
                po.setdefault(lab, {})[metric] = \
                    S.summarize(_over_runs(docs, prot, have, lab, metric)).as_dict()
                if len(have) < len(runs):   # a mean over fewer runs than the others'
                    po[lab][metric]["runs"] = list(have)
    return ps, po


def _give_failed_their_metrics(metrics: dict[str, set], failed: dict, plan) -> None:
    """A method that failed in every replicate has no metric of its own: it is given the other
    methods' (else every row's), so its summaries (n = 0, n_failed = R) and series (all null)
    list it wherever the methods are listed, in place."""
    others = set().union(*(metrics.get(m.label, set()) for m in plan.methods))
    every = others or set().union(*metrics.values())
    for lab, f in failed.items():
        if not metrics.get(lab) and f["failed"] == f["replicates"]:
            metrics[lab] = set(every)


def _add_seed_spread(seed_spread: dict, docs: list[dict], prot: str,
                     metrics: dict[str, set]) -> None:
    """Add each replicate's sd over method seeds to ``seed_spread`` (paper 002's question)."""
    for d in docs:
        for r, by_label in d["protocols"].get(prot, {}).get("seeds", {}).items():
            for lab, ms in by_label.items():
                for metric in metrics.get(lab, ()):
                    vals = [m[metric] for m in ms if isinstance(m, dict) and
                            _is_num(m.get(metric))]
                    if len(vals) > 1:
                        seed_spread.setdefault(prot, {}).setdefault(r, {}).setdefault(
                            lab, {}).setdefault(metric, []).append(float(np.std(vals, ddof=1)))


def _finish_seed_spread(seed_spread: dict) -> None:
    """Replace each list of per-replicate seed sds by its mean and count, in place."""
    for prot in seed_spread.values():
        for by_label in prot.values():
            for by_metric in by_label.values():
                for metric, sds in by_metric.items():
                    by_metric[metric] = {"mean_std_over_seeds": float(np.mean(sds)),
                                         "replicates": len(sds)}


def _start_series(docs: list[dict], plan, labels: list[str], runs_of: dict) -> dict:
    """Every start of a seeded method (K > 1), per replicate: its mean over the scored runs."""
    start_series: dict = {}
    for prot in plan.protocols:
        for metric in SERIES_METRICS:
            for lab in labels:
                vals = [_seed_values(d, prot.name, runs_of[prot.name], lab, metric)
                        for d in docs]
                if vals and all(v is not None for v in vals) and \
                        any(np.isfinite(v).any() for v in vals):
                    start_series.setdefault(prot.name, {}).setdefault(metric, {})[lab] = \
                        [[None if not math.isfinite(x) else float(x) for x in v] for v in vals]
    return start_series


def _replicate_series(docs: list[dict], plan, labels: list[str], runs_of: dict,
                      over_runs: dict) -> dict:
    """Per replicate, each summarised ``SERIES_METRICS`` as its mean over the scored runs."""
    series: dict = {}
    for prot in plan.protocols:
        for metric in SERIES_METRICS:
            for lab in labels:
                if metric in over_runs[prot.name].get(lab, {}):
                    vals = _over_runs(docs, prot.name, runs_of[prot.name], lab, metric)
                    series.setdefault(prot.name, {}).setdefault(metric, {})[lab] = \
                        [None if not math.isfinite(v) else float(v) for v in vals]
    return series


def _claim_oracle(c, plan, labels: list[str]) -> tuple[bool, str]:
    """(whether the oracle bounds the claim, which oracle row) for a claim's method."""
    import fogcomp

    better_cls = None
    spec = next((m for m in plan.methods if m.label == c.better), None)
    if spec is not None:
        better_cls = fogcomp.get_method(spec.name)
    # the oracle removes the true deterministic error terms: a floor for a model of those
    # terms (a supervised method); for a filter, which also removes noise, the floor is the
    # filter oracle (the best estimate given the true noise model, where the true rate is
    # constant: fogbench.run.runner.oracle_filter)
    oracle_bounds = better_cls is not None and better_cls.supervised
    oracle_label = "oracle"
    if better_cls is not None and not better_cls.supervised and \
            "oracle_filter" in labels:
        oracle_bounds, oracle_label = True, "oracle_filter"
    return oracle_bounds, oracle_label


def _claim_on_protocol(docs: list[dict], c, prot, runs: list[str], oracle_bounds: bool,
                       oracle_label: str) -> dict | None:
    """One claim judged on one protocol's replicates; None: the comparator has no value."""
    a, b = (_over_runs(docs, prot.name, runs, lab, c.metric)
            for lab in (c.better, c.than))
    vals = _improvement(a, b)
    if np.all(np.isnan(vals)) and not any(
            _is_num(m.get(c.metric)) or m.get("status") == "failed"    # a failed comparator
            for d in docs                                           # keeps its claim
            if isinstance(m := d["protocols"].get(prot.name, {}).get("runs", {})
                          .get(runs[0], {}).get(c.than), dict)):
        return None
    o = _over_runs(docs, prot.name, runs, oracle_label, c.metric)
    ovals = _improvement(o, b)
    if oracle_label == "oracle_filter" and np.all(np.isnan(ovals)):
        # the filter oracle has no value on these runs (withheld where its noise model does
        # not hold, or never computed there): no bound, rather than a bound nobody checked
        oracle_bounds = False
    v = S.claim_verdict(vals, c.min_pct, c.max_pct,
                        oracle=ovals if oracle_bounds else None, better="higher")
    pair = S.paired_difference(a, b, better="higher" if c.metric.endswith("_pct")
                               else "lower")
    return {"text": c.text, "source": c.source, "protocol": prot.name,
            "in_sample": prot.in_sample, "metric": c.metric, "better": c.better,
            "than": c.than, "runs": runs, "min_pct": c.min_pct,
            "max_pct": c.max_pct, **v.as_dict(),
            "oracle_improvement": S.summarize(ovals).as_dict(),
            "oracle_bounds_claim": oracle_bounds, "oracle": oracle_label,
            "paired": pair.as_dict(),
            # oracle minus comparator, in the metric's unit (the claim figure)
            "oracle_paired": S.paired_difference(
                o, b, better=pair.better).as_dict(),
            "per_replicate": _claim_values(docs, a, b, o, vals, ovals),
            "over_seeds": _over_seeds(docs, prot.name, runs, c.better, c.than,
                                      c.metric)}


def _claims(docs: list[dict], plan, labels: list[str], runs_of: dict) -> list[dict]:
    """Every claim of the plan judged on every protocol that scored its run(s)."""
    claims = []
    for c in plan.claims:
        if c.better not in labels or c.than not in labels:
            continue  # a method left out of this run (--method)
        oracle_bounds, oracle_label = _claim_oracle(c, plan, labels)
        for prot in plan.protocols:
            runs = [r for r in runs_of[prot.name] if c.run is None or r == c.run]
            if not runs:
                continue
            claim = _claim_on_protocol(docs, c, prot, runs, oracle_bounds, oracle_label)
            if claim is not None:
                claims.append(claim)
    return claims


def _lab_cost(docs: list[dict], plan, runs_of: dict, over_runs: dict,
              failed_methods: dict) -> list[dict]:
    """What the lab's references cost each method (lab minus ideal-lab twin, paired); a
    method that failed in every replicate of either protocol has none (the report names its
    failure)."""
    # its metric fitted on the lab's references minus fitted on the truth (the ideal-lab twin
    # protocol), replicate by replicate (the same power-ons and the same random starts in both)
    lab_cost = []
    for prot in plan.protocols:
        if prot.twin_of is None or prot.twin_of not in runs_of:
            continue
        runs = [r for r in runs_of[prot.twin_of] if r in runs_of[prot.name]]
        for m in plan.methods:
            if any((f := failed_methods.get(p, {}).get(m.label)) and
                   f["failed"] == f["replicates"] for p in (prot.twin_of, prot.name)):
                continue
            for metric in LAB_COST_METRICS:
                if metric not in over_runs[prot.twin_of].get(m.label, {}) or \
                        metric not in over_runs[prot.name].get(m.label, {}):
                    continue
                have = [r for r in runs if _computed(docs, prot.twin_of, r, m.label, metric)
                        and _computed(docs, prot.name, r, m.label, metric)]
                if not have:
                    continue
                a = _over_runs(docs, prot.twin_of, have, m.label, metric)
                b = _over_runs(docs, prot.name, have, m.label, metric)
                pair = S.paired_difference(a, b, better="lower").as_dict()
                if metric in _SIGNED:    # worse: further from 0
                    size = S.paired_difference(np.abs(a), np.abs(b), better="lower").as_dict()
                    pair["second_better"] = size["second_better"]
                lab_cost.append({"protocol": prot.twin_of, "ideal": prot.name,
                                 "method": m.label, "metric": metric, "runs": have,
                                 "lab": S.summarize(a).as_dict(),
                                 "truth": S.summarize(b).as_dict(), "paired": pair})
    return lab_cost


def _rankings(docs: list[dict], plan, runs_of: dict) -> list[dict]:
    """How often the replicates order the methods as each table of the paper does."""
    rankings = []
    groups: dict = {}
    for pv in plan.paper:
        if pv.segment is None:
            groups.setdefault((pv.metric, pv.run), {})[pv.method] = pv.value
    for (metric, run), theirs in groups.items():
        if len(theirs) < 2:
            continue
        better = "higher" if metric.endswith("_pct") else "lower"
        paper_order = sorted(theirs, key=theirs.get, reverse=(better == "higher"))
        for prot in plan.protocols:
            for r in [run] if run else runs_of[prot.name]:
                if r not in runs_of[prot.name]:
                    continue
                vals = {lab: _series(docs, prot.name, r, lab, metric) for lab in theirs}
                if all(np.all(np.isnan(v)) for v in vals.values()):
                    continue
                orders = S.ordering_probabilities(vals, better=better)
                rankings.append({
                    "protocol": prot.name, "run": r, "metric": metric,
                    "paper_order": paper_order,
                    "p_paper_order": S.ordering_probability(vals, paper_order, better=better),
                    "orderings": [o.as_dict() for o in orders]})
    return rankings


def aggregate(docs: list[dict], sc, plan) -> dict:
    """The replicate distributions of every metric, claim and ranking (see the module doc)."""
    docs = sorted(docs, key=lambda d: d["replicate"])
    summary: dict = {}
    over_runs: dict = {}
    seed_spread: dict = {}
    runs_of: dict = {}
    failed_methods: dict = {}
    labels = _labels(docs, plan)
    for prot in plan.protocols:
        runs_of[prot.name] = runs = _scored_runs(docs, prot.name)
        metrics = _metric_names(docs, prot.name, runs, labels)
        failed_methods[prot.name] = _failed_methods(docs, prot.name,
                                                    [m.label for m in plan.methods])
        _give_failed_their_metrics(metrics, failed_methods[prot.name], plan)
        summary[prot.name], over_runs[prot.name] = _protocol_summaries(
            docs, prot.name, runs, labels, metrics)
        _add_seed_spread(seed_spread, docs, prot.name, metrics)
    _finish_seed_spread(seed_spread)
    start_series = _start_series(docs, plan, labels, runs_of)
    series = _replicate_series(docs, plan, labels, runs_of, over_runs)
    claims = _claims(docs, plan, labels, runs_of)
    lab_cost = _lab_cost(docs, plan, runs_of, over_runs, failed_methods)
    rankings = _rankings(docs, plan, runs_of)
    return {"replicates": len(docs), "summary": summary, "over_runs": over_runs,
            "seed_spread": seed_spread, "claims": claims, "rankings": rankings,
            "lab_cost": lab_cost, "failed_methods": {p: f for p, f in failed_methods.items() if f},
            "oracle_filter_withheld": oracle_filter_withheld(docs),
            "series": series, "start_series": start_series,
            "interval": "95 % Student t-interval of the mean over replicates "
                        "(fogbench.run.stats.summarize)"}
