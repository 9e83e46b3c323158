"""Monte Carlo over power-ons and method seeds: every number of a scenario as a distribution.

A scenario runs R replicates (``[montecarlo] replicates``, or ``--replicates``). Replicate r
draws every random stream from (scenario seed, r, run, stream) alone (``fogbench.runner``); the
table's motion is deterministic and simulated once per run definition and process. Each
replicate's metrics are written atomically, one file each, into a work folder beside the run
directory (``.<name>.replicates``, with the bench's marker), so a killed run loses only the
replicates in flight and ``--resume`` skips the completed ones. When all are done the files move
into ``<run dir>/replicates/`` and the aggregate goes into ``metrics.json`` under
``"montecarlo"``: per protocol, run, method and metric the mean, median, standard deviation and
the 95 % t-interval of the mean over replicates (``fogbench.stats``); the claims' verdicts
(agrees / disagrees / inconclusive / untestable) with the oracle's improvement beside them; the
probability of each ranking of the methods a paper compares.

Replicate 0 is the single run of old (the runs' own seeds): it is computed in full in the main
process, for the report's figures and the recording, while the other replicates run on the
executor (a local process pool, or Dask).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import threading
import time
from pathlib import Path

import numpy as np

from . import stats as S
from .io import atomic_write_text, json_ready, versions
from .outdir import MARKER, Claim, OutDirError, _marker
from .scenario import method_environment, method_environment_set

__all__ = ["MonteCarloError", "replicate_task", "replicate_doc", "aggregate", "WorkDir",
           "scenario_digest", "TIMING_METRICS"]

TIMING_METRICS = ("fit_time_s", "compensate_time_s", "compensate_samples_per_s")
# per-replicate values kept for the distribution figure and the recording (mean over scored runs)
SERIES_METRICS = ("rmse_dph", "std_dps", "bias_stability_100s_dph", "drift_rms_dph",
                  "coef_rms_error_dph", "coef_rms_stderr_dph", "coef_z_rms", "arw_deg_rt_h", "bias_instability_dph", "rrw_dph_rt_h",
                  "gm_sigma_dph", "gm_tau_s",
                  "improvement_rmse_pct", "improvement_bias_stability_pct",
                  "improvement_drift_pct", "improvement_std_pct")


class MonteCarloError(ValueError):
    """A Monte Carlo run cannot go on as asked (e.g. ``--resume`` on another scenario)."""


def scenario_digest(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()


# ---------------------------------------------------------------------------------------------
# One replicate (runs on a worker)
def replicate_task(task: tuple) -> dict:
    """Worker: ``(scenario path, digest, replicate r, method_seeds K, method labels or None,
    truths, overrides)`` -> the replicate's metrics (:func:`replicate_doc`). ``truths`` (run
    name -> ``Truth``) is the table's motion, simulated once by the main process and reused by
    every replicate; ``overrides`` the claim-map point's values (or None)."""
    from .runner import run_scenario

    path, digest, r, k, methods, truths, overrides, env = task
    try:
        now = scenario_digest(Path(path).read_bytes().decode("utf-8", "replace")
                              + _overrides_text(overrides))
    except OSError as exc:
        raise MonteCarloError(f"{path}: cannot read the scenario file on this worker "
                              f"({exc.strerror}); the workers need it at the same path") from None
    if now != digest:
        raise MonteCarloError(f"{path}: the scenario file changed during the run; replicate "
                              f"{r} was not computed (its results would mix two versions)")
    t0 = time.perf_counter()
    with method_environment_set(env):   # --with-method, --fit-timeout-s of the main process
        res = run_scenario(path, replicate=r, method_seeds=k, methods=methods,
                           truths=dict(truths), overrides=overrides)
    return replicate_doc(res, time.perf_counter() - t0)


def _overrides_text(overrides: dict | None) -> str:
    """What a claim-map point adds to its scenario file's text for the digests."""
    return "" if not overrides else "\n" + json.dumps(overrides, sort_keys=True)


def replicate_doc(res, wall_s: float) -> dict:
    """What a replicate leaves: every scored piece's metrics (and per seed, with K > 1)."""
    prots: dict = {}
    for it in res.scored:
        p = prots.setdefault(it.protocol, {"runs": {}, "seeds": {}})
        p["runs"][it.run] = {lab: _clean(m) for lab, m in it.metrics.items()}
        if it.seed_metrics:
            p["seeds"][it.run] = {lab: [_clean(m) for m in ms]
                                  for lab, ms in it.seed_metrics.items()}
    return {"replicate": int(res.metrics.get("replicate", 0)),
            "method_seeds": int(res.metrics.get("method_seeds", 1)),
            "wall_s": wall_s, "protocols": prots}


