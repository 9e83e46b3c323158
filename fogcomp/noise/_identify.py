"""The identifier: :func:`identify_noise_model`, from an Allan variance curve to a
:class:`~fogcomp.noise.NoiseModel` (the estimator, the selection and the intervals in
:mod:`fogcomp.noise`'s docstring)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .._stats import ONE_SIGMA_CI
from ._fit import _fisher_inverse, _Fit, _jacobian, _param_cov, _pilot, _Problem, _Spec, _stated
from ._intervals import _interval_sqrt, _record_for, _score_interval, _tau_interval
from ._processes import FLICKER_FLOOR, LINEAR_TERMS, avar_gm, parse_model
from ._result import ModelTerm, NoiseModel
from ._select import _alternative, _gm_threshold, _saturated, _select, _weak_terms


def identify_noise_model(taus, avar, fs: float, n, *, model=None, ci: float | None = None,
                         alpha: float = 0.01, max_gm: int = 3, model_error: float = 0.001,
                         record_length: bool = True, alternative: bool = True) -> NoiseModel:
    """Identify the noise model of a record from its overlapping Allan variance.

    The estimator, the model selection and the intervals are described in the docstring of
    :mod:`fogcomp.noise`; :func:`fogcomp.allan.allan_analysis` computes the curve of a record
    and calls this.

    Parameters
    ----------
    taus : array_like, shape (k,)
        Averaging times, s: whole multiples ``m / fs`` of the sample interval, octave-spaced
        as :func:`fogcomp.allan.oadev` gives them (at least 3).
    avar : array_like, shape (k,)
        The overlapping Allan variance at ``taus``, rad^2/s^2 (the square of the deviation).
    fs : float
        Sample rate of the record, Hz.
    n : int or sequence of int
        Number of samples of the record, or of each gap-free segment whose estimates were pooled
        (each weighted by its number of terms).
    model : str or list of str, optional
        A stated model (``"N + B + K"``, ``"N + GM + GM"``): fitted as stated, no selection.
        Default: selected among the five IEEE Std 952 terms and up to ``max_gm`` Gauss-Markov
        terms.
    ci : float, optional
        Probability content of the intervals (default 0.6827, one sigma).
    alpha : float, optional
        Level of the selection tests (default 0.01: a term absent from the record enters the
        model in about 1 % of records).
    max_gm : int, optional
        Most Gauss-Markov terms tried (default 3); a model that holds fewer (selected or
        stated) reports a further one outside it by its upper bound at the correlation times
        the record can see (0: no Gauss-Markov candidate, none reported).
    model_error : float, optional
        Relative uncertainty of each Allan variance point added to the statistical one (default
        0.001): the model's own approximations (the flicker floor is flat only well above its
        band's upper corner; a random walk's sampling). Measured on 20 simulated 24 h
        tactical records: with 0.01 the 68 % interval of the angle random walk covered in 95 %
        of them (too wide: the statistical error there is 0.1 %), with 0.001 in 70 %.
    record_length : bool, optional
        Predict, for each identified term known to worse than 10 %, the record length that
        would give 10 % (default True; a few more covariance evaluations).
    alternative : bool, optional
        When the selection holds flicker or a Gauss-Markov term, fit the other reading of that
        feature and report it (``NoiseModel.alternative``) when it fits as well (default True;
        up to about 1.5 times the identification's time). False: the selection only (the
        bench's per-method metrics, which read the selected terms).

    Returns
    -------
    NoiseModel
    """
    ci = ONE_SIGMA_CI if ci is None else ci
    _check_options(ci, alpha, max_gm, model_error)
    t, v, m, segs, fs = _checked_curve(taus, avar, fs, n)
    stated = None if model is None else _checked_model(model, t.size)
    pb = _Problem(t, v, m, segs, fs, model_error)
    big, fit, weak, log = _fit_and_select(pb, stated, alpha, max_gm, model_error)
    cov_v = pb.covariance(*big.coefficients())
    dof, p_value, scale = _fit_quality(fit, t.size)
    terms = _model_terms(_Report.of(pb, fit, scale, ci, stated is not None, alpha,
                                    record_length), weak, log, max_gm)
    found = None if stated is not None or not alternative else \
        _alternative(pb, fit, weak, alpha, max_gm, log)
    floor = _floor_reading(t, v, cov_v)

    def model(f, terms, log, scale, p_value, dof, alternative=None):
        return NoiseModel(terms=terms, taus=t, avar=v, avar_cov=cov_v, fs=fs, n=segs, ci=ci,
                          J=float(f.J), dof=int(dof), p_value=p_value, scale=float(scale),
                          floor_reading=floor, selection=log, stated=stated is not None,
                          alpha=alpha, model_error=float(pb.model_error),
                          alternative=alternative)

    other = None
    if found is not None:
        alt, swapped_in = found
        a_dof, a_p, a_scale = _fit_quality(alt, t.size)
        a_terms, a_log = _alternative_terms(pb, fit, alt, swapped_in, a_scale, ci, alpha,
                                            log[-1])
        other = model(alt, a_terms, a_log, a_scale, a_p, a_dof)
    return model(fit, terms, log, scale, p_value, dof, other)


def _fit_quality(fit: _Fit, k: int) -> tuple[int, float, float]:
    """(degrees of freedom, chi-squared probability of J, the factor on the parameter
    covariance): ``J / dof`` when the curve departs from the model (p < 0.05), else 1."""
    from scipy.stats import chi2

    dof = k - fit.spec.n_params
    p_value = float(chi2.sf(fit.J, dof)) if dof > 0 else float("nan")
    return dof, p_value, (fit.J / dof if dof > 0 and p_value < 0.05 else 1.0)


def _alternative_terms(pb: _Problem, fit: _Fit, alt: _Fit, swapped_in: str, scale: float,
                       ci: float, alpha: float, said: str) -> tuple[list, list]:
    """(terms, log) of the alternative reading ``alt`` of the selected ``fit``: its IEEE
    terms tested as the selection's are, the correlation times held (a term the selection
    found weak is not called identified here); no bounds of the terms it leaves out or of a
    further Gauss-Markov term (the selection has them); each reason says it is the
    alternative, the swapped-in term's that it fits as well."""
    a_log = [said]
    a_weak = _weak_terms(pb, alt, alpha, a_log, hold_times=True)
    a_terms = _model_terms(_Report.of(pb, alt, scale, ci, False, alpha, False), a_weak,
                           [], len(alt.spec.gm), bounds=False)
    head = f"the alternative reading ({alt.spec.label()}): "
    what = "flicker" if swapped_in == "GM" else "Gauss-Markov term"
    swapped = (f"in place of the selection's {what}, fits as well ({fit.spec.label()}: "
               f"J {fit.J:.4g}, this: {alt.J:.4g})")
    kept = {round(T, 6) for T in fit.spec.gm}
    return [replace(x, reason=head + (swapped if x.term == swapped_in and x.in_model
                                      and (x.term == "B" or round(x.tau, 6) not in kept)
                                      else x.reason))
            for x in a_terms], a_log


