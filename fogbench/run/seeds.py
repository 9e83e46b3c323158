"""Seeds that do not depend on the engine: :func:`replicate_seed` derives every stream's seed
from its coordinates (scenario seed, replicate, run, stream) with ``numpy.random.SeedSequence``,
so a replicate gives the same numbers on any worker, in any order, whatever ran before it."""

from __future__ import annotations

import hashlib
from typing import Any

import numpy as np

__all__ = ["replicate_seed", "replicate_seed_sequence"]


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
