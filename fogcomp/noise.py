"""Composite noise identification: the Allan variance of a record fitted to a sum of processes.

The overlapping Allan variance ``v[j]`` of a record at the octave averaging times
``tau_j = m_j tau0`` is fitted to the variance a sum of independent latent processes implies,
``v(tau; theta) = sum_p v_p(tau; theta_p)``, by minimising the quadratic form

    J(theta) = (v - v(theta))^T  Omega  (v - v(theta)),      Omega = Sigma(theta_pilot)^-1,

with ``Sigma`` the covariance of the estimates ``v`` for Gaussian processes of the model at a
pilot value of ``theta``, computed exactly from the processes' autocovariances (below), not from
an approximation per point. This is the generalized method of wavelet moments (GMWM; Guerrier,
Skaloud, Stebler, Victoria-Feser, JASA 108(502), 776-789, 2013, eq. 4) written for the Allan
variance: the Haar wavelet variance at scale tau is half the Allan variance,
``nu_Haar^2(tau) = AVAR(tau) / 2`` (Percival & Guttorp, "Long-memory processes, the Allan
variance and wavelets", 1994; Percival & Walden, *Wavelet Methods for Time Series Analysis*,
2000, eq. 322b), so the two fits are the same up to a factor that cancels in ``J``.

Processes and their Allan variance (``tau = m tau0``, ``tau0 = 1/fs``)
-----------------------------------------------------------------------
=====  ==========================  ==========================  =====================================
term   process                     coefficient (SI)            AVAR(tau)
=====  ==========================  ==========================  =====================================
Q      quantisation (white angle)  Q, rad (rms angle error)    3 Q^2 / tau^2
N      white rate (ARW)            N, rad/sqrt(s)              N^2 / tau
B      flicker rate (bias instab.) B, rad/s                    (2 ln 2 / pi) B^2
K      rate random walk            K, rad/s/sqrt(s)            K^2 tau / 3
R      rate ramp                   R, rad/s^2                  R^2 tau^2 / 2
GM     first-order Gauss-Markov    sigma rad/s, T s            see below
=====  ==========================  ==========================  =====================================

Q, N, B, K, R: IEEE Std 952-1997 Annex C, Table C.1 (B the flicker coefficient: its Allan floor
is ``sqrt(2 ln 2 / pi) B = 0.664 B`` for tau well above the inverse of the flicker band's upper
corner; an angle quantum q gives ``Q = q / sqrt(12)``). GM: a stationary first-order
Gauss-Markov (AR(1)) rate sampled at fs, ``x[k+1] = phi x[k] + w[k]``, ``phi = exp(-tau0 / T)``,
variance ``sigma^2``: its autocovariance is ``sigma^2 phi^|h|``, and the Allan variance of m-sample
means follows exactly (Zhang, "Allan variance of time series models for measurement data",
Metrologia 45, 549-561, 2008, section 3 for AR(1))::

    AVAR(m) = sigma^2 / (m^2 (1 - phi)^2) * [ m (1 - phi^2) - phi (1 - phi^m) (3 - phi^m) ]

which tends to IEEE 952's correlated-noise term ``(q_c T)^2/tau [1 - T/(2 tau)(3 - 4 e^(-tau/T) +
e^(-2 tau/T))]`` with ``q_c^2 = 2 sigma^2 / T`` as fs grows, to ``2 sigma^2 T / tau`` (white) for
tau >> T and to ``2 sigma^2 tau / (3 T)`` (a random walk's slope, K^2 = 2 sigma^2 / T) for tau << T.

The covariance of the estimates
-------------------------------
With the integrated angle ``x`` and ``d_k(m) = x[k+2m] - 2 x[k+m] + x[k]`` (``c = (1, -2, 1)``),
the overlapping estimator is ``v(m) = sum_k d_k(m)^2 / (2 tau^2 M)``, ``M = n + 1 - 2m``. For
Gaussian d, ``Cov(d^2, d'^2) = 2 Cov(d, d')^2``, so

    Cov(v_i, v_j) = [2 sum_h N_ij(h) f_ij(h)^2 + 4 delta_i delta_j sum_h N_ij(h) f_ij(h)]
                    / (4 tau_i^2 tau_j^2 M_i M_j),

    f_ij(h) = sum_{a, b = 0..2} c_a c_b G((h + a m_i - b m_j) tau0),

``N_ij(h)`` the number of pairs (k, l) with k - l = h, ``delta = R tau^2`` the ramp's second
difference, and ``G`` the generalised autocovariance of the angle (second differences annihilate
polynomials of degree 3, so ``G`` is needed only up to those): ``-N^2 |t| / 2`` (white rate),
``K^2 |t|^3 / 12`` (random walk), ``B^2 t^2 ln|t| / (2 pi)`` (flicker), ``Q^2 [t = 0]``
(quantisation) and ``-sigma^2 tau0^2 S(|t|/tau0) / 2`` with
``S(j) = (j (1 - phi^2) - 2 phi (1 - phi^j)) / (1 - phi)^2`` (Gauss-Markov; ``tau0^2 sigma^2 S(j)``
is the variance of the sum of j samples). The same ``G`` gives the expected variance,
``E[d^2] = 6 G(0) - 8 G(tau) + 2 G(2 tau)`` (a test checks it against the table). The sum over h
is exact (term by term) for short averaging times and a Gauss-Legendre quadrature between the
kinks of ``f`` and ``N`` for long ones.

Estimation, selection and intervals
-----------------------------------
For given Gauss-Markov correlation times the model is linear in the variances
(Q^2, N^2, B^2, K^2, R^2, sigma_g^2), solved by non-negative least squares on the whitened system;
the correlation times are found by a grid over the octaves and a Nelder-Mead refinement of
``J``. ``Omega`` is computed at a pilot fit and then once more at the estimate (two steps, as
GMWM's two-step estimator). Model selection is by the distance-difference test of the method of
moments (Newey & West, "Hypothesis testing with efficient method of moments estimation",
Int. Econ. Rev. 28(3), 777-787, 1987): with ``Omega`` the inverse covariance, the increase of J
when q parameters are removed is asymptotically chi-squared with q degrees of freedom; a term
is kept only when removing it raises J by more than the 1 - ``alpha`` quantile (``alpha`` = 1 %
by default), and a further Gauss-Markov term is added only when it lowers J by as much. The
intervals come from the covariance ``(D^T Omega D)^-1`` of the estimate (D the Jacobian of the
model), scaled by ``J / dof`` when the fit is significantly worse than its error bars say (a real
curve departing from the model); a variance coefficient's normal interval is taken to the square
root, a correlation time's is normal in log T.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize, nnls

from ._stats import ONE_SIGMA_CI
from .units import ARCSEC, DEG_RT_H, DPH, DPH_PER_H, DPH_RT_H

__all__ = ["LINEAR_TERMS", "TERM_NAMES", "avar_term", "avar_gm", "avar_model", "avar_covariance",
           "ModelTerm", "NoiseModel", "identify_noise_model", "parse_model"]

#: The terms whose Allan variance is linear in one coefficient squared (IEEE Std 952).
LINEAR_TERMS = ("Q", "N", "B", "K", "R")
TERM_NAMES = {"Q": "quantisation", "N": "angle random walk", "B": "bias instability",
              "K": "rate random walk", "R": "rate ramp", "GM": "Gauss-Markov"}
FLICKER_FLOOR = 2.0 * math.log(2.0) / math.pi          # AVAR of flicker B = 1: (2 ln 2/pi)
# datasheet unit (SI per unit) and key of each term's coefficient
DATASHEET = {"N": (DEG_RT_H, "arw_deg_rt_h"), "B": (DPH, "bias_instability_dph"),
             "K": (DPH_RT_H, "rrw_dph_rt_h"), "Q": (ARCSEC, "quantisation_arcsec"),
             "R": (DPH_PER_H, "rate_ramp_dph_per_h"), "GM": (DPH, "gm_sigma_dph")}
_C = (1.0, -2.0, 1.0)
_EXACT_MAX = 4096           # lags summed term by term below this many
_KINK_WINDOW = 32           # lags summed term by term on each side of a kink of f
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)


# ---------------------------------------------------------------------------------------------
# The Allan variance of each process
def avar_term(term: str, taus) -> np.ndarray:
    """Allan variance of a linear term with unit coefficient at ``taus`` (s), shape (k,)."""
    t = np.asarray(taus, dtype=float)
    if term == "Q":
        return 3.0 / t**2
    if term == "N":
        return 1.0 / t
    if term == "B":
        return np.full_like(t, FLICKER_FLOOR)
    if term == "K":
        return t / 3.0
    if term == "R":
        return t**2 / 2.0
    raise ValueError(f"term: unknown term {term!r}; expected one of {LINEAR_TERMS}")


_GM_SERIES_TERMS = 30


@functools.lru_cache(maxsize=None)
def _bernoulli(k_max: int) -> tuple:
    """Bernoulli numbers B_0..B_k_max as Fractions, with B_1 = +1/2 (so that Faulhaber's
    formula gives sum_{u=1}^{n} u^k)."""
    from fractions import Fraction

    b = [Fraction(0)] * (k_max + 1)
    b[0] = Fraction(1)
    for k in range(1, k_max + 1):
        b[k] = -sum(math.comb(k + 1, j) * b[j] for j in range(k)) / (k + 1)
    b[1] = Fraction(1, 2)
    return tuple(b)


def _power_sum(k: int, n: int) -> int:
    """sum_{u=1}^{n} u^k, exactly (Faulhaber's formula in rationals)."""
    if n <= 0:
        return 0
    b = _bernoulli(k + 1)
    total = sum(math.comb(k + 1, j) * b[j] * n ** (k + 1 - j) for j in range(k + 1))
    return int(total / (k + 1))


@functools.lru_cache(maxsize=4096)
def _gm_series(m: int) -> np.ndarray:
    """e_k(m), k = 1.., of AVAR(m) = sum_k e_k(m) (m x)^k for a unit AR(1) with phi = e^-x:
    AVAR(m) = (1/m^2) [S(m) - T(m)] with S(m) = sum_{|u|<m} (m-|u|) phi^|u| and
    T(m) = sum_{t=1}^{2m-1} (m - |t-m|) phi^t, each phi^t expanded in powers of x; the sums
    of powers are exact integers (Faulhaber), so nothing cancels in floating point."""
    out = np.empty(_GM_SERIES_TERMS)
    p = {}

    def ps(k, n):
        if (k, n) not in p:
            p[(k, n)] = _power_sum(k, n)
        return p[(k, n)]

    for k in range(1, _GM_SERIES_TERMS + 1):
        a_k = 2 * (m * ps(k, m - 1) - ps(k + 1, m - 1))
        c_k = (ps(k + 1, m) + 2 * m * (ps(k, 2 * m - 1) - ps(k, m))
               - (ps(k + 1, 2 * m - 1) - ps(k + 1, m)))
        d_k = a_k - c_k
        out[k - 1] = (-1) ** k * (d_k / (m ** (k + 2) * math.factorial(k)))
    return out


def avar_gm(taus, T: float, fs: float) -> np.ndarray:
    """Allan variance of a unit-variance first-order Gauss-Markov rate of correlation time
    ``T`` (s) sampled at ``fs`` (Hz), at ``taus`` (whole multiples of 1/fs), shape (k,).

    The closed form (module docstring) where ``m tau0 / T >= 1``; below, where it cancels
    catastrophically (``1 - phi^2`` of a T of many samples has lost all its digits), its Taylor
    series in ``x = tau0 / T`` with exact integer coefficients (:func:`_gm_series`)."""
    m_all = np.rint(np.asarray(taus, dtype=float) * fs).astype(np.int64)
    x = 1.0 / (fs * T)
    out = np.empty(m_all.shape, dtype=float)
    big = m_all * x >= 1.0
    if big.any():
        m = m_all[big].astype(float)
        phi = math.exp(-x)
        om = -math.expm1(-x)
        pm = np.exp(-m * x)
        out[big] = (m * om * (1.0 + phi) - phi * (1.0 - pm) * (3.0 - pm)) / (m * m * om * om)
    for i in np.flatnonzero(~big):
        m = int(m_all.flat[i])
        a = m * x
        out.flat[i] = float(np.polyval(np.concatenate([_gm_series(m)[::-1], [0.0]]), a))
    return out


def avar_model(taus, coefficients: dict, gm=(), fs: float | None = None) -> np.ndarray:
    """Allan variance of a sum of processes at ``taus`` (s).

    Parameters
    ----------
    taus : array_like, shape (k,)
        Averaging times, s.
    coefficients : dict
        ``{"Q": rad, "N": rad/sqrt(s), "B": rad/s, "K": rad/s/sqrt(s), "R": rad/s^2}``; missing
        or None terms count as zero.
    gm : sequence of (sigma, T)
        Gauss-Markov terms: standard deviation rad/s, correlation time s (needs ``fs``).
    fs : float, optional
        Sample rate, Hz (for the Gauss-Markov terms).
    """
    t = np.asarray(taus, dtype=float)
    out = np.zeros_like(t)
    for term in LINEAR_TERMS:
        c = coefficients.get(term)
        if c:
            out = out + avar_term(term, t) * float(c) ** 2
    for sigma, T in gm:
        if fs is None:
            raise ValueError("fs: the Gauss-Markov terms need the sample rate")
        out = out + avar_gm(t, T, fs) * sigma**2
    return out


# ---------------------------------------------------------------------------------------------
# The covariance of the overlapping estimates
def _g_unit(kind: str, T: float | None, a: np.ndarray, tau0: float) -> np.ndarray:
    """Generalised autocovariance of the angle of a unit-coefficient process at lags ``a``
    (samples, |real|), rad^2 per unit of the coefficient (module docstring). The quantisation
    (a Kronecker delta) is summed apart."""
    if kind == "N":
        return -0.5 * tau0 * a
    if kind == "K":
        return tau0**3 * a**3 / 12.0
    if kind == "B":
        with np.errstate(divide="ignore", invalid="ignore"):
            lg = np.where(a > 0, a * a * np.log(np.where(a > 0, a, 1.0)), 0.0)
        return tau0**2 * lg / (2.0 * math.pi)
    if kind == "GM":
        # S(j) = (j (1 - phi^2) - 2 phi (1 - phi^j)) / (1 - phi)^2, written as
        # (2 w - j u^2 + 2 u v) / u^2 with u = 1 - phi, v = 1 - phi^j, w = j u - v (each
        # well conditioned; see avar_gm)
        x = tau0 / T
        u = -math.expm1(-x)
        v = -np.expm1(-x * a)
        w = a * u - v
        s = (2.0 * w - a * u * u + 2.0 * u * v) / (u * u)
        return -0.5 * tau0**2 * s
    raise ValueError(kind)  # pragma: no cover


def _f_unit(kind, T, h, mi, mj, tau0):
    """f_ij(h) of one unit process (module docstring), shape of h: the sum over a, b in 0..2
    of C_a C_b g(|h + a mi - b mj|), g at the nine shifts in one call (this is the inner loop
    of the covariance basis) and summed in the order of that double loop, so that the result
    is the loop's to the last bit (tests/test_noise.py keeps the loop as the twin)."""
    h = np.asarray(h, dtype=float)
    ab = [(a, b) for a in range(3) for b in range(3)]
    col = (9,) + (1,) * h.ndim
    # (h + a mi) - b mj, as the loop computed it (the quadrature's lags are not integers)
    arg = (h[None, ...] + np.array([a * mi for a, _ in ab], dtype=float).reshape(col)) \
        - np.array([b * mj for _, b in ab], dtype=float).reshape(col)
    g = (arg == 0) if kind == "Q" else _g_unit(kind, T, np.abs(arg), tau0)
    out = np.zeros_like(h, dtype=float)
    for k, (a, b) in enumerate(ab):
        out += _C[a] * _C[b] * g[k]
    return out


def _pairs_count(h, mi_terms: int, mj_terms: int):
    """N(h): pairs (k, l), 0 <= k < Mi, 0 <= l < Mj, with k - l = h."""
    return np.maximum(0.0, np.minimum(mi_terms, mj_terms + h) - np.maximum(0.0, h))


def _geometric_pieces(a: float, b: float, towards: str) -> list[tuple[float, float]]:
    """[a, b] cut into pieces of lengths 1, 1, 2, 4, ... growing away from ``towards`` ("a",
    "b" or "both" ends): fine where the integrand varies fast, coarse where it is smooth."""
    length = b - a
    if length <= 8:
        return [(a, b)]
    cuts, d = [0.0], 1.0
    limit = length / 2 if towards == "both" else length
    while d < limit:
        cuts.append(d)
        d *= 2.0
    cuts = np.array(cuts)
    if towards == "a":
        grid = np.concatenate([a + cuts, [b]])
    elif towards == "b":
        grid = np.concatenate([[a], b - cuts[::-1]])
    else:
        grid = np.concatenate([a + cuts, [a + length / 2], b - cuts[::-1]])
    grid = np.unique(grid)
    return list(zip(grid[:-1], grid[1:]))


def _gl_nodes(pieces) -> tuple[np.ndarray, np.ndarray]:
    seg = np.asarray(pieces, dtype=float)
    half = (seg[:, 1] - seg[:, 0]) / 2.0
    mid = (seg[:, 1] + seg[:, 0]) / 2.0
    return ((mid[:, None] + half[:, None] * _GL_X[None, :]).ravel(),
            (half[:, None] * _GL_W[None, :]).ravel())


def _pair_sums(procs, mi: int, mj: int, n: int, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """(S2[p, q] = sum_h N f_p f_q, S1[p] = sum_h N f_p) of the unit processes ``procs``
    (``[(kind, T), ...]``) for the averaging factors mi, mj of an n-sample record: over the
    core of f (lags within 2 m of each other: every term's support) term by term when it is
    short, else by quadrature between its kinks; over the tails beyond it (flicker and
    Gauss-Markov terms only, where f is smooth) by quadrature on pieces growing away from it.
    A sum over integers is taken as the integral over [h - 1/2, h + 1/2] of each."""
    tau0 = 1.0 / fs
    P = len(procs)
    S2, S1 = np.zeros((P, P)), np.zeros(P)
    Mi, Mj = n + 1 - 2 * mi, n + 1 - 2 * mj
    h_lo, h_hi = -(Mj - 1), Mi - 1
    c_lo, c_hi = max(h_lo, -2 * mi - 2), min(h_hi, 2 * mj + 2)
    if c_hi < c_lo:
        return S2, S1
    cont = [k for k, (kind, _) in enumerate(procs) if kind != "Q"]
    quant = [k for k, (kind, _) in enumerate(procs) if kind == "Q"]

    def add(h, w, which):
        F = np.array([_f_unit(*procs[k], h, mi, mj, tau0) for k in which])
        S2[np.ix_(which, which)] += (F * w) @ F.T
        S1[which] += F @ w

    if c_hi - c_lo + 1 <= _EXACT_MAX:
        h = np.arange(c_lo, c_hi + 1, dtype=float)
        add(h, _pairs_count(h, Mi, Mj), list(range(P)))
    else:
        # every lag summed near each kink of f (where a Gauss-Markov term's exponential and
        # the |t| of the white and random-walk terms bend), a quadrature between
        kinks = sorted(k for k in ({b * mj - a * mi for a in range(3) for b in range(3)}
                                   | {0, Mi - Mj}) if c_lo <= k <= c_hi)
        windows = []
        for k in kinks:
            a, b = max(c_lo, k - _KINK_WINDOW), min(c_hi, k + _KINK_WINDOW)
            if windows and a <= windows[-1][1] + 1:
                windows[-1][1] = max(windows[-1][1], b)
            else:
                windows.append([a, b])
        exact = np.concatenate([np.arange(a, b + 1, dtype=float) for a, b in windows])
        if cont:
            add(exact, _pairs_count(exact, Mi, Mj), cont)
        pieces = []
        gaps = [(c_lo - 0.5, windows[0][0] - 0.5)] if windows[0][0] > c_lo else []
        gaps += [(w0[1] + 0.5, w1[0] - 0.5) for w0, w1 in zip(windows[:-1], windows[1:])]
        if windows[-1][1] < c_hi:
            gaps.append((windows[-1][1] + 0.5, c_hi + 0.5))
        for a, b in gaps:
            if b > a:
                pieces += _geometric_pieces(a, b, "both")
        if pieces and cont:
            h, wq = _gl_nodes(pieces)
            add(h, _pairs_count(h, Mi, Mj) * wq, cont)
        if quant:  # the delta sits at the integer kinks: its products with every process there
            hk = np.array(sorted(k for k in {b * mj - a * mi for a in range(3)
                                              for b in range(3)} if c_lo <= k <= c_hi),
                          dtype=float)
            nk = _pairs_count(hk, Mi, Mj)
            F = np.array([_f_unit(*procs[k], hk, mi, mj, tau0) for k in range(P)])
            for q in quant:
                for k in range(P):
                    v = float(np.sum(nk * F[q] * F[k]))
                    S2[q, k] += v
                    if k != q:
                        S2[k, q] += v
                S1[q] += float(np.sum(nk * F[q]))
    tail = 0.0
    for kind, T in procs:
        if kind == "B":
            tail = max(tail, 50.0 * (mi + mj))
        elif kind == "GM":
            tail = max(tail, 30.0 * T * fs)
    smooth = [k for k in cont if procs[k][0] in ("B", "GM")]
    if tail > 0 and smooth:
        left = (max(h_lo - 0.5, c_lo - 0.5 - tail), c_lo - 0.5)
        right = (c_hi + 0.5, min(h_hi + 0.5, c_hi + 0.5 + tail))
        pieces = []
        if left[1] > left[0]:
            pieces += _geometric_pieces(*left, towards="b")
        if right[1] > right[0]:
            pieces += _geometric_pieces(*right, towards="a")
        if pieces:
            h, wq = _gl_nodes(pieces)  # only the tailed processes are non-zero here
            add(h, _pairs_count(h, Mi, Mj) * wq, smooth)
    return S2, S1


class _CovBasis:
    """The covariance of the estimates as a quadratic form in the processes' variances.

    ``Sigma = [2 sum_pq c_p c_q S2_pq / (4 tau_i^2 tau_j^2) + c_R sum_p c_p S1_p] / (W_i W_j)``,
    with ``c`` the coefficients squared of the unit processes ``procs`` (``[(kind, T), ...]``:
    Q, N, B, K and the Gauss-Markov terms, whose correlation times are fixed here), ``c_R`` the
    ramp's R^2 and ``W_i`` the number of terms at tau_i over the pooled segments: any model of
    this structure in one contraction, without summing over lags again."""

    def __init__(self, m, segments, fs: float, procs):
        self.m = np.asarray(m, dtype=np.int64)
        self.fs = float(fs)
        self.procs = list(procs)
        k, P = self.m.size, len(self.procs)
        self.S2 = np.zeros((P, P, k, k))
        self.S1 = np.zeros((P, k, k))
        self.W = np.zeros(k)
        for n in segments:
            ok = np.flatnonzero(self.m <= (n - 1) // 2)
            self.W[ok] += n + 1 - 2 * self.m[ok]
            for a, i in enumerate(ok):
                for j in ok[a:]:
                    s2, s1 = _pair_sums(self.procs, int(self.m[i]), int(self.m[j]), n, fs)
                    self.S2[:, :, i, j] += s2
                    self.S1[:, i, j] += s1
                    if i != j:
                        self.S2[:, :, j, i] += s2
                        self.S1[:, j, i] += s1
        tau = self.m / self.fs
        self._norm2 = 1.0 / (4.0 * np.outer(tau**2, tau**2))
        self._norm = 1.0 / np.outer(self.W, self.W)

    def cov(self, c: np.ndarray, c_ramp: float = 0.0) -> np.ndarray:
        c = np.asarray(c, dtype=float)
        out = 2.0 * np.einsum("p,q,pqij->ij", c, c, self.S2) * self._norm2
        if c_ramp:
            out = out + c_ramp * np.einsum("p,pij->ij", c, self.S1)
        return out * self._norm


def _procs_of(coefficients: dict, gm) -> tuple[list, np.ndarray, float]:
    """The unit processes of a model, their variances, and the ramp's R^2."""
    procs, c = [], []
    for kind in ("Q", "N", "B", "K"):
        v = float(coefficients.get(kind) or 0.0)
        if v:
            procs.append((kind, None))
            c.append(v * v)
    for sigma, T in gm:
        procs.append(("GM", float(T)))
        c.append(float(sigma) ** 2)
    return procs, np.asarray(c), float(coefficients.get("R") or 0.0) ** 2


def avar_covariance(m, n: int, fs: float, coefficients: dict, gm=()) -> np.ndarray:
    """Covariance of the overlapping Allan variance estimates of an n-sample record at the
    averaging factors ``m``, for Gaussian processes of the given model (module docstring).

    Parameters
    ----------
    m : array_like of int, shape (k,)
        Averaging factors (tau = m / fs), each at most (n - 1) // 2.
    n : int
        Number of rate samples.
    fs : float
        Sample rate, Hz.
    coefficients : dict
        ``{"Q", "N", "B", "K", "R"}`` coefficients, SI (as :func:`avar_model`).
    gm : sequence of (sigma, T)
        Gauss-Markov terms, rad/s and s.

    Returns
    -------
    ndarray, shape (k, k)
        Covariance of the Allan variance estimates, rad^4/s^4.
    """
    procs, c, c_ramp = _procs_of(coefficients, gm)
    return _CovBasis(m, (int(n),), fs, procs).cov(c, c_ramp)


# ---------------------------------------------------------------------------------------------
# The fit
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
    weak = {}
    for t in cur.spec.linear:
        if len(cur.spec.linear) + len(cur.spec.gm) == 1:
            break
        rise = pb.refine(_drop(cur.spec, t)).J - cur.J
        if rise < _threshold(1, alpha):
            weak[t] = (rise, _threshold(1, alpha))
            log.append(f"{t} not significant: removing it raises J by only {rise:.3g} "
                       f"(< {_threshold(1, alpha):.3g}); kept in the model for the others' "
                       "sake, reported as an upper bound")
    return cur, weak


# ---------------------------------------------------------------------------------------------
# The result
@dataclass(frozen=True)
class ModelTerm:
    """One term of an identified noise model.

    Attributes
    ----------
    term : str
        ``"Q"``, ``"N"``, ``"B"``, ``"K"``, ``"R"`` or ``"GM"``.
    status : str
        ``"identified"`` (significant at the selection's level), ``"upper bound"`` (not
        significant: ``bound`` is its one-sided 95 % upper bound; when the term is still in the
        model, ``value`` and its interval are the estimate) or ``"not identified"``.
    value : float or None
        The coefficient, SI (GM: its standard deviation, rad/s); None for a term outside the
        model.
    low, high : float or None
        The interval of probability content ``ci`` (the model's), SI.
    sigma : float or None
        One-sigma uncertainty of ``value`` (linearised, symmetric: for display), SI.
    tau : float or None
        GM: the correlation time, s (``tau_low``, ``tau_high``: its interval).
    reason : str
        Why it is (not) in the model, in words.
    record_s_for_10pct : float or None
        For a term known to worse than 10 % (one sigma): the record length, s, that would give
        10 %, predicted from this model's covariance at longer records (same sample rate).
    bound : float or None
        One-sided 95 % upper bound of the coefficient, SI (None: the record does not bound it).
    in_model : bool
        Whether the term is part of the fitted model (the curve and the others' estimates).
    """

    term: str
    status: str
    value: float | None
    low: float | None
    high: float | None
    sigma: float | None
    reason: str
    tau: float | None = None
    tau_low: float | None = None
    tau_high: float | None = None
    record_s_for_10pct: float | None = None
    bound: float | None = None
    in_model: bool = False

    @property
    def name(self) -> str:
        return TERM_NAMES[self.term]

    @property
    def label(self) -> str:
        return f"GM({self.tau:.3g} s)" if self.term == "GM" else self.term

    def to_datasheet(self) -> dict:
        """This term in datasheet units, the unit in every key (``arw_deg_rt_h``, its
        ``_low``, ``_high``, ``_sigma``; GM: ``gm_sigma_dph`` and ``gm_tau_s``)."""
        unit, key = DATASHEET[self.term]

        def ds(v):
            return None if v is None else float(v / unit)

        out = {"term": self.term, "status": self.status, key: ds(self.value),
               f"{key}_low": ds(self.low), f"{key}_high": ds(self.high),
               f"{key}_sigma": ds(self.sigma), f"{key}_bound95": ds(self.bound),
               "in_model": self.in_model, "reason": self.reason}
        if self.term == "GM":
            out.update(gm_tau_s=self.tau, gm_tau_low_s=self.tau_low, gm_tau_high_s=self.tau_high)
        if self.record_s_for_10pct is not None:
            out["record_s_for_10pct"] = float(self.record_s_for_10pct)
        return out


@dataclass(frozen=True)
class NoiseModel:
    """The identified noise model of a record (:func:`identify_noise_model`).

    Attributes
    ----------
    terms : list of ModelTerm
        The five IEEE Std 952 terms (``Q, N, B, K, R``, each identified, an upper bound or not
        identified) followed by the identified Gauss-Markov terms, by correlation time.
    taus, avar : ndarray, shape (k,)
        The averaging times (s) and the Allan variance estimates fitted (rad^2/s^2).
    avar_cov : ndarray, shape (k, k)
        Their covariance under the identified model (rad^4/s^4).
    fs : float
        Sample rate, Hz.
    n : tuple of int
        Samples of each gap-free segment the estimates pool.
    ci : float
        Probability content of the intervals.
    J, dof, p_value : float, int, float
        The fit's quadratic form, its degrees of freedom and the chi-squared probability of a
        value as large; a small ``p_value`` says the curve departs from the model more than its
        uncertainty allows (the intervals are then scaled by ``scale``).
    scale : float
        Factor applied to the parameter covariance (``J / dof`` when ``p_value`` < 0.05, else 1).
    model_error : float
        The relative error per point added to the statistical one: the default, or, when the
        curve departs from the model beyond its error bars (``p`` < 0.01), the value that
        brings J to its degrees of freedom (the selection is then made again with it).
    floor_reading : dict
        The IEEE Std 952 datasheet reading of the bias instability beside the fit: the minimum
        of the Allan deviation over its points known to 25 % or better, divided by 0.664
        (``value`` rad/s, ``sigma``, ``tau_s``, ``reason``). It is biased high where white noise
        or a random walk still adds to the curve at its minimum, and is no estimate of the
        flicker coefficient; the fit's ``B`` is.
    selection : list of str
        The steps of the model selection.
    stated : bool
        True when the model was stated (``model=``) rather than selected.
    """

    terms: list
    taus: np.ndarray
    avar: np.ndarray
    avar_cov: np.ndarray
    fs: float
    n: tuple
    ci: float
    J: float
    dof: int
    p_value: float
    scale: float
    floor_reading: dict
    selection: list = field(default_factory=list)
    stated: bool = False
    alpha: float = 0.01
    model_error: float = 0.001

    def term(self, name: str) -> ModelTerm:
        """The term ``"Q"``, ``"N"``, ``"B"``, ``"K"``, ``"R"`` (GM terms: :attr:`gm_terms`)."""
        return next(t for t in self.terms if t.term == name)

    @property
    def gm_terms(self) -> list:
        return [t for t in self.terms if t.term == "GM"]

    @property
    def identified(self) -> list:
        return [t for t in self.terms if t.status == "identified"]

    @property
    def in_model(self) -> list:
        """The terms of the fitted model (identified, and weak ones kept for the others)."""
        return [t for t in self.terms if t.in_model]

    def coefficients(self) -> tuple[dict, list]:
        """The fitted model: ``({term: SI coefficient}, [(sigma, T), ...])``."""
        co = {t.term: t.value for t in self.in_model if t.term != "GM"}
        gm = [(t.value, t.tau) for t in self.in_model if t.term == "GM"]
        return co, gm

    def model_avar(self, taus) -> np.ndarray:
        co, gm = self.coefficients()
        return avar_model(taus, co, gm, self.fs)

    def model_adev(self, taus) -> np.ndarray:
        """The identified model's Allan deviation at ``taus`` (s), rad/s."""
        return np.sqrt(self.model_avar(taus))

    def contributions(self, taus) -> dict:
        """Each fitted term's Allan deviation at ``taus``: ``{label: ndarray}``, rad/s."""
        out = {}
        for t in self.in_model:
            if t.term == "GM":
                out[t.label] = np.sqrt(avar_gm(taus, t.tau, self.fs)) * t.value
            else:
                out[t.label] = np.sqrt(avar_term(t.term, taus)) * t.value
        return out

    def spec(self) -> str:
        """The identified terms as a ``model=`` string (``"N + B + K + GM"``)."""
        return " + ".join(t.term for t in self.identified) or "(none)"

    def filter_parameters(self, fs: float | None = None) -> list[dict]:
        """Each identified term as a filter designer needs it: the continuous-time spectral
        density and its discrete-time form at ``fs`` (default: the record's).

        White rate N: noise density ``N`` rad/s/sqrt(Hz) (Kalibr's ``gyroscope_noise_density``);
        discrete rate noise ``N sqrt(fs)`` rad/s per sample. Rate random walk K: ``K``
        rad/s^2/sqrt(Hz) (Kalibr's ``gyroscope_random_walk``); discrete bias step ``K /
        sqrt(fs)`` rad/s per sample. Gauss-Markov (sigma, T): ``x' = -x/T + w``, w of spectral
        density ``sigma sqrt(2/T)`` rad/s/sqrt(s); discrete ``phi = exp(-1/(fs T))``, driving
        noise ``sigma sqrt(1 - phi^2)``. Quantisation Q: white angle noise of std Q rad per
        sample. Flicker B has no finite-state model (an approximation by Gauss-Markov terms is
        a choice of the filter's designer); rate ramp R: a deterministic drift, rad/s^2.
        """
        fs = self.fs if fs is None else float(fs)
        out = []
        for t in self.identified:
            v = t.value
            if t.term == "N":
                out.append({"term": "N", "continuous": {"noise_density_rad_s_rt_hz": v},
                            "discrete": {"rate_sigma_rad_s": v * math.sqrt(fs)}})
            elif t.term == "K":
                out.append({"term": "K", "continuous": {"random_walk_rad_s2_rt_hz": v},
                            "discrete": {"bias_step_sigma_rad_s": v / math.sqrt(fs)}})
            elif t.term == "GM":
                phi = math.exp(-1.0 / (fs * t.tau))
                out.append({"term": "GM", "continuous": {
                    "sigma_rad_s": v, "tau_s": t.tau,
                    "driving_density_rad_s_rt_s": v * math.sqrt(2.0 / t.tau)},
                    "discrete": {"phi": phi, "driving_sigma_rad_s": v * math.sqrt(1 - phi**2)}})
            elif t.term == "Q":
                out.append({"term": "Q", "continuous": {"angle_noise_rad": v},
                            "discrete": {"angle_sigma_rad": v}})
            elif t.term == "B":
                out.append({"term": "B", "continuous": {"flicker_coefficient_rad_s": v},
                            "discrete": None})
            elif t.term == "R":
                out.append({"term": "R", "continuous": {"ramp_rad_s2": v}, "discrete": None})
        return out

    def to_datasheet(self) -> dict:
        """The whole model in datasheet units: ``terms`` (:meth:`ModelTerm.to_datasheet` each),
        ``floor_reading`` (deg/h), the fit's ``J``, ``dof``, ``p_value``, ``scale`` and the
        ``selection`` steps."""
        fr = self.floor_reading
        return {
            "model": self.spec(), "stated": self.stated, "ci": self.ci,
            "terms": [t.to_datasheet() for t in self.terms],
            "floor_reading": {
                "bias_instability_dph": None if fr.get("value") is None else fr["value"] / DPH,
                "bias_instability_sigma_dph": None if fr.get("sigma") is None
                else fr["sigma"] / DPH,
                "tau_s": fr.get("tau_s"), "convention": "IEEE Std 952 datasheet reading: the "
                "Allan deviation's minimum / 0.664", "reason": fr.get("reason")},
            "fit": {"J": self.J, "dof": self.dof, "p_value": self.p_value, "scale": self.scale,
                    "alpha": self.alpha, "model_error": self.model_error},
            "selection": list(self.selection),
        }

    def datasheet_values(self) -> dict:
        """The flat ``{key: value}`` of the identified IEEE terms in datasheet units (None where
        not identified): ``arw_deg_rt_h``, ``bias_instability_dph``, ``rrw_dph_rt_h``,
        ``quantisation_arcsec``, ``rate_ramp_dph_per_h`` (what the bench's metrics hold)."""
        out = {}
        for term in ("N", "B", "K", "Q", "R"):
            t = self.term(term)
            unit, key = DATASHEET[term]
            out[key] = None if t.status != "identified" else float(t.value / unit)
        return out


def parse_model(model) -> tuple[tuple[str, ...], int]:
    """A stated model: ``"N + B + K"``, ``"N+GM+GM"`` or a list of term names -> (linear
    terms, number of Gauss-Markov terms)."""
    if isinstance(model, str):
        parts = [p.strip() for p in model.replace(",", "+").split("+") if p.strip()]
    elif isinstance(model, (list, tuple)):
        parts = [str(p).strip() for p in model]
    else:
        raise ValueError(f"model: expected terms like 'N + B + K + GM', got {model!r}")
    if not parts:
        raise ValueError("model: name at least one term (Q, N, B, K, R, GM)")
    linear, n_gm = [], 0
    for p in parts:
        u = p.upper()
        if u == "GM":
            n_gm += 1
        elif u in LINEAR_TERMS:
            if u in linear:
                raise ValueError(f"model: term {u!r} named twice")
            linear.append(u)
        else:
            raise ValueError(f"model: unknown term {p!r}; expected Q, N, B, K, R or GM")
    if n_gm > 5:
        raise ValueError(f"model: at most 5 Gauss-Markov terms, got {n_gm}")
    return tuple(t for t in LINEAR_TERMS if t in linear), n_gm


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
                    lower: bool = True) -> tuple[float, float | None]:
    """{c >= 0 : |c_hat - c| <= z sigma(c)} for coefficient k, sigma(c) the estimate's spread
    were c the truth (:func:`_sigma_at`). The spread of a variance estimate grows with the
    variance itself, so a Wald interval (sigma at the estimate) is too short below a low
    estimate and too long above a high one; inverting at each hypothesised value, as a score
    test does, is not (measured: the 68 % interval of a 24 h record's rate random walk covers
    in 50 % of records as Wald). Returns (low, high); high None when the interval has no upper
    end (the record cannot bound the term from above at this level)."""
    c = float(fit.coef[k])

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


def identify_noise_model(taus, avar, fs: float, n, *, model=None, ci: float | None = None,
                         alpha: float = 0.01, max_gm: int = 3, model_error: float = 0.001,
                         record_length: bool = True) -> NoiseModel:
    """Identify the noise model of a record from its overlapping Allan variance.

    The estimator, the model selection and the intervals are described in the module
    docstring; :func:`fogcomp.allan.allan_analysis` computes the curve of a record and calls
    this.

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
        Most Gauss-Markov terms tried (default 3).
    model_error : float, optional
        Relative uncertainty of each Allan variance point added to the statistical one (default
        0.001): the model's own approximations (the flicker floor is flat only well above its
        band's upper corner; a random walk's sampling). Measured on 20 simulated 24 h
        tactical records: with 0.01 the 68 % interval of the angle random walk covered in 95 %
        of them (too wide: the statistical error there is 0.1 %), with 0.001 in 70 %.
    record_length : bool, optional
        Predict, for each identified term known to worse than 10 %, the record length that
        would give 10 % (default True; a few more covariance evaluations).

    Returns
    -------
    NoiseModel
    """
    from scipy.stats import chi2, norm

    ci = ONE_SIGMA_CI if ci is None else ci
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
    if isinstance(fs, bool) or not isinstance(fs, (int, float, np.integer, np.floating)) or \
            not math.isfinite(fs) or fs <= 0:
        raise ValueError(f"fs: sample rate must be a positive finite number in Hz, got {fs!r}")
    fs = float(fs)
    segs = (n,) if isinstance(n, (int, np.integer)) and not isinstance(n, bool) else tuple(n)
    if not segs or any(isinstance(s, bool) or not isinstance(s, (int, np.integer)) or s < 8
                       for s in segs):
        raise ValueError(f"n: expected the number of samples (an integer >= 8) or one per "
                         f"gap-free segment, got {n!r}")
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
    stated = model is not None
    if stated:
        linear, n_gm = parse_model(model)
        if len(linear) + 2 * n_gm >= t.size:
            raise ValueError(f"model: {len(linear) + 2 * n_gm} parameters from {t.size} "
                             "averaging times: not enough points to fit it")

    pb = _Problem(t, v, m, segs, fs, model_error)
    log: list[str] = []

    def weights_and_fit(eps: float, select: bool):
        """Omega, once for every candidate (as GMWM's is model-free): the covariance under the
        largest model (every linear term and the Gauss-Markov terms that lower J), fitted
        twice with the weights at its own estimate (a smaller model's covariance would
        understate the variance where a term it lacks adds to the curve, and so keep that term
        out); then the selection (or the stated model) under it."""
        pb.model_error = eps
        pb.set_weights(*_pilot(pb))
        for _ in range(2):
            big = _saturated(pb, alpha, max_gm) if not stated else \
                _stated(pb, tuple(sorted(set(LINEAR_TERMS) | set(linear),
                                         key=LINEAR_TERMS.index)), n_gm)
            pb.set_weights(*big.coefficients())
        steps: list[str] = [f"weights (Omega) from the largest model, {big.spec.label()}"]
        if stated:
            fit, weak = _stated(pb, linear, n_gm), {}
        elif select:
            fit, weak = _select(pb, alpha, max_gm, steps)
        else:
            return big, None, None, steps
        return big, pb.refine(fit.spec), weak, steps

    big, fit, weak, steps = weights_and_fit(model_error, True)
    dof = t.size - fit.spec.n_params
    if dof > 0 and chi2.sf(fit.J, dof) < 0.01:
        # The curve departs from every model of these terms more than its statistical error
        # allows (a real sensor's anti-alias filter, vibration, temperature): that misfit is
        # estimated as a relative error per point, the value that brings J to its degrees of
        # freedom (a method-of-moments dispersion), and the selection is made again under
        # it, so that the few very precise short-tau points do not decide every term.
        spec0 = fit.spec
        lo_e, hi_e = math.log(max(model_error, 1e-4)), math.log(0.5)
        for _ in range(14):
            mid = 0.5 * (lo_e + hi_e)
            pb.model_error = math.exp(mid)
            pb.set_weights(*big.coefficients())
            if pb.refine(spec0).J > dof:
                lo_e = mid
            else:
                hi_e = mid
            if hi_e - lo_e < 0.05:
                break
        eps = math.exp(hi_e)
        log.append(f"the curve departs from the model {spec0.label()} beyond its error bars "
                   f"(J = {fit.J:.3g} on {dof} degrees of freedom): a model error of "
                   f"{100 * eps:.2g} % per point brings J to its degrees of freedom; selected "
                   "again with it")
        big, fit, weak, steps = weights_and_fit(eps, True)
    log.extend(steps)
    cov_v = pb.covariance(*big.coefficients())

    # the parameter covariance, scaled when the curve departs from the model
    p = fit.spec.n_params
    dof = t.size - p
    p_value = float(chi2.sf(fit.J, dof)) if dof > 0 else float("nan")
    scale = fit.J / dof if dof > 0 and p_value < 0.05 else 1.0
    cov = _param_cov(pb, fit) * scale
    z = float(norm.ppf(0.5 + ci / 2.0))
    z95 = float(norm.ppf(0.95))
    n_lin, n_gm_fit = len(fit.spec.linear), len(fit.spec.gm)
    terms: dict = {}

    def interval(k):
        """(value, low, high, sigma, bound) of the square root of coefficient k: the score
        interval of content ci, the linearised sigma for display, the one-sided 95 % bound."""
        sc = math.sqrt(max(cov[k, k], 0.0))
        val, _, _, sigma = _interval_sqrt(float(fit.coef[k]), sc, z)
        c_lo, c_hi = _score_interval(pb, fit, k, z, scale)
        _, c_b = _score_interval(pb, fit, k, z95, scale, lower=False)
        root = (lambda c: None if c is None else math.sqrt(c))
        return val, math.sqrt(c_lo), root(c_hi), sigma, root(c_b)

    for k, term in enumerate(fit.spec.linear):
        val, lo, hi, sigma, bound = interval(k)
        rel = (sigma / val) if sigma and val else math.inf
        # the record a 10 % estimate needs, for a term the record shows (a term it does not
        # show has only a bound, and its estimate is no base for a prediction)
        rec = _record_for(pb, fit, k, rel, scale=scale) \
            if record_length and term not in weak else None
        if term in weak:
            rise, need = weak[term]
            terms[term] = ModelTerm(
                term, "upper bound" if bound is not None else "not identified", val, lo, hi,
                sigma, f"in the model ({fit.spec.label()}) but not significant: removing it "
                f"raises J by {rise:.3g} < {need:.3g}; "
                + ("95 % upper bound from the model" if bound is not None else
                   "the record does not bound it from above"),
                record_s_for_10pct=rec, bound=bound, in_model=True)
        else:
            why = ("stated" if stated else "significant: removing it raises J by more than "
                   f"the level-{alpha:g} critical value") + f" (model {fit.spec.label()})"
            terms[term] = ModelTerm(term, "identified", val, lo, hi, sigma, why,
                                    record_s_for_10pct=rec, bound=bound, in_model=True)
    gms = []
    for g, T in enumerate(fit.spec.gm):
        k = n_lin + g
        val, lo, hi, sigma, bound = interval(k)
        kt = n_lin + n_gm_fit + g
        st = math.sqrt(max(cov[kt, kt], 0.0))
        rel = (sigma / val) if sigma and val else math.inf
        rec = _record_for(pb, fit, k, rel, scale=scale) if record_length else None
        gms.append(ModelTerm("GM", "identified", val, lo, hi, sigma,
                             "stated" if stated else "significant: adding it lowered J by more "
                             f"than the critical value {_gm_threshold(pb, alpha):.3g}",
                             tau=float(T), tau_low=float(T * math.exp(-z * st)),
                             tau_high=float(T * math.exp(z * st)), record_s_for_10pct=rec,
                             bound=bound, in_model=True))
    # the terms left out: a one-sided 95 % upper bound from the model with the term forced in
    for term in LINEAR_TERMS:
        if term in terms:
            continue
        why = next((s for s in reversed(log) if s.startswith(f"dropped {term}:")), None)
        try:
            forced = pb.refine(_Spec(tuple(x for x in LINEAR_TERMS
                                           if x in fit.spec.linear or x == term), fit.spec.gm))
            k = forced.spec.linear.index(term)
            _, c_b = _score_interval(pb, forced, k, z95, scale, lower=False)
            bound = None if c_b is None else math.sqrt(c_b)
        except (np.linalg.LinAlgError, ValueError):
            bound = None
        reason = (why or ("not in the stated model" if stated else "not selected"))
        if bound is not None and math.isfinite(bound) and bound > 0:
            terms[term] = ModelTerm(term, "upper bound", None, None, None, None,
                                    reason + "; 95 % upper bound from the model with it "
                                    "forced in", bound=bound)
        else:
            terms[term] = ModelTerm(term, "not identified", None, None, None, None, reason)
    ordered = [terms[x] for x in LINEAR_TERMS] + sorted(gms, key=lambda g: g.tau)

    # the IEEE 952 floor reading, beside the fit
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
    return NoiseModel(terms=ordered, taus=t, avar=v, avar_cov=cov_v, fs=fs, n=segs, ci=ci,
                      J=float(fit.J), dof=int(dof), p_value=p_value, scale=float(scale),
                      floor_reading=floor, selection=log, stated=stated, alpha=alpha,
                      model_error=float(pb.model_error))
