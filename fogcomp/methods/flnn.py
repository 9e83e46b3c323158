"""Functional-link neural network (FLNN) for the g-dependent static drift of a strapdown gyro.

Two estimators of the same linear-in-the-coefficients drift model (paper [1]_, eqs. 8-10),

    w = d0 + d1 gx + d2 gy + d3 gz + d4 gx^2 + d5 gy^2 + d6 gz^2 + d7 gx gy + d8 gy gz + d9 gx gz,

``flnn`` (the paper's LMS training, eqs. 5-7, in its normalised form [2]_) and ``flnn_lstsq``
(the closed-form least-squares solution, eqs. 2-4), plus the identifiability analysis both
share, which :mod:`~fogcomp.methods.model_lstsq` and :mod:`~fogcomp.methods.temperature` reuse:
:func:`lstsq_identify` and :class:`Identifiability`.

Identifiability in one paragraph: in static positions the specific force is the gravity
projection, ``|g| = 1``, so ``gx^2 + gy^2 + gz^2 = 1`` and the design columns of d0, d4, d5, d6
are linearly dependent: the data determine only ``d0 + d6``, ``d4 - d6`` and ``d5 - d6`` (any
three independent combinations orthogonal to the null direction ``(d0 - d4 - d5 - d6) / 2``),
never d0, d4, d5, d6 one by one. The paper's Table 1 lists all ten; from multi-position data
alone the split between d0 and the squared terms is whatever the solver's start left in the null
direction. Both methods here report the minimum-norm representative and say which combinations
are determined. Data with ``|g| != 1`` (a centrifuge, or an off-axis gyro on a spinning table)
identifies all ten.

.. rubric:: References

.. [1] Chen Xiyuan, Cheng Qiming, "Function-type neural networks application for nonlinear
   evaluation of strapdown gyroscope", J. Yancheng Institute of Technology, 2000 (1): 8-10
   (fogbench seed 004). Eqs. 1-4: XW = Y and its closed-form solutions; eqs. 5-7: the FLNN
   output, error and LMS weight update; eqs. 8-10: the drift model.
.. [2] B. Widrow, M. A. Lehr, "30 years of adaptive neural networks: perceptron, madaline and
   backpropagation", Proc. IEEE 78(9), 1990: the LMS rule and its normalised form (alpha-LMS,
   stable for 0 < alpha < 2).
"""

from __future__ import annotations

import sys
import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy.linalg.blas import dtrsv as _dtrsv

from .._checks import _random_state
from .._data import GyroData
from .._estimator import Compensator, DivergenceError
from .._registry import register
from ..units import DPH

__all__ = [
    "FLNN_TERMS",
    "IdentifiabilityWarning",
    "Identifiability",
    "lstsq_identify",
    "flnn_features",
    "find_dwells",
    "Flnn",
    "FlnnLstsq",
]

#: The ten functional-link terms of paper eq. 8 / eq. 10, in the order d0 ... d9.
FLNN_TERMS = ("1", "gx", "gy", "gz", "gx^2", "gy^2", "gz^2", "gx*gy", "gy*gz", "gx*gz")
_COEF_NAMES = tuple(f"d{i}" for i in range(10))
#: Unit suffix of each coefficient in deg/h for :meth:`_FlnnBase.coef_dph`.
_DPH_KEYS = ("d0_dph",) + tuple(f"d{i}_dph_per_g" for i in (1, 2, 3)) + tuple(
    f"d{i}_dph_per_g2" for i in range(4, 10))

#: Default relative singular-value threshold below which a direction counts as unidentified.
#: 1e-4, not machine precision: on a real table |g| at rest departs from 1 by 1e-5..1e-4 g
#: (servo sag, wobble, accelerometer error), which makes a 1 g design numerically full rank
#: while d0 - d4 - d5 - d6 stays determined only by that error (standard error of hundreds of
#: deg/h). Treating such a direction as unidentified is the honest report.
DEFAULT_RCOND = 1e-4
#: Condition number (identified, column-scaled part) above which a fit warns: well-posed
#: column-scaled designs sit at 1-100; 1e3 means some combination is determined 1,000 times
#: worse than the best one (e.g. |g| = 1 +- 1e-3 from accelerometer noise ties d0, d4-d6).
COND_WARN = 1e3
#: A coefficient whose null-space component (unit-norm null basis) exceeds this is unidentified.
_NULL_TOL = 1e-8
#: A loss larger than this multiple of the starting loss counts as exploding.
_EXPLODE = 1e6


def _warn(message: str, category: type[Warning]) -> None:
    """``warnings.warn`` attributed to the first caller outside the fogcomp package."""
    frame, level = sys._getframe(1), 2
    while frame is not None and frame.f_globals.get("__name__", "").startswith("fogcomp"):
        frame, level = frame.f_back, level + 1
    warnings.warn(message, category, stacklevel=level)


class IdentifiabilityWarning(UserWarning):
    """The data do not determine every coefficient (rank deficiency), or do so badly."""


