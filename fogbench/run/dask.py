"""Dask engines: a running scheduler (``scheduler="tcp://HOST:PORT"``), or a batch cluster
through dask-jobqueue (``cluster="slurm"`` or ``"pbs"`` with the ``[cluster]`` options); both
optional (``pip install fogbench[distributed]``) and imported only when asked for.

A scheduler's address is probed before any work by a bounded handshake of our own
(:func:`probe_scheduler`), not by Dask's, because Dask's own connection does not refuse a
non-Dask peer within a bound. Measured with distributed 2026.8.0 against three local TCP
servers: a peer that accepts and waits for a request (as an HTTP server does) kept
``distributed.comm.connect(address, timeout=2)`` waiting past 10 s and
``distributed.Client(address, timeout=2)`` for 60 s, until the peer closed; a peer that answers
with bytes that are not a Dask frame (an HTTP 400 line, or a length prefix of 2^60) made both
allocate that length at once (``MemoryError``: "Unable to allocate 1.00 EiB"). The probe reads
at most :data:`_MAX_HANDSHAKE_BYTES` under one deadline and only then lets Dask decode the
frames and ask the peer's ``identity``.
"""

from __future__ import annotations

import re
import socket
import struct
import time
from typing import Any, Mapping

import numpy as np

__all__ = ["EngineError", "SchedulerUnreachableError", "NotASchedulerError", "probe_scheduler", "render_job_script", "CLUSTER_KINDS", "CLUSTER_OPTIONS"]

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
        import distributed
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
    except Exception:
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
    except Exception as exc:
        raise NotASchedulerError(f"scheduler {address}: the peer did not answer as a Dask "
                                 f"scheduler ({type(exc).__name__}: {exc})") from None
    kind = ident.get("type") if isinstance(ident, dict) else None
    if kind != "Scheduler":
        raise NotASchedulerError(f"scheduler {address}: a Dask {kind or 'peer'} answered, not a "
                                 "scheduler; give the scheduler's address (its log shows "
                                 "'Scheduler at: tcp://...')")
    return address