_clean = json_ready


# ---------------------------------------------------------------------------------------------
# The work folder: one file per completed replicate, resumable
class WorkDir:
    """``.<run dir name>.replicates`` beside the run directory: ``r00000.json``, ... and the
    marker naming the scenario (its text's SHA-256), the fogbench version, K and the methods.

    The folder is claimed when it is opened, before any work: an exclusive ``flock`` on the
    folder itself, held until this process ends (the kernel releases it even after kill -9),
    so a second run into the same place is refused at once. Every replicate file carries a
    SHA-256 of its content and of the scenario it belongs to (``sha256``): a file edited,
    relabelled or copied from another scenario's run is refused by ``--resume``, naming it."""

    def __init__(self, out: Path, sc, method_seeds: int, methods: list[str] | None,
                 tag: str | None = None):
        self.out = Path(out)
        self.path = self.out.parent / (f".{self.out.name}.replicates" if tag is None else
                                       f".{self.out.name}.{tag}.replicates")
        self.identity = {"kind": "replicates", "scenario": sc.name,
                         "scenario_file": str(sc.path), "scenario_sha256": scenario_digest(sc.text),
                         "fogbench": versions().get("fogbench"), "method_seeds": method_seeds,
                         "methods": sorted(methods) if methods else None,
                         "method_environment": method_environment() or None}
        self._claim = Claim(self.path, self._busy)

    def _mismatch(self, found: dict, where: Path) -> str | None:
        for key, what in (("scenario_sha256", "another scenario file (or an edited one)"),
                          ("fogbench", "another fogbench version"),
                          ("method_seeds", "another method_seeds"), ("methods", "other methods"),
                          ("method_environment", "other --with-method / --fit-timeout-s")):
            if found.get(key) != self.identity[key]:
                return (f"--resume: {where} holds replicates of {what} "
                        f"({key}: {found.get(key)!r}, now {self.identity[key]!r}); refused. Run "
                        "without --resume to start afresh")
        return None

    def _busy(self, path):
        found = _marker(path, kinds=("replicates",)) or {}
        return MonteCarloError(f"{path} is being filled by another fogbench process"
                               + (f" (pid {found['pid']})" if found.get("pid") else "")
                               + "; wait for it or give another --out")

    def release(self) -> None:
        self._claim.release()

    def open(self, resume: bool) -> dict[int, dict]:
        """Claim the folder and check it; return the completed replicates (empty unless
        ``resume``).

        Nothing is deleted: replicates a previous run left are kept unless the user resumes
        them or removes the folder; a folder another live process is filling is refused; a
        folder that is not ours is refused untouched.
        """
        found = _marker(self.path, kinds=("replicates",))
        if (self.path.exists() or self.path.is_symlink()) and found is None and not (
                self.path.is_dir() and not self.path.is_symlink()
                and not os.listdir(self.path)):
            raise OutDirError(f"{self.path} exists and is not a fogbench replicates folder; it "
                              "was left untouched. Move it away or give another --out")
        created = self._claim.acquire()
        try:
            done = self._open(resume)
            self._write_marker()
        except BaseException:
            if created:
                self.remove()
            else:
                self.release()
            raise
        return done

    def _open(self, resume: bool) -> dict[int, dict]:
        found = _marker(self.path, kinds=("replicates",))
        done: dict[int, dict] = {}
        if not resume:
            left = sorted(self.path.glob("r*.json")) if found is not None else []
            if left:
                raise MonteCarloError(
                    f"{self.path} holds {len(left)} replicate(s) of an earlier run that did not "
                    "finish; give --resume to keep them and compute the rest, or remove the "
                    "folder to start afresh")
            return done
        prev = self.out / "replicates"
        if found is not None and any(self.path.glob("r*.json")):
            src, ident = self.path, found
        elif (self.out / MARKER).exists() and prev.is_dir():
            src, ident = prev, _read_json(prev / "identity.json")
        elif found is not None:
            src, ident = self.path, found
        else:
            raise MonteCarloError(f"--resume: nothing to resume for {self.out} (neither "
                                  f"{self.path} nor {prev} holds replicates)")
        msg = self._mismatch(ident or {}, src)
        if msg:
            raise MonteCarloError(msg)
        for f in sorted(src.glob("r*.json")):
            doc = self._checked(f)
            done[doc["replicate"]] = doc
        if src != self.path:
            for doc in done.values():
                self.write(doc)
        return done

    def _checked(self, f: Path) -> dict:
        """A stored replicate, refused (naming the file) unless its checksum, its scenario and
        its file name agree with its content."""
        doc = _read_json(f)
        why = None
        if not isinstance(doc, dict):
            why = "not a replicate file (not a JSON object)"
        elif doc.get("sha256") != _doc_sha256(doc):
            why = ("its content does not match its checksum (key 'sha256'): it was edited or "
                   "damaged" if "sha256" in doc else "it has no checksum (key 'sha256')")
        elif doc.get("scenario_sha256") != self.identity["scenario_sha256"]:
            why = "it belongs to another scenario file (key 'scenario_sha256')"
        elif not isinstance(doc.get("replicate"), int) or \
                f.name != f"r{doc['replicate']:05d}.json":
            why = f"it holds replicate {doc.get('replicate')!r}, not the one its name says"
        if why:
            raise MonteCarloError(f"--resume: {f}: {why}; refused. Remove the file to compute "
                                  "that replicate again, or run without --resume")
        return doc

    def _write_marker(self) -> None:
        atomic_write_text(self.path / MARKER, json.dumps({**self.identity, "pid": os.getpid()},
                                                         indent=2))

    def write(self, doc: dict) -> None:
        if not (self.path / MARKER).exists():
            self.path.mkdir(parents=True, exist_ok=True)
            self._write_marker()
        body = {k: v for k, v in _clean(doc).items() if k != "sha256"}
        body["scenario_sha256"] = self.identity["scenario_sha256"]
        body["sha256"] = _doc_sha256(body)
        atomic_write_text(self.path / f"r{doc['replicate']:05d}.json", json.dumps(body))

    def copy_into(self, run_tmp: Path, keep: list[int]) -> None:
        """Copy the replicates ``keep`` into the new run directory; the work folder stays until
        the run directory is in place (:meth:`remove`), so a failed rename loses nothing."""
        dest = run_tmp / "replicates"
        dest.mkdir()
        for r in keep:
            f = self.path / f"r{r:05d}.json"
            if f.exists():
                shutil.copyfile(f, dest / f.name)
        atomic_write_text(dest / "identity.json", json.dumps(self.identity, indent=2))

    def remove(self) -> None:
        self._claim.remove()

    def remove_if_empty(self) -> None:
        """After a failure before any replicate was stored: leave nothing behind."""
        if self.path.is_dir() and not any(self.path.glob("r*.json")):
            self.remove()
        else:
            self.release()