# ---------------------------------------------------------------------------------------------
# Shared least squares with an identifiability report
@dataclass
class Identifiability:
    """What a least-squares design determines, from the SVD of its column-scaled matrix.

    Attributes
    ----------
    names : tuple of str
        Coefficient names, length p (for the FLNN ``d0`` ... ``d9``).
    rank : int
        Numerical rank of the design (singular values above ``rcond`` times the largest).
    n_terms : int
        Number of coefficients p.
    n_samples : int
        Number of rows of the design.
    condition : float
        Condition number of the whole column-scaled design, largest / smallest singular value
        (huge, ~1e15 or more, when rank-deficient).
    condition_identified : float
        Condition number of the identified part, largest / ``rank``-th singular value.
    singular_values : ndarray, shape (p,)
        Singular values of the column-scaled design (columns divided by their RMS), descending.
    null_basis : ndarray, shape (p - rank, p)
        Orthonormal basis of the null space in the coefficients' own (physical) coordinates:
        each row is a direction ``v`` with ``X v = 0``, its first non-zero weight positive
        (for ``|g| = 1`` FLNN data: ``(d0 - d4 - d5 - d6) / 2``).
    identified : ndarray of bool, shape (p,)
        True where the coefficient alone is determined by the data (orthogonal to the null space).
    stderr : ndarray, shape (p,)
        Standard error of each identified coefficient, ``sqrt(diag(sigma^2 (X^T X)^+))``, in the
        coefficient's unit; NaN where not identified (or where no residual degree of freedom is
        left to estimate sigma).
    sigma : float
        Residual standard deviation ``sqrt(RSS / (n - rank))`` in the target's unit (NaN when
        ``n == rank``).
    combinations : ndarray, shape (m, p)
        Rows ``a`` of identified combinations ``a . coef`` of the unidentified coefficients (a
        reduced row-echelon basis of the identifiable subspace on those coefficients; empty when
        full rank).
    combination_values : ndarray, shape (m,)
        ``combinations @ coef``.
    combination_stderr : ndarray, shape (m,)
        ``sqrt(a^T sigma^2 (X^T X)^+ a)`` for each row.
    summary : list of str
        Human-readable statements of the above.
    """

    names: tuple
    rank: int
    n_terms: int
    n_samples: int
    condition: float
    condition_identified: float
    singular_values: np.ndarray
    null_basis: np.ndarray
    identified: np.ndarray
    stderr: np.ndarray
    sigma: float
    combinations: np.ndarray
    combination_values: np.ndarray
    combination_stderr: np.ndarray
    summary: list = field(default_factory=list)

    @property
    def full_rank(self) -> bool:
        """True when every coefficient is identified."""
        return self.rank == self.n_terms

    @property
    def null_space(self) -> list[dict]:
        """The null-space basis as ``[{name: weight}, ...]`` (zero weights left out), e.g.
        ``[{"d0": 0.5, "d4": -0.5, "d5": -0.5, "d6": -0.5}]`` for ``|g| = 1`` FLNN data."""
        return [_as_terms(v, self.names) for v in self.null_basis]

    def identified_combinations(self) -> list[dict]:
        """Identified combinations, ``[{"weights": {name: w}, "value": v, "stderr": se}, ...]``."""
        return [{"weights": _as_terms(a, self.names), "value": float(v), "stderr": float(s)}
                for a, v, s in zip(self.combinations, self.combination_values,
                                   self.combination_stderr)]

    def to_state(self) -> tuple[dict, dict]:
        """JSON-able scalars and a dict of arrays (NaN and inf live in the arrays)."""
        info = {"names": list(self.names), "rank": int(self.rank), "n_terms": int(self.n_terms),
                "n_samples": int(self.n_samples), "summary": list(self.summary)}
        arrays = {"condition": np.array([self.condition, self.condition_identified, self.sigma]),
                  "singular_values": self.singular_values, "null_basis": self.null_basis,
                  "identified": self.identified, "stderr": self.stderr,
                  "combinations": self.combinations,
                  "combination_values": self.combination_values,
                  "combination_stderr": self.combination_stderr}
        return info, arrays

    @classmethod
    def from_state(cls, info: dict, arrays: dict) -> "Identifiability":
        """Inverse of :meth:`to_state`."""
        c = np.asarray(arrays["condition"], dtype=float)
        p = int(info["n_terms"])
        return cls(names=tuple(info["names"]), rank=int(info["rank"]), n_terms=p,
                   n_samples=int(info["n_samples"]), condition=float(c[0]),
                   condition_identified=float(c[1]), sigma=float(c[2]),
                   singular_values=np.asarray(arrays["singular_values"], dtype=float),
                   null_basis=np.asarray(arrays["null_basis"], dtype=float).reshape(-1, p),
                   identified=np.asarray(arrays["identified"], dtype=bool),
                   stderr=np.asarray(arrays["stderr"], dtype=float),
                   combinations=np.asarray(arrays["combinations"], dtype=float).reshape(-1, p),
                   combination_values=np.asarray(arrays["combination_values"], dtype=float),
                   combination_stderr=np.asarray(arrays["combination_stderr"], dtype=float),
                   summary=list(info["summary"]))


def _as_terms(v: np.ndarray, names) -> dict:
    return {n: float(w) for n, w in zip(names, v) if abs(w) > 1e-12}


def _format_combination(a: np.ndarray, names) -> str:
    parts = []
    for w, n in zip(a, names):
        if abs(w) < 1e-12:
            continue
        sign = "-" if w < 0 else "+"
        mag = abs(w)
        term = n if abs(mag - 1.0) < 1e-9 else f"{mag:.4g}*{n}"
        parts.append((sign, term))
    if not parts:
        return "0"
    text = ("-" if parts[0][0] == "-" else "") + parts[0][1]
    for sign, term in parts[1:]:
        text += f" {sign} {term}"
    return text


