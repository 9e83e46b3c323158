"""fogbench.run.executor: the determinism law over engines, job scripts, bad engines, seeds."""

import hashlib
import io
import json
import time

import numpy as np
import pytest

from fogbench.run.dask import EngineError, SchedulerUnreachableError, render_job_script
from fogbench.run.engines import SerialExecutor, engine_label, make_executor
from helpers import run_tasks
from fogbench.run.seeds import replicate_seed, replicate_seed_sequence
from fogbench.console import Progress

SCENARIO_SEED = 20240611
N_REPLICATES = 8


def toy_replicate(r: int) -> dict:
    """A stand-in for one replicate: several runs and streams, each with its own numpy work."""
    out = []
    for run in range(2):
        noise = np.random.default_rng(replicate_seed(SCENARIO_SEED, r, run, "fog"))
        init = np.random.default_rng(replicate_seed_sequence(SCENARIO_SEED, r, run, "method:bp"))
        x = noise.standard_normal((200, 3)).cumsum(axis=0)
        w = init.normal(size=3)
        coef, *_ = np.linalg.lstsq(x, x @ w + noise.standard_normal(200), rcond=None)
        out.append([float(v) for v in coef] + [float(np.std(x))])
    return {"replicate": r, "values": out}


def digest(results) -> str:
    ordered = sorted(results, key=lambda d: d["replicate"])
    return hashlib.sha256(json.dumps(ordered, sort_keys=True).encode()).hexdigest()


def collect(executor) -> str:
    results = [fut.result() for _, fut in run_tasks(executor, toy_replicate,
                                                    range(N_REPLICATES))]
    assert len(results) == N_REPLICATES
    return digest(results)


@pytest.fixture(scope="module")
def serial_digest():
    with make_executor(jobs=1) as ex:
        assert isinstance(ex, SerialExecutor)
        return collect(ex)


def test_serial_equals_two_local_processes(serial_digest):
    with make_executor(jobs=2) as ex:
        assert collect(ex) == serial_digest


def test_the_order_of_replicates_does_not_change_them(serial_digest):
    results = [toy_replicate(r) for r in reversed(range(N_REPLICATES))]
    assert digest(results) == serial_digest
    # a replicate run alone is the same as inside the whole set
    assert toy_replicate(5) == toy_replicate(5)


def test_serial_equals_a_dask_local_cluster_of_two_worker_processes(serial_digest):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        with make_executor(scheduler=cluster.scheduler_address) as ex:
            assert collect(ex) == serial_digest


def test_the_slurm_job_script_names_the_resources_asked_for():
    pytest.importorskip("dask_jobqueue")
    script = render_job_script("slurm", {"cores": 8, "memory": "16GiB", "walltime": "02:30:00",
                                         "queue": "gyro", "account": "fogcal",
                                         "job_extra_directives": ["--exclusive"]})
    for line in ("#SBATCH -p gyro", "#SBATCH -A fogcal", "#SBATCH --cpus-per-task=8",
                 "#SBATCH --mem=16G", "#SBATCH -t 02:30:00", "#SBATCH --exclusive"):
        assert line in script.splitlines(), (line, script)
    assert "tcp://SCHEDULER:8786" in script
    pbs = render_job_script("pbs", {"cores": 4, "memory": "8GiB", "walltime": "01:00:00",
                                    "queue": "workq"})
    assert "#PBS -q workq" in pbs and "#PBS -l walltime=01:00:00" in pbs and "ncpus=4" in pbs


@pytest.mark.parametrize("options, match", [
    ({"memory": "16GB", "walltime": "01:00:00"}, r"needs \['cores'\]"),
    ({"cores": 8, "memory": "16GB"}, r"needs \['walltime'\]"),
    ({"cores": 0, "memory": "16GB", "walltime": "01:00:00"}, "cores: expected a positive"),
    ({"cores": 8, "memory": "lots", "walltime": "01:00:00"}, "memory"),
    ({"cores": 8, "memory": "16GB", "walltime": "two hours"}, "walltime"),
    ({"cores": 8, "memory": "16GB", "walltime": "01:00:00", "qeue": "x"}, r"unknown option"),
    ({"cores": 2, "memory": "16GB", "walltime": "01:00:00", "processes": 4}, "exceeds cores"),
])
def test_bad_cluster_options_are_refused_with_the_option_named(options, match):
    with pytest.raises(EngineError, match=match):
        render_job_script("slurm", options)


def test_an_unknown_cluster_kind_is_refused():
    with pytest.raises(EngineError, match="cluster: expected one of"):
        render_job_script("lsf", {"cores": 1, "memory": "1GB", "walltime": "01:00:00"})


