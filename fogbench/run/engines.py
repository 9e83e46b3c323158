"""Where replicates run: one ``concurrent.futures.Executor`` in front of every engine.

- serial, in this process (``jobs=1``): :class:`SerialExecutor`;
- a local process pool (``jobs=N``, default the CPUs this process may use);
- an existing Dask cluster (``scheduler="tcp://HOST:PORT"``): ``distributed.Client.get_executor``;
- a batch cluster through dask-jobqueue (``cluster="slurm"`` or ``"pbs"``, with queue, cores,
  memory and walltime in ``cluster_options``) (:mod:`fogbench.run.dask`).

The workers need only the project installed; seeds do not depend on the engine
(:mod:`fogbench.run.seeds`)."""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
from dataclasses import dataclass
import multiprocessing
import os
import signal
import threading
import time
from typing import Any, Callable, Iterator, Mapping

import numpy as np

from fogbench.run.dask import (
    DEFAULT_CONNECT_TIMEOUT_S,
    EngineError,
    SchedulerUnreachableError,
    _check_address,
    _check_cluster,
    _import_dask,
    _jobqueue_job_class,
    _jobqueue_kwargs,
    probe_scheduler,
)

__all__ = ["SerialExecutor", "check_engine", "make_executor", "engine_label", "Engine"]


# ---------------------------------------------------------------------------------------------
# Engines
class SerialExecutor(cf.Executor):
    """A ``concurrent.futures.Executor`` that runs each task at once, in the calling thread.

    ``submit`` returns a finished future (its exception set if the task raised), so code written
    for a pool runs unchanged, with tracebacks in this process and no pickling.
    """

    def __init__(self):
        self._shutdown = False
        self._lock = threading.Lock()

    def submit(self, fn: Callable, /, *args, **kwargs) -> cf.Future:
        with self._lock:
            if self._shutdown:
                raise RuntimeError("cannot schedule new tasks after shutdown")
        fut: cf.Future = cf.Future()
        fut.set_running_or_notify_cancel()
        try:
            result = fn(*args, **kwargs)
        except Exception as exc:  # delivered through the future, as a pool does; Ctrl-C, SIGTERM
            fut.set_exception(exc)  # (BaseException) end the run at once
        else:
            fut.set_result(result)
        return fut

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        with self._lock:
            self._shutdown = True


#: How often a local worker checks that the process that started the pool is alive, s.
PARENT_POLL_S = 0.5


