"""The engineer's deterministic error model, fitted in one least-squares solve.

::

    error = b0 + k w + sum_i d_i g_i + sum_{i<=j} d_ij g_i g_j
            + c_T (T - T0) + c_Tdot dT/dt  [+ c_T2 (T - T0)^2]

with w the true angular rate (rad/s), g the specific force (g), T the temperature (degC). It is
the union of the scale-factor error, the g-sensitive drift of the FLNN paper (eq. 8 [1]_) and
the temperature model of the ACO-BP paper (eq. 7 [2]_), which is how a calibration engineer
would write the gyro's systematic error (the terms of IEEE Std 952's FOG model equation [3]_)
before reaching for a neural network: a baseline for the learned methods.

.. rubric:: References

.. [1] Chen & Cheng 2000 (fogbench seed 004), eq. 8: the bias, g and g^2 terms.
.. [2] Qiu et al. 2023 (fogbench seed 002), eq. 7: the T and dT/dt terms (eq. 1, the Shupe
   error, is why dT/dt enters).
.. [3] IEEE Std 952-1997, IEEE Standard Specification Format Guide and Test Procedure for
   Single-Axis Interferometric Fiber Optic Gyros: the scale-factor, bias, g-sensitivity and
   temperature-sensitivity terms of the FOG model equation.
"""

from __future__ import annotations

import numpy as np

from .._data import GyroData
from .._estimator import Compensator, DivergenceError
from .._registry import register
from ..units import DPH, PPM
from .flnn import DEFAULT_RCOND, _restore_ident, _state_with_ident, lstsq_identify

__all__ = ["ModelLstsq", "TERM_GROUPS"]

#: Term groups, their coefficients, and each coefficient's (to-datasheet divisor, key suffix).
TERM_GROUPS = {
    "bias": (("bias", DPH, "bias_dph"),),
    "scale_factor": (("scale_factor", PPM, "scale_factor_ppm"),),
    "g": (("gx", DPH, "gx_dph_per_g"), ("gy", DPH, "gy_dph_per_g"), ("gz", DPH, "gz_dph_per_g")),
    "g2": (("gxx", DPH, "gxx_dph_per_g2"), ("gyy", DPH, "gyy_dph_per_g2"),
           ("gzz", DPH, "gzz_dph_per_g2"), ("gxy", DPH, "gxy_dph_per_g2"),
           ("gyz", DPH, "gyz_dph_per_g2"), ("gxz", DPH, "gxz_dph_per_g2")),
    "temp": (("temp", DPH, "temp_dph_per_c"),),
    "temp_rate": (("temp_rate", DPH, "temp_rate_dph_per_c_per_s"),),
    "temp2": (("temp2", DPH, "temp2_dph_per_c2"),),
}
_DEFAULT_TERMS = ("bias", "scale_factor", "g", "g2", "temp", "temp_rate")


