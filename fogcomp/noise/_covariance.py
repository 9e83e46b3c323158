"""The covariance of the overlapping Allan variance estimates of a record, for Gaussian
processes of a given model: the weights ``Omega = Sigma^-1`` of the fit (:mod:`fogcomp.noise`).

With the integrated angle ``x`` and ``d_k(m) = x[k+2m] - 2 x[k+m] + x[k]`` (``c = (1, -2, 1)``),
the overlapping estimator is ``v(m) = sum_k d_k(m)^2 / (2 tau^2 M)``, ``M = n + 1 - 2m``. For
Gaussian d, ``Cov(d^2, d'^2) = 2 Cov(d, d')^2``, so::

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
``E[d^2] = 6 G(0) - 8 G(tau) + 2 G(2 tau)`` (a test checks it against the table of
:mod:`fogcomp.noise`). The sum over h is exact (term by term) for short averaging times and a
Gauss-Legendre quadrature between the kinks of ``f`` and ``N`` for long ones.
"""

from __future__ import annotations

import math

import numpy as np

_C = (1.0, -2.0, 1.0)
_EXACT_MAX = 4096           # lags summed term by term below this many
_KINK_WINDOW = 32           # lags summed term by term on each side of a kink of f
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)


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
    acc = _LagSums(procs, mi, mj, n, fs)
    h_lo, h_hi = -(acc.Mj - 1), acc.Mi - 1
    c_lo, c_hi = max(h_lo, -2 * mi - 2), min(h_hi, 2 * mj + 2)
    if c_hi < c_lo:
        return acc.S2, acc.S1
    if c_hi - c_lo + 1 <= _EXACT_MAX:
        h = np.arange(c_lo, c_hi + 1, dtype=float)
        acc.add(h, _pairs_count(h, acc.Mi, acc.Mj), list(range(len(procs))))
    else:
        _add_long_core(acc, c_lo, c_hi)
    _add_tails(acc, (h_lo, h_hi), (c_lo, c_hi))
    return acc.S2, acc.S1


class _LagSums:
    """The sums of :func:`_pair_sums`, ``S2[p, q] = sum_h N f_p f_q`` and ``S1[p] = sum_h N f_p``,
    for the averaging factors mi, mj of an n-sample record, accumulated one range of lags at
    a time (:meth:`add`)."""

    def __init__(self, procs, mi: int, mj: int, n: int, fs: float):
        self.procs, self.mi, self.mj, self.fs = procs, mi, mj, fs
        self.tau0 = 1.0 / fs
        self.Mi, self.Mj = n + 1 - 2 * mi, n + 1 - 2 * mj      # terms at tau_i, tau_j
        P = len(procs)
        self.S2, self.S1 = np.zeros((P, P)), np.zeros(P)
        self.continuous = [k for k, (kind, _) in enumerate(procs) if kind != "Q"]
        self.quantisation = [k for k, (kind, _) in enumerate(procs) if kind == "Q"]

    def f(self, k: int, h) -> np.ndarray:
        """f_ij(h) of unit process k at the lags ``h``."""
        return _f_unit(*self.procs[k], h, self.mi, self.mj, self.tau0)

    def add(self, h, w, which) -> None:
        """Add the lags ``h``, each weighted by ``w`` (its pair count, times a quadrature
        weight), to the sums of the processes ``which``."""
        F = np.array([self.f(k, h) for k in which])
        self.S2[np.ix_(which, which)] += (F * w) @ F.T
        self.S1[which] += F @ w


def _add_long_core(acc: _LagSums, c_lo: int, c_hi: int) -> None:
    """The core lags c_lo..c_hi when they are too many to sum one by one: every lag summed near
    each kink of f (where a Gauss-Markov term's exponential and the |t| of the white and
    random-walk terms bend), a quadrature between, and the quantisation's delta at the
    integer kinks."""
    mi, mj, Mi, Mj = acc.mi, acc.mj, acc.Mi, acc.Mj
    cont = acc.continuous
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
        acc.add(exact, _pairs_count(exact, Mi, Mj), cont)
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
        acc.add(h, _pairs_count(h, Mi, Mj) * wq, cont)
    if acc.quantisation:
        _add_quantisation(acc, c_lo, c_hi)


def _add_quantisation(acc: _LagSums, c_lo: int, c_hi: int) -> None:
    """The quantisation's delta sits at the integer kinks: its products with every process
    there."""
    mi, mj = acc.mi, acc.mj
    hk = np.array(sorted(k for k in {b * mj - a * mi for a in range(3)
                                      for b in range(3)} if c_lo <= k <= c_hi),
                  dtype=float)
    nk = _pairs_count(hk, acc.Mi, acc.Mj)
    P = len(acc.procs)
    F = np.array([acc.f(k, hk) for k in range(P)])
    for q in acc.quantisation:
        for k in range(P):
            v = float(np.sum(nk * F[q] * F[k]))
            acc.S2[q, k] += v
            if k != q:
                acc.S2[k, q] += v
        acc.S1[q] += float(np.sum(nk * F[q]))


def _add_tails(acc: _LagSums, lags: tuple[int, int], core: tuple[int, int]) -> None:
    """The lags beyond the core (within ``lags``, the record's), where only the flicker and
    Gauss-Markov terms reach and f is smooth: a quadrature on pieces growing away from the
    core, as far as those terms' correlation reaches."""
    (h_lo, h_hi), (c_lo, c_hi) = lags, core
    tail = 0.0
    for kind, T in acc.procs:
        if kind == "B":
            tail = max(tail, 50.0 * (acc.mi + acc.mj))
        elif kind == "GM":
            tail = max(tail, 30.0 * T * acc.fs)
    smooth = [k for k in acc.continuous if acc.procs[k][0] in ("B", "GM")]
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
            acc.add(h, _pairs_count(h, acc.Mi, acc.Mj) * wq, smooth)


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
    averaging factors ``m``, for Gaussian processes of the given model (the derivation is in
    ``fogcomp/noise/_covariance.py``'s docstring).

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
