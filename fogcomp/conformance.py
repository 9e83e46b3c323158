"""``check_method``: the contract of a :class:`fogcomp.Compensator`, checked on one class.

In the spirit of scikit-learn's ``check_estimator``: one call runs every rule on a class and says,
per rule, whether it holds and what failed. The rules (``RULES``):

- ``init_stores_only``: the constructor stores each hyperparameter under its own name, as given,
  and nothing else (no validation, no learned attribute): ``get_params`` and a later
  ``check_params`` rely on it;
- ``get_params_round_trip``: ``cls(**m.get_params()).get_params() == m.get_params()``;
- ``check_params_refuses_wrong_types``: a hyperparameter of a type no method takes (a bare
  ``object()``) makes ``check_params`` raise ``ValueError`` naming it;
- ``fit_returns_self``: ``fit`` returns the instance, sets learned attributes only with a
  trailing underscore, and leaves the hyperparameters as they were;
- ``not_fitted_raises``: compensating before ``fit`` raises ``NotFittedError``;
- ``inputs_not_modified``: ``fit`` and ``compensate`` leave the caller's arrays as they were;
- ``reproducible``: the same ``random_state`` gives the same result (methods that draw random
  numbers), and no method uses or changes numpy's global random state;
- ``bad_input_refused``: a record with only the declared inputs (``requires``) is enough; one
  without a required input, and a missing, short or non-finite reference rate (supervised
  methods), raise ``ValueError`` naming the argument;
- ``save_load_exact``: save and load (JSON + NPZ, no pickle) give the same output, bit for bit;
- ``probe_1e5``: a record of 10^5 samples is fitted and compensated, the output finite and of
  the input's shape; the time it took is reported.

The data are synthetic (a seeded generator of their own): a slowly varying error in
temperature, its rate and the attitude, plus white noise, at 100 Hz.
"""

from __future__ import annotations

import copy
import inspect
import math
import tempfile
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ._data import GyroData
from ._estimator import NotFittedError
from ._limits import MethodExit, MethodTimeout, no_exit, sigint_seen, time_limit
from ._persistence import load_model
from ._registry import class_problem, get_method

__all__ = ["RULES", "MethodCheck", "RuleResult", "check_method"]

RULES = ("init_stores_only", "get_params_round_trip", "check_params_refuses_wrong_types",
         "fit_returns_self", "not_fitted_raises", "inputs_not_modified", "reproducible",
         "bad_input_refused", "save_load_exact", "probe_1e5")


@dataclass
class RuleResult:
    """One rule's result: whether it holds, what failed, and (the probe) how long it took."""

    rule: str
    ok: bool
    message: str = ""
    seconds: float | None = None

    def line(self) -> str:
        """``ok   rule`` or ``FAIL rule: what failed``, as the report prints it."""
        t = f" ({self.seconds:.3g} s)" if self.seconds is not None else ""
        return f"{'ok  ' if self.ok else 'FAIL'} {self.rule}{t}" + (
            f": {self.message}" if self.message else "")


@dataclass
class MethodCheck:
    """The result of :func:`check_method`: one :class:`RuleResult` per rule."""

    method: str
    results: list = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return all(r.ok for r in self.results)

    @property
    def failures(self) -> list:
        return [r for r in self.results if not r.ok]

    def __str__(self) -> str:
        lines = [f"check_method {self.method}: " + ("every rule holds" if self.ok else
                                                   f"{len(self.failures)} rule(s) fail")]
        lines += [f"  {r.line()}" for r in self.results]
        return "\n".join(lines)