def test_a_dead_scheduler_address_errors_within_10_s_naming_it():
    pytest.importorskip("distributed")
    t0 = time.monotonic()
    with pytest.raises(SchedulerUnreachableError, match=r"tcp://127\.0\.0\.1:9\b"):
        with make_executor(scheduler="tcp://127.0.0.1:9"):
            pytest.fail("the body must not run")
    assert time.monotonic() - t0 < 10


@pytest.mark.parametrize("kwargs, match", [
    (dict(jobs=0), "jobs: expected a positive integer"),
    (dict(jobs=-1), "jobs"),
    (dict(jobs=True), "jobs"),
    (dict(jobs=2.0), "jobs"),
    (dict(scheduler="127.0.0.1"), "tcp://HOST:PORT"),
    (dict(scheduler="http://127.0.0.1:8786"), "unknown protocol 'http'"),
    (dict(scheduler="tcp://127.0.0.1:0"), "port 0"),
    (dict(scheduler="tcp://a:1", cluster="slurm"), "not both"),
    (dict(cluster_options={"cores": 1}), "without cluster"),
])
def test_bad_engine_arguments_are_refused_before_any_work(kwargs, match):
    with pytest.raises(EngineError, match=match):
        with make_executor(**kwargs):
            pytest.fail("the body must not run")


def test_engine_labels():
    assert engine_label(jobs=1) == "serial (in process)"
    assert engine_label(jobs=2) == "2 local processes"
    assert engine_label(scheduler="localhost:8786") == "Dask cluster at tcp://localhost:8786"


def boom(r):
    if r == 2:
        raise ArithmeticError(f"replicate {r} failed")
    return r


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_failing_task_is_a_failed_future_not_the_end_of_the_run(jobs):
    buf = io.StringIO()
    with make_executor(jobs=jobs) as ex, Progress(5, "toy", file=buf) as bar:
        got = {i: fut for i, fut in run_tasks(ex, boom, range(5), progress=bar)}
    assert sorted(got) == list(range(5))
    assert isinstance(got[2].exception(), ArithmeticError)
    assert [got[i].result() for i in (0, 1, 3, 4)] == [0, 1, 3, 4]
    assert bar.done == 5 and bar.failed == 1
    assert "5/5" in buf.getvalue() and "1 failed" in buf.getvalue()


def test_progress_writes_to_stderr_and_is_silent_when_quiet(capsys):
    with Progress(3, "quiet", quiet=True) as bar:
        for _ in range(3):
            bar.advance()
    with Progress(2, "loud") as bar:
        bar.advance(2)
    out, err = capsys.readouterr()
    assert out == "" and "quiet" not in err and "2/2" in err and "loud" in err


def test_progress_to_fraction_moves_forward_only_and_ends_at_total():
    """Work reported as a fraction (the rig's rollout): the bar follows round(f * total),
    never goes back, never passes the total, and ends full."""
    buf = io.StringIO()
    with Progress(100, "sim", unit="%", file=buf) as bar:
        for f in (0.0, 0.254, 0.25, 0.5, 1.2):
            bar.to_fraction(f)
            if f == 0.254:
                assert bar.done == 25
            if f == 0.25:
                assert bar.done == 25                  # not back
        assert bar.done == 100                         # 1.2 clipped to the total
    assert "100%" in buf.getvalue() and "%/s" not in buf.getvalue()


# -- seeds ---------------------------------------------------------------------------------------
def test_seeds_are_distinct_over_coordinates_and_depend_on_them_only():
    seen = {replicate_seed(s, r, k, st) for s in (0, 1) for r in range(40) for k in range(5)
            for st in (0, 1, "fog", "method:wnn")}
    assert len(seen) == 2 * 40 * 5 * 4
    assert replicate_seed(7, 3, 1, "fog") == replicate_seed(7, 3, 1, "fog")
    assert all(0 <= s < 2**64 for s in seen)


def test_a_seed_sequence_is_keyed_by_its_coordinates():
    seq = replicate_seed_sequence(11, 4, 2, 9)
    assert seq.entropy == 11 and seq.spawn_key == (4, 2, 9)


@pytest.mark.parametrize("args", [(-1, 0, 0, 0), (0, True, 0, 0), (0, 0, 1.5, 0), (0, 0, 0, ""),
                                  (0, 0, 0, -3)])
def test_bad_seed_coordinates_are_refused(args):
    with pytest.raises(ValueError):
        replicate_seed(*args)
