"""The bundled scenarios' cost: each one's first run and one replicate after it, and the
replicates per second of two of them on one and on two local processes."""

from __future__ import annotations

import time


def _warm_up(i: int) -> int:
    import fogbench.run.runner  # noqa: F401  (the imports a replicate needs)

    time.sleep(0.2)  # keep this worker busy so that every worker gets one
    return i


def bench_scenario_replicates(root=None, first_only: bool = False) -> list[dict]:
    """Every bundled scenario: its first run (the table's motion simulated by MuJoCo, then
    replicate 0 in full, as ``fogbench run`` and the suite do) and one replicate after it (the
    table's motion reused, what each further replicate costs a worker), in one process, each
    once; the replicate as a ratio to the first run. ``make run`` costs about the first runs
    plus (R - 1) replicates per scenario, shared between the processes. ``first_only``: the
    first run alone (the quick bench)."""
    import tempfile
    from pathlib import Path

    from fogbench.run.engines import SerialExecutor
    from fogbench.run.montecarlo import ScenarioMC

    root = Path(root) if root else Path(__file__).resolve().parents[2] / "scenarios"
    paths = sorted(root.glob("*.toml"))
    then = "" if first_only else " and one replicate after it"
    print(f"Scenarios: the first run (table + replicate 0){then}, one process, wall time, "
          f"{len(paths)} scenario(s) of {root}")
    print(f"  {'scenario':<26}{'table s':>9}{'replicate 0 s':>15}"
          + ("" if first_only else f"{'replicate 1 s':>15}{'replicate / first run':>23}")
          + f"{'replicates':>12}", flush=True)
    rows = []
    for path in paths:
        with tempfile.TemporaryDirectory() as d:
            mc = ScenarioMC(path, Path(d) / "run", replicates=2)
            mc.simulate_truths()
            t0 = time.perf_counter()
            mc.run_first()
            first_s = time.perf_counter() - t0
            t0 = time.perf_counter()
            if not first_only:
                with SerialExecutor() as ex:
                    mc.submit(ex)
                    mc.wait()
            rep_s = time.perf_counter() - t0 if not first_only else float("nan")
            failed = bool(mc.failures)
            mc.work.remove()
        row = {"scenario": mc.sc.name, "table_s": mc.truth_s, "first_s": first_s,
               "replicate_s": rep_s, "ratio": rep_s / (mc.truth_s + first_s),
               "replicates": mc.plan.replicates, "failed": failed}
        rows.append(row)
        print(f"  {row['scenario']:<26}{row['table_s']:>9.1f}{first_s:>15.1f}"
              + ("" if first_only else f"{rep_s:>15.1f}{row['ratio']:>23.2f}")
              + f"{row['replicates']:>12}"
              + ("  (the replicate failed)" if failed else ""), flush=True)
    if first_only:
        return rows
    total = sum(r["table_s"] + r["first_s"] + (r["replicates"] - 1) * r["replicate_s"]
                for r in rows)
    print(f"  one process would need about {total / 60:.1f} min for every scenario's replicates "
          "(first run + (R - 1) replicates each); make run shares them between the processes "
          "and also writes figures, recordings and the claim maps")
    return rows


def bench_replicates(names=("paper000_wnn", "paper002_acobp"), replicates: int = 10) -> None:
    """Replicates per second of two bundled scenarios on 1 and on 2 local processes, and the
    parallel efficiency (rate on 2 / (2 x rate on 1)); the table's motion is simulated before
    the clock starts, as the runner does once per run definition."""
    import tempfile
    from pathlib import Path

    from fogbench.run.engines import make_executor
    from fogbench.run.montecarlo import ScenarioMC

    root = Path(__file__).resolve().parents[2] / "scenarios"
    print(f"Monte Carlo: {replicates} replicates after replicate 0, wall time")
    for name in names:
        path = root / f"{name}.toml"
        if not path.exists():
            print(f"  {name}: {path} not found; skipped")
            continue
        rates = {}
        for jobs in (1, 2):
            with tempfile.TemporaryDirectory() as d:
                mc = ScenarioMC(path, Path(d) / "run", replicates=replicates + 1)
                mc.simulate_truths()
                with make_executor(jobs=jobs) as ex:
                    # start the workers and import the bench in them before the clock starts
                    for f in [ex.submit(_warm_up, i) for i in range(2 * jobs)]:
                        f.result()
                    t0 = time.perf_counter()
                    mc.submit(ex)
                    mc.wait()
                    rates[jobs] = replicates / (time.perf_counter() - t0)
                mc.work.remove()
        print(f"  {name:16s} {rates[1]:7.2f} replicates/s on 1 process, {rates[2]:7.2f} on 2: "
              f"parallel efficiency {rates[2] / (2 * rates[1]):.0%}")
