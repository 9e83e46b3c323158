"""Choosing among models: which terms the record shows.

Model selection is by the distance-difference test of the method of moments (Newey & West,
"Hypothesis testing with efficient method of moments estimation", Int. Econ. Rev. 28(3),
777-787, 1987): with ``Omega`` the inverse covariance of the estimates, the increase of J when
q parameters are removed is asymptotically chi-squared with q degrees of freedom; a term is kept
only when removing it raises J by more than the 1 - ``alpha`` quantile, and a further
Gauss-Markov term is added only when it lowers J by as much (:func:`_select`).
"""

from __future__ import annotations

import numpy as np

from ._fit import _Fit, _Problem, _Spec
from ._processes import LINEAR_TERMS


def _threshold(q: int, alpha: float) -> float:
    """The level-alpha critical value of the rise of J when a term of q parameters is removed.
    A variance tested at zero sits on the boundary of its range: the rise is then distributed
    as the even mixture of chi-squared(0) and chi-squared(q) (Self & Liang, JASA 82(398),
    605-610, 1987), whose critical value is chi-squared(q)'s at 1 - 2 alpha."""
    from scipy.stats import chi2

    return float(chi2.ppf(1.0 - 2.0 * alpha, q))


#: Least share of the model's Allan variance a Gauss-Markov term must make at some tau to be
#: kept: a term that never makes 10 % of the curve bends it by a few per cent, which the short,
#: precise averaging times of a long record can show as significant while no correlated process
#: is there (measured: a GM of 3 s and 2 % share "found" in 1 of 10 records of white noise and
#: a random walk); a correlated term a filter needs stands out more than that.
GM_MIN_SHARE = 0.10


def _gm_share(pb: _Problem, fit: _Fit) -> float:
    """The smallest over the fit's Gauss-Markov terms of each one's largest share of the
    model's Allan variance over the averaging times (1 without GM terms)."""
    if not fit.spec.gm:
        return 1.0
    A = pb.design(fit.spec)
    parts = A * fit.coef
    total = parts.sum(axis=1)
    n_lin = len(fit.spec.linear)
    return float(min(np.max(parts[:, n_lin + g] / total) for g in range(len(fit.spec.gm))))


def _gm_threshold(pb: _Problem, alpha: float) -> float:
    """The critical gain of J for a further Gauss-Markov term. Its correlation time is chosen
    by the search over the octaves, so the gain of the best one is the largest of about as
    many gains as octaves (the Davies problem: the time is not identified when the term is
    absent); the level is divided among them (Bonferroni). Measured on 100 white-noise
    records of 8 h at 10 Hz (18 octaves): the best gain exceeded 7.6 in 1 % of them, this
    threshold (15.0 at alpha = 1 %) in none."""
    return _threshold(2, alpha / max(1, pb.taus.size))


def _drop(spec: _Spec, term) -> _Spec:
    if isinstance(term, str):
        return _Spec(tuple(t for t in spec.linear if t != term), spec.gm)
    return _Spec(spec.linear, tuple(T for k, T in enumerate(spec.gm) if k != term))


def _select(pb: _Problem, alpha: float, max_gm: int, log: list) -> tuple[_Fit, dict]:
    """Forward over Gauss-Markov terms, backward over them, by the distance-difference test
    (module docstring); the linear terms fitted as zero leave the model, and each other one is
    tested the same way but stays in it when the test fails (returned in ``weak``, term ->
    (rise of J when removed, critical value)): every FOG has all five processes, and leaving
    out one the record cannot show biases the others (measured on 20 tactical records of 24 h:
    the bias instability +11 % with the rate random walk left out, +4 % with it kept)."""
    lo, hi = pb.taus[0], pb.taus[-1]
    cur = pb.solve(_Spec(LINEAR_TERMS))
    need = _gm_threshold(pb, alpha)
    for _ in range(max_gm):
        cand = pb.add_gm(cur.spec)
        gain = cur.J - cand.J
        new = [T for T in cand.spec.gm if T not in cur.spec.gm]
        inside = all(lo <= T <= hi for T in cand.spec.gm)
        share = _gm_share(pb, cand)
        if gain > need and inside and share >= GM_MIN_SHARE:
            log.append(f"added GM({new[0] if new else float('nan'):.3g} s): J {cur.J:.4g} -> "
                       f"{cand.J:.4g}")
            cur = cand
        else:
            log.append(f"no further Gauss-Markov term: the best one lowers J by {gain:.3g} "
                       f"(needs {need:.3g})"
                       + ("" if inside else ", and its correlation time falls outside the "
                          f"averaging times {lo:g}..{hi:g} s")
                       + ("" if share >= GM_MIN_SHARE else f", and it makes at most "
                          f"{100 * share:.0f} % of the variance at any tau (needs "
                          f"{100 * GM_MIN_SHARE:.0f} %)"))
            break
    while True:
        zero = [t for t, c in zip(cur.spec.linear, cur.coef) if c <= 0]
        if zero:
            for t in zero:
                log.append(f"dropped {t}: fitted as zero")
            cur = pb.refine(_Spec(tuple(t for t in cur.spec.linear if t not in zero),
                                  cur.spec.gm))
            continue
        rises = [(pb.refine(_drop(cur.spec, k)).J - cur.J, k) for k in range(len(cur.spec.gm))]
        rises = [(r, k) for r, k in rises if r < need]
        if not rises:
            break
        r, k = min(rises)
        log.append(f"dropped GM({cur.spec.gm[k]:.3g} s): removing it raises J by only {r:.3g} "
                   f"(< {need:.3g})")
        cur = pb.refine(_drop(cur.spec, k))
    return cur, _weak_terms(pb, cur, alpha, log)


