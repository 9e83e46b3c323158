"""The terms of an identified model, each with its status, interval or bound, and reason.

One meaning of each status (:class:`~fogcomp.noise.ModelTerm`):

- ``"identified"``: the term is in the model, significant (or stated and fitted above zero);
  ``value`` with its interval ``low``..``high`` of content ``ci``, ``bound`` its one-sided 95 %
  upper bound.
- ``"upper bound"``: the record does not show the term; ``bound`` is its one-sided 95 % upper
  bound and ``low``/``high`` are None (no two-sided interval is claimed). A term the model keeps
  for the others' sake (``in_model`` True) keeps its estimate in ``value``, the curve's.
- ``"not identified"``: neither shown nor bounded by the record.

Every candidate term is reported: the five IEEE terms, the selected Gauss-Markov terms, and a
further Gauss-Markov term's bound at the correlation times the record can see
(:func:`_gm_bound_term`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._fit import _fisher_inverse, _Fit, _jacobian, _param_cov, _Problem, _Spec
from ._intervals import _interval_sqrt, _record_for, _score_interval
from ._processes import LINEAR_TERMS
from ._result import ModelTerm
from ._select import _gm_threshold


@dataclass(frozen=True)
class _Report:
    """What the report of each term needs: the fit, its parameter covariance (scaled), the
    normal quantiles of the intervals, and the identifier's options."""

    pb: _Problem
    fit: _Fit
    cov: np.ndarray          # covariance of the coefficients (and log T), times ``scale``
    scale: float
    z: float                 # normal quantile of the interval of content ci
    z95: float               # of the one-sided 95 % bound
    stated: bool
    alpha: float
    record_length: bool

    @classmethod
    def of(cls, pb, fit, scale, ci, stated, alpha, record_length) -> _Report:
        from scipy.stats import norm

        cov = _param_cov(pb, fit) * scale
        return cls(pb, fit, cov, scale, float(norm.ppf(0.5 + ci / 2.0)), float(norm.ppf(0.95)),
                   stated, alpha, record_length)


def _model_terms(r: _Report, weak: dict, log: list, max_gm: int) -> list:
    """The five IEEE terms in their order (each in the model, or left out), then the
    Gauss-Markov terms by correlation time, then (``max_gm`` > number in the model) the bound
    of a further one."""
    terms: dict = {}
    for k, term in enumerate(r.fit.spec.linear):
        terms[term] = _linear_term(r, k, weak.get(term))
    gms = sorted((_gm_term(r, g) for g in range(len(r.fit.spec.gm))), key=lambda g: g.tau)
    # the terms left out: a one-sided 95 % upper bound from the model with the term forced in
    for term in LINEAR_TERMS:
        if term not in terms:
            terms[term] = _left_out_term(r, term, log)
    if len(gms) < max(max_gm, 1 if r.stated else 0):
        gms.append(_gm_bound_term(r))
    return [terms[x] for x in LINEAR_TERMS] + gms


def _interval(r: _Report, k: int):
    """(value, low, high, sigma, bound) of the square root of coefficient k: the score
    interval of content ci, the linearised sigma for display, the one-sided 95 % bound."""
    sc = math.sqrt(max(r.cov[k, k], 0.0))
    val, _, _, sigma = _interval_sqrt(float(r.fit.coef[k]), sc, r.z)
    c_lo, c_hi = _score_interval(r.pb, r.fit, k, r.z, r.scale)
    _, c_b = _score_interval(r.pb, r.fit, k, r.z95, r.scale, lower=False)
    root = (lambda c: None if c is None else math.sqrt(c))
    return val, math.sqrt(c_lo), root(c_hi), sigma, root(c_b)


def _bound_or_none(term, val, bound, reason, **kw) -> ModelTerm:
    """A term of the model the record does not show: an upper bound when there is one."""
    if bound is not None and math.isfinite(bound) and bound > 0:
        return ModelTerm(term, "upper bound", val, None, None, None,
                         reason + "; 95 % upper bound from the model", bound=bound,
                         in_model=True, **kw)
    return ModelTerm(term, "not identified", val, None, None, None,
                     reason + "; the record does not bound it from above", in_model=True, **kw)


def _linear_term(r: _Report, k: int, weak) -> ModelTerm:
    """Linear term k of the fit: identified, or (``weak``: (rise of J when removed, critical
    value)) kept in the model but not significant, or stated and fitted as zero: reported
    with its bound."""
    term = r.fit.spec.linear[k]
    val, lo, hi, sigma, bound = _interval(r, k)
    label = r.fit.spec.label()
    if weak is not None:
        rise, need = weak
        return _bound_or_none(term, val, bound, f"in the model ({label}) but not significant: "
                              f"removing it raises J by {rise:.3g} < {need:.3g}")
    if not val > 0:
        return _bound_or_none(term, val, bound, f"stated, fitted as zero (model {label})")
    rel = (sigma / val) if sigma and val else math.inf
    # the record a 10 % estimate needs, for a term the record shows
    rec = _record_for(r.pb, r.fit, k, rel, scale=r.scale) if r.record_length else None
    why = ("stated" if r.stated else "significant: removing it raises J by more than "
           f"the level-{r.alpha:g} critical value") + f" (model {label})"
    return ModelTerm(term, "identified", val, lo, hi, sigma, why,
                     record_s_for_10pct=rec, bound=bound, in_model=True)


