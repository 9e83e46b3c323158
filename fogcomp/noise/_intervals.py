"""The intervals of a fitted model's coefficients, and the record length a term would need.

The intervals come from the covariance ``(D^T Omega D)^-1`` of the estimate (:mod:`._fit`),
scaled by ``J / dof`` when the fit is significantly worse than its error bars say; a variance
coefficient's interval is inverted as a score test's (:func:`_score_interval`) and taken to the
square root; a correlation time's inverts the distance-difference test (:func:`_tau_interval`).
"""

from __future__ import annotations

import math

import numpy as np

from ._fit import _fisher_inverse, _Fit, _jacobian, _param_cov, _Problem
from ._processes import avar_model


def _fit_with(fit: _Fit, k: int, value: float) -> _Fit:
    coef = np.array(fit.coef, dtype=float)
    coef[k] = value
    return _Fit(fit.spec, coef, fit.J)


def _sigma_at(pb: _Problem, fit: _Fit, k: int, value: float, scale: float) -> float:
    """Standard deviation of coefficient k's estimate if its true value were ``value`` (the
    others at the estimate): the weights and the Fisher information at that model."""
    hyp = _fit_with(fit, k, value)
    W = pb.weights(*hyp.coefficients())
    cov = _fisher_inverse(W @ _jacobian(pb, hyp)) * scale
    return math.sqrt(max(float(cov[k, k]), 0.0))


def _score_interval(pb: _Problem, fit: _Fit, k: int, z: float, scale: float,
                    lower: bool = True, sig=None) -> tuple[float, float | None]:
    """{c >= 0 : |c_hat - c| <= z sigma(c)} for coefficient k, sigma(c) the estimate's spread
    were c the truth (:func:`_sigma_at`). The spread of a variance estimate grows with the
    variance itself, so a Wald interval (sigma at the estimate) is too short below a low
    estimate and too long above a high one; inverting at each hypothesised value, as a score
    test does, is not (measured: the 68 % interval of a 24 h record's rate random walk covers
    in 50 % of records as Wald). Returns (low, high); high None when the interval has no upper
    end (the record cannot bound the term from above at this level). ``sig``: a function
    c -> sigma(c) in place of :func:`_sigma_at` (a further Gauss-Markov term's bound,
    ``_identify._gm_bound_term``)."""
    c = float(fit.coef[k])

    if sig is None:
        def sig(v):
            return _sigma_at(pb, fit, k, v, scale)

    lo = 0.0
    if lower and c > 0 and c - z * sig(0.0) > 0:
        a, b = 0.0, c                # g(a) > 0 >= g(b), g(v) = (c - v) - z sigma(v)
        for _ in range(40):
            mid = 0.5 * (a + b)
            if (c - mid) - z * sig(mid) > 0:
                a = mid
            else:
                b = mid
            if b - a <= 1e-4 * c:
                break
        lo = 0.5 * (a + b)
    ref = c if c > 0 else max(sig(0.0), 1e-300)
    a, b = c, c + ref
    while (b - c) - z * sig(b) <= 0:
        a, b = b, c + 2.0 * (b - c)
        if b > c + 1e6 * ref:
            return lo, None
    for _ in range(40):
        mid = 0.5 * (a + b)
        if (mid - c) - z * sig(mid) > 0:
            b = mid
        else:
            a = mid
        if b - a <= 1e-4 * max(c, ref):
            break
    return lo, 0.5 * (a + b)


def _interval_sqrt(c: float, sc: float, z: float):
    """(value, low, high, sigma) of sqrt(c) from a normal interval c +- z sc (c a variance)."""
    v = math.sqrt(max(c, 0.0))
    lo = math.sqrt(max(c - z * sc, 0.0))
    hi = math.sqrt(max(c + z * sc, 0.0))
    sigma = sc / (2.0 * v) if v > 0 else None
    return v, lo, hi, sigma