def _worker_init(parent_pid: int) -> None:
    """Worker initializer: Ctrl-C is the parent's to handle (it stops the workers), so workers
    print no KeyboardInterrupt traceback of their own; and a worker ends when the process that
    started the pool has gone, even by kill -9 (no ``finally`` of the parent runs then, and an
    idle worker would wait on its queue for ever, a busy one finish its replicate)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # SIGTERM is how the parent stops a worker: it ends at once, printing nothing (a handler
    # inherited from the command line's would raise Terminated in the worker's loop, whose
    # traceback multiprocessing prints); a worker writes nothing, its parent writes each result
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    # the pool was started with SIGINT and SIGTERM blocked (make_executor): SIGTERM must reach
    # a worker again
    signal.pthread_sigmask(signal.SIG_UNBLOCK, (signal.SIGINT, signal.SIGTERM))

    def watch():
        while True:
            time.sleep(PARENT_POLL_S)
            try:
                os.kill(parent_pid, 0)
            except ProcessLookupError:
                os._exit(1)
            except PermissionError:  # pragma: no cover - the pid was reused by another user
                os._exit(1)

    threading.Thread(target=watch, name="fogbench-parent-watch", daemon=True).start()


def _started() -> int:
    """A task that only starts a worker (the pool is started before the work)."""
    return os.getpid()


def _default_jobs() -> int:
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


def _check_jobs(jobs) -> int:
    if jobs is None:
        return _default_jobs()
    if isinstance(jobs, bool) or not isinstance(jobs, (int, np.integer)) or jobs < 1:
        raise EngineError(f"jobs: expected a positive integer number of processes, got {jobs!r}")
    return int(jobs)


def engine_label(jobs: int | None = None, scheduler: str | None = None,
                 cluster: str | None = None) -> str:
    """A one-line description of the engine, for reports ("2 local processes", ...)."""
    if scheduler is not None:
        return f"Dask cluster at {_check_address(scheduler)}"
    if cluster is not None:
        return f"Dask on {cluster.upper()} through dask-jobqueue"
    n = _check_jobs(jobs)
    return "serial (in process)" if n == 1 else f"{n} local processes"


def _stop_pool(pool: cf.ProcessPoolExecutor) -> None:
    """Cancel what has not started and stop the workers now (a replicate in flight is lost)."""
    terminate = getattr(pool, "terminate_workers", None)  # Python >= 3.14
    if terminate is not None:
        terminate()
        return
    # the worker processes, taken before shutdown(), which forgets them (and would otherwise
    # wait, at interpreter exit, for the replicates in flight to finish)
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        if proc.is_alive():
            proc.terminate()
    for proc in procs:
        proc.join(timeout=5)


def check_engine(jobs: int | None = None, scheduler: str | None = None,
                 cluster: str | None = None, cluster_options: Mapping[str, Any] | None = None,
                 *, connect_timeout_s: float = DEFAULT_CONNECT_TIMEOUT_S) -> None:
    """Every engine option checked before any work, whether or not a pool will be needed (a
    run of one replicate never starts one): the flags' combination, ``jobs``, the cluster
    options, and a scheduler by :func:`probe_scheduler`. Raises :class:`EngineError`."""
    if scheduler is not None and cluster is not None:
        raise EngineError("give either scheduler (a running Dask cluster) or cluster "
                          "(start one through dask-jobqueue), not both")
    if cluster_options is not None and cluster is None:
        raise EngineError("cluster options given without cluster = 'slurm' or 'pbs'")
    if isinstance(connect_timeout_s, bool) or not isinstance(connect_timeout_s, (int, float)) \
            or not 0 < connect_timeout_s <= 600:
        raise EngineError(f"connect_timeout_s: expected a number of seconds in (0, 600], got "
                          f"{connect_timeout_s!r}")
    if scheduler is not None:
        probe_scheduler(scheduler, connect_timeout_s)
    elif cluster is not None:
        _check_cluster(cluster, cluster_options)
        _import_dask(f"cluster = {cluster!r}")
        _jobqueue_job_class(cluster)
    else:
        _check_jobs(jobs)


@contextlib.contextmanager
def make_executor(jobs: int | None = None, scheduler: str | None = None,
                  cluster: str | None = None, cluster_options: Mapping[str, Any] | None = None,
                  *, connect_timeout_s: float = DEFAULT_CONNECT_TIMEOUT_S,
                  ) -> Iterator[cf.Executor]:
    """A ``concurrent.futures.Executor`` on the engine asked for, as a context manager.

    Parameters
    ----------
    jobs : int, optional
        Local processes; 1 runs serially in this process; default: the CPUs this process may
        use. Ignored with ``scheduler`` or ``cluster``.
    scheduler : str, optional
        Address of a running Dask scheduler, ``tcp://HOST:PORT``.
    cluster : {"slurm", "pbs"}, optional
        Start Dask workers as batch jobs through dask-jobqueue.
    cluster_options : mapping, optional
        For ``cluster``: see :data:`CLUSTER_OPTIONS` (``cores``, ``memory``, ``walltime``
        required).
    connect_timeout_s : float
        How long to wait for the scheduler to answer, s.

    Yields
    ------
    concurrent.futures.Executor
        Its futures are ``concurrent.futures.Future`` on every engine (``as_completed`` works).

    Raises
    ------
    EngineError
        A bad option, or Dask / dask-jobqueue not installed; raised before any work starts.
    SchedulerUnreachableError
        No scheduler answered at ``scheduler`` within ``connect_timeout_s``; names the address.

    Notes
    -----
    On leaving the block by an exception (Ctrl-C included) queued tasks are cancelled and local
    workers are stopped at once; workers ignore SIGINT themselves, so Ctrl-C prints one message
    from the parent, not a traceback per worker. Local workers are started with the
    ``forkserver`` method (``spawn`` where it is missing): forking a parent that already runs
    threads (MuJoCo's rollout, BLAS) can deadlock.
    """
    check_engine(jobs, scheduler, cluster, cluster_options,
                 connect_timeout_s=connect_timeout_s)
    if scheduler is not None:
        cm = _scheduler_executor(scheduler, connect_timeout_s)
    elif cluster is not None:
        cm = _jobqueue_executor(cluster, cluster_options)
    else:
        cm = _local_executor(_check_jobs(jobs))
    with cm as ex:
        yield ex


@contextlib.contextmanager
def _scheduler_executor(scheduler: str, connect_timeout_s: float) -> Iterator[cf.Executor]:
    """The executor of a running Dask scheduler (already probed by :func:`check_engine`)."""
    import distributed

    address = _check_address(scheduler)
    try:
        client = distributed.Client(address, timeout=connect_timeout_s, set_as_default=False)
    except (OSError, TimeoutError) as exc:
        raise SchedulerUnreachableError(
            f"scheduler {address}: no Dask scheduler answered within {connect_timeout_s:g} s "
            f"({exc}); check the address and that the scheduler is running") from None
    try:
        yield client.get_executor()
    finally:
        client.close()


@contextlib.contextmanager
def _jobqueue_executor(cluster: str, cluster_options) -> Iterator[cf.Executor]:
    """Dask workers started as batch jobs through dask-jobqueue, and their executor."""
    import dask_jobqueue
    import distributed

    opts = _check_cluster(cluster, cluster_options)
    cls = dask_jobqueue.SLURMCluster if cluster == "slurm" else dask_jobqueue.PBSCluster
    batch = cls(**_jobqueue_kwargs(opts))
    try:
        batch.scale(jobs=opts.get("jobs", 1))
        client = distributed.Client(batch, set_as_default=False)
        try:
            yield client.get_executor()
        finally:
            client.close()
    finally:
        batch.close()


@contextlib.contextmanager
def _local_executor(n: int) -> Iterator[cf.Executor]:
    """``n`` local worker processes (forkserver, else spawn), or this process for ``n == 1``."""
    if n == 1:
        ex = SerialExecutor()
        try:
            yield ex
        finally:
            ex.shutdown()
        return
    methods = multiprocessing.get_all_start_methods()
    ctx = multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")
    # The worker processes (and the forkserver) are started with SIGINT and SIGTERM blocked:
    # a Ctrl-C to the whole process group while a new interpreter imports its site would
    # otherwise print "Fatal Python error: init_import_site" from it. A signal meanwhile stays
    # pending in this process and is delivered when the pool is up.
    from fogbench.outputs.interrupts import block, unblock

    mask, pool = block(), None
    try:
        pool = cf.ProcessPoolExecutor(max_workers=n, mp_context=ctx, initializer=_worker_init,
                                      initargs=(os.getpid(),))
        cf.wait([pool.submit(_started) for _ in range(n)])
        blocked, mask = mask, None
        unblock(blocked)                # a pending Ctrl-C is raised here
    except BaseException:
        if mask is not None:
            unblock(mask)
        if pool is not None:
            _stop_pool(pool)
        raise
    try:
        yield pool
    except BaseException:
        _stop_pool(pool)
        raise
    else:
        pool.shutdown(wait=True)


@dataclass(frozen=True)
class Engine:
    """Where a command's replicates run, as its flags say: ``jobs`` local processes, a Dask
    ``scheduler`` address, or a batch ``cluster`` with its ``cluster_options``."""

    jobs: int | None = None
    scheduler: str | None = None
    cluster: str | None = None
    cluster_options: Mapping[str, Any] | None = None

    def check(self) -> None:
        """:func:`check_engine` on these options (before any work)."""
        check_engine(self.jobs, self.scheduler, self.cluster, self.cluster_options)

    def executor(self):
        """:func:`make_executor` on these options (a context manager)."""
        return make_executor(self.jobs, self.scheduler, self.cluster, self.cluster_options)

    @property
    def label(self) -> str:
        """:func:`engine_label` of these options."""
        return engine_label(self.jobs, self.scheduler, self.cluster)
