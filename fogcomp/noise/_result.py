"""The result of the identification: :class:`NoiseModel` and its :class:`ModelTerm` terms,
in SI units, with their datasheet form (:meth:`NoiseModel.to_datasheet`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..units import ARCSEC, DEG_RT_H, DPH, DPH_PER_H, DPH_RT_H
from ._processes import TERM_NAMES, avar_model

# datasheet unit (SI per unit) and key of each term's coefficient
DATASHEET = {"N": (DEG_RT_H, "arw_deg_rt_h"), "B": (DPH, "bias_instability_dph"),
             "K": (DPH_RT_H, "rrw_dph_rt_h"), "Q": (ARCSEC, "quantisation_arcsec"),
             "R": (DPH_PER_H, "rate_ramp_dph_per_h"), "GM": (DPH, "gm_sigma_dph")}


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
        """The term ``"Q"``, ``"N"``, ``"B"``, ``"K"``, ``"R"`` (GM terms: ``gm_terms``)."""
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