# ---------------------------------------------------------------------------------------------
# The inputs
def _check_options(ci, alpha, max_gm, model_error) -> None:
    if not (isinstance(ci, (int, float)) and 0.0 < ci < 1.0):
        raise ValueError(f"ci: expected a probability between 0 and 1, got {ci!r}")
    if not (isinstance(alpha, (int, float)) and 0.0 < alpha < 0.5):
        raise ValueError(f"alpha: expected a test level between 0 and 0.5, got {alpha!r}")
    if isinstance(max_gm, bool) or not isinstance(max_gm, (int, np.integer)) or \
            not 0 <= max_gm <= 5:
        raise ValueError(f"max_gm: expected an integer from 0 to 5, got {max_gm!r}")
    if not (isinstance(model_error, (int, float)) and 0.0 <= model_error < 1.0):
        raise ValueError(f"model_error: expected a relative error in [0, 1), got "
                         f"{model_error!r}")


def _checked_curve(taus, avar, fs, n):
    """(taus, avar sorted by tau, averaging factors m, samples per segment, fs), checked."""
    if isinstance(fs, bool) or not isinstance(fs, (int, float, np.integer, np.floating)) or \
            not math.isfinite(fs) or fs <= 0:
        raise ValueError(f"fs: sample rate must be a positive finite number in Hz, got {fs!r}")
    fs = float(fs)
    segs = (n,) if isinstance(n, (int, np.integer)) and not isinstance(n, bool) else tuple(n)
    # A piece of 3 samples holds one term at the shortest averaging time; the longest must
    # give the 3 octave averaging times a fit needs (8 samples).
    if not segs or any(isinstance(s, bool) or not isinstance(s, (int, np.integer)) or s < 3
                       for s in segs) or max(segs) < 8:
        raise ValueError(f"n: expected the number of samples (an integer >= 8) or one per "
                         f"gap-free segment (each >= 3, the longest >= 8), got {n!r}")
    segs = tuple(int(s) for s in segs)
    t = np.asarray(taus, dtype=float)
    v = np.asarray(avar, dtype=float)
    if t.ndim != 1 or t.shape != v.shape:
        raise ValueError(f"taus, avar: expected two 1-D arrays of one length, got shapes "
                         f"{t.shape} and {v.shape}")
    if t.size < 3:
        raise ValueError(f"taus: expected at least 3 averaging times to fit, got {t.size}")
    if not (np.all(np.isfinite(t)) and np.all(t > 0) and np.all(np.isfinite(v))
            and np.all(v > 0)):
        raise ValueError("taus, avar: expected positive finite values (a constant record has "
                         "no noise to identify)")
    order = np.argsort(t)
    t, v = t[order], v[order]
    mf = t * fs
    m = np.rint(mf).astype(np.int64)
    if np.any(np.abs(mf - m) > 1e-6 * np.maximum(1.0, mf)) or np.any(m < 1):
        raise ValueError(f"taus: every averaging time must be a whole multiple of 1/fs = "
                         f"{1 / fs:g} s")
    if np.unique(m).size != m.size:
        raise ValueError("taus: averaging times must be distinct")
    if m[-1] > (max(segs) - 1) // 2:
        raise ValueError(f"taus: the longest averaging time {t[-1]:g} s needs more than the "
                         f"{max(segs)} samples given (n)")
    return t, v, m, segs, fs


