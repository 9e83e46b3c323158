"""What the command line sets for every scenario loaded in this process and in its workers
(``--fit-timeout-s``, ``--with-method``, ``--reference``), carried as environment variables so
that a forkserver or Dask worker reads the same."""

from __future__ import annotations

import contextlib
import os

#: Longest a method's fit (and, separately, its compensation of one piece) may take, s, before it
#: is stopped and reported as failed ([compensation] fit_timeout_s; fogbench run/suite
#: --fit-timeout-s). The slowest built-in fit of the suite (wnn, paper 003's 13,000 samples) takes
#: about a minute on a laptop core.
DEFAULT_FIT_TIMEOUT_S = 600.0
#: The environment variable ``--fit-timeout-s`` sets: it overrides the file's fit_timeout_s.
FIT_TIMEOUT_ENV = "FOGBENCH_FIT_TIMEOUT_S"
#: The environment variable ``--with-method`` sets (names separated by commas): methods added
#: to every scenario that has [[methods]] (unless it names them already), with their defaults.
WITH_METHODS_ENV = "FOGBENCH_WITH_METHODS"

#: The environment variable ``--reference`` sets: "lab" fits every protocol that does not name
#: its reference on the lab's references (each beside its ideal-lab twin, <name>.ideal).
REFERENCE_ENV = "FOGBENCH_REFERENCE"
_ENV_KEYS = (FIT_TIMEOUT_ENV, WITH_METHODS_ENV, REFERENCE_ENV)


def method_environment() -> dict:
    """The environment variables --with-method, --fit-timeout-s and --reference set here."""
    return {k: os.environ[k] for k in _ENV_KEYS if os.environ.get(k)}


@contextlib.contextmanager
def method_environment_set(env: dict):
    """Exactly ``env`` for those variables while the code inside runs (a replicate on a
    forkserver or Dask worker, which has its own environment; a command's flags), then what was
    there before."""
    keys = _ENV_KEYS
    before = {k: os.environ.get(k) for k in keys}
    for k in keys:
        if env.get(k):
            os.environ[k] = env[k]
        else:
            os.environ.pop(k, None)
    try:
        yield
    finally:
        for k, v in before.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def reference_override() -> str | None:
    """``--reference``'s value ("lab" or "truth"), None when not given (``REFERENCE_ENV``); any
    other value of the variable is refused (a ``ValueError`` naming it), never ignored."""
    v = os.environ.get(REFERENCE_ENV) or None
    if v is not None and v not in ("lab", "truth"):
        raise ValueError(f"environment variable {REFERENCE_ENV}={v!r}: expected 'lab' or "
                         "'truth' (what --reference sets); unset it or give --reference")
    return v


def with_methods() -> list[str]:
    """The method names ``--with-method`` adds to every scenario (``WITH_METHODS_ENV``)."""
    return [n for n in os.environ.get(WITH_METHODS_ENV, "").split(",") if n]
