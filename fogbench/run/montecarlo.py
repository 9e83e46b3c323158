"""Monte Carlo over power-ons and method seeds: every number of a scenario as a distribution.

A scenario runs R replicates (``[montecarlo] replicates``, or ``--replicates``). Replicate r
draws every random stream from (scenario seed, r, run, stream) alone (``fogbench.run.runner``); the
table's motion is deterministic and simulated once per run definition and process. Each
replicate's metrics are written atomically, one file each, into a work folder beside the run
directory (``.<name>.replicates``, with the bench's marker), so a killed run loses only the
replicates in flight and ``--resume`` skips the completed ones. When all are done the files move
into ``<run dir>/replicates/`` and the aggregate goes into ``metrics.json`` under
``"montecarlo"``: per protocol, run, method and metric the mean, median, standard deviation and
the 95 % t-interval of the mean over replicates (``fogbench.run.stats``); the claims' verdicts
(agrees / disagrees / inconclusive / untestable) with the oracle's improvement beside them; the
probability of each ranking of the methods a paper compares.

Replicate 0 is the single run of old (the runs' own seeds): it is computed in full in the main
process, for the report's figures and the recording, while the other replicates run on the
executor (a local process pool, or Dask).
"""

from __future__ import annotations

import hashlib
import json
import threading
import time
from pathlib import Path

import numpy as np

from fogbench.run.aggregate import TIMING_METRICS, _is_num, aggregate
from fogbench.run.workdir import (
    MonteCarloError,
    WorkDir,
    _clean,
    _overrides_text,
    replicate_doc,
    scenario_digest,
)
from fogbench.scenario.environment import method_environment, method_environment_set

__all__ = ["replicate_task"]


# ---------------------------------------------------------------------------------------------
# One replicate (runs on a worker)
def replicate_task(task: tuple) -> dict:
    """Worker: ``(scenario path, digest, replicate r, method_seeds K, method labels or None,
    truths, overrides)`` -> the replicate's metrics (:func:`replicate_doc`). ``truths`` (run
    name -> ``Truth``) is the table's motion, simulated once by the main process and reused by
    every replicate; ``overrides`` the claim-map point's values (or None)."""
    from fogbench.run.runner import run_scenario

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
        from fogbench.run.runner import scenario_seed
        from fogbench.scenario import load_plan, load_scenario
        from fogbench.scenario.load import RUNNER_SECTIONS

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
        from fogbench.run.runner import run_scenario

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
