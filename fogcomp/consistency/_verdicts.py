"""Consistency of a bias filter: NEES where the truth is known (a simulation), NIS where it is
not (a real log), and the inflation factor that makes the NIS consistent.

**NEES of one record** (:func:`nees_test`). The normalised estimation error squared of the bias
(``(b_k - b^_k)^2 / P_k``, one degree of freedom) at m tracked times after a burn-in, averaged
over them. The errors of one record are correlated in time (a filter's error decays at its
closed-loop rate; the error of an unknown constant never does), so the time-averaged NEES is not
chi-squared with m degrees of freedom (Bar-Shalom, Li, Kirubarajan, *Estimation with
Applications to Tracking and Navigation*, Wiley 2001, section 5.4.2, assume independent
samples). Under the hypothesis that the filter is consistent its error covariance is the
filter's own, and the cross-covariance of the errors is exact:
``E[e_i e_j^T] = A_i A_{i-1} ... A_{j+1} P_j`` with ``A_k = (I - K_k H) F``. For Gaussian errors
``cov(e_i^2, e_j^2) = 2 c_ij^2``, so the mean NEES has mean 1 and variance
``V = (2 / m^2) sum_ij rho_ij^2``; the band is that of the scaled chi-square of the same two
moments, ``chi2(nu) / nu`` with ``nu = 2 / V`` (Satterthwaite, "An approximate distribution of
estimates of variance components", Biometrics Bulletin 2(6), 110-114, 1946). A record is
consistent inside the two-sided band (level ``alpha``), overconfident above it.

**Over replicates**: the fraction of records inside the band with its Clopper-Pearson interval
(:func:`clopper_pearson`), the fraction flagged overconfident likewise, and the coverage of the
1-sigma and 2-sigma bands (fraction of tracked times with ``|e| <= sigma``, ``2 sigma``),
averaged over records with a t-interval over the records (the times of one record are
correlated, the records are not).

**NIS on a real log** (:func:`nis_scales`). For a consistent filter the normalised innovations
``u_k = nu_k / sqrt(S_k)`` are white and N(0, 1) (Bar-Shalom et al. 2001, section 5.4.2); at
the sample rate the NIS is dominated by the white noise and says little about the bias model,
so it is taken at block lengths L = 1, 2, 4, ...: ``NIS_L = mean over the n // L blocks of
(sum of u in the block)^2 / L``, chi2(n // L) / (n // L) under the hypothesis. A filter whose
bias model is too small has innovations correlated at long lags: its ``NIS_L`` grows with L.

**The inflation factor** (:func:`inflation_factor`): the filter of the model with every
coefficient times f (variances times f^2), for f on a log grid, all run side by side. For each
scale L, the factor at which ``NIS_L(f)`` crosses a level (by interpolation in log-log); the
binding scale is the one that needs the largest factor. Reported: ``f_hat`` (the worst scale's
NIS at 1, its expectation), and the interval by inverting the test (the set of factors the
chi-square test of every scale does not reject): ``f_low``, the smallest factor no scale finds
overconfident (its NIS_L below the upper quantile, Bonferroni over the scales), and ``f_high``,
the largest the binding scale does not find underconfident. The chi-square distribution is
exact under each factor's own hypothesis (white innovations), which is what a test inversion
needs; the block bootstrap would be the choice for an interval of a statistic under the
alternative, and would cost one filter run per resample.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["NeesResult", "nees_test", "clopper_pearson", "summarise_nees", "nis_scales",
           "InflationResult", "inflation_factor", "inflation_factors", "track_indices"]


def clopper_pearson(k: int, n: int, ci: float = 0.95) -> tuple[float, float]:
    """Exact (Clopper-Pearson, Biometrika 26(4), 1934) interval of a binomial proportion."""
    from scipy.stats import beta

    a = (1.0 - ci) / 2.0
    lo = 0.0 if k == 0 else float(beta.ppf(a, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(1.0 - a, k + 1, n - k))
    return lo, hi


def track_indices(n: int, m: int = 200, burn_in: float = 0.1) -> np.ndarray:
    """m sample indices evenly spread over ``[burn_in n, n)``."""
    start = int(burn_in * n)
    return np.unique(np.linspace(start, n - 1, min(m, n - start)).astype(int))


@dataclass
class NeesResult:
    """:func:`nees_test` of each member: ``nees`` (B,) the time-averaged NEES, ``low``, ``high``
    (B,) its band, ``nu`` (B,) the band's degrees of freedom, ``verdict`` (B,) of str,
    ``cover1``, ``cover2`` (B,) the fractions of times inside the 1- and 2-sigma bands."""

    nees: np.ndarray
    low: np.ndarray
    high: np.ndarray
    nu: np.ndarray
    verdict: list
    cover1: np.ndarray
    cover2: np.ndarray


def nees_test(run, truth_bias, alpha: float = 0.05) -> NeesResult:
    """The time-averaged NEES of the bias of each member of a :class:`FilterRun` (run with
    ``track=``) and its band under the filter's own model (module docstring).

    Parameters
    ----------
    run : FilterRun
        With ``track`` set (:func:`track_indices`).
    truth_bias : array_like, shape (B, n)
        The true bias of each member's record, rad/s.
    alpha : float
        Level of the two-sided band (default 0.05).
    """
    from scipy.stats import chi2

    if run.track is None:
        raise ValueError("run: run the filter with track= (the tracked times) for the NEES")
    tb = np.asarray(truth_bias, dtype=float)
    if tb.shape != run.bias.shape:
        raise ValueError(f"truth_bias: expected shape {run.bias.shape}, got {tb.shape}")
    tr = run.track
    e = tb[:, tr] - run.bias[:, tr]                       # (B, m)
    s = run.bias_var[:, tr]
    nees = e * e / s
    h = run.bias_row                                      # (B, d)
    B, m = e.shape
    # c(j + lag, j) = h Phi_{j+lag} ... Phi_{j+1} P_j h'
    G = run.P_track.copy()                                # (B, m, d, d)
    sum_rho2 = np.full(B, float(m))
    for lag in range(1, m):
        G = run.Phi_track[:, lag:] @ G[:, :m - lag]
        c = np.einsum("bi,bjik,bk->bj", h, G, h)
        rho2 = c * c / (s[:, lag:] * s[:, :m - lag])
        sum_rho2 += 2.0 * rho2.sum(axis=1)
        if rho2.max() < 1e-12:
            break
    V = 2.0 * sum_rho2 / (m * m)
    nu = 2.0 / V
    low = chi2.ppf(alpha / 2.0, nu) / nu
    high = chi2.ppf(1.0 - alpha / 2.0, nu) / nu
    nbar = nees.mean(axis=1)
    verdict = ["overconfident" if a > hi else "underconfident" if a < lo else "consistent"
               for a, lo, hi in zip(nbar, low, high)]
    z = np.abs(e) / np.sqrt(s)
    return NeesResult(nees=nbar, low=low, high=high, nu=nu, verdict=verdict,
                      cover1=(z <= 1.0).mean(axis=1), cover2=(z <= 2.0).mean(axis=1))


def _t_interval(x, ci=0.95):
    from scipy.stats import t

    x = np.asarray(x, dtype=float)
    if x.size < 2:
        return float(x.mean()), float("nan"), float("nan")
    half = t.ppf(0.5 + ci / 2, x.size - 1) * x.std(ddof=1) / math.sqrt(x.size)
    # a share: the interval clipped to [0, 1]
    return float(x.mean()), max(0.0, float(x.mean() - half)), min(1.0, float(x.mean() + half))


def summarise_nees(results) -> dict:
    """Over replicates (NeesResult of each, or one with B members): the fraction consistent and
    overconfident with Clopper-Pearson 95 % intervals, and the mean 1- and 2-sigma coverage with
    t-intervals."""
    if isinstance(results, NeesResult):
        results = [results]
    verdict = sum((list(r.verdict) for r in results), [])
    c1 = np.concatenate([r.cover1 for r in results])
    c2 = np.concatenate([r.cover2 for r in results])
    nees = np.concatenate([r.nees for r in results])
    n = len(verdict)
    k_in = sum(v == "consistent" for v in verdict)
    k_over = sum(v == "overconfident" for v in verdict)
    return {"n": n, "in_band": k_in / n, "in_band_ci": clopper_pearson(k_in, n),
            "overconfident": k_over / n, "overconfident_ci": clopper_pearson(k_over, n),
            "cover1": _t_interval(c1), "cover2": _t_interval(c2),
            "median_nees": float(np.median(nees))}


def nis_scales(u, min_blocks: int = 16) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The NIS of normalised innovations at block lengths L = 1, 2, 4, ... (while ``n // L >=
    min_blocks``).

    Parameters
    ----------
    u : array_like, shape (n,) or (B, n)
        Normalised innovations ``nu / sqrt(S)``.

    Returns
    -------
    L : ndarray of int, shape (k,)
    nis : ndarray, shape (k,) or (B, k)
        ``mean over blocks of (sum of u in the block)^2 / L``.
    dof : ndarray of int, shape (k,)
        Number of blocks (the chi-square's degrees of freedom).
    """
    u = np.asarray(u, dtype=float)
    one = u.ndim == 1
    u = np.atleast_2d(u)
    n = u.shape[1]
    Ls, stats, dofs = [], [], []
    L = 1
    while n // L >= min_blocks:
        nb = n // L
        blocks = u[:, :nb * L].reshape(u.shape[0], nb, L).sum(axis=2)
        Ls.append(L)
        stats.append((blocks**2).mean(axis=1) / L)
        dofs.append(nb)
        L *= 2
    st = np.array(stats).T
    return np.array(Ls), (st[0] if one else st), np.array(dofs)


