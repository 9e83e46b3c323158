"""Where replicates run: one ``concurrent.futures.Executor`` in front of every engine.

- serial, in this process (``jobs=1``): :class:`SerialExecutor`;
- a local process pool (``jobs=N``, default the CPUs this process may use);
- an existing Dask cluster (``scheduler="tcp://HOST:PORT"``): ``distributed.Client.get_executor``;
- a batch cluster through dask-jobqueue (``cluster="slurm"`` or ``"pbs"``, with queue, cores,
  memory and walltime in ``cluster_options``).

Dask and dask-jobqueue are optional (``pip install fogbench[distributed]``); they are imported only
when asked for. The workers need only the project installed.

Seeds do not depend on the engine: :func:`replicate_seed` derives every stream's seed from its
coordinates (scenario seed, replicate, run, stream) with ``numpy.random.SeedSequence``, so a
replicate gives the same numbers on any worker, in any order, whatever ran before it.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import hashlib
import multiprocessing
import os
import re
import signal
import socket
import struct
import threading
import time
from typing import Any, Callable, Iterable, Iterator, Mapping

import numpy as np

__all__ = [
    "EngineError",
    "SchedulerUnreachableError",
    "NotASchedulerError",
    "SerialExecutor",
    "check_engine",
    "probe_scheduler",
    "make_executor",
    "engine_label",
    "render_job_script",
    "replicate_seed",
    "replicate_seed_sequence",
    "run_tasks",
    "CLUSTER_KINDS",
    "CLUSTER_OPTIONS",
]

CLUSTER_KINDS = ("slurm", "pbs")
# Options of a [cluster] table: name -> (type, required, meaning)
CLUSTER_OPTIONS: dict[str, tuple[type | tuple, bool, str]] = {
    "cores": (int, True, "CPU cores per batch job"),
    "memory": (str, True, "memory per batch job, e.g. '16GB'"),
    "walltime": (str, True, "wall time per batch job, e.g. '02:00:00'"),
    "queue": (str, False, "queue (SLURM partition)"),
    "account": (str, False, "account to charge"),
    "processes": (int, False, "Dask worker processes per job (default: one per core)"),
    "jobs": (int, False, "number of batch jobs to start (default 1)"),
    "job_extra_directives": (list, False, "further #SBATCH / #PBS lines, without the prefix"),
    "log_directory": (str, False, "folder for the jobs' stdout and stderr"),
    "python": (str, False, "python executable on the compute nodes"),
}
DEFAULT_CONNECT_TIMEOUT_S = 5.0
_WALLTIME = re.compile(r"^(\d+-)?\d+(:\d{1,2}){0,2}$")
_ADDRESS = re.compile(r"^(?:(?P<scheme>[a-z]+)://)?(?P<host>\[[0-9a-fA-F:.]+\]|[^:/\s]+)"
                      r":(?P<port>\d+)$")


class EngineError(ValueError):
    """The engine asked for cannot be used: a bad option, or Dask not installed."""


class SchedulerUnreachableError(EngineError):
    """No Dask scheduler answered at the address given."""


class NotASchedulerError(SchedulerUnreachableError):
    """Something answered at the address, but not a Dask scheduler."""


# ---------------------------------------------------------------------------------------------
# Seeds
def _coordinate(name: str, v: Any) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
        raise ValueError(f"{name}: expected a non-negative integer, got {v!r}")
    return int(v)


def _stream_key(stream: int | str) -> int:
    if isinstance(stream, str):
        if not stream:
            raise ValueError("stream: a stream name must not be empty")
        # a name maps to a fixed 63-bit integer, the same on every machine and Python version
        return int.from_bytes(hashlib.sha256(stream.encode()).digest()[:8], "big") >> 1
    return _coordinate("stream", stream)


def replicate_seed_sequence(scenario_seed: int, replicate: int, run_index: int,
                            stream: int | str) -> np.random.SeedSequence:
    """The ``SeedSequence`` of one random stream of one run of one replicate.

    ``SeedSequence(entropy=scenario_seed, spawn_key=(replicate, run_index, stream))``: its state
    depends on these four coordinates only, never on the worker, the order of execution or the
    replicates run before.

    Parameters
    ----------
    scenario_seed : int
        The scenario file's seed, >= 0.
    replicate : int
        Replicate index r, >= 0.
    run_index : int
        Index of the run (protocol) in the scenario, >= 0.
    stream : int or str
        Which stream: an index >= 0, or a name (``"fog"``, ``"method:wnn"``) mapped to a fixed
        integer through SHA-256.
    """
    return np.random.SeedSequence(
        entropy=_coordinate("scenario_seed", scenario_seed),
        spawn_key=(_coordinate("replicate", replicate), _coordinate("run_index", run_index),
                   _stream_key(stream)))


def replicate_seed(scenario_seed: int, replicate: int, run_index: int, stream: int | str) -> int:
    """A 64-bit integer seed for one stream (e.g. a method's ``random_state``).

    The first 64-bit word of :func:`replicate_seed_sequence`'s state; an int, so it can be stored
    in a saved model or a report. Arguments as there.
    """
    seq = replicate_seed_sequence(scenario_seed, replicate, run_index, stream)
    return int(seq.generate_state(1, dtype=np.uint64)[0])


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
    # the pool was started with SIGINT and SIGTERM blocked (make_executor): SIGTERM must reach
    # a worker again, it is how the parent stops one
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


def _check_address(scheduler) -> str:
    if not isinstance(scheduler, str) or not (m := _ADDRESS.match(scheduler.strip())):
        raise EngineError(f"scheduler: expected an address like tcp://HOST:PORT, got "
                          f"{scheduler!r}")
    scheme = m.group("scheme") or "tcp"
    if scheme not in ("tcp", "tls", "ws", "wss", "ucx"):
        raise EngineError(f"scheduler: unknown protocol {scheme!r} in {scheduler!r}; "
                          "expected tcp://, tls://, ws://, wss:// or ucx://")
    port = int(m.group("port"))
    if not 1 <= port <= 65535:
        raise EngineError(f"scheduler: port {port} out of range 1-65535 in {scheduler!r}")
    return f"{scheme}://{m.group('host')}:{port}"


def _check_cluster(cluster, options) -> dict:
    if cluster not in CLUSTER_KINDS:
        raise EngineError(f"cluster: expected one of {list(CLUSTER_KINDS)}, got {cluster!r}")
    if options is None:
        options = {}
    if not isinstance(options, Mapping):
        raise EngineError(f"cluster options: expected a table of options, got "
                          f"{type(options).__name__}")
    unknown = sorted(set(options) - set(CLUSTER_OPTIONS))
    if unknown:
        raise EngineError(f"cluster options: unknown option(s) {unknown}; allowed: "
                          f"{sorted(CLUSTER_OPTIONS)}")
    missing = [k for k, (_, req, _) in CLUSTER_OPTIONS.items() if req and k not in options]
    if missing:
        raise EngineError(f"cluster options: {cluster} needs {missing} "
                          f"({'; '.join(f'{k}: {CLUSTER_OPTIONS[k][2]}' for k in missing)})")
    out = {}
    for k, v in options.items():
        typ, _, meaning = CLUSTER_OPTIONS[k]
        if typ is int:
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise EngineError(f"cluster option {k}: expected a positive integer ({meaning}), "
                                  f"got {v!r}")
            v = int(v)
        elif typ is str:
            if not isinstance(v, str) or not v.strip() or "\n" in v:
                raise EngineError(f"cluster option {k}: expected a one-line text ({meaning}), "
                                  f"got {v!r}")
        elif typ is list:
            if not (isinstance(v, (list, tuple)) and all(isinstance(x, str) and "\n" not in x
                                                         for x in v)):
                raise EngineError(f"cluster option {k}: expected a list of one-line texts "
                                  f"({meaning}), got {v!r}")
            v = list(v)
        out[k] = v
    if not _WALLTIME.match(out["walltime"]):
        raise EngineError(f"cluster option walltime: expected [D-]HH:MM:SS, got "
                          f"{out['walltime']!r}")
    try:
        from dask.utils import parse_bytes
    except ImportError:
        parse_bytes = None
    if parse_bytes is not None:
        try:
            if parse_bytes(out["memory"]) <= 0:
                raise ValueError("not positive")
        except (ValueError, TypeError) as exc:
            raise EngineError(f"cluster option memory: expected a size like '16GB', got "
                              f"{out['memory']!r} ({exc})") from None
    if "processes" in out and out["processes"] > out["cores"]:
        raise EngineError(f"cluster options: processes = {out['processes']} exceeds cores = "
                          f"{out['cores']}")
    return out


def _import_dask(what: str):
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise EngineError(f"{what} needs Dask: pip install 'fogbench[distributed]'") from None
    return distributed


def _jobqueue_job_class(cluster: str):
    try:
        if cluster == "slurm":
            from dask_jobqueue.slurm import SLURMJob as job_cls
        else:
            from dask_jobqueue.pbs import PBSJob as job_cls
    except ImportError:
        raise EngineError(f"cluster = {cluster!r} needs dask-jobqueue: "
                          "pip install 'fogbench[distributed]'") from None
    return job_cls


def _jobqueue_kwargs(opts: dict) -> dict:
    kw = {k: v for k, v in opts.items() if k != "jobs"}
    kw.setdefault("processes", opts["cores"])
    kw["job_name"] = "fogbench-worker"
    return kw


def render_job_script(cluster: str, options: Mapping[str, Any],
                      scheduler: str = "tcp://SCHEDULER:8786") -> str:
    """The batch script dask-jobqueue would submit for one worker job, rendered offline.

    No scheduler is started and nothing is submitted: the script is built by dask-jobqueue's own
    job class (``SLURMJob`` / ``PBSJob``, the object behind ``SLURMCluster.job_script()``) with
    ``scheduler`` as the address the workers would connect to.

    Parameters
    ----------
    cluster : {"slurm", "pbs"}
    options : mapping
        As :data:`CLUSTER_OPTIONS`: ``cores``, ``memory`` and ``walltime`` required; ``queue``,
        ``account``, ``processes``, ``job_extra_directives``, ``log_directory``, ``python``.
    scheduler : str
        Scheduler address written into the worker command.

    Returns
    -------
    str
        The job script.
    """
    opts = _check_cluster(cluster, options)
    job_cls = _jobqueue_job_class(cluster)
    job = job_cls(scheduler=scheduler, name="fogbench-worker", **_jobqueue_kwargs(opts))
    return job.job_script()


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


#: Largest first message a Dask peer may send in the probe (its handshake is about 100 bytes):
#: a peer that announces more is not a Dask scheduler, and nothing that large is allocated.
_MAX_HANDSHAKE_BYTES = 1 << 20


def _recv_exact(sock: socket.socket, n: int, deadline: float, address: str) -> bytes:
    buf = bytearray()
    while len(buf) < n:
        left = deadline - time.monotonic()
        if left <= 0:
            raise socket.timeout()
        sock.settimeout(left)
        chunk = sock.recv(n - len(buf))
        if not chunk:
            raise NotASchedulerError(
                f"scheduler {address}: the peer closed the connection after {len(buf)} byte(s) "
                "without a Dask handshake; it is not a Dask scheduler")
        buf += chunk
    return bytes(buf)


def _raw_handshake(host: str, port: int, address: str, deadline: float,
                   timeout_s: float) -> dict:
    """Read the handshake a Dask server sends on every new TCP connection, with bounded time
    and memory: 8 bytes of total length, then the frames' prelude (their count and lengths) and
    the frames, as ``distributed.comm.tcp`` writes them; decoded by ``distributed.protocol``
    only once the sizes are plausible. A peer that sends nothing (an HTTP server waits for a
    request) runs into the deadline; one that sends something else is refused at once."""
    try:
        sock = socket.create_connection((host, port),
                                        timeout=max(deadline - time.monotonic(), 0.01))
    except socket.timeout:
        raise SchedulerUnreachableError(
            f"scheduler {address}: no Dask scheduler answered within {timeout_s:g} s (the "
            "connection was never accepted: nothing at that address, or a firewall); "
            "check the address and that the scheduler is running") from None
    with sock:
        head = _recv_exact(sock, 8, deadline, address)
        (total,) = struct.unpack("<Q", head)
        if not 16 <= total <= _MAX_HANDSHAKE_BYTES:
            raise NotASchedulerError(
                f"scheduler {address}: the peer answered {head!r}, not a Dask handshake; it is "
                "not a Dask scheduler (is this the address of another service?)")
        body = _recv_exact(sock, total, deadline, address)
    (nframes,) = struct.unpack_from("<Q", body)
    if not 1 <= nframes <= 64 or 8 + 8 * nframes > total:
        raise NotASchedulerError(f"scheduler {address}: the peer's first message is not a Dask "
                                 "handshake; it is not a Dask scheduler")
    lengths = struct.unpack_from(f"<{nframes}Q", body, 8)
    frames, pos = [], 8 + 8 * nframes
    for nb in lengths:
        if pos + nb > total:
            raise NotASchedulerError(f"scheduler {address}: the peer's first message is not a "
                                     "Dask handshake; it is not a Dask scheduler")
        frames.append(body[pos:pos + nb])
        pos += nb
    import logging

    from distributed.protocol.core import loads

    logger = logging.getLogger("distributed.protocol.core")
    level = logger.level
    logger.setLevel(logging.CRITICAL + 1)   # its own report of undecodable bytes: ours follows
    try:
        msg = loads(frames, deserialize=False)
    except Exception:  # noqa: BLE001 - whatever the peer sent, it is not a Dask handshake
        msg = None
    finally:
        logger.setLevel(level)
    if not isinstance(msg, dict) or "compression" not in msg:
        raise NotASchedulerError(f"scheduler {address}: the peer's first message is not a Dask "
                                 "handshake; it is not a Dask scheduler")
    return msg


async def _identity(address: str, timeout_s: float) -> dict:
    """Dask's own ``identity`` request (every Dask server answers it with its type)."""
    from distributed.comm import connect

    comm = await connect(address, timeout=timeout_s)
    try:
        await comm.write({"op": "identity", "reply": True})
        return await comm.read()
    finally:
        comm.abort()


def probe_scheduler(scheduler: str, timeout_s: float = DEFAULT_CONNECT_TIMEOUT_S) -> str:
    """Check that a Dask scheduler answers at ``scheduler`` within ``timeout_s``; return the
    normalised address.

    A bounded handshake of our own before ``distributed.Client`` is made: the client's own
    connection does not bound the handshake's time (against an HTTP server it waits for ever)
    and trusts the peer's length prefix (a non-Dask peer made it try to allocate exabytes). On
    ``tcp://``: a TCP connection, the first message read and checked as a Dask handshake with
    bounded size (:func:`_raw_handshake`), then Dask's ``identity`` request, whose answer must
    name a ``Scheduler`` (a worker's address is refused). On other protocols (tls, ws, ucx),
    the ``identity`` request alone, under the same deadline.

    Raises
    ------
    EngineError
        A malformed address, or Dask not installed.
    SchedulerUnreachableError
        Nothing answered within ``timeout_s`` (the message names the address).
    NotASchedulerError
        Something answered, but not a Dask scheduler.
    """
    import asyncio

    import importlib.util

    address = _check_address(scheduler)
    if importlib.util.find_spec("distributed") is None:  # without importing it (seconds)
        _import_dask(f"scheduler = {address!r}")
    m = _ADDRESS.match(address)
    host, port = m.group("host").strip("[]"), int(m.group("port"))
    deadline = time.monotonic() + timeout_s
    try:
        if m.group("scheme") == "tcp":  # before distributed is imported: its import takes time
            _raw_handshake(host, port, address, deadline, timeout_s)
        from distributed.comm.core import CommClosedError

        left = max(deadline - time.monotonic(), 0.5)
        try:
            ident = asyncio.run(asyncio.wait_for(_identity(address, left), left))
        except CommClosedError:
            raise NotASchedulerError(
                f"scheduler {address}: the peer closed the connection without answering Dask's "
                "identity request; it is not a Dask scheduler") from None
    except SchedulerUnreachableError:
        raise
    except (OSError, TimeoutError, asyncio.TimeoutError, socket.timeout) as exc:
        why = ("connection accepted, but no Dask handshake" if isinstance(
            exc, (TimeoutError, asyncio.TimeoutError, socket.timeout)) else
            (exc.strerror or str(exc) or type(exc).__name__))
        raise SchedulerUnreachableError(
            f"scheduler {address}: no Dask scheduler answered within {timeout_s:g} s ({why}); "
            "check the address and that the scheduler is running") from None
    except Exception as exc:  # noqa: BLE001 - a peer speaking something else
        raise NotASchedulerError(f"scheduler {address}: the peer did not answer as a Dask "
                                 f"scheduler ({type(exc).__name__}: {exc})") from None
    kind = ident.get("type") if isinstance(ident, dict) else None
    if kind != "Scheduler":
        raise NotASchedulerError(f"scheduler {address}: a Dask {kind or 'peer'} answered, not a "
                                 "scheduler; give the scheduler's address (its log shows "
                                 "'Scheduler at: tcp://...')")
    return address


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
        import distributed

        address = _check_address(scheduler)
        try:
            client = distributed.Client(address, timeout=connect_timeout_s,
                                        set_as_default=False)
        except (OSError, TimeoutError) as exc:
            raise SchedulerUnreachableError(
                f"scheduler {address}: no Dask scheduler answered within {connect_timeout_s:g} s "
                f"({exc}); check the address and that the scheduler is running") from None
        try:
            yield client.get_executor()
        finally:
            client.close()
        return
    if cluster is not None:
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
        return
    n = _check_jobs(jobs)
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
    from .signals import block, unblock

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


def run_tasks(executor: cf.Executor, fn: Callable, items: Iterable, *,
              progress=None) -> Iterator[tuple[int, cf.Future]]:
    """Submit ``fn(item)`` for every item; yield ``(index, future)`` as each one completes.

    Completion order depends on the engine; results must be put back in order by ``index`` (or
    by the replicate number inside the result) before aggregating. The caller decides what a
    failed future means (``future.exception()``). If the caller stops iterating (an exception,
    Ctrl-C), every task not yet started is cancelled.

    Parameters
    ----------
    executor : concurrent.futures.Executor
        From :func:`make_executor`.
    fn : callable
        A picklable module-level function of one argument.
    items : iterable
        The arguments, e.g. replicate indices.
    progress : fogbench.progress.Progress, optional
        Advanced once per completed task, with the failures counted.
    """
    futures = {executor.submit(fn, item): i for i, item in enumerate(items)}
    try:
        for fut in cf.as_completed(futures):
            if progress is not None:
                progress.advance(failed=fut.cancelled() or fut.exception() is not None)
            yield futures[fut], fut
    finally:
        for fut in futures:
            fut.cancel()
