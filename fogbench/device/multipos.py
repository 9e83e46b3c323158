"""The g-sensitive terms and the scale factor of a device file from a multi-position,
centrifuge or rate-table log (``fogbench device fit --multipos``): one gyro axis, the specific
force along the body axes (``acc_x/y/z``: an accelerometer's, or the table's attitude turned into
one) and the reference rate about the input axis (the table's rate plus the Earth rate's
projection: the reference a lab computes from its table and its latitude).

Model (``sim.fog``; paper 004 eq. 8 for the g terms)::

    rate - ref = d0 + d1 fx + d2 fy + d3 fz + d4 fx^2 + d5 fy^2 + d6 fz^2 + d7 fx fy
                 + d8 fy fz + d9 fx fz + k ref + k_nl ref |ref| / w_fs + noise

with f in g, ``k`` the scale-factor error and ``k_nl`` its non-linearity at full scale
``w_fs`` (fitted only when the full scale is given; without it the column is still in the
model, so that a non-linearity does not leak into ``k``).

Which terms a log determines is decided before the fit, from the design alone (estimability,
e.g. Searle, *Linear Models*, 1971, sec. 5.4): a coefficient can be estimated without bias iff
its unit vector lies in the row space of the design matrix, i.e. has no component in its null
space (numerically: the right singular vectors of the unit-scaled design whose singular values
are below 1e-3 of the largest, so that an accelerometer's noise and scale errors, which keep
fx^2 + fy^2 + fz^2 from being exactly 1, do not make a term look determined; the fit is then
made in the remaining directions only). At 1 g, fx^2 + fy^2 + fz^2 = 1 in every static position, so the constant and the three
squares are never separable without a centrifuge (or positions at other than 1 g); six
positions (each axis up and down) leave the cross terms at zero. A term that is not estimable is
listed as such; the others are estimated by generalised least squares on block means (as the
thermal fit, :mod:`fogbench.device.thermal`: the residual's covariance is the noise model's, so
flicker and random walks do not shrink the intervals), the covariance scaled up by the residual's
chi-square per degree of freedom when that exceeds 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["MultiposLog", "TERMS", "design", "estimable", "confounded", "fit_multipos",
           "g_terms_at", "lab_program", "six_positions"]

MAX_BLOCKS = 3000              # the fit works on at most 3000 block means (covariance m x m)
#: The scale factor (and its non-linearity) is in the model only where the reference rate
#: goes beyond this many Earth rates: excited by the Earth rate alone, a scale-factor error of
#: even 1e4 ppm is 0.15 deg/h, and its column follows fx where the input axis is up and down
#: (ref = +-Omega sin(latitude) exactly when fx = +-1), so it would take d1 away.
SF_EXCITATION = 10.0
RANK_TOL = 1e-3                # singular values below this (relative): the design's null space
NULL_TOL = 1e-2                # a unit vector with more of its length in the null space: not
                               # estimable

#: The columns of the model (module docstring): name and the device key (index) it gives.
TERMS = (("constant", None),
         ("fx", ("g_sens_dph_per_g", 0)), ("fy", ("g_sens_dph_per_g", 1)),
         ("fz", ("g_sens_dph_per_g", 2)),
         ("fx^2", ("g2_sens_dph_per_g2", 0)), ("fy^2", ("g2_sens_dph_per_g2", 1)),
         ("fz^2", ("g2_sens_dph_per_g2", 2)), ("fx fy", ("g2_sens_dph_per_g2", 3)),
         ("fy fz", ("g2_sens_dph_per_g2", 4)), ("fx fz", ("g2_sens_dph_per_g2", 5)),
         ("scale factor", ("scale_factor_ppm", None)),
         ("non-linearity", ("sf_nonlinearity_ppm", None)))


@dataclass(frozen=True)
class MultiposLog:
    """One gyro axis through several attitudes or rates: rate and ref (rad/s), specific force
    f (n, 3) in g along the body axes, sample rate (Hz)."""

    name: str
    rate: np.ndarray
    ref: np.ndarray
    f: np.ndarray
    fs: float
    column: str = ""


def design(f: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """The model's columns (TERMS order) at every sample; the non-linearity as ref |ref|
    (rad/s)^2 (divide its coefficient's unit by the full scale later)."""
    fx, fy, fz = f[:, 0], f[:, 1], f[:, 2]
    return np.column_stack([np.ones_like(fx), fx, fy, fz, fx * fx, fy * fy, fz * fz, fx * fy,
                            fy * fz, fx * fz, ref, ref * np.abs(ref)])


def _basis(X: np.ndarray):
    """(column norms, the columns used, singular values, right singular vectors) of ``X``
    with its columns scaled to unit length."""
    norms = np.linalg.norm(X, axis=0)
    used = norms > 0
    Xs = X[:, used] / norms[used]
    _, s, vt = np.linalg.svd(Xs, full_matrices=Xs.shape[0] < Xs.shape[1])
    return norms, used, s, vt


def estimable(X: np.ndarray, tol: float = NULL_TOL) -> np.ndarray:
    """Per column of ``X``: is its coefficient estimable (its unit vector in the row space)?
    Columns scaled to unit length first (an estimable coefficient stays estimable); directions
    with singular values below RANK_TOL of the largest count as the null space (an
    accelerometer's noise and scale errors keep fx^2 + fy^2 + fz^2 from being exactly 1, but
    not by more than about 1e-3); a coefficient whose unit vector has more than ``tol`` of its
    length in that null space is not estimable."""
    norms, used, s, vt = _basis(X)
    rank = int(np.sum(s > RANK_TOL * s[0])) if s.size else 0
    null = vt[rank:]
    res = np.zeros(X.shape[1], bool)
    res[np.flatnonzero(used)] = np.linalg.norm(null, axis=0) < tol if null.size else True
    return res


_INDEX = {name: j for j, (name, _) in enumerate(TERMS)}


def confounded(X: np.ndarray, tol: float = NULL_TOL) -> dict[str, list[str]]:
    """Per term that is not estimable, the other terms of the model it cannot be told apart
    from in this design: those sharing a direction of the null space with it (fx^2 with fy^2,
    fz^2 and the constant at 1 g: fx^2 + fy^2 + fz^2 = 1 in every position). A column the
    design leaves at zero (a term the program does not excite) has no partner."""
    norms, used, s, vt = _basis(X)
    rank = int(np.sum(s > RANK_TOL * s[0])) if s.size else 0
    null = vt[rank:]
    cols = np.flatnonzero(used)
    out: dict[str, list[str]] = {}
    for i, j in enumerate(cols):
        partners = set()
        for v in null:
            if abs(v[i]) >= tol:
                partners |= {TERMS[cols[q]][0] for q in np.flatnonzero(np.abs(v) >= tol)
                             if q != i}
        if partners:
            out[TERMS[j][0]] = [t for t, _ in TERMS if t in partners]
    for j in np.flatnonzero(~used):
        out[TERMS[j][0]] = []
    return out


def _blocks(x: np.ndarray, k: int) -> np.ndarray:
    m = x.shape[0] // k
    return x[:m * k].reshape(m, k, *x.shape[1:]).mean(axis=1)


def fit_multipos(log: MultiposLog, noise, ci: float, full_scale: float | None = None) -> dict:
    """GLS fit of the g terms and the scale factor (module docstring). ``noise``: FogParams of
    the noise terms; ``full_scale``: rad/s, or None (non-linearity not stated). Returns
    {term name: (value, low, high) or None (not estimable)} in SI (g terms rad/s per g or
    g^2, scale factor and non-linearity dimensionless), ``chi2_per_dof``, ``block_s``,
    ``blocks``."""
    from scipy.linalg import solve_triangular
    from scipy.stats import norm, t as student_t

    from fogbench.device.thermal import block_covariance

    if not (np.all(np.isfinite(log.rate)) and np.all(np.isfinite(log.ref))
            and np.all(np.isfinite(log.f))):
        raise ValueError(f"{log.name}: the rate, the reference or the specific force holds NaN "
                         "or infinite values")
    from sim.earth import EARTH_RATE

    k = max(1, math.ceil(log.rate.size / MAX_BLOCKS))
    X = _blocks(design(log.f, log.ref), k)
    y = _blocks(log.rate - log.ref, k)
    m = y.size
    sf_excited = float(np.max(np.abs(log.ref))) > SF_EXCITATION * EARTH_RATE
    if not sf_excited:       # the scale-factor columns out of the model (SF_EXCITATION)
        X = X.copy()
        X[:, [_INDEX["scale factor"], _INDEX["non-linearity"]]] = 0.0
    if m < 30:
        raise ValueError(f"{log.name}: {m} blocks; the multi-position fit needs at least 30 "
                         "samples")
    ok = estimable(X)
    norms, used, s, vt = _basis(X)
    rank = int(np.sum(s > RANK_TOL * s[0]))
    dof = m - rank
    if dof < 10:
        raise ValueError(f"{log.name}: {m} blocks for {rank} separable terms; record longer")
    Vr = vt[:rank].T                              # the directions the log determines
    C = block_covariance(noise, log.fs, k, m)
    C[np.diag_indices_from(C)] *= 1.0 + 1e-10
    L = np.linalg.cholesky(C)
    wX = solve_triangular(L, (X[:, used] / norms[used]) @ Vr, lower=True)
    wy = solve_triangular(L, y, lower=True)
    # generalised least squares in those directions (full rank), mapped back: one cutoff for
    # the estimate, its covariance and what is reported (the estimable coefficients)
    gamma, *_ = np.linalg.lstsq(wX, wy, rcond=None)
    chi = float(np.sum((wy - wX @ gamma) ** 2))
    scale = max(chi / dof, 1.0)
    cov_g = np.linalg.inv(wX.T @ wX) * scale
    beta_s, cov_s = Vr @ gamma, Vr @ cov_g @ Vr.T
    beta = np.zeros(X.shape[1])
    sd = np.zeros(X.shape[1])
    beta[used] = beta_s / norms[used]
    sd[used] = np.sqrt(np.maximum(np.diag(cov_s), 0.0)) / norms[used]
    # the noise model's own scale: normal quantiles; scaled up by the residual: Student's t
    z = float(norm.ppf(0.5 + ci / 2)) if scale == 1.0 else float(student_t.ppf(0.5 + ci / 2,
                                                                               dof))
    cov = np.zeros((X.shape[1], X.shape[1]))
    cov[np.ix_(used, used)] = cov_s / np.outer(norms[used], norms[used])
    out: dict = {"chi2_per_dof": chi / dof, "block_s": k / log.fs, "blocks": m,
                 "confounded": confounded(X), "scale_factor_excited": sf_excited,
                 "beta": beta, "cov": cov, "estimable": ok, "quantile": z}
    for j, (name, _) in enumerate(TERMS):
        out[name] = (beta[j], beta[j] - z * sd[j], beta[j] + z * sd[j]) if ok[j] else None
    if out["non-linearity"] is not None:
        # k_nl at full scale; without the full scale it stays per rad/s (not a device key)
        out["non-linearity"] = tuple(v * (full_scale or 1.0) for v in out["non-linearity"])
    return out


def g_terms_at(res: dict, f) -> tuple[np.ndarray, float]:
    """(the fitted g and g^2 terms at each specific force of ``f`` (k, 3) in g, rad/s; the
    standard deviation of their mean) from :func:`fit_multipos`'s result: the terms the log
    determines only (the others are written 0 in the device file, so the bias keeps them)."""
    rows = design(np.atleast_2d(np.asarray(f, float)), np.zeros(len(np.atleast_2d(f))))
    a = np.zeros_like(rows)
    g = slice(_INDEX["fx"], _INDEX["fx fz"] + 1)
    a[:, g] = rows[:, g]
    a[:, ~res["estimable"]] = 0.0
    abar = a.mean(axis=0)
    return a @ res["beta"], float(math.sqrt(max(abar @ res["cov"] @ abar, 0.0)))


def lab_program(fs: float, hold_s: float = 60.0, rates_dps=(10.0, 50.0, 150.0, 250.0),
                latitude_deg: float = 45.0) -> tuple[np.ndarray, np.ndarray, list]:
    """The calibration a lab would run on a gyro whose input axis is x, as (f (n, 3) in g,
    ref (n,) rad/s, part names), each part held ``hold_s``:

    - 18 static positions at 1 g: each axis up and down, and 45 deg between each pair of axes
      (the tumble test);
    - 12 centrifuge positions, 2 g and 4 g of radial acceleration along +-x, +-y, +-z with 1 g
      of gravity along another axis, the spin axis always perpendicular to x (the input axis
      sees no spin, as in paper 004's centrifuge test);
    - the input axis up on a rate table at +- each of ``rates_dps``.

    The reference holds the Earth rate's vertical projection on x (latitude ``latitude_deg``;
    the horizontal part depends on the heading, taken east-west here, where it is zero; on the
    centrifuge x spins about a horizontal axis or lies level) plus the table's rate."""
    from sim.earth import EARTH_RATE

    c = math.sqrt(0.5)
    parts = []
    for a in range(3):
        for s in (1.0, -1.0):
            u = np.zeros(3)
            u[a] = s
            parts.append((f"{'xyz'[a]}{'+' if s > 0 else '-'}", u, u[0], 0.0))
    for a, b in ((0, 1), (1, 2), (0, 2)):
        for sa in (1.0, -1.0):
            for sb in (1.0, -1.0):
                u = np.zeros(3)
                u[a], u[b] = sa * c, sb * c
                parts.append((f"45deg {'xyz'[a]}{sa:+.0f} {'xyz'[b]}{sb:+.0f}", u, u[0], 0.0))
    for radial, up in ((0, 2), (1, 2), (2, 1)):
        for acc in (2.0, 4.0):
            for s in (1.0, -1.0):
                u = np.zeros(3)
                u[radial], u[up] = s * acc, 1.0
                # x horizontal or spinning about a horizontal axis: no vertical Earth rate on it
                parts.append((f"centrifuge {acc:g} g along {'xyz'[radial]}{s:+.0f}", u, 0.0,
                              0.0))
    for r in rates_dps:
        for s in (1.0, -1.0):
            parts.append((f"rate table {s * r:+g} deg/s", np.array([1.0, 0.0, 0.0]), 1.0,
                          s * r * math.pi / 180.0))
    n = int(round(hold_s * fs))
    vert = EARTH_RATE * math.sin(math.radians(latitude_deg))
    f = np.repeat(np.array([u for _, u, _, _ in parts]), n, axis=0)
    ref = np.repeat(np.array([w + vert * up for _, _, up, w in parts]), n)
    return f, ref, [p[0] for p in parts]


def six_positions(fs: float, hold_s: float = 600.0,
                  latitude_deg: float = 45.0) -> tuple[np.ndarray, np.ndarray, list]:
    """The classic six-position test of a gyro whose input axis is x: each body axis up and
    down at rest, ``hold_s`` each, as (f (n, 3) in g, ref (n,) rad/s, part names); the reference
    is the Earth rate's vertical projection on x (the heading taken east-west for x level)."""
    f, ref, names = lab_program(fs, hold_s=hold_s, rates_dps=(), latitude_deg=latitude_deg)
    n = int(round(hold_s * fs))
    return f[:6 * n], ref[:6 * n], names[:6]