def _crossing(grid, stat, level):
    """Smallest factor at which the decreasing-in-f statistic reaches ``level`` (log-log
    interpolation on the grid); (value, flag) with flag "<=" below the grid, ">" above it."""
    below = np.flatnonzero(stat <= level)
    if below.size == 0:
        return float(grid[-1]), ">"
    i = below[0]
    if i == 0:
        return float(grid[0]), "<="
    x0, x1 = math.log(grid[i - 1]), math.log(grid[i])
    y0, y1 = math.log(stat[i - 1]), math.log(stat[i])
    t = (math.log(level) - y0) / (y1 - y0) if y1 != y0 else 1.0
    return float(math.exp(x0 + t * (x1 - x0))), ""


@dataclass
class InflationResult:
    """:func:`inflation_factor`. Factors multiply the model's coefficients (standard
    deviations and densities; variances go by their square).

    Attributes
    ----------
    f_hat, f_low, f_high : float
        The estimate and its interval (the module docstring); ``flags`` say where one is at the
        grid's edge (``"<="``: at most this; ``">"``: beyond the grid).
    scale_L : int
        The binding block length, samples.
    nis_at_1 : ndarray, shape (k,)
        NIS_L of the model as identified; ``band`` (k, 2) its Bonferroni band.
    L : ndarray, shape (k,)
    consistent_at_1 : bool
        Whether the model as identified passes at every scale.
    underconfident_at_f_low : list of int
        The scales found underconfident at ``f_low`` (one factor cannot fit every scale).
    terms : str
        "all" or "bias".
    n : int
        Innovations used.
    """

    f_hat: float
    f_low: float
    f_high: float
    flags: dict
    scale_L: int
    L: np.ndarray
    nis_at_1: np.ndarray
    band: np.ndarray
    consistent_at_1: bool
    underconfident_at_f_low: list
    terms: str
    n: int
    grid: np.ndarray = field(repr=False, default=None)
    nis_grid: np.ndarray = field(repr=False, default=None)
    method: str = ("chi-square test inversion of the block NIS at L = 1, 2, 4, ... "
                   "(Bonferroni over the scales, 95 %)")

    def verdict_at(self, factor: float) -> dict:
        """The block NIS of the model inflated by ``factor`` (interpolated in log-log on the
        grid): how many block lengths are overconfident (above their band), underconfident
        (below it) and consistent, and the largest NIS."""
        g = np.log(self.grid)
        x = min(max(math.log(factor), g[0]), g[-1])
        st = np.array([math.exp(np.interp(x, g, np.log(self.nis_grid[:, j])))
                       for j in range(self.L.size)])
        # (a relative 1e-9: at f_low the binding block length's NIS is its bound)
        over = int(np.sum(st > self.band[:, 1] * (1 + 1e-9)))
        under = int(np.sum(st < self.band[:, 0] * (1 - 1e-9)))
        return {"factor": float(factor), "overconfident": over, "underconfident": under,
                "consistent": int(self.L.size - over - under), "max_nis": float(st.max())}


