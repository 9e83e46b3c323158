"""Fitting one stated model: its Allan variance to the estimates, weighted by their covariance.

For given Gauss-Markov correlation times the model is linear in the variances
(Q^2, N^2, B^2, K^2, R^2, sigma_g^2), solved by non-negative least squares on the system
whitened by ``Omega`` (:class:`_Problem`); the correlation times are found by a grid over the
octaves and a Nelder-Mead refinement of ``J``. The covariance of the estimate is
``(D^T Omega D)^-1``, D the Jacobian of the model (:func:`_param_cov`). Choosing among models
is :mod:`._select`'s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize, nnls

from ._covariance import _CovBasis
from ._processes import LINEAR_TERMS, avar_gm, avar_model, avar_term


@dataclass(frozen=True)
class _Spec:
    """A candidate model: the linear terms it holds and its Gauss-Markov correlation times."""

    linear: tuple[str, ...]
    gm: tuple[float, ...] = ()

    def label(self) -> str:
        parts = list(self.linear) + [f"GM({T:.3g} s)" for T in self.gm]
        return " + ".join(parts) if parts else "(none)"

    @property
    def n_params(self) -> int:
        return len(self.linear) + 2 * len(self.gm)


#: A whitened NNLS coefficient below this fraction of the data's norm is a term at its zero
#: bound (rounding of the solve), taken as exactly zero.
NNLS_ZERO = 1e-10


@dataclass(frozen=True)
class _Fit:
    spec: _Spec
    coef: np.ndarray        # linear coefficients squared, then GM variances (SI)
    J: float

    def coefficients(self) -> tuple[dict, list]:
        co = {t: math.sqrt(max(c, 0.0)) for t, c in zip(self.spec.linear, self.coef)}
        gm = [(math.sqrt(max(c, 0.0)), T) for c, T in
              zip(self.coef[len(self.spec.linear):], self.spec.gm)]
        return co, gm


class _Problem:
    """The data of one fit: the estimates, where they are, and the whitening of J."""

    def __init__(self, taus, avar, m, n_segments, fs, model_error):
        self.taus, self.avar, self.m = taus, avar, m
        self.segments = n_segments
        self.fs = fs
        self.model_error = model_error
        self.W = None
        self._bases: dict = {}

    def design(self, spec: _Spec) -> np.ndarray:
        cols = [avar_term(t, self.taus) for t in spec.linear]
        cols += [avar_gm(self.taus, T, self.fs) for T in spec.gm]
        return np.column_stack(cols) if cols else np.zeros((self.taus.size, 0))

    def basis(self, Ts: tuple) -> _CovBasis:
        """The covariance basis of the structure Q, N, B, K + GM(T) for T in ``Ts`` (cached:
        any variances of that structure then cost one contraction)."""
        key = tuple(float(T) for T in Ts)
        if key not in self._bases:
            procs = [(k, None) for k in ("Q", "N", "B", "K")] + [("GM", T) for T in key]
            self._bases[key] = _CovBasis(self.m, self.segments, self.fs, procs)
        return self._bases[key]

    def covariance(self, co: dict, gm) -> np.ndarray:
        """Covariance of the estimates under a model, pooled over the gap-free segments (each
        segment's estimate weighted by its number of terms, as the pooled curve is)."""
        c = [float(co.get(k) or 0.0) ** 2 for k in ("Q", "N", "B", "K")]
        c += [float(sg) ** 2 for sg, _ in gm]
        return self.basis(tuple(T for _, T in gm)).cov(np.array(c),
                                                       float(co.get("R") or 0.0) ** 2)

    def avar_of(self, co: dict, gm) -> np.ndarray:
        """The model's Allan variance at the averaging times, the estimates where it is 0."""
        v = avar_model(self.taus, co, gm, self.fs)
        return np.where(v > 0, v, self.avar)

    def weights(self, co: dict, gm) -> np.ndarray:
        """W with J = |W r|^2 for Omega from the model (co, gm): W = L^-1 D^-1, D the model's
        Allan variance, L L^T = D^-1 Sigma D^-1 + model_error^2 I."""
        v = avar_model(self.taus, co, gm, self.fs)
        v = np.where(v > 0, v, self.avar)
        cov = self.covariance(co, gm)
        rel = cov / np.outer(v, v) + self.model_error**2 * np.eye(v.size)
        L = np.linalg.cholesky(rel)
        return np.linalg.solve(L, np.diag(1.0 / v))

    def set_weights(self, co: dict, gm) -> None:
        self.W = self.weights(co, gm)

    def solve(self, spec: _Spec) -> _Fit:
        """Non-negative least squares of the whitened system for the given spec."""
        A = self.design(spec)
        if A.shape[1] == 0:
            r = self.W @ self.avar
            return _Fit(spec, np.zeros(0), float(r @ r))
        Aw, bw = self.W @ A, self.W @ self.avar
        norm = np.linalg.norm(Aw, axis=0)
        norm[norm == 0] = 1.0
        c, rnorm = nnls(Aw / norm, bw, maxiter=50 * A.shape[1])
        # a coefficient at rounding level of the solve is a term at its zero bound: scipy's
        # nnls (1.15+) returns such terms as ~1e-14 of the data rather than exactly 0
        c[c <= NNLS_ZERO * float(np.linalg.norm(bw))] = 0.0
        return _Fit(spec, c / norm, float(np.sum((bw - (Aw / norm) @ c)**2)))

    # -- Gauss-Markov correlation times -------------------------------------------------------
    def t_bounds(self) -> tuple[float, float]:
        return float(self.taus[0]) / 2.0, float(self.taus[-1]) * 2.0

    def refine(self, spec: _Spec) -> _Fit:
        """The spec's correlation times moved to the minimum of J (Nelder-Mead in log T)."""
        if not spec.gm:
            return self.solve(spec)
        lo, hi = (math.log(b) for b in self.t_bounds())

        def obj(x):
            x = np.clip(x, lo, hi)
            return self.solve(_Spec(spec.linear, tuple(np.exp(x)))).J

        x0 = np.log(np.asarray(spec.gm))
        res = minimize(obj, x0, method="Nelder-Mead",
                       options={"xatol": 1e-3, "fatol": 1e-6, "maxiter": 400 * len(x0)})
        ts = tuple(sorted(np.exp(np.clip(res.x, lo, hi))))
        fit = self.solve(_Spec(spec.linear, ts))
        start = self.solve(spec)
        return fit if fit.J <= start.J else start

    def add_gm(self, spec: _Spec) -> _Fit:
        """The best fit with one more Gauss-Markov term: a grid of correlation times over the
        octaves for the new one, then all refined together."""
        lo, hi = self.t_bounds()
        best = None
        for T in np.geomspace(lo, hi, 33):
            f = self.solve(_Spec(spec.linear, tuple(sorted(spec.gm + (float(T),)))))
            if best is None or f.J < best.J:
                best = f
        return self.refine(best.spec)


def _pilot(pb: _Problem) -> tuple[dict, list]:
    """A first model for the weights: the five linear terms fitted with each point weighted
    by its variance over the model (IEEE Std 952 Annex C.2 error bars, n/m clusters)."""
    n = max(pb.segments)
    rel = np.sqrt(2.0 / np.maximum(n / pb.m - 1.0, 1.0))
    A = np.column_stack([avar_term(t, pb.taus) for t in LINEAR_TERMS])
    scale = pb.avar
    c = np.zeros(len(LINEAR_TERMS))
    for _ in range(4):
        sig = rel * scale
        Aw = A / sig[:, None]
        norm = np.linalg.norm(Aw, axis=0)
        c, _ = nnls(Aw / norm, pb.avar / sig)
        c = c / norm
        model = A @ c
        if not np.all(model > 0):
            break
        scale = model
    return {t: math.sqrt(v) for t, v in zip(LINEAR_TERMS, c)}, []


def _stated(pb: _Problem, linear: tuple, n_gm: int) -> _Fit:
    fit = pb.solve(_Spec(linear))
    for _ in range(n_gm):
        fit = pb.add_gm(fit.spec)
    return fit


def _jacobian(pb: _Problem, fit: _Fit) -> np.ndarray:
    """d model / d (coefficients..., log T of each GM), shape (k, p)."""
    A = pb.design(fit.spec)
    cols = [A]
    n_lin = len(fit.spec.linear)
    for g, T in enumerate(fit.spec.gm):
        s2 = fit.coef[n_lin + g]
        e = 1e-4
        d = (avar_gm(pb.taus, T * math.exp(e), pb.fs) - avar_gm(pb.taus, T * math.exp(-e),
                                                                pb.fs)) / (2 * e)
        cols.append((s2 * d)[:, None])
    return np.column_stack(cols)


def _fisher_inverse(D: np.ndarray) -> np.ndarray:
    """(D^T D)^-1 with the columns scaled to unit norm first (their scales differ by many
    orders of magnitude: a variance's column and a correlation time's)."""
    norm = np.linalg.norm(D, axis=0)
    norm[norm == 0] = 1.0
    Dn = D / norm
    return np.linalg.pinv(Dn.T @ Dn) / np.outer(norm, norm)


def _param_cov(pb: _Problem, fit: _Fit) -> np.ndarray:
    return _fisher_inverse(pb.W @ _jacobian(pb, fit))