def _doc_sha256(doc: dict) -> str:
    """SHA-256 of a replicate file's content without its ``sha256`` key (canonical JSON)."""
    body = {k: v for k, v in doc.items() if k != "sha256"}
    return hashlib.sha256(json.dumps(body, sort_keys=True, separators=(",", ":"))
                          .encode()).hexdigest()


def _read_json(path: Path):
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError, RecursionError):
        return None


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


def aggregate(docs: list[dict], sc, plan) -> dict:
    """The replicate distributions of every metric, claim and ranking (see the module doc)."""
    import fogcomp

    docs = sorted(docs, key=lambda d: d["replicate"])
    summary: dict = {}
    over_runs: dict = {}
    seed_spread: dict = {}
    runs_of: dict = {}
    labels = ["raw", "oracle"] + [m.label for m in plan.methods]
    if any("oracle_filter" in by for d in docs for p in d["protocols"].values()
           for by in p.get("runs", {}).values()):
        labels.insert(2, "oracle_filter")
    for prot in plan.protocols:
        runs: list[str] = []
        for d in docs:
            for r in d["protocols"].get(prot.name, {}).get("runs", {}):
                if r not in runs:
                    runs.append(r)
        runs_of[prot.name] = runs
        metrics: dict[str, set] = {lab: set() for lab in labels}
        for d in docs:
            for r in runs:
                for lab, m in d["protocols"].get(prot.name, {}).get("runs", {}).get(r, {}).items():
                    if isinstance(m, dict) and lab in metrics:
                        metrics[lab] |= {k for k, v in m.items()
                                         if _is_num(v) and k not in TIMING_METRICS}
        ps = summary.setdefault(prot.name, {})
        po = over_runs.setdefault(prot.name, {})
        for lab in labels:
            for metric in sorted(metrics[lab]):
                # a metric some runs cannot have (drift needs dwells, Allan terms long records)
                # is "not computed" there, not failed: those runs are left out of its summary
                have = [r for r in runs if _computed(docs, prot.name, r, lab, metric)]
                for r in have:
                    ps.setdefault(r, {}).setdefault(lab, {})[metric] = \
                        S.summarize(_series(docs, prot.name, r, lab, metric)).as_dict()
                if have:
                    po.setdefault(lab, {})[metric] = \
                        S.summarize(_over_runs(docs, prot.name, have, lab, metric)).as_dict()
                    if len(have) < len(runs):   # a mean over fewer runs than the others'
                        po[lab][metric]["runs"] = list(have)
        # spread over method seeds inside a replicate (paper 002's question)
        for d in docs:
            for r, by_label in d["protocols"].get(prot.name, {}).get("seeds", {}).items():
                for lab, ms in by_label.items():
                    for metric in metrics.get(lab, ()):
                        vals = [m[metric] for m in ms if isinstance(m, dict) and
                                _is_num(m.get(metric))]
                        if len(vals) > 1:
                            seed_spread.setdefault(prot.name, {}).setdefault(r, {}).setdefault(
                                lab, {}).setdefault(metric, []).append(float(np.std(vals, ddof=1)))
    for prot in seed_spread.values():
        for by_label in prot.values():
            for by_metric in by_label.values():
                for metric, sds in by_metric.items():
                    by_metric[metric] = {"mean_std_over_seeds": float(np.mean(sds)),
                                         "replicates": len(sds)}

    # every start of a seeded method (K > 1), per replicate: its mean over the scored runs
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

    series: dict = {}
    for prot in plan.protocols:
        for metric in SERIES_METRICS:
            for lab in labels:
                if metric in over_runs[prot.name].get(lab, {}):
                    vals = _over_runs(docs, prot.name, runs_of[prot.name], lab, metric)
                    series.setdefault(prot.name, {}).setdefault(metric, {})[lab] = \
                        [None if not math.isfinite(v) else float(v) for v in vals]

    claims = []
    for c in plan.claims:
        if c.better not in labels or c.than not in labels:
            continue  # a method left out of this run (--method)
        better_cls = None
        spec = next((m for m in plan.methods if m.label == c.better), None)
        if spec is not None:
            better_cls = fogcomp.get_method(spec.name)
        # the oracle removes the true deterministic error terms: a floor for a model of those
        # terms (a supervised method); for a filter, which also removes noise, the floor is the
        # filter oracle (the best estimate given the true noise model, where the true rate is
        # constant: fogbench.runner.oracle_filter)
        oracle_bounds = better_cls is not None and better_cls.supervised
        oracle_label = "oracle"
        if better_cls is not None and not better_cls.supervised and \
                "oracle_filter" in labels:
            oracle_bounds, oracle_label = True, "oracle_filter"
        for prot in plan.protocols:
            runs = [r for r in runs_of[prot.name] if c.run is None or r == c.run]
            if not runs:
                continue
            a, b = (_over_runs(docs, prot.name, runs, lab, c.metric)
                    for lab in (c.better, c.than))
            vals = _improvement(a, b)
            if np.all(np.isnan(vals)) and not any(
                    _is_num(d["protocols"].get(prot.name, {}).get("runs", {}).get(runs[0], {})
                            .get(c.than, {}).get(c.metric)) for d in docs):
                continue
            o = _over_runs(docs, prot.name, runs, oracle_label, c.metric)
            ovals = _improvement(o, b)
            v = S.claim_verdict(vals, c.min_pct, c.max_pct,
                                oracle=ovals if oracle_bounds else None, better="higher")
            pair = S.paired_difference(a, b, better="higher" if c.metric.endswith("_pct")
                                       else "lower")
            claims.append({"text": c.text, "source": c.source, "protocol": prot.name,
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
                                                     c.metric)})

    # what the lab's references cost each method: its metric fitted on the lab's references
    # minus fitted on the truth (the ideal-lab twin protocol), replicate by replicate (the same
    # power-ons and the same random starts in both)
    lab_cost = []
    for prot in plan.protocols:
        if prot.twin_of is None or prot.twin_of not in runs_of:
            continue
        runs = [r for r in runs_of[prot.twin_of] if r in runs_of[prot.name]]
        for m in plan.methods:
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
    return {"replicates": len(docs), "summary": summary, "over_runs": over_runs,
            "seed_spread": seed_spread, "claims": claims, "rankings": rankings,
            "lab_cost": lab_cost,
            "series": series, "start_series": start_series,
            "interval": "95 % Student t-interval of the mean over replicates "
                        "(fogbench.stats.summarize)"}