def default_grid() -> np.ndarray:
    return np.geomspace(0.25, 1000.0, 37)


def inflation_factor(model, pieces, *, terms: str = "all", grid=None, alpha: float = 0.05,
                     min_blocks: int = 16) -> InflationResult:
    """The smallest inflation of ``model`` that makes the NIS of its filter consistent on the
    held-out ``pieces`` of a log, with its interval (module docstring).

    Parameters
    ----------
    model : BiasFilterModel
    pieces : list of ndarray, each shape (n_i,)
        Held-out gap-free pieces of the log, measured minus known rate, rad/s; the filter is
        restarted on each and their normalised innovations are put end to end.
    terms : {"all", "bias"}
        Which coefficients the factor multiplies (:meth:`BiasFilterModel.inflated`).
    grid : array_like, optional
        Factors tried (default 0.25 to 1000, 37 log-spaced).
    """
    from ._filter import run_filter

    grid = default_grid() if grid is None else np.asarray(grid, dtype=float)
    grid = np.union1d(grid, [1.0])              # the model as identified is always run
    members = [model.inflated(f, terms) for f in grid]
    us = []
    for p in pieces:
        r = run_filter(members, np.asarray(p, dtype=float))
        us.append(r.innov / np.sqrt(r.S))
    return _from_innovations(grid, np.concatenate(us, axis=1), terms, alpha, min_blocks)