def _checked_model(model, k: int) -> tuple[tuple[str, ...], int]:
    """The stated model's (linear terms, number of Gauss-Markov terms), fewer parameters than
    the ``k`` points of the curve."""
    linear, n_gm = parse_model(model)
    if len(linear) + 2 * n_gm >= k:
        raise ValueError(f"model: {len(linear) + 2 * n_gm} parameters from {k} "
                         "averaging times: not enough points to fit it")
    return linear, n_gm


# ---------------------------------------------------------------------------------------------
# The fit and the selection
def _fit_and_select(pb: _Problem, stated, alpha: float, max_gm: int, model_error: float):
    """(largest model, fitted model, weak terms, the selection's log) of the curve in ``pb``:
    the stated model (``(linear, n_gm)``) or the selected one (``stated`` None), under the
    weights of the largest model; once more with a larger model error when the curve departs
    from the fit beyond its error bars."""
    from scipy.stats import chi2

    log: list[str] = []
    big, fit, weak, steps = _weights_and_fit(pb, model_error, stated, alpha, max_gm)
    dof = pb.taus.size - fit.spec.n_params
    if dof > 0 and chi2.sf(fit.J, dof) < 0.01:
        # The curve departs from every model of these terms more than its statistical error
        # allows (a real sensor's anti-alias filter, vibration, temperature): that misfit is
        # estimated as a relative error per point, and the selection is made again under
        # it, so that the few very precise short-tau points do not decide every term.
        eps = _misfit_model_error(pb, big, fit.spec, dof, model_error)
        log.append(f"the curve departs from the model {fit.spec.label()} beyond its error bars "
                   f"(J = {fit.J:.3g} on {dof} degrees of freedom): a model error of "
                   f"{100 * eps:.2g} % per point brings J to its degrees of freedom; selected "
                   "again with it")
        big, fit, weak, steps = _weights_and_fit(pb, eps, stated, alpha, max_gm)
    log.extend(steps)
    return big, fit, weak, log


def _weights_and_fit(pb: _Problem, eps: float, stated, alpha: float, max_gm: int):
    """Omega, once for every candidate (as GMWM's is model-free): the covariance under the
    largest model (every linear term and the Gauss-Markov terms that lower J), fitted
    twice with the weights at its own estimate (a smaller model's covariance would
    understate the variance where a term it lacks adds to the curve, and so keep that term
    out); then the selection (or the stated model) under it. Returns (largest model, fit,
    weak terms, steps)."""
    pb.model_error = eps
    pb.set_weights(*_pilot(pb))
    for _ in range(2):
        big = _saturated(pb, alpha, max_gm) if stated is None else \
            _stated(pb, tuple(sorted(set(LINEAR_TERMS) | set(stated[0]),
                                     key=LINEAR_TERMS.index)), stated[1])
        pb.set_weights(*big.coefficients())
    steps: list[str] = [f"weights (Omega) from the largest model, {big.spec.label()}"]
    if stated is not None:
        fit, weak = _stated(pb, *stated), {}
    else:
        fit, weak = _select(pb, alpha, max_gm, steps)
    return big, pb.refine(fit.spec), weak, steps