@register
class ModelLstsq(Compensator):
    """Least-squares fit of bias, scale factor, g, g^2, temperature and temperature-rate terms.

    Model (coefficient: unit)::

        error = bias                                   rad/s
              + scale_factor * w                       1 (w: true rate, rad/s)
              + gx gx + gy gy + gz gz                  rad/s/g
              + gxx gx^2 + gyy gy^2 + gzz gz^2
              + gxy gx gy + gyz gy gz + gxz gx gz      rad/s/g^2
              + temp (T - T0)                          rad/s/degC
              + temp_rate dT/dt                        rad/s/(degC/s)
              + temp2 (T - T0)^2   (only if "temp2")   rad/s/degC^2

    Fitting uses the true rate ``w = data.rate - error`` (the reference the rig applied), so the
    scale-factor column carries no noise and every coefficient keeps its physical meaning. At
    estimate time the true rate is unknown; with ``raw = (1 + k) w + e`` (k the scale-factor
    error, e the sum of the other terms) the error is ``raw - w = (k raw + e) / (1 + k)``, which
    is what :meth:`~fogcomp.Compensator.estimate_error` returns (for the scale-factor part alone,
    ``error ~ k / (1 + k) raw``); the compensated rate ``(raw - e) / (1 + k)`` is then exact
    for data that follow the model.

    Solved by :func:`fogcomp.methods.flnn.lstsq_identify`: columns scaled to unit RMS, SVD,
    numerical rank with ``rcond``. A record that does not excite a term (constant temperature:
    ``T - T0`` collinear with the bias; static positions: ``gx^2 + gy^2 + gz^2 = 1``; a constant
    rate: scale factor collinear with the bias) is rank-deficient: the fit warns
    (:class:`~fogcomp.methods.flnn.IdentifiabilityWarning`), returns the minimum-norm solution
    and reports in ``identifiability_`` which combinations are determined.

    Parameters
    ----------
    terms : sequence of str, default ("bias", "scale_factor", "g", "g2", "temp", "temp_rate")
        Term groups to include, among ``"bias"``, ``"scale_factor"``, ``"g"`` (3 terms),
        ``"g2"`` (6 terms), ``"temp"``, ``"temp_rate"``, ``"temp2"`` (not in the default).
    t0_c : float or None, default None
        Reference temperature T0, degC; None uses the mean temperature of the fitting data.
    rcond : float, default 1e-4
        Relative singular-value threshold (column-scaled design) for the numerical rank.

    Attributes
    ----------
    coef_ : ndarray, shape (n_coef,)
        Coefficients in SI units, in the order of ``coef_names_``.
    coef_names_ : tuple of str
        Their names (``"bias"``, ``"scale_factor"``, ``"gx"``, ... ``"temp_rate"``).
    t0_c_ : float
        Reference temperature used, degC.
    identifiability_ : fogcomp.methods.flnn.Identifiability
        Rank, conditioning, null space, standard errors.

    References
    ----------
    .. [1] Chen & Cheng 2000 (fogbench seed 004), eq. 8 (g and g^2 terms).
    .. [2] Qiu et al. 2023 (fogbench seed 002), eq. 7 (T and dT/dt terms).
    .. [3] IEEE Std 952-1997 (FOG model equation).
    """

    name = "model_lstsq"
    requires = ("rate", "g", "temp", "temp_rate")
    supervised = True

    def __init__(self, terms=_DEFAULT_TERMS, t0_c=None, rcond: float = DEFAULT_RCOND):
        self.terms = terms
        self.t0_c = t0_c
        self.rcond = rcond

    def _groups(self) -> tuple:
        terms = self.terms
        if isinstance(terms, str) or not hasattr(terms, "__iter__"):
            raise ValueError(f"terms: expected a sequence of group names among "
                             f"{list(TERM_GROUPS)}, got {terms!r}")
        terms = tuple(terms)
        bad = [t for t in terms if not isinstance(t, str) or t not in TERM_GROUPS]
        if bad:
            raise ValueError(f"terms: unknown group(s) {bad}; valid: {list(TERM_GROUPS)}")
        if not terms:
            raise ValueError("terms: at least one group is needed")
        if len(set(terms)) != len(terms):
            raise ValueError(f"terms: groups repeated in {list(terms)}")
        # canonical order, whatever the order given
        return tuple(t for t in TERM_GROUPS if t in terms)

    def _columns(self, data: GyroData, rate: np.ndarray, groups, t0: float) -> np.ndarray:
        cols = []
        gx, gy, gz = data.g.T
        dT = data.temp - t0
        for grp in groups:
            if grp == "bias":
                cols.append(np.ones(len(data)))
            elif grp == "scale_factor":
                cols.append(rate)
            elif grp == "g":
                cols += [gx, gy, gz]
            elif grp == "g2":
                cols += [gx * gx, gy * gy, gz * gz, gx * gy, gy * gz, gx * gz]
            elif grp == "temp":
                cols.append(dT)
            elif grp == "temp_rate":
                cols.append(data.temp_rate)
            elif grp == "temp2":
                cols.append(dT * dT)
        return np.column_stack(cols)

    def _validate(self) -> tuple:
        """Check every hyperparameter; returns the term groups in canonical order."""
        groups = self._groups()
        if self.t0_c is not None and not (
                isinstance(self.t0_c, (int, float, np.integer, np.floating))
                and not isinstance(self.t0_c, bool) and np.isfinite(self.t0_c)):
            raise ValueError(f"t0_c: must be a finite temperature in degC or None, "
                             f"got {self.t0_c!r}")
        if not (isinstance(self.rcond, (int, float, np.floating)) and not isinstance(
                self.rcond, bool) and np.isfinite(self.rcond) and self.rcond > 0):
            raise ValueError(f"rcond: must be a positive finite number, got {self.rcond!r}")
        return groups

    def _fit(self, data, error):
        groups = self._validate()
        t0 = float(np.mean(data.temp)) if self.t0_c is None else float(self.t0_c)
        names = tuple(c[0] for g in groups for c in TERM_GROUPS[g])
        true_rate = data.rate - error
        X = self._columns(data, true_rate, groups, t0)
        coef, ident = lstsq_identify(X, error, names, rcond=float(self.rcond), label=self.name)
        if "scale_factor" in groups and not abs(1.0 + coef[names.index("scale_factor")]) > 1e-6:
            raise DivergenceError(f"{self.name}: fitted scale-factor error "
                                  f"{coef[names.index('scale_factor')]:.6g} makes 1 + k = 0; the "
                                  "error model cannot be inverted")
        self.coef_, self.coef_names_, self.t0_c_, self.identifiability_ = coef, names, t0, ident

    def _estimate(self, data):
        # the same sum as ``columns @ coef_``, accumulated term by term so that a long record
        # does not build its (n, n_coef) design matrix
        c = dict(zip(self.coef_names_, self.coef_))
        n = len(data)
        other = np.full(n, c.get("bias", 0.0))
        if any(k in c for k in ("gx", "gy", "gz", "gxx", "gyy", "gzz", "gxy", "gyz", "gxz")):
            gx, gy, gz = data.g[:, 0], data.g[:, 1], data.g[:, 2]
            for name, col in (("gx", gx), ("gy", gy), ("gz", gz)):
                if name in c:
                    other += c[name] * col
            for name, a, b in (("gxx", gx, gx), ("gyy", gy, gy), ("gzz", gz, gz),
                               ("gxy", gx, gy), ("gyz", gy, gz), ("gxz", gx, gz)):
                if name in c:
                    other += c[name] * (a * b)
        if "temp" in c or "temp2" in c:
            dT = data.temp - self.t0_c_
            if "temp" in c:
                other += c["temp"] * dT
            if "temp2" in c:
                other += c["temp2"] * (dT * dT)
        if "temp_rate" in c:
            other += c["temp_rate"] * data.temp_rate
        if "scale_factor" not in c:
            return other
        k = c["scale_factor"]
        return (k * data.rate + other) / (1.0 + k)

    def coef_dict(self) -> dict:
        """The coefficients in datasheet units, each key ending in its unit.

        Returns
        -------
        dict
            e.g. ``bias_dph``, ``scale_factor_ppm``, ``gx_dph_per_g``, ``gxx_dph_per_g2``,
            ``temp_dph_per_c``, ``temp_rate_dph_per_c_per_s``, ``temp2_dph_per_c2``, plus
            ``t0_c`` (the reference temperature, degC).
        """
        self._check_fitted()
        lookup = {c[0]: c for grp in TERM_GROUPS.values() for c in grp}
        out = {lookup[n][2]: float(v / lookup[n][1]) for n, v in zip(self.coef_names_, self.coef_)}
        out["t0_c"] = self.t0_c_
        return out

    def _state(self):
        return _state_with_ident(self.identifiability_,
                                 {"coef_names_": list(self.coef_names_), "t0_c_": self.t0_c_},
                                 {"coef": self.coef_})

    def _restore(self, info, arrays):
        self.coef_ = np.asarray(arrays["coef"], dtype=float)
        self.coef_names_ = tuple(info["coef_names_"])
        self.t0_c_ = float(info["t0_c_"])
        self.identifiability_ = _restore_ident(info, arrays)