def inflation_factors(models, records, *, terms: str = "all", grid=None, alpha: float = 0.05,
                      min_blocks: int = 16) -> list:
    """:func:`inflation_factor` of many (model, record) pairs in one batched filter run (the
    records of one length, each one gap-free piece): a list of InflationResult."""
    from ._filter import run_filter

    grid = default_grid() if grid is None else np.asarray(grid, dtype=float)
    grid = np.union1d(grid, [1.0])
    z = np.asarray(records, dtype=float)
    members = [m.inflated(f, terms) for m in models for f in grid]
    r = run_filter(members, np.repeat(z, grid.size, axis=0))
    u = (r.innov / np.sqrt(r.S)).reshape(len(models), grid.size, -1)
    return [_from_innovations(grid, u[i], terms, alpha, min_blocks) for i in range(len(models))]


def _from_innovations(grid, u, terms, alpha, min_blocks) -> InflationResult:
    """The InflationResult of normalised innovations ``u`` (grid.size, n), one row a factor."""
    from scipy.stats import chi2

    L, st, dof = nis_scales(u, min_blocks)
    k = L.size
    a = alpha / k
    lo_q = chi2.ppf(a / 2, dof) / dof
    hi_q = chi2.ppf(1 - a / 2, dof) / dof
    i1 = int(np.flatnonzero(grid == 1.0)[0])
    hat = [_crossing(grid, st[:, j], 1.0) for j in range(k)]
    low = [_crossing(grid, st[:, j], hi_q[j]) for j in range(k)]
    jb = int(np.argmax([h[0] for h in hat]))
    jl = int(np.argmax([x[0] for x in low]))
    high = _crossing(grid, st[:, jb], lo_q[jb])
    f_low = low[jl][0]
    # the scales below their band at f_low (interpolated on the grid)
    st_at = np.array([np.exp(np.interp(math.log(f_low), np.log(grid), np.log(st[:, j])))
                      for j in range(k)])
    under = [int(L[j]) for j in range(k) if st_at[j] < lo_q[j] * (1 - 1e-9)]
    at1 = st[i1]
    return InflationResult(
        f_hat=hat[jb][0], f_low=f_low, f_high=high[0],
        flags={"f_hat": hat[jb][1], "f_low": low[jl][1], "f_high": high[1]},
        scale_L=int(L[jb]), L=L, nis_at_1=at1, band=np.column_stack([lo_q, hi_q]),
        consistent_at_1=bool(np.all((at1 <= hi_q) & (at1 >= lo_q))),
        underconfident_at_f_low=under, terms=terms, n=int(u.shape[1]), grid=grid,
        nis_grid=st)