def _misfit_model_error(pb: _Problem, big: _Fit, spec: _Spec, dof: int,
                        model_error: float) -> float:
    """The relative error per point that brings J of ``spec`` to its degrees of freedom (a
    method-of-moments dispersion), by bisection in its logarithm between the given model
    error (at least 1e-4) and 0.5; the weights from the largest model ``big``."""
    lo_e, hi_e = math.log(max(model_error, 1e-4)), math.log(0.5)
    for _ in range(14):
        mid = 0.5 * (lo_e + hi_e)
        pb.model_error = math.exp(mid)
        pb.set_weights(*big.coefficients())
        if pb.refine(spec).J > dof:
            lo_e = mid
        else:
            hi_e = mid
        if hi_e - lo_e < 0.05:
            break
    return math.exp(hi_e)


# ---------------------------------------------------------------------------------------------
# The terms of the result
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


def _model_terms(r: _Report, weak: dict, log: list, max_gm: int,
                 bounds: bool = True) -> list:
    """Every candidate term: the five IEEE terms in their order (each in the model, or left
    out), the model's Gauss-Markov terms by correlation time (keys ``GM1``, ``GM2``, ...) and,
    when it holds fewer than ``max_gm``, a further one's bound (the next key)."""
    terms: dict = {}
    for k, term in enumerate(r.fit.spec.linear):
        terms[term] = _linear_term(r, k, weak.get(term))
    gms = sorted((_gm_term(r, g) for g in range(len(r.fit.spec.gm))), key=lambda g: g.tau)
    # the terms left out: a one-sided 95 % upper bound from the model with the term forced in
    for term in LINEAR_TERMS:
        if term not in terms:
            terms[term] = _left_out_term(r, term, log) if bounds else ModelTerm(
                term, "not identified", None, None, None, None,
                "not in this model (its bound is the selection's)")
    if len(gms) < max_gm:
        try:
            gms.append(_gm_bound_term(r))
        except (np.linalg.LinAlgError, ValueError) as e:
            gms.append(ModelTerm("GM", "not identified", None, None, None, None,
                                 f"a further Gauss-Markov term: its bound could not be "
                                 f"computed ({e})"))
    return [replace(terms[x], key=x) for x in LINEAR_TERMS] + \
        [replace(g, key=f"GM{i + 1}") for i, g in enumerate(gms)]


def _interval(r: _Report, k: int):
    """(value, low, high, sigma, bound) of the square root of coefficient k: the score
    interval of content ci, the linearised sigma for display, the one-sided 95 % bound."""
    sc = math.sqrt(max(r.cov[k, k], 0.0))
    val, _, _, sigma = _interval_sqrt(float(r.fit.coef[k]), sc, r.z)
    c_lo, c_hi = _score_interval(r.pb, r.fit, k, r.z, r.scale)
    _, c_b = _score_interval(r.pb, r.fit, k, r.z95, r.scale, lower=False)
    root = (lambda c: None if c is None else math.sqrt(c))
    return val, math.sqrt(c_lo), root(c_hi), sigma, root(c_b)


def _not_shown(term: str, val: float, bound, reason: str, **kw) -> ModelTerm:
    """A term of the fitted model the record does not show (not significant, or stated and
    fitted as exactly zero): reported as a term left out is, by its one-sided 95 % upper
    bound, with no two-sided interval; ``value`` stays the fitted one (the model's curve)."""
    if bound is not None and math.isfinite(bound) and bound > 0:
        return ModelTerm(term, "upper bound", val, None, None, None,
                         reason + "; 95 % upper bound from the model", bound=bound,
                         in_model=True, **kw)
    return ModelTerm(term, "not identified", val, None, None, None,
                     reason + "; the record does not bound it from above", in_model=True, **kw)