def _record(n: int, fs: float = 100.0, seed: int = 7) -> tuple[GyroData, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    phase = 2.0 * np.pi * t / max(t[-1], 1e-9)
    temp = 20.0 + 10.0 * np.sin(phase)
    temp_rate = np.gradient(temp, t) if n > 1 else np.zeros(n)
    g = np.column_stack([0.6 * np.cos(3 * phase), 0.6 * np.sin(3 * phase), np.full(n, 0.8)])
    ref = 1e-3 * np.sin(5 * phase)
    dph = math.radians(1.0) / 3600.0
    err = (2.0 + 0.05 * (temp - 20.0) + 0.5 * temp_rate * 60.0 + 1.0 * g[:, 0]) * dph
    rate = ref + err + 0.05 * dph * math.sqrt(fs) * rng.standard_normal(n)
    return GyroData(rate=rate, fs=fs, g=g, temp=temp, temp_rate=temp_rate), ref


def _only(data: GyroData, fields) -> GyroData:
    return GyroData(rate=data.rate, fs=data.fs,
                    **{f: getattr(data, f) for f in ("g", "temp", "temp_rate") if f in fields})


def _copy(data: GyroData) -> GyroData:
    return GyroData(rate=data.rate.copy(), fs=data.fs,
                    **{f: None if getattr(data, f) is None else getattr(data, f).copy()
                       for f in ("g", "temp", "temp_rate")})


def _same(a, b) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(np.asarray(a), np.asarray(b))
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    try:
        return bool(a == b)
    except Exception:  # noqa: BLE001
        return a is b


def _hyper(cls) -> dict:
    sig = inspect.signature(cls.__init__)
    return {k: p.default for k, p in list(sig.parameters.items())[1:]}


def _fit(cls, params, data, ref, seed=0):
    m = cls(**params)
    if cls.random and getattr(m, "random_state", None) is None:
        m.random_state = seed
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return m, m.fit(data, ref if cls.supervised else None)


def check_method(method, params: dict | None = None, *, samples: int = 2000,
                 probe_samples: int = 100_000, timeout_s: float | None = 300.0,
                 progress=None) -> MethodCheck:
    """Run every rule of the contract (module docstring) on ``method``.

    Parameters
    ----------
    method : str or type
        A registered name, ``module:Class``, or the class itself.
    params : dict, optional
        Hyperparameters to check it with (default: its own defaults), e.g. fewer epochs.
    samples : int
        Length of the records of the functional rules.
    probe_samples : int
        Length of the probe record (``probe_1e5``; 10^5 by default; its result names it).
    timeout_s : float or None
        Longest a rule may take, s (a hanging method fails the rule it hangs in, and the rules
        after it are not run: the whole check takes at most about this long once a rule
        hangs); None: no limit.
    progress : callable, optional
        Called with each ``RuleResult`` as its rule ends (the command prints it).

    Returns
    -------
    MethodCheck
        Per rule: holds or not, and what failed. Never raises for a method's failure: an
        exception inside a rule is that rule's failure, and so is a call of ``os._exit``.

    Notes
    -----
    Every rule gets records of its own (the same seeded values, fresh arrays), so a method that
    changes its input in place is caught by ``inputs_not_modified`` whichever rule ran first.
    """
    cls = get_method(method) if isinstance(method, str) else method
    name = method if isinstance(method, str) else f"{cls.__module__}:{cls.__qualname__}"
    report = MethodCheck(name)
    problem = class_problem(cls)
    if problem:
        report.results = [RuleResult(r, False, f"not checked: {problem}") for r in RULES]
        return report
    params = dict(params or {})
    saved = np.random.get_state()     # a method that draws from it is put right afterwards
    hung = None
    try:
        for rule in RULES:
            if hung is not None:
                result = RuleResult(rule, False, f"not checked: {hung}")
            else:
                result = _run_rule(rule, cls, params, samples, probe_samples, timeout_s)
                if result.message.startswith("raised MethodTimeout"):
                    hung = f"rule {rule} did not finish within {timeout_s:g} s"
            report.results.append(result)
            if progress is not None:
                progress(result)
    finally:
        np.random.set_state(saved)
    return report


def _run_rule(rule: str, cls, params: dict, samples: int, probe_samples: int,
              timeout_s) -> RuleResult:
    """One rule on records of its own, within the time limit, ``os._exit`` a failure."""
    data, ref = _record(samples)
    t0 = time.perf_counter()
    with sigint_seen() as seen:
        try:
            with time_limit(timeout_s, rule, verb="finish"), no_exit(f"rule {rule}"):
                msg = _RULES[rule](cls, params, data, ref, probe_samples)
        except KeyboardInterrupt as exc:
            if seen:                 # Ctrl-C: the user stops the check
                raise
            msg = f"raised KeyboardInterrupt (not a Ctrl-C: the method's own): {exc}"
        except (Exception, SystemExit, MethodTimeout, MethodExit) as exc:  # noqa: BLE001
            msg = f"raised {type(exc).__name__}: {exc}"     # a rule's crash is its failure
    seconds = time.perf_counter() - t0 if rule == "probe_1e5" else None
    ok = msg is None
    if rule == "probe_1e5" and ok:
        msg = f"{probe_samples} samples fitted and compensated"
    return RuleResult(rule, ok, msg or "", seconds)


# ---------------------------------------------------------------------------------------------
# the rules: each returns None when it holds, else what failed
def _init_stores_only(cls, params, data, ref, _):
    given = {**_hyper(cls), **params}
    given = {k: copy.copy(v) for k, v in given.items()}
    m = cls(**given)
    attrs = dict(vars(m))
    extra = sorted(set(attrs) - set(given))
    if extra:
        return f"the constructor sets {extra} besides the hyperparameters {sorted(given)}"
    for k, v in given.items():
        if k not in attrs:
            return f"hyperparameter {k!r} is not stored under its own name"
        if attrs[k] is not v:
            return (f"hyperparameter {k!r} is stored as {attrs[k]!r}, not as given ({v!r}): "
                    "validate and convert in check_params/_validate or fit, not __init__")
    return None


def _get_params_round_trip(cls, params, data, ref, _):
    p = cls(**params).get_params()
    q = cls(**p).get_params()
    if set(p) != set(q) or not all(_same(p[k], q[k]) for k in p):
        return f"cls(**get_params()).get_params() = {q!r}, not {p!r}"
    return None


class _WrongType:
    def __repr__(self) -> str:
        return "<object of no hyperparameter's type>"


def _check_params_refuses_wrong_types(cls, params, data, ref, _):
    for k in _hyper(cls):
        m = cls(**{**params, k: _WrongType()})
        try:
            m.check_params()
        except ValueError as exc:
            if k not in str(exc):
                return f"check_params refused {k} = object() without naming {k!r}: {exc}"
            continue
        except Exception as exc:  # noqa: BLE001
            return (f"check_params raised {type(exc).__name__} (not ValueError) for {k} = "
                    f"object(): {exc}")
        return f"check_params accepted {k} = object() (a value of no hyperparameter's type)"
    return None


def _fit_returns_self(cls, params, data, ref, _):
    m = cls(**params)
    if cls.random and getattr(m, "random_state", None) is None:
        m.random_state = 0
    before = dict(vars(m))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = m.fit(data, ref if cls.supervised else None)
    if out is not m:
        return f"fit returned {type(out).__name__}, not the instance (return self)"
    new = sorted(k for k in set(vars(m)) - set(before) if not k.endswith("_"))
    if new:
        return f"fit set {new}: learned attributes end with an underscore"
    changed = sorted(k for k in _hyper(cls) if not _same(before.get(k), vars(m).get(k)))
    if changed:
        return f"fit changed the hyperparameter(s) {changed}"
    return None


def _not_fitted_raises(cls, params, data, ref, _):
    try:
        cls(**params).compensate(data)
    except NotFittedError:
        return None
    except Exception as exc:  # noqa: BLE001
        return f"compensate before fit raised {type(exc).__name__}, not NotFittedError: {exc}"
    return "compensate before fit returned an output (expected NotFittedError)"


def _inputs_not_modified(cls, params, data, ref, _):
    d, r = _copy(data), ref.copy()
    m, _ = _fit(cls, params, d, r)
    m.compensate(d)
    for f in ("rate", "g", "temp", "temp_rate"):
        if getattr(data, f) is not None and not np.array_equal(getattr(d, f), getattr(data, f)):
            return f"fit or compensate modified the input array {f!r} in place"
    if not np.array_equal(r, ref):
        return "fit modified reference_rate in place"
    return None


def _reproducible(cls, params, data, ref, _):
    saved = np.random.get_state()            # the caller's, put back below
    try:
        np.random.seed(12345)
        state = np.random.get_state()
        m1, _ = _fit(cls, params, data, ref, seed=3)
        y1 = m1.compensate(data)
        after = np.random.get_state()
    finally:
        np.random.set_state(saved)
    if not (state[0] == after[0] and np.array_equal(state[1], after[1]) and
            state[2:] == after[2:]):
        return ("fit or compensate used or changed numpy's global random state (np.random.*); "
                "draw from self._rng() (random_state)")
    m2, _ = _fit(cls, params, data, ref, seed=3)
    if not np.array_equal(m2.compensate(data), y1):
        return "two fits with the same random_state (or none drawn) give different outputs"
    return None


def _expect_value_error(call, arg: str, what: str):
    try:
        call()
    except ValueError as exc:
        return None if arg in str(exc) else f"{what}: ValueError does not name {arg!r}: {exc}"
    except Exception as exc:  # noqa: BLE001
        return f"{what}: raised {type(exc).__name__}, not ValueError naming {arg!r}: {exc}"
    return f"{what}: accepted (expected ValueError naming {arg!r})"


def _bad_input_refused(cls, params, data, ref, _):
    declared = _only(data, cls.requires)
    try:
        m, _ = _fit(cls, params, declared, ref)
        m.compensate(declared)
    except Exception as exc:  # noqa: BLE001
        return (f"a record with only the declared inputs {list(cls.requires)} raised "
                f"{type(exc).__name__}: {exc} (declare every input the method reads)")
    for req in cls.requires:
        if req == "rate":
            continue
        missing = _only(data, [r for r in cls.requires if r != req])
        msg = _expect_value_error(lambda: _fit(cls, params, missing, ref), req,
                                  f"fit without {req!r}")
        if msg:
            return msg
        msg = _expect_value_error(lambda: m.compensate(missing), req,
                                  f"compensate without {req!r}")
        if msg:
            return msg
    if cls.supervised:
        def fit_with(r):
            mm = cls(**params)
            if cls.random and getattr(mm, "random_state", None) is None:
                mm.random_state = 0
            return mm.fit(data, r)

        bad_ref = ref.copy()
        bad_ref[len(bad_ref) // 2] = np.nan
        for r, what in ((None, "fit without reference_rate"),
                        (ref[:-1], "fit with a short reference_rate"),
                        (bad_ref, "fit with NaN in reference_rate")):
            msg = _expect_value_error(lambda: fit_with(r), "reference_rate", what)
            if msg:
                return msg
    return None


def _save_load_exact(cls, params, data, ref, _):
    m, _ = _fit(cls, params, data, ref)
    y = m.compensate(data)
    with tempfile.TemporaryDirectory() as d:
        m.save(Path(d) / "model")
        again = load_model(Path(d) / "model")
    y2 = again.compensate(data)
    if not np.array_equal(y, y2):
        diff = float(np.max(np.abs(y - y2))) if y.shape == y2.shape else float("nan")
        return f"the loaded model's output differs from the saved one's (max {diff:.3g} rad/s)"
    return None


def _probe(cls, params, data, ref, probe_samples):
    big, bref = _record(probe_samples, seed=11)
    m, _ = _fit(cls, params, big, bref)
    y = np.asarray(m.compensate(big))
    if y.shape != big.rate.shape:
        return f"output shape {y.shape} for an input of {big.rate.shape}"
    if not np.all(np.isfinite(y)):
        return "non-finite output"
    return None


_RULES = {"init_stores_only": _init_stores_only, "get_params_round_trip": _get_params_round_trip,
          "check_params_refuses_wrong_types": _check_params_refuses_wrong_types,
          "fit_returns_self": _fit_returns_self, "not_fitted_raises": _not_fitted_raises,
          "inputs_not_modified": _inputs_not_modified, "reproducible": _reproducible,
          "bad_input_refused": _bad_input_refused, "save_load_exact": _save_load_exact,
          "probe_1e5": _probe}
