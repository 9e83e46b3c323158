"""The candidate processes of a noise model and their theoretical Allan variance.

Each term of :data:`LINEAR_TERMS` (IEEE Std 952-1997 Annex C, Table C.1) has an Allan variance
linear in its coefficient squared (:func:`avar_term`); a first-order Gauss-Markov term has the
exact Allan variance of a sampled AR(1) (:func:`avar_gm`, Zhang, Metrologia 45, 2008, section 3).
The table of the processes and the Gauss-Markov closed form are in :mod:`fogcomp.noise`'s
docstring. :func:`parse_model` reads a stated model (``"N + B + K + GM"``) into these terms.
"""

from __future__ import annotations

import functools
import math

import numpy as np

#: The terms whose Allan variance is linear in one coefficient squared (IEEE Std 952).
LINEAR_TERMS = ("Q", "N", "B", "K", "R")
TERM_NAMES = {"Q": "quantisation", "N": "angle random walk", "B": "bias instability",
              "K": "rate random walk", "R": "rate ramp", "GM": "Gauss-Markov"}
FLICKER_FLOOR = 2.0 * math.log(2.0) / math.pi          # AVAR of flicker B = 1: (2 ln 2/pi)


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

    The closed form (:mod:`fogcomp.noise`'s docstring) where ``m tau0 / T >= 1``; below, where
    it cancels catastrophically (``1 - phi^2`` of a T of many samples has lost all its digits),
    its Taylor series in ``x = tau0 / T`` with exact integer coefficients (``_gm_series``)."""
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