def _rref(a: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Reduced row-echelon form (partial pivoting), rows of exact zeros dropped."""
    a = np.array(a, dtype=float)
    rows, cols = a.shape
    r = 0
    for c in range(cols):
        if r == rows:
            break
        piv = r + int(np.argmax(np.abs(a[r:, c])))
        if abs(a[piv, c]) <= tol:
            continue
        a[[r, piv]] = a[[piv, r]]
        a[r] /= a[r, c]
        others = np.arange(rows) != r
        a[others] -= np.outer(a[others, c], a[r])
        r += 1
    a = a[:r]
    a[np.abs(a) < tol] = 0.0
    return a


#: A column whose RMS is below this fraction of the largest column's holds rounding, not a
#: regressor: the lab's nominal attitude puts gy gz at 1e-17 g^2 where the truth's table has
#: 5 arcsec of tilt (2.4e-5 g^2); scaled to unit RMS, the rounding looked like a well-conditioned
#: column and its coefficient came out at 1e14 deg/h/g^2 (thermal_with_motion, lab references).
NUMERICALLY_ZERO = 1e-10


def _column_scale(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(unit-RMS scale of each column, mask of numerically zero columns)."""
    s = np.sqrt(np.mean(X * X, axis=0))
    zero = ~(s > NUMERICALLY_ZERO * (s.max() if s.size else 0.0))
    s[zero] = 1.0
    return s, zero


def lstsq_identify(X: np.ndarray, y: np.ndarray, names, rcond: float = DEFAULT_RCOND,
                   label: str = "least squares", warn: bool = True):
    """Minimum-norm least squares ``X coef ~ y`` with an identifiability report.

    The columns of ``X`` are scaled to unit RMS, the scaled design is decomposed by SVD, singular
    values below ``rcond`` times the largest are treated as zero (numerical rank), and the
    solution is the pseudo-inverse one: the minimum-norm solution *in the column-scaled
    coordinates* (its component along the null space is zero). For a full-rank design it is the
    ordinary least-squares solution ``(X^T X)^-1 X^T y`` of paper [1]_ eq. 4.

    Parameters
    ----------
    X : ndarray, shape (n, p)
        Design matrix, each column in its own unit.
    y : ndarray, shape (n,)
        Target, in the model's output unit (rad/s here).
    names : sequence of str, length p
        Coefficient names for the report.
    rcond : float
        Relative singular-value threshold for the numerical rank (> 0).
    label : str
        Method name used in warning messages.
    warn : bool
        Issue an :class:`IdentifiabilityWarning` when rank-deficient or when the identified part
        has a condition number above ``COND_WARN``.

    Returns
    -------
    coef : ndarray, shape (p,)
        Coefficients, column j in (unit of y) / (unit of column j).
    report : Identifiability
        Rank, conditioning, null space, identified coefficients and combinations, standard
        errors ``sigma^2 (X^T X)^+`` with ``sigma^2 = RSS / (n - rank)``.

    References
    ----------
    .. [1] Chen & Cheng 2000 (fogbench seed 004), eq. 4 (pseudo-inverse solution).
    """
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    names = tuple(names)
    n, p = X.shape
    if y.shape != (n,):
        raise ValueError(f"y: shape must be ({n},) to match X, got {y.shape}")
    if len(names) != p:
        raise ValueError(f"names: need {p} names, got {len(names)}")
    if not (np.isfinite(rcond) and rcond > 0):
        raise ValueError(f"rcond: must be a positive finite number, got {rcond!r}")
    s, zero = _column_scale(X)
    if zero.any():          # such a column identifies nothing: its coefficient is in the null space
        X = X.copy()
        X[:, zero] = 0.0
    coef, S, Vt, S_full, r = _min_norm_solution(X, y, s, rcond)
    resid = y - X @ coef
    dof = n - r
    sigma = float(np.sqrt(resid @ resid / dof)) if dof > 0 else float("nan")
    # covariance of the minimum-norm estimate, sigma^2 (X^T X)^+, back in physical coordinates
    Vr = Vt[:r].T / S[:r]
    cov = (sigma ** 2) * (Vr @ Vr.T) / np.outer(s, s)
    null = _null_basis(X, s, Vt, r)
    in_null = np.max(np.abs(null), axis=0) > _NULL_TOL if null.size else np.zeros(p, bool)
    identified = ~in_null
    stderr = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    stderr[~identified] = np.nan
    comb = _identified_combinations(null, in_null)
    comb_val = comb @ coef
    comb_se = np.sqrt(np.clip(np.einsum("ij,jk,ik->i", comb, cov, comb), 0.0, None))
    cond = float(S_full[0] / S_full[-1]) if S_full[-1] > 0 else float("inf")
    cond_id = float(S_full[0] / S_full[r - 1]) if r else float("inf")
    summary = _identifiability_summary(label, names, n, r, cond, cond_id, null, in_null,
                                       comb)
    report = Identifiability(
        names=names, rank=r, n_terms=p, n_samples=n, condition=cond, condition_identified=cond_id,
        singular_values=S_full, null_basis=null, identified=identified, stderr=stderr,
        sigma=sigma, combinations=comb, combination_values=comb_val, combination_stderr=comb_se,
        summary=summary)
    if warn:
        _warn_identifiability(report, label)
    return coef, report


def _min_norm_solution(X: np.ndarray, y: np.ndarray, s: np.ndarray, rcond: float):
    """The SVD of the column-scaled design ``X / s`` and the minimum-norm solution in those
    coordinates, back in physical ones: (coef, S, Vt, S_full, r), ``S_full`` the singular values
    padded with zeros to p, ``r`` the numerical rank (those above ``rcond`` times the largest)."""
    p = X.shape[1]
    U, S, Vt = np.linalg.svd(X / s, full_matrices=False)
    S_full = np.zeros(p)
    S_full[:S.size] = S
    tol = rcond * S_full[0] if S_full[0] > 0 else np.inf
    r = int(np.sum(S_full > tol))
    c = Vt[:r].T @ ((U[:, :r].T @ y) / S[:r]) if r else np.zeros(p)
    return c / s, S, Vt, S_full, r


def _warn_identifiability(report: Identifiability, label: str) -> None:
    """An :class:`IdentifiabilityWarning` when the design is rank-deficient (the report's lines)
    or its identified part has a condition number above ``COND_WARN``."""
    if report.rank < report.n_terms:
        _warn("; ".join(report.summary[1:]), IdentifiabilityWarning)
    elif report.condition_identified > COND_WARN:
        _warn(f"{label}: design badly conditioned (condition number "
              f"{report.condition_identified:.3g} > {COND_WARN:g} after column scaling); see the "
              "stderr of each coefficient in identifiability_", IdentifiabilityWarning)


def _null_basis(X: np.ndarray, s: np.ndarray, Vt: np.ndarray, r: int) -> np.ndarray:
    """A readable orthonormal basis of the design's null space, shape (p - r, p), in physical
    coordinates: rows r.. of V^T (the SVD of the column-scaled design ``X / s``) mapped back,
    small weights dropped, in reduced row-echelon form, each row's first weight positive."""
    p = X.shape[1]
    if r >= p:
        return np.zeros((0, p))
    Vfull = Vt if Vt.shape[0] == p else np.linalg.svd(X / s, full_matrices=True)[2]
    Q, _ = np.linalg.qr(Vfull[r:].T / s[:, None])        # (p, k), physical coordinates
    # weights below 1e-3 of a direction's largest come from the design's own small errors
    # (|g| not exactly 1 on a real table), not from the structure: drop them
    Q = np.where(np.abs(Q) < 1e-3 * np.abs(Q).max(axis=0, keepdims=True), 0.0, Q)
    # a readable basis of that subspace: reduced row-echelon rows, then Gram-Schmidt
    null, _ = np.linalg.qr(_rref(Q.T, tol=1e-12).T)
    null = null.T
    for i in range(null.shape[0]):                       # first non-zero weight > 0
        if null[i, int(np.argmax(np.abs(null[i]) > 1e-8))] < 0:
            null[i] = -null[i]
    null[np.abs(null) < 1e-13] = 0.0
    return null


def _identified_combinations(null: np.ndarray, in_null: np.ndarray) -> np.ndarray:
    """The combinations of the coefficients not identified one by one (``in_null``) that the
    design does identify: the complement of the null space among them, shape (c, p), reduced
    row-echelon rows."""
    p = in_null.shape[0]
    J = np.flatnonzero(in_null)
    if not J.size:
        return np.zeros((0, p))
    NJ = null[:, J].T                                     # (|J|, k)
    Uj, Sj, _ = np.linalg.svd(NJ, full_matrices=True)
    k = int(np.sum(Sj > 1e-10))
    comp = Uj[:, k:].T                                    # (|J| - k, |J|)
    comp = _rref(comp) if comp.size else comp
    comb = np.zeros((comp.shape[0], p))
    comb[:, J] = comp
    return comb


def _identifiability_summary(label: str, names: tuple, n: int, r: int, cond: float,
                             cond_id: float, null: np.ndarray, in_null: np.ndarray,
                             comb: np.ndarray) -> list[str]:
    """The report's lines: rank and conditioning; for a rank-deficient design the coefficients
    not identifiable one by one, the null directions and the combinations identified instead;
    the coefficients identified one by one."""
    p = in_null.shape[0]
    summary = [f"{label}: rank {r} of {p} ({n} samples), condition number {cond:.3g} "
               f"(identified part {cond_id:.3g})"]
    if r < p:
        unid = [names[j] for j in np.flatnonzero(in_null)]
        summary.append(f"not identifiable one by one: {', '.join(unid)}")
        for v in null:
            summary.append("null direction (no effect on the fit): "
                           + _format_combination(v, names))
        if comb.shape[0]:
            summary.append("identified instead: " + ", ".join(
                _format_combination(a, names) for a in comb))
        summary.append("minimum-norm solution (column-scaled coordinates) reported for "
                       + ", ".join(unid))
    identified = ~in_null
    if np.any(identified):
        summary.append("identified one by one: " + ", ".join(
            names[j] for j in np.flatnonzero(identified)))
    return summary


# ---------------------------------------------------------------------------------------------
# The FLNN
def flnn_features(g: np.ndarray) -> np.ndarray:
    """The functional-link expansion of paper eq. 8 / eq. 10.

    Parameters
    ----------
    g : ndarray, shape (n, 3)
        Specific force along the gyro axes (gx, gy, gz), in g.

    Returns
    -------
    ndarray, shape (n, 10)
        Columns ``[1, gx, gy, gz, gx^2, gy^2, gz^2, gx gy, gy gz, gx gz]`` (units 1, g, g^2),
        the regressors of d0 ... d9.

    References
    ----------
    Chen & Cheng 2000 (fogbench seed 004), eqs. 8-10.
    """
    g = np.asarray(g, dtype=float)
    if g.ndim != 2 or g.shape[1] != 3:
        raise ValueError(f"g: shape must be (n, 3), got {g.shape}")
    gx, gy, gz = g.T
    return np.column_stack([np.ones(g.shape[0]), gx, gy, gz, gx * gx, gy * gy, gz * gz,
                            gx * gy, gy * gz, gx * gz])


def _state_with_ident(ident: Identifiability, info: dict, arrays: dict) -> tuple[dict, dict]:
    i_info, i_arrays = ident.to_state()
    info = dict(info, identifiability=i_info)
    arrays = dict(arrays, **{f"ident_{k}": v for k, v in i_arrays.items()})
    return info, arrays


def _restore_ident(info: dict, arrays: dict) -> Identifiability:
    return Identifiability.from_state(
        info["identifiability"],
        {k[len("ident_"):]: v for k, v in arrays.items() if k.startswith("ident_")})


class _FlnnBase(Compensator):
    """What both FLNN estimators share: the expansion, the units, the estimate and persistence.

    Attributes
    ----------
    coef_ : ndarray, shape (10,)
        d0 ... d9 of paper eq. 8: d0 in rad/s, d1-d3 in rad/s/g, d4-d9 in rad/s/g^2.
    identifiability_ : Identifiability
        Rank, condition number, null space, identified combinations and standard errors of the
        least-squares problem on the fitting data (see :func:`lstsq_identify`).

    Re-calibration: every call of ``fit`` starts afresh and replaces ``coef_`` (the paper's
    on-line dynamic calibration at each switch-on: a short multi-position record, a new fit).
    """

    requires = ("g",)
    supervised = True
    coef_names = _COEF_NAMES

    def coef_dph(self) -> dict:
        """The coefficients in datasheet units.

        Returns
        -------
        dict
            ``{"d0_dph": ..., "d1_dph_per_g": ..., ..., "d4_dph_per_g2": ..., ...}``: d0 in deg/h,
            d1-d3 in deg/h/g, d4-d9 in deg/h/g^2 (the units of paper Table 1).
        """
        self._check_fitted()
        return {k: float(v / DPH) for k, v in zip(_DPH_KEYS, self.coef_)}

    def _estimate(self, data: GyroData) -> np.ndarray:
        return flnn_features(data.g) @ self.coef_

    def _identify(self, F: np.ndarray, error: np.ndarray):
        rcond = _check_rcond(self.rcond)
        return lstsq_identify(F, error, _COEF_NAMES, rcond=rcond, label=self.name)


@register
class FlnnLstsq(_FlnnBase):
    """FLNN drift model solved in closed form: the pseudo-inverse least-squares solution.

    ``coef = (X^T X)^-1 X^T y`` (paper eq. 4) with X the functional-link expansion of g
    (eq. 8 / eq. 10), computed by SVD of the column-scaled design. When the data do not identify
    every coefficient (static positions only, ``|g| = 1``: d0, d4, d5, d6 are tied), the
    minimum-norm solution in column-scaled coordinates is returned and an
    :class:`IdentifiabilityWarning` says which combinations are determined; see
    ``identifiability_``.

    Parameters
    ----------
    rcond : float, default 1e-4
        Relative singular-value threshold (of the column-scaled design) for the numerical rank.

    Attributes
    ----------
    coef_ : ndarray, shape (10,)
        d0 (rad/s), d1-d3 (rad/s/g), d4-d9 (rad/s/g^2).
    identifiability_ : Identifiability
        See :func:`lstsq_identify`.

    References
    ----------
    .. [1] Chen & Cheng 2000 (fogbench seed 004): eq. 4 (pseudo-inverse), eqs. 8-10 (model).
    """

    name = "flnn_lstsq"

    def __init__(self, rcond: float = DEFAULT_RCOND):
        self.rcond = rcond

    def _validate(self) -> None:
        _check_rcond(self.rcond)

    def _fit(self, data: GyroData, error: np.ndarray) -> None:
        self._validate()
        F = flnn_features(data.g)
        self.coef_, self.identifiability_ = self._identify(F, error)

    def _state(self):
        return _state_with_ident(self.identifiability_, {}, {"coef": self.coef_})

    def _restore(self, info, arrays):
        self.coef_ = np.asarray(arrays["coef"], dtype=float)
        self.identifiability_ = _restore_ident(info, arrays)


def _lms_pass(w: np.ndarray, F: np.ndarray, y: np.ndarray, mu: np.ndarray,
              chunk: int = 64, grams: np.ndarray | None = None,
              scale: float = 1.0) -> np.ndarray:
    """One sequential LMS pass, ``w <- w + mu_k (y_k - f_k . w) f_k`` for k = 0 ... n-1.

    Exact (up to rounding) but vectorised by chunks. Inside a chunk that starts with weights
    ``w0``, the weights before update k are ``w0 + sum_{j<k} mu_j e_j f_j``, so the errors obey
    ``e_k + sum_{j<k} mu_j (f_k . f_j) e_j = y_k - f_k . w0``: a unit lower-triangular system
    whose forward substitution (LAPACK ``dtrsv``) is the LMS recursion itself. The chunk then
    ends at ``w0 + F_c^T (mu * e)``. Per sample this costs ``chunk * p`` multiply-adds in BLAS
    (the Gram matrix of the chunk) instead of p in a Python loop. The tests compare it with
    the plain loop.

    Parameters
    ----------
    w : ndarray, shape (p,)
        Weights at the start of the pass.
    F : ndarray, shape (n, p)
        Inputs, in presentation order.
    y : ndarray, shape (n,)
        Targets.
    mu : ndarray, shape (n,)
        Step of each update (alpha, or alpha / ||f_k||^2 for normalised LMS).
    chunk : int
        Samples per triangular solve (64: the fastest here).
    grams, scale : ndarray or None, float
        The chunks' matrices from :func:`chunk_grams` (same ``F`` and chunk) when
        ``mu = scale * step``: reused between passes instead of recomputed.

    Returns
    -------
    ndarray, shape (p,)
        Weights after the pass.

    References
    ----------
    Chen & Cheng 2000 (fogbench seed 004), eqs. 5-7 (output, error, weight update).
    """
    n = F.shape[0]
    if grams is not None and grams.shape != (-(-n // chunk), chunk, chunk):
        raise ValueError(f"grams: shape {grams.shape} is not that of chunk_grams(F, step, "
                         f"chunk={chunk}) for {n} samples")
    w = np.array(w, dtype=float)
    for i, s in enumerate(range(0, n, chunk)):
        f = F[s:s + chunk]
        m = mu[s:s + chunk]
        r = y[s:s + chunk] - f @ w
        # A[k, j] = mu_j f_k . f_j, built as its transpose in C order: A itself in Fortran
        # order, as LAPACK reads it (no copy)
        if grams is None:
            At = f @ f.T
            At *= m[:, None]
        else:
            At = grams[i][:f.shape[0], :f.shape[0]] * scale
        At.flat[::At.shape[0] + 1] = 1.0
        e = _dtrsv(At.T, r, lower=1)                # the strict upper part is not read
        e *= m
        w += e @ f
    return w


#: Largest memory, bytes, for the Gram matrices :func:`chunk_grams` keeps between LMS passes.
GRAM_BYTES = 64 * 2 ** 20


def chunk_grams(F: np.ndarray, step: np.ndarray, chunk: int = 64):
    """``A[k, j] = step_j f_k . f_j`` of every chunk, transposed (the layout :func:`_lms_pass`
    hands to LAPACK), shape (n_chunks, chunk, chunk), for the
    passes of :func:`_lms_pass` over a fixed order, whose step is ``alpha * step`` (pass them
    with ``scale=alpha``); None when they would take more than :data:`GRAM_BYTES`."""
    n = F.shape[0]
    nc = -(-n // chunk)
    if nc * chunk * chunk * 8 > GRAM_BYTES:
        return None
    out = np.zeros((nc, chunk, chunk))
    for i, s in enumerate(range(0, n, chunk)):
        f = F[s:s + chunk]
        k = f.shape[0]
        np.matmul(f, f.T, out=out[i, :k, :k])
        out[i, :k, :k] *= step[s:s + chunk, None]
    return out


def find_dwells(g: np.ndarray, tol_g: float) -> np.ndarray:
    """Dwell index of every sample: a new dwell starts where some component of g changes by
    more than ``tol_g`` from the previous sample.

    Parameters
    ----------
    g : ndarray, shape (n, 3)
        Specific force, g.
    tol_g : float
        Largest sample-to-sample change within one dwell, g.

    Returns
    -------
    ndarray of int, shape (n,)
        0, 0, ..., 1, 1, ...: consecutive integers, one per dwell, in recorded order.
    """
    g = np.asarray(g, dtype=float)
    jump = np.zeros(g.shape[0], dtype=int)
    if g.shape[0] > 1:
        jump[1:] = np.max(np.abs(np.diff(g, axis=0)), axis=1) > tol_g
    return np.cumsum(jump)


#: Sample presentations of :class:`Flnn` (see its docstring).
PRESENTATIONS = ("recorded", "shuffled", "dwell_means")


def _dwell_means(F: np.ndarray, y: np.ndarray, dwell: np.ndarray):
    """Mean of the rows of ``F`` and of ``y`` over each dwell (``dwell``: consecutive ids)."""
    m = int(dwell[-1]) + 1
    cnt = np.bincount(dwell, minlength=m).astype(float)
    Fm = np.stack([np.bincount(dwell, weights=F[:, j], minlength=m) for j in range(F.shape[1])],
                  axis=1) / cnt[:, None]
    ym = np.bincount(dwell, weights=y, minlength=m) / cnt
    return Fm, ym


def _real(v) -> bool:
    return (isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)
            and bool(np.isfinite(v)))


def _check_rcond(rcond) -> float:
    if not (_real(rcond) and rcond > 0):
        raise ValueError(f"rcond: must be a positive finite number, got {rcond!r}")
    return float(rcond)


@register
class Flnn(_FlnnBase):
    """Functional-link neural network trained by (normalised) LMS, as in the paper.

    One linear layer on the ten functional-link terms of g (paper eq. 8 / eq. 10). Training
    (paper eqs. 5-7): samples are presented one after another in their recorded order,
    ``e(k) = y(k) - w . f(k)``, ``w <- w + mu_k e(k) f(k)``; one pass over all samples is one
    iteration; the learning factor alpha falls linearly from ``alpha_start`` (0.95) to
    ``alpha_end`` (0.4) over ``n_iter`` iterations; initial weights uniform in (-1, 1).

    Normalisation (the paper normalises before learning without saying how): each functional-
    link column is divided by its RMS over the fitting data (so the constant column stays 1) and
    the target by its RMS; no centring, so that the map back is a plain rescaling and the
    de-normalised coefficients come out exactly in the model's units,
    ``d_j = w_j * rms(y) / rms(f_j)``.

    Normalised LMS (``normalized=True``, default): ``mu_k = alpha / ||f(k)||^2``. Plain LMS,
    ``mu_k = alpha``, is stable only for ``alpha < 2 / lambda_max(R) <= 2 / trace(R)``; with ten
    unit-RMS features ``trace(R) = 10``, so the paper's alpha = 0.95 makes it diverge (each update
    overshoots the error by a factor ``alpha ||f||^2 ~ 10``). The normalised form (Widrow's
    alpha-LMS) is stable for ``0 < alpha < 2`` whatever the scaling, which is why it is the
    default; ``normalized=False`` gives the literal eq. 7 and raises
    :class:`~fogcomp.DivergenceError` when it blows up.

    The weights along the null space of the design (``|g| = 1`` data: ``d0 - d4 - d5 - d6``)
    never change under LMS (every update is along some ``f(k)``, orthogonal to it), so they keep
    their random initial value. With ``min_norm=True`` (default) that component is removed
    after training, which makes the answer the same minimum-norm representative as
    ``flnn_lstsq``; ``identifiability_`` says which combinations are determined.

    With noise, LMS with a step that does not go to zero keeps a misadjustment: the final
    weights scatter around the least-squares ones, weighted towards the last samples presented
    (memory of about ``p / alpha_end`` = 25 samples). ``identifiability_.stderr`` is that of the
    least-squares estimate on the same data, a lower bound for the LMS weights.

    Presentation (``presentation``), three readings of "samples presented in sequence, one
    pass = one iteration" (paper section 4):

    * ``"recorded"`` (default, the literal reading): every sample, in recorded order, each pass.
      With a 10 Hz record the final weights mostly fit the last ~25 samples presented.
    * ``"shuffled"``: every sample, in a new random order each pass (from ``random_state``).
    * ``"dwell_means"``: one sample per dwell (static position): the mean of the functional-
      link terms and of the error over the dwell, dwells in recorded order. Dwells are the
      runs of samples whose g changes by no more than ``dwell_tol_g`` from one sample to the
      next (:func:`find_dwells`), or, when ``data.meta["dwell_id"]`` holds an integer array
      of shape (n,), the runs of equal ids there. The paper's Table 1 comes from positions,
      one value each; fed means, LMS converges to the least-squares fit of the means.

    Parameters
    ----------
    n_iter : int, default 100
        Maximum number of passes (the paper: "until the MSE is small"; it gives no number).
    alpha_start, alpha_end : float, default 0.95, 0.4
        Learning factor at the first and last pass (paper section 5), linear in between.
    normalized : bool, default True
        Normalised LMS (see above) or the literal eq. 7.
    tol : float, default 1e-6
        Stop early when the relative change of the MSE over one pass is below ``tol``.
    min_norm : bool, default True
        Remove the (data-undetermined) null-space component of the weights after training.
    warm_start : bool, default False
        When already fitted, start LMS from the previous coefficients instead of random weights
        (a re-calibration that begins from the last switch-on's values).
    rcond : float, default 1e-4
        Relative singular-value threshold for the identifiability analysis.
    presentation : {"recorded", "shuffled", "dwell_means"}, default "recorded"
        What each pass presents (see above).
    dwell_tol_g : float, default 0.01
        Largest sample-to-sample change of any g component within one dwell, g (used by
        ``presentation="dwell_means"`` when the data carry no ``meta["dwell_id"]``).
    random_state : int, numpy Generator or None
        Seed for the initial weights and the shuffling (required).

    Attributes
    ----------
    coef_ : ndarray, shape (10,)
        d0 (rad/s), d1-d3 (rad/s/g), d4-d9 (rad/s/g^2).
    loss_curve_ : ndarray, shape (``n_iter_`` + 1,)
        MSE over the presented samples (normalised units) with the initial weights and after
        each pass.
    n_presented_ : int
        Samples presented per pass (the number of dwells for ``"dwell_means"``).
    n_iter_ : int
        Number of passes run.
    identifiability_ : Identifiability
        See :func:`lstsq_identify`.

    References
    ----------
    .. [1] Chen & Cheng 2000 (fogbench seed 004): eqs. 5-7 (FLNN output, error, LMS update),
       eqs. 8-10 (drift model), section 5 (normalisation, alpha 0.95 -> 0.4, weights in (-1, 1)).
    .. [2] Widrow & Lehr 1990, Proc. IEEE 78(9): alpha-LMS (normalised LMS) and its stability.
    """

    name = "flnn"
    random = True

    def __init__(self, n_iter: int = 100, alpha_start: float = 0.95, alpha_end: float = 0.4,
                 normalized: bool = True, tol: float = 1e-6, min_norm: bool = True,
                 warm_start: bool = False, rcond: float = DEFAULT_RCOND,
                 presentation: str = "recorded", dwell_tol_g: float = 0.01, random_state=None):
        self.n_iter = n_iter
        self.alpha_start = alpha_start
        self.alpha_end = alpha_end
        self.normalized = normalized
        self.tol = tol
        self.min_norm = min_norm
        self.warm_start = warm_start
        self.rcond = rcond
        self.presentation = presentation
        self.dwell_tol_g = dwell_tol_g
        self.random_state = random_state

    def _validate(self) -> None:
        if not (isinstance(self.n_iter, (int, np.integer)) and not isinstance(self.n_iter, bool)
                and self.n_iter >= 1):
            raise ValueError(f"n_iter: must be an integer >= 1, got {self.n_iter!r}")
        for nm in ("alpha_start", "alpha_end"):
            a = getattr(self, nm)
            if not (_real(a) and a > 0):
                raise ValueError(f"{nm}: must be a positive finite number, got {a!r}")
            if self.normalized and a >= 2:
                raise ValueError(f"{nm}: normalised LMS is stable only for 0 < alpha < 2, "
                                 f"got {a!r}")
        if not (_real(self.tol) and self.tol >= 0):
            raise ValueError(f"tol: must be a finite number >= 0, got {self.tol!r}")
        for nm in ("normalized", "min_norm", "warm_start"):
            if not isinstance(getattr(self, nm), (bool, np.bool_)):
                raise ValueError(f"{nm}: expected True or False, got {getattr(self, nm)!r}")
        _check_rcond(self.rcond)
        if not (isinstance(self.presentation, str) and self.presentation in PRESENTATIONS):
            raise ValueError(f"presentation: expected one of {list(PRESENTATIONS)}, got "
                             f"{self.presentation!r}")
        if not (_real(self.dwell_tol_g) and self.dwell_tol_g >= 0):
            raise ValueError(f"dwell_tol_g: must be a finite number >= 0 (g), got "
                             f"{self.dwell_tol_g!r}")
        _random_state(self.random_state)

    def _fit(self, data: GyroData, error: np.ndarray) -> None:
        self._validate()
        dwell = self._dwells(data) if self.presentation == "dwell_means" else None
        F = flnn_features(data.g)
        prev = getattr(self, "coef_", None) if (self.warm_start and
                                                getattr(self, "fitted_", False)) else None
        self.fitted_ = False                       # a re-fit replaces everything
        _, ident = self._identify(F, error)
        s, zero = _column_scale(F)
        y_scale = float(np.sqrt(np.mean(error * error))) or 1.0
        Fs = F / s
        Fs[:, zero] = 0.0       # rounding, not a regressor (NUMERICALLY_ZERO): left untrained
        ys = error / y_scale
        rng = self._rng()
        if prev is not None:
            w = prev * s / y_scale
        else:
            w = rng.uniform(-1.0, 1.0, size=F.shape[1])
        if self.presentation == "dwell_means":
            Fs, ys = _dwell_means(Fs, ys, dwell)
        sq = np.einsum("ij,ij->i", Fs, Fs)
        step = 1.0 / (1e-12 + sq) if self.normalized else np.ones_like(sq)
        # a fixed order: every pass solves with the same chunk matrices, times its alpha
        grams = chunk_grams(Fs, step) if self.presentation != "shuffled" else None

        def mse(w):
            r = Fs @ w - ys
            return float(r @ r / r.size)

        losses = [mse(w)]
        l0 = losses[0]
        n_iter = int(self.n_iter)
        alphas = np.linspace(self.alpha_start, self.alpha_end, n_iter) if n_iter > 1 else \
            np.array([float(self.alpha_start)])
        for it in range(n_iter):
            with np.errstate(all="ignore"):
                if self.presentation == "shuffled":
                    order = rng.permutation(Fs.shape[0])
                    w = _lms_pass(w, Fs[order], ys[order], alphas[it] * step[order])
                else:
                    w = _lms_pass(w, Fs, ys, alphas[it] * step, grams=grams,
                                  scale=alphas[it])
                loss = mse(w)
            if not (np.all(np.isfinite(w)) and np.isfinite(loss)) or loss > _EXPLODE * max(l0, 1.0):
                raise DivergenceError(
                    f"{self.name}: LMS diverged at pass {it + 1} (alpha {alphas[it]:.3g}, MSE "
                    f"{loss:.3g} from {l0:.3g}); "
                    + ("plain LMS needs alpha < 2/trace(R); use normalized=True"
                       if not self.normalized else "check the data"))
            losses.append(loss)
            if abs(losses[-2] - loss) <= self.tol * losses[-2]:
                break
        if self.min_norm and ident.null_basis.shape[0]:
            Nc, _ = np.linalg.qr((ident.null_basis * s).T)   # null space, scaled coordinates
            w = w - Nc @ (Nc.T @ w)
        self.coef_ = w * y_scale / s
        self.loss_curve_ = np.asarray(losses)
        self.n_iter_ = len(losses) - 1
        self.n_presented_ = int(Fs.shape[0])
        self.identifiability_ = ident

    def _dwells(self, data: GyroData) -> np.ndarray:
        ids = data.meta.get("dwell_id") if isinstance(data.meta, dict) else None
        if ids is None:
            return find_dwells(data.g, float(self.dwell_tol_g))
        ids = np.asarray(ids)
        if ids.shape != (len(data),) or not np.issubdtype(ids.dtype, np.integer):
            raise ValueError(f"meta['dwell_id']: expected an integer array of shape "
                             f"({len(data)},), got dtype {ids.dtype} shape {ids.shape}")
        run = np.zeros(len(data), dtype=int)
        run[1:] = ids[1:] != ids[:-1]
        return np.cumsum(run)

    def _state(self):
        return _state_with_ident(self.identifiability_, {"n_iter_": self.n_iter_,
                                                         "n_presented_": self.n_presented_},
                                 {"coef": self.coef_, "loss_curve": self.loss_curve_})

    def _restore(self, info, arrays):
        self.coef_ = np.asarray(arrays["coef"], dtype=float)
        self.loss_curve_ = np.asarray(arrays["loss_curve"], dtype=float)
        self.n_iter_ = int(info["n_iter_"])
        self.n_presented_ = int(info["n_presented_"])
        self.identifiability_ = _restore_ident(info, arrays)