def _linear_term(r: _Report, k: int, weak) -> ModelTerm:
    """Linear term k of the fit: identified, or (``weak``: (rise of J when removed, critical
    value)) kept in the model but not significant, or stated and fitted as exactly zero:
    those two reported by their bound (:func:`_not_shown`)."""
    term = r.fit.spec.linear[k]
    val, lo, hi, sigma, bound = _interval(r, k)
    label = r.fit.spec.label()
    if weak is not None:
        rise, need = weak
        return _not_shown(term, val, bound, f"in the model ({label}) but not significant: "
                          f"removing it raises J by {rise:.3g} < {need:.3g}")
    if not val > 0:
        return _not_shown(term, val, bound, f"stated, fitted as exactly zero (model {label})")
    rel = (sigma / val) if sigma and val else math.inf
    # the record a 10 % estimate needs, for a term the record shows (a term it does not
    # show has only a bound, and its estimate is no base for a prediction)
    rec = _record_for(r.pb, r.fit, k, rel, scale=r.scale) if r.record_length else None
    why = ("stated" if r.stated else "significant: removing it raises J by more than "
           f"the level-{r.alpha:g} critical value") + f" (model {label})"
    return ModelTerm(term, "identified", val, lo, hi, sigma, why,
                     record_s_for_10pct=rec, bound=bound, in_model=True)


def _gm_term(r: _Report, g: int) -> ModelTerm:
    """Gauss-Markov term g of the fit, its correlation time's interval by inverting J
    (:func:`._intervals._tau_interval`)."""
    n_lin = len(r.fit.spec.linear)
    T = r.fit.spec.gm[g]
    k = n_lin + g
    val, lo, hi, sigma, bound = _interval(r, k)
    t_lo, t_hi = _tau_interval(r.pb, r.fit, g, r.z, r.scale)
    tau = dict(tau=float(T), tau_low=t_lo, tau_high=t_hi)
    if not val > 0:
        return _not_shown("GM", val, bound, "stated, fitted as exactly zero", **tau)
    rel = (sigma / val) if sigma and val else math.inf
    rec = _record_for(r.pb, r.fit, k, rel, scale=r.scale) if r.record_length else None
    return ModelTerm("GM", "identified", val, lo, hi, sigma,
                     "stated" if r.stated else "significant: adding it lowered J by more "
                     f"than the critical value {_gm_threshold(r.pb, r.alpha):.3g}",
                     record_s_for_10pct=rec, bound=bound, in_model=True, **tau)


def _left_out_term(r: _Report, term: str, log: list) -> ModelTerm:
    """A linear term outside the fitted model: why (the selection's step that dropped it), and
    its one-sided 95 % upper bound from the model refitted with it forced in, when there is
    one."""
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


#: The most a further Gauss-Markov term at its bound may exceed the fitted model's Allan
#: variance at any averaging time for its bound at that correlation time to be reported
#: (:func:`_gm_bound_term`).
GM_BOUND_MAX_EXCESS = 4.0


def _gm_bound_grid(pb: _Problem) -> np.ndarray:
    """The correlation times a further Gauss-Markov term is bounded at: octaves from 4
    sample intervals (and twice the first averaging time: below it the term is white noise
    to the curve) to a tenth of the longest gap-free segment (and the longest averaging
    time: beyond, the record holds too few correlation times to tell it from a random
    walk)."""
    lo = max(4.0 / pb.fs, 2.0 * float(pb.taus[0]))
    hi = min(max(pb.segments) / pb.fs / 10.0, float(pb.taus[-1]))
    if hi < lo:
        return np.zeros(0)
    return lo * 2.0 ** np.arange(int(math.floor(math.log2(hi / lo) + 1e-9)) + 1)