def _weak_terms(pb: _Problem, cur: _Fit, alpha: float, log: list,
                hold_times: bool = False) -> dict:
    """The IEEE terms of ``cur`` whose removal raises J by less than one term's critical
    value: term -> (rise, critical value); each said in ``log``. ``hold_times``: the
    Gauss-Markov correlation times held where they are when a term is removed (else refitted:
    a time then free to leave the averaging times can mimic the removed term, e.g. a term
    of a few milliseconds standing in for white noise)."""
    weak = {}
    for t in cur.spec.linear:
        if len(cur.spec.linear) + len(cur.spec.gm) == 1:
            break
        rise = (pb.solve if hold_times else pb.refine)(_drop(cur.spec, t)).J - cur.J
        if rise < _threshold(1, alpha):
            weak[t] = (rise, _threshold(1, alpha))
            log.append(f"{t} not significant: removing it raises J by only {rise:.3g} "
                       f"(< {_threshold(1, alpha):.3g}); kept in the model for the others' "
                       "sake, reported as an upper bound")
    return weak


def _saturated(pb: _Problem, alpha: float, max_gm: int) -> _Fit:
    """Every linear term, and Gauss-Markov terms added while each lowers J significantly."""
    cur = pb.solve(_Spec(LINEAR_TERMS))
    for _ in range(max_gm):
        cand = pb.add_gm(cur.spec)
        if cur.J - cand.J > _gm_threshold(pb, alpha):
            cur = cand
        else:
            break
    return cur


def _alternative(pb: _Problem, fit: _Fit, weak: dict, alpha: float, max_gm: int,
                 log: list) -> tuple[_Fit, str] | None:
    """The other reading of the same feature, when the record cannot choose: over a record of
    a few correlation times a flicker floor and a Gauss-Markov hump bend the Allan curve alike.
    For a selected model with an identified flicker B (and room for one more Gauss-Markov
    term), the model with B replaced by a Gauss-Markov term; for one with Gauss-Markov terms
    and no flicker, each with one of them replaced by B. An alternative *fits as well* when its
    J, under the same weights, exceeds the selected model's by less than the critical value of
    one term (``_threshold(1, alpha)``: the two are not nested, and this is the bar a term
    must clear to enter the selection at all) or is lower, its swapped-in term is above zero,
    and a
    Gauss-Markov term of it lies inside the averaging times and makes 10 % of the curve
    somewhere. Returns the best one (least J; its IEEE terms fitted as exactly zero left
    out, the correlation times held) and the term swapped in ("GM" or "B"), or None; the log
    says which and both J.

    Why the selection is not changed by it: measured (``fogbench.bench.noise_select``, and a
    Whittle likelihood on the full periodogram, docs/theory/noise-identification.md), an 8 h
    record of white noise + GM(0.05 deg/h, 500 s) and its mirror, white + flicker 0.037 deg/h,
    differ in their log-likelihoods of the two readings by a few units in either direction:
    no rule on the data is right for both, so the criterion's choice stands and the other
    reading is reported beside it (``NoiseModel.alternative``)."""
    from ._processes import LINEAR_TERMS as ORDER

    lo, hi = pb.taus[0], pb.taus[-1]
    bar = _threshold(1, alpha)
    cands = []
    lin = fit.spec.linear
    if "B" in lin and "B" not in weak and len(fit.spec.gm) < max_gm:
        k = lin.index("B")
        if fit.coef[k] > 0:
            cands.append(("a Gauss-Markov term in place of the flicker B",
                          pb.add_gm(_Spec(tuple(t for t in lin if t != "B"), fit.spec.gm))))
    if "B" not in lin:
        with_b = tuple(t for t in ORDER if t in lin or t == "B")
        for g, T in enumerate(fit.spec.gm):
            cands.append((f"the flicker B in place of GM({T:.3g} s)",
                          pb.refine(_Spec(with_b, tuple(x for i, x in enumerate(fit.spec.gm)
                                                        if i != g)))))
    best = None
    for what, alt in cands:
        n_lin = len(alt.spec.linear)
        if "B" in alt.spec.linear and not alt.coef[alt.spec.linear.index("B")] > 0:
            continue
        if not all(c > 0 for c in alt.coef[n_lin:]):
            continue
        if not all(lo <= T <= hi for T in alt.spec.gm) or _gm_share(pb, alt) < GM_MIN_SHARE:
            continue
        if alt.J - fit.J < bar and (best is None or alt.J < best[1].J):
            best = (what, alt)
    if best is None:
        return None
    what, alt = best
    while True:                     # the terms fitted as exactly zero leave, as in _select
        n_lin = len(alt.spec.linear)
        zero = [t for t, c in zip(alt.spec.linear, alt.coef[:n_lin]) if c <= 0]
        if not zero:
            break
        alt = pb.solve(_Spec(tuple(t for t in alt.spec.linear if t not in zero), alt.spec.gm))
    extra = alt.spec.n_params - fit.spec.n_params
    wvic = "the alternative" if alt.J + 2 * extra < fit.J else "the selection"
    log.append(f"both fit: {fit.spec.label()} (J {fit.J:.4g}) and, with {what}, "
               f"{alt.spec.label()} (J {alt.J:.4g}, {alt.J - fit.J:+.3g}; within one term's "
               f"critical value {bar:.3g}); the first is the selection (the tests above), the "
               f"second the alternative; a criterion of 2 per parameter (WVIC) would prefer "
               f"{wvic}")
    return alt, ("B" if "B" in alt.spec.linear else "GM")
