"""What several commands share on the command line: numbers checked as they are parsed, the
Monte Carlo and engine flags of ``run`` and ``suite``, the log flags of the real-log commands,
and options dataclasses filled from the parsed flags."""

from __future__ import annotations

import argparse
import math
from dataclasses import fields

__all__ = ["number", "add_mc_flags", "add_log_flags", "engine", "cluster_options",
           "method_environment", "options"]


def number(kind, lo, lo_open=False, hi=None):
    """An argparse type: a finite number of ``kind`` in range; the message names the flag."""
    def parse(text: str):
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected {'an integer' if kind is int else 'a number'}, got {text!r}") from None
        if kind is float and not math.isfinite(v):
            raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
        if (v <= lo) if lo_open else (v < lo):
            raise argparse.ArgumentTypeError(f"expected a value {'>' if lo_open else '>='} "
                                             f"{lo:g}, got {text!r}")
        if hi is not None and v > hi:
            raise argparse.ArgumentTypeError(f"expected a value <= {hi:g}, got {text!r}")
        return v

    return parse


def options(cls, args):
    """An options dataclass ``cls`` from the parsed flags: each field from the attribute of its
    name (a field the command has no flag for keeps its default)."""
    return cls(**{f.name: getattr(args, f.name) for f in fields(cls) if hasattr(args, f.name)})


def add_mc_flags(p) -> None:
    """Flags of the Monte Carlo and where it runs (``run`` and ``suite``)."""
    p.add_argument("--replicates", type=number(int, 1, hi=10_000),
                   help="replicates R (overrides the file's [montecarlo] replicates)")
    p.add_argument("--method-seeds", type=number(int, 1, hi=1000),
                   help="random starts per fit of a random method (overrides method_seeds)")
    p.add_argument("--jobs", type=number(int, 1, hi=256), default=None,
                   help="local worker processes (default: the machine's cores)")
    p.add_argument("--scheduler", help="a running Dask scheduler, tcp://HOST:PORT "
                   "(pip install 'fogbench[distributed]'; workers need fogbench installed)")
    p.add_argument("--cluster", choices=("slurm", "pbs"),
                   help="start Dask workers as batch jobs (dask-jobqueue); see --cluster-config")
    p.add_argument("--cluster-config",
                   help="TOML file with a [cluster] table: queue, cores, memory, walltime, ...")
    p.add_argument("--fit-timeout-s", type=number(float, 0.001, hi=86_400.0),
                   help="stop a method's fit (or its compensation of a piece) after this many "
                   "seconds and report it as failed (overrides [compensation] fit_timeout_s; "
                   "default 600)")
    p.add_argument("--with-method", action="append", metavar="NAME",
                   help="add this method (a built-in, an entry-point plug-in or module:Class; "
                   "its defaults) to every scenario's [[methods]] (repeatable); it is written "
                   "into the run folder's scenario.toml")
    p.add_argument("--reference", choices=("truth", "lab"), default=None,
                   help="lab: fit every protocol that does not name its reference on the lab's "
                   "references (the table's commands, the nominal Earth rate), each beside its "
                   "ideal-lab twin <name>.ideal fitted on the truth; written into the run "
                   "folder's scenario.toml (default: each file's own, truth when unsaid)")


def cluster_options(path: str) -> dict:
    """The ``[cluster]`` table of a TOML config file (queue, cores, memory, walltime...)."""
    import tomllib

    from fogbench.scenario.tables import ScenarioError, read_text

    try:
        doc = tomllib.loads(read_text(path, "cluster config file"))
    except ScenarioError as exc:
        raise ValueError(f"--cluster-config {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"--cluster-config {path}: not valid TOML ({exc})") from None
    if set(doc) != {"cluster"} or not isinstance(doc["cluster"], dict):
        raise ValueError(f"--cluster-config {path}: expected one table [cluster] (queue, cores, "
                         f"memory, walltime, ...), got {sorted(doc)}")
    return doc["cluster"]


def engine(args):
    """The :class:`fogbench.run.engines.Engine` the flags ask for."""
    from fogbench.run.engines import Engine

    opts = cluster_options(args.cluster_config) if getattr(args, "cluster_config", None) \
        else None
    return Engine(jobs=args.jobs, scheduler=args.scheduler, cluster=args.cluster,
                  cluster_options=opts)


def method_environment(args) -> dict:
    """--fit-timeout-s, --with-method and --reference as the environment the scenario loader
    reads (so that worker processes see them too; each flag given wins over the variable
    inherited); a --with-method name that is unknown is refused here."""
    import fogcomp

    from fogbench.scenario.environment import FIT_TIMEOUT_ENV, REFERENCE_ENV, WITH_METHODS_ENV

    env = {}
    if getattr(args, "fit_timeout_s", None) is not None:
        env[FIT_TIMEOUT_ENV] = repr(args.fit_timeout_s)
    if args.command in ("run", "suite") and args.reference is not None:
        # "truth" too: the flag given wins over a FOGBENCH_REFERENCE inherited from the shell
        # (device fit's and calibrate's --reference name a log's column: not this)
        env[REFERENCE_ENV] = args.reference
    names = getattr(args, "with_method", None) or []
    for n in names:
        try:
            fogcomp.get_method(n)
        except fogcomp.PluginError:
            pass                 # installed but broken: the run reports it as failed
        except KeyError as exc:
            raise ValueError(f"--with-method: {exc.args[0]}") from None
    if names:
        env[WITH_METHODS_ENV] = ",".join(dict.fromkeys(names))
    return env


def add_log_flags(p) -> None:
    """The flags every log command shares (:class:`fogbench.logs.options.LogOptions`)."""
    p.add_argument("--format", choices=("csv", "euroc", "rosbag", "ulog"),
                   help="the log's format (default: recognised from the file: a CSV, a "
                   "EuRoC/TUM-VI imu0/data.csv, a ROS 1/2 bag or MCAP file, a PX4 ULog)")
    p.add_argument("--topic", help="a bag's sensor_msgs/msg/Imu topic, or a ULog's "
                   "sensor_gyro, sensor_gyro:1, sensor_combined (default: the only one)")
    p.add_argument("--column", action="append", metavar="CH=HEADER:UNIT",
                   help="map a file column to a channel, e.g. gyro_z=GyroZ:dps (repeatable, or "
                        "comma-separated)")
    p.add_argument("--fs", type=float, help="sample rate, Hz (when the log has no time column)")
    p.add_argument("--gaps", choices=("refuse", "split"), default="refuse",
                   help="a gap in the time column: refuse the file (default) or split at it")
    p.add_argument("--time-tolerance", type=float, default=0.05,
                   help="largest relative departure of a sample interval from the median one "
                        "(default 0.05)")