def _gm_bound_term(r: _Report) -> ModelTerm:
    """A further Gauss-Markov term, not in the model: the one-sided 95 % upper bound of its
    sigma at each correlation time T of :func:`_gm_bound_grid`, from the model with the term
    forced in at T (T held), as the IEEE terms' bounds are: the score inversion of
    :func:`~._intervals._score_interval`, {c : c - c_hat <= z95 sigma(c)}. One approximation
    keeps its cost small: sigma(c) is computed with the relative covariance of the estimates
    (their correlation and spread relative to the curve) held at the fitted model's, the
    curve's level at each c exact (the exact covariance needs a covariance basis per T,
    about 0.3 s each on a 10^6-sample record). Checked against the exact one
    (``tests/fogcomp/test_noise_terms.py``; measured on the ADIS16405 log's three axes and
    a 6 h record at 100 Hz): within 3 % where the term at its bound stays under the fitted
    model's curve, lower by up to 8 % where it exceeds it up to 4 times, by a third where it
    exceeds it 6 times and more; a correlation time whose bound would make the term exceed
    the fitted curve more than :data:`GM_BOUND_MAX_EXCESS` times at some averaging time is
    reported as not bounded there (None: the record bounds it there only through the other
    terms' shapes, where the approximation does not hold). ``bound`` is the largest over the correlation
    times bounded; ``bound_by_tau`` holds each (T, bound or None)."""
    pb, fit = r.pb, r.fit
    reason = "not in the stated model" if r.stated else \
        f"not selected (model {fit.spec.label()})"
    grid = [float(T) for T in _gm_bound_grid(pb)
            if all(abs(math.log(T / Tm)) > math.log(2.0) / 2 for Tm in fit.spec.gm)]
    rows = []
    if grid:
        co, gm = fit.coefficients()
        v0 = pb.avar_of(co, gm)
        rel = pb.covariance(co, gm) / np.outer(v0, v0) + pb.model_error**2 * np.eye(v0.size)
        L = np.linalg.cholesky(rel)
        n_lin = len(fit.spec.linear)
        for T in grid:
            spec = _Spec(fit.spec.linear, tuple(sorted(fit.spec.gm + (T,))))
            forced = pb.solve(spec)
            g = spec.gm.index(T)
            k = n_lin + g
            # T held: its log-T column out of the Jacobian (the others' stay)
            D = np.delete(_jacobian(pb, forced), n_lin + len(spec.gm) + g, axis=1)
            unit = avar_gm(pb.taus, T, pb.fs)
            rest = pb.design(spec) @ forced.coef - unit * forced.coef[k]

            def sig(c, D=D, unit=unit, rest=rest, k=k):
                v = rest + c * unit
                W = np.linalg.solve(L, np.diag(1.0 / np.where(v > 0, v, pb.avar)))
                cov = _fisher_inverse(W @ D) * r.scale
                return math.sqrt(max(float(cov[k, k]), 0.0))

            _, c_b = _score_interval(pb, forced, k, r.z95, r.scale, lower=False, sig=sig)
            ok = c_b is not None and math.isfinite(c_b) and c_b > 0 and \
                float(np.max(c_b * unit / v0)) <= GM_BOUND_MAX_EXCESS
            rows.append((T, math.sqrt(c_b) if ok else None))
    held = [(T, b) for T, b in rows if b is not None]
    if not held:
        why = "no correlation time on the record's grid" if not grid else \
            "the record does not bound it at any correlation time of its grid"
        return ModelTerm("GM", "not identified", None, None, None, None,
                         f"{reason}; a further Gauss-Markov term: {why}",
                         bound_by_tau=tuple(rows))
    best = min(held, key=lambda x: x[1])
    loose = [T for T, b in rows if b is None]
    return ModelTerm("GM", "upper bound", None, None, None, None,
                     f"{reason}; a further Gauss-Markov term: 95 % upper bound of its sigma at "
                     f"each correlation time {rows[0][0]:.3g}..{rows[-1][0]:.3g} s "
                     f"(bound_by_tau; the tightest {best[1]:.3g} rad/s at {best[0]:.3g} s), "
                     "the largest as the bound"
                     + (f"; not bounded at {', '.join(f'{T:.3g}' for T in loose)} s"
                        if loose else ""), bound=max(b for _, b in held),
                     bound_by_tau=tuple(rows))


def _floor_reading(t: np.ndarray, v: np.ndarray, cov_v: np.ndarray) -> dict:
    """The IEEE 952 datasheet reading of the bias instability beside the fit: the Allan
    deviation's minimum over its points known to 25 % or better, divided by 0.664."""
    adev = np.sqrt(v)
    rel_adev = np.sqrt(np.diag(cov_v)) / (2.0 * v)
    ok = rel_adev <= 0.25
    floor: dict = {"value": None, "sigma": None, "tau_s": None}
    if ok.any():
        idx = np.flatnonzero(ok)
        i = int(idx[np.argmin(adev[idx])])
        if i == 0:
            floor["reason"] = (f"the curve's minimum is its first point (tau {t[0]:g} s): it "
                               "only rises, there is no floor")
        elif i == idx[-1]:
            floor.update(value=float(adev[i] / math.sqrt(FLICKER_FLOOR)), tau_s=float(t[i]),
                         reason="upper bound only: the curve still falls at its longest "
                                f"reliable point (tau {t[i]:g} s)")
        else:
            floor.update(value=float(adev[i] / math.sqrt(FLICKER_FLOOR)),
                         sigma=float(adev[i] * rel_adev[i] / math.sqrt(FLICKER_FLOOR)),
                         tau_s=float(t[i]), reason=f"minimum of the curve at tau {t[i]:g} s")
    else:
        floor["reason"] = "no point of the curve is known to 25 % or better"
    return floor