def summary_digest(mc: dict) -> str:
    """SHA-256 of the aggregate without anything that depends on the machine (for the
    determinism law: serial, process pool and Dask must agree)."""
    keep = {k: mc.get(k) for k in ("replicates", "summary", "over_runs", "seed_spread",
                                   "claims", "rankings", "series", "start_series")}
    if mc.get("lab_cost"):     # only where there is one: earlier digests stay the same
        keep["lab_cost"] = mc["lab_cost"]
    return hashlib.sha256(json.dumps(_clean(keep), sort_keys=True).encode()).hexdigest()


# ---------------------------------------------------------------------------------------------
# Orchestration: one scenario's replicates on an executor
class ScenarioMC:
    """The replicates of one scenario: submit them, compute replicate 0 in full here, collect.

    ``replicates`` and ``method_seeds`` override the file's ``[montecarlo]`` values.
    """

    def __init__(self, path, out: Path, replicates: int | None = None,
                 method_seeds: int | None = None, methods: list[str] | None = None,
                 resume: bool = False, overrides: dict | None = None, tag: str | None = None,
                 first_in_process: bool = True):
        from .runner import scenario_seed
        from .scenario import RUNNER_SECTIONS, load_plan, load_scenario

        self.path = str(path)
        self.overrides = dict(overrides) if overrides else None
        self.sc = load_scenario(path, extra_sections=RUNNER_SECTIONS, overrides=self.overrides)
        self.plan = load_plan(self.sc)
        self.R = int(replicates or self.plan.replicates)
        self.K = int(method_seeds or self.plan.method_seeds)
        self.methods = methods
        self.env = method_environment()     # sent with every task (workers need not share it)
        self.seed = scenario_seed(self.sc, self.plan)
        self.first_in_process = first_in_process
        self.work = WorkDir(out, self.sc, self.K, methods, tag=tag)
        self.digest = scenario_digest(Path(self.path).read_bytes().decode("utf-8", "replace")
                                      + _overrides_text(self.overrides))
        done = self.work.open(resume)
        # a resumed folder may hold more replicates than asked for now: the first R are used,
        # the others are left out of this run (and say so)
        self.dropped = sorted(r for r in done if r >= self.R)
        self.done = {r: d for r, d in done.items() if r < self.R}
        self.resumed = sorted(self.done)
        first = 1 if first_in_process else 0
        self.todo = [r for r in range(first, self.R) if r not in self.done]
        self.futures: dict = {}
        self.failures: list[dict] = []
        # a future is stored once, by its done-callback (a pool's thread) or by wait(),
        # whichever comes first
        self._stored: set = set()
        self._store_lock = threading.Lock()
        self.store_error: OSError | None = None
        self._on_done = None
        self.res0 = None
        self.first_s = None
        self.truths: dict = {}
        self.truth_s = 0.0

    def simulate_truths(self, say=None, cache: dict | None = None) -> None:
        """The table's motion of every run, once (it is the same in every replicate).
        ``cache`` shares it between scenarios on one table (the points of a claim map)."""
        from sim.rate_table import simulate_truth

        t0 = time.perf_counter()
        # power-ons with one motion program share one simulation of the table
        same: dict = {} if cache is None else cache
        for i, run in enumerate(self.sc.runs):
            key = (run.motion, run.tilt0, self.sc.table, self.sc.fs)
            if key in same:
                self.truths[run.name] = same[key]
                continue
            if say:
                say(f"simulate the table for {run.name} ({i + 1}/{len(self.sc.runs)}, "
                    f"{run.duration:g} s)")
            self.truths[run.name] = same[key] = simulate_truth(
                run.motion, self.sc.fs, self.sc.table, tilt0=run.tilt0)
        self.truth_s = time.perf_counter() - t0

    def submit(self, executor, on_done=None) -> None:
        """Submit the replicates still to do; each is stored (its file written) the moment it
        completes, whatever the main process is doing, so a killed run keeps every finished
        replicate. ``on_done(ok)`` is called after each (e.g. a progress bar)."""
        self._on_done = on_done
        for r in self.todo:
            if self.store_error is not None:   # a serial executor runs each task at submit
                break
            fut = executor.submit(replicate_task, (self.path, self.digest, r, self.K,
                                                   self.methods, self.truths, self.overrides,
                                                   self.env))
            self.futures[fut] = r
            fut.add_done_callback(lambda f, cb=on_done: self._store(f, cb))

    def _store(self, fut, on_done=None) -> None:
        with self._store_lock:
            if fut.cancelled() or fut in self._stored:
                return
            self._stored.add(fut)
            r = self.futures[fut]
            exc = fut.exception()
            if exc is None:
                doc = fut.result()
                if self.store_error is None:
                    try:
                        self.work.write(doc)
                    except OSError as err:
                        # a full disk: no replicate can be kept, so none more is computed; the
                        # error is raised by wait() (a done-callback cannot raise)
                        self.store_error = err
                        for f in self.futures:
                            f.cancel()
                    else:
                        self.done[r] = doc
            elif isinstance(exc, Exception):  # a crashed replicate is a failure, not the end
                self.failures.append({"replicate": r,
                                      "error": f"{type(exc).__name__}: {exc}"})
            if on_done is not None:  # under the lock: one thread at a time advances the bar
                on_done(exc is None)

    def run_first(self, say=None) -> None:
        """Replicate 0 in full (arrays for the figures and the recording)."""
        from .runner import run_scenario

        if not self.truths:
            self.simulate_truths(say)
        t0 = time.perf_counter()
        self.res0 = run_scenario(self.path, progress=say, methods=self.methods,
                                 method_seeds=self.K, truths=dict(self.truths))
        self.first_s = time.perf_counter() - t0 + self.truth_s
        if self.store_error is not None:
            raise self.store_error
        doc = replicate_doc(self.res0, self.first_s)
        if 0 in self.done and _digest_doc(self.done[0]) != _digest_doc(doc):
            raise MonteCarloError(f"--resume: replicate 0 of {self.sc.name} does not reproduce "
                                  "the stored one; the stored replicates were made by other "
                                  "code. Run without --resume")
        self.work.write(doc)
        self.done[0] = doc

    def wait(self) -> None:
        """Until every submitted replicate has completed (and been stored)."""
        import concurrent.futures as cf

        cf.wait(list(self.futures))
        for fut in self.futures:
            exc = fut.exception() if not fut.cancelled() else None
            if exc is not None and not isinstance(exc, Exception):
                raise exc  # Ctrl-C or SIGTERM inside a serial replicate
            # a future is done before its done-callbacks have run (in the pool's thread):
            # store it here if the callback has not yet, so that no replicate is left out
            self._store(fut, self._on_done)
        if self.store_error is not None:
            raise self.store_error

    def kept(self) -> list[int]:
        """The replicates this run reports: 0 .. R-1 (a resumed folder may hold more)."""
        return [r for r in range(self.R) if r in self.done]

    def finish(self, engine: str) -> dict:
        docs = [self.done[r] for r in self.kept()]
        plan = self.plan
        if self.methods:  # --method: the claims and rankings of the methods that ran
            from dataclasses import replace

            plan = replace(plan, methods=tuple(m for m in plan.methods
                                               if m.label in self.methods))
        mc = aggregate(docs, self.sc, plan)
        walls = [d["wall_s"] for d in docs if d["replicate"] > 0 and _is_num(d.get("wall_s"))]
        med = float(np.median(walls)) if walls else None
        mc.update({
            "replicates_requested": self.R, "method_seeds": self.K, "seed": self.seed,
            "engine": engine, "resumed_replicates": self.resumed,
            "failed_replicates": self.failures,
            "cost": {"first_run_s": self.first_s, "replicate_median_s": med,
                     "replicate_over_first": (med / self.first_s) if med and self.first_s
                     else None,
                     "note": "first run: replicate 0 with the table simulated; a replicate: "
                             "FOG draws, fits and scoring with the table's motion reused "
                             "(wall times, this machine)"},
        })
        mc["digest"] = summary_digest(mc)
        return mc


def _digest_doc(doc: dict) -> str:
    def strip(v):
        if isinstance(v, dict):
            return {k: strip(x) for k, x in v.items()
                    if k not in TIMING_METRICS and k not in ("wall_s", "sha256",
                                                             "scenario_sha256")}
        if isinstance(v, list):
            return [strip(x) for x in v]
        return v

    return hashlib.sha256(json.dumps(strip(_clean(doc)), sort_keys=True).encode()).hexdigest()