def _gm_term(r: _Report, g: int) -> ModelTerm:
    """Gauss-Markov term g of the fit, its correlation time's interval normal in log T."""
    n_lin, n_gm = len(r.fit.spec.linear), len(r.fit.spec.gm)
    T = r.fit.spec.gm[g]
    k = n_lin + g
    val, lo, hi, sigma, bound = _interval(r, k)
    t_lo, t_hi = _tau_interval(r, g)
    tau = dict(tau=float(T), tau_low=t_lo, tau_high=t_hi)
    if not val > 0:
        return _bound_or_none("GM", val, bound, "stated, fitted as zero", **tau)
    rel = (sigma / val) if sigma and val else math.inf
    rec = _record_for(r.pb, r.fit, k, rel, scale=r.scale) if r.record_length else None
    return ModelTerm("GM", "identified", val, lo, hi, sigma,
                     "stated" if r.stated else "selected: the least criterion "
                     f"(each Gauss-Markov term charged {_gm_threshold(r.pb, r.alpha):.3g})",
                     record_s_for_10pct=rec, bound=bound, in_model=True, **tau)


def _tau_interval(r: _Report, g: int) -> tuple[float, float]:
    """The interval of Gauss-Markov term g's correlation time by inverting the
    distance-difference test (Newey & West 1987; the profile of J): the times T at which the
    model refitted with T held (the others' variances free, the other times at the estimate)
    raises J by at most z^2 (times ``scale`` when the curve departs from the model). Unlike a
    normal interval in log T from the linearised covariance, it follows J's own shape, which
    is flat towards long times where the record holds few correlation times and steep
    towards short ones; bisection in log T on each side, within the fit's bounds of T."""
    pb, fit = r.pb, r.fit
    T0 = fit.spec.gm[g]
    need = fit.J + r.z**2 * r.scale
    lo_b, hi_b = (math.log(b) for b in pb.t_bounds())

    def J(x):
        ts = list(fit.spec.gm)
        ts[g] = math.exp(x)
        return pb.solve(_Spec(fit.spec.linear, tuple(ts))).J

    out = []
    for edge in (lo_b, hi_b):
        a, b = math.log(T0), edge
        if J(b) <= need:
            out.append(math.exp(b))
            continue
        for _ in range(30):
            mid = 0.5 * (a + b)
            a, b = (mid, b) if J(mid) <= need else (a, mid)
            if abs(b - a) < 1e-3:
                break
        out.append(math.exp(0.5 * (a + b)))
    return float(min(out[0], T0)), float(max(out[1], T0))


def _left_out_term(r: _Report, term: str, log: list) -> ModelTerm:
    """A linear term outside the fitted model: why, and its one-sided 95 % upper bound from
    the model refitted with it forced in, when there is one."""
    why = next((s for s in reversed(log) if s.startswith(f"dropped {term}:")), None)
    try:
        forced = r.pb.refine(_Spec(tuple(x for x in LINEAR_TERMS
                                         if x in r.fit.spec.linear or x == term), r.fit.spec.gm))
        k = forced.spec.linear.index(term)
        _, c_b = _score_interval(r.pb, forced, k, r.z95, r.scale, lower=False)
        bound = None if c_b is None else math.sqrt(c_b)
    except (np.linalg.LinAlgError, ValueError):
        bound = None
    reason = (why or ("not in the stated model" if r.stated else "not selected"))
    if bound is not None and math.isfinite(bound) and bound > 0:
        return ModelTerm(term, "upper bound", None, None, None, None,
                         reason + "; 95 % upper bound from the model with it "
                         "forced in", bound=bound)
    return ModelTerm(term, "not identified", None, None, None, None, reason)


def _gm_bound_term(r: _Report) -> ModelTerm:
    """A further Gauss-Markov term, not in the model: its one-sided 95 % upper bound at each
    correlation time the record can see (every other octave from the third averaging time to
    the third last: below, a Gauss-Markov term is white noise to the curve, above it a random
    walk, and its sigma is bounded only through those terms' shapes), from the
    model with it forced in at that time, linearised (the estimate plus 1.645 of its standard
    deviation from ``(D^T Omega D)^-1``, as the Wald bound; the score inversion the IEEE terms'
    bounds use would need the covariance of the estimates at each time), and the largest of
    them as ``bound``."""
    pb, fit = r.pb, r.fit
    taus = pb.taus[2:-2:2] if pb.taus.size >= 7 else pb.taus
    rows = []
    for T in taus:
        forced = pb.solve(_Spec(fit.spec.linear, tuple(sorted(fit.spec.gm + (float(T),)))))
        k = len(fit.spec.linear) + forced.spec.gm.index(float(T))
        cov = _fisher_inverse(pb.W @ _jacobian(pb, forced)) * r.scale
        c = float(forced.coef[k]) + r.z95 * math.sqrt(max(cov[k, k], 0.0))
        if c > 0 and math.isfinite(c):
            rows.append((float(T), math.sqrt(c)))
    reason = "not in the stated model" if r.stated else \
        f"not selected (model {fit.spec.label()})"
    if not rows:
        return ModelTerm("GM", "not identified", None, None, None, None,
                         reason + "; the record does not bound a further Gauss-Markov term")
    return ModelTerm("GM", "upper bound", None, None, None, None,
                     reason + "; a further Gauss-Markov term: 95 % upper bound of its sigma at "
                     f"correlation times {rows[0][0]:.3g}..{rows[-1][0]:.3g} s (the largest, "
                     "linearised)", bound=max(b for _, b in rows),
                     bound_by_tau=tuple(rows))