def _predicted_rel_sigma(pb: _Problem, fit: _Fit, index: int, n_new: int) -> float:
    """The relative one-sigma uncertainty of the coefficient ``index`` (its square root, as
    reported) that a record of ``n_new`` samples would give under the fitted model."""
    m = 2 ** np.arange(int(math.floor(math.log2((n_new - 1) // 2))) + 1)
    m = m[m >= pb.m[0]]
    other = _Problem(m / pb.fs, avar_model(m / pb.fs, *fit.coefficients(), fs=pb.fs), m,
                     (n_new,), pb.fs, pb.model_error)
    other.set_weights(*fit.coefficients())
    cov = _param_cov(other, fit)
    c = fit.coef[index]
    return math.sqrt(max(cov[index, index], 0.0)) / (2.0 * c) if c > 0 else math.inf


def _record_for(pb: _Problem, fit: _Fit, index: int, rel_now: float,
                target: float = 0.10, scale: float = 1.0) -> float | None:
    """Record length (s) at which the coefficient would be known to ``target`` (one sigma):
    the predicted uncertainty at 1 and 4 times the record gives its power law in the length,
    refined once at the extrapolated length."""
    n = max(pb.segments)
    if not (math.isfinite(rel_now) and rel_now > target):
        return None
    try:
        f = math.sqrt(scale)
        r1 = f * _predicted_rel_sigma(pb, fit, index, n)
        r4 = f * _predicted_rel_sigma(pb, fit, index, 4 * n)
        if not (r4 < r1):
            return None
        beta = math.log(r1 / r4) / math.log(4.0)
        n_t = n * (r1 / target) ** (1.0 / beta)
        if n_t > 1e11:
            return None
        r_t = f * _predicted_rel_sigma(pb, fit, index, int(n_t))
        n_t = n_t * (r_t / target) ** (1.0 / beta)
    except (np.linalg.LinAlgError, ValueError, OverflowError):
        return None
    return float(n_t / pb.fs)


def _tau_interval(pb: _Problem, fit: _Fit, g: int, z: float,
                  scale: float) -> tuple[float | None, float | None]:
    """The interval of Gauss-Markov term g's correlation time by inverting the
    distance-difference test: ``{T : J(T) - J_hat <= z^2 scale}``, J(T) the fit with that term's
    time held at T and the variances refitted (the other correlation times held at their
    estimates: a conditional interval, a little short where two terms' times trade off).

    A correlation time estimated from the Allan variance runs short of the truth on records of
    a few dozen correlation times (measured: median -20 % for a 500 s term over 8 h, stated
    model, 20 records, ``fogbench.bench.noise_select``), and a normal interval in log T from the linearised covariance is
    symmetric about that short estimate; J rises slowly towards the long times a record holds
    few of, so the inverted interval reaches further up than down and owns the bias (its
    coverage is printed by ``fogbench.bench.noise_select``). (low, high): None on a side where J
    does not rise that far before the correlation time leaves the averaging times' range
    (half the shortest to twice the longest): the record does not bound it there.
    """
    lo_b, hi_b = (math.log(b) for b in pb.t_bounds())
    x_hat = math.log(fit.spec.gm[g])
    need = z * z * max(scale, 1.0)

    def rise(x: float) -> float:
        ts = list(fit.spec.gm)
        ts[g] = math.exp(x)
        return pb.solve(type(fit.spec)(fit.spec.linear, tuple(ts))).J - fit.J

    def side(direction: int) -> float | None:
        edge = hi_b if direction > 0 else lo_b
        a, step = x_hat, 0.05
        while True:
            b = a + direction * step
            if (b - edge) * direction >= 0:
                if rise(edge) <= need:
                    return None
                b = edge
            if rise(b) > need:
                break
            a, step = b, step * 1.5
        for _ in range(40):           # rise(a) <= need < rise(b)
            mid = 0.5 * (a + b)
            if rise(mid) > need:
                b = mid
            else:
                a = mid
            if abs(b - a) < 1e-3:
                break
        return math.exp(0.5 * (a + b))

    return side(-1), side(+1)
