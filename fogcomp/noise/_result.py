"""The result of the identification: :class:`NoiseModel` and its :class:`ModelTerm` terms,
in SI units, with their datasheet form (:meth:`NoiseModel.to_datasheet`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..units import ARCSEC, DEG_RT_H, DPH, DPH_PER_H, DPH_RT_H
from ._processes import TERM_NAMES, avar_model

#: The version of :meth:`NoiseModel.to_datasheet`'s shape (its docstring; the versions before
#: it are listed there).
DATASHEET_VERSION = 2
DATASHEET_FORMAT = "fogcomp.noise datasheet"

# datasheet unit (SI per unit) and key of each term's coefficient
DATASHEET = {"N": (DEG_RT_H, "arw_deg_rt_h"), "B": (DPH, "bias_instability_dph"),
             "K": (DPH_RT_H, "rrw_dph_rt_h"), "Q": (ARCSEC, "quantisation_arcsec"),
             "R": (DPH_PER_H, "rate_ramp_dph_per_h"), "GM": (DPH, "gm_sigma_dph")}


#: The top-level keys of version 0 of the datasheet (``fogcomp.allan``'s five-term fit).
_VERSION0_KEYS = ("quantisation", "angle_random_walk", "bias_instability", "rate_random_walk",
                  "rate_ramp", "model_fit", "model_fit_sigma", "model_fit_chi2_red")


def _old_shape(key) -> str:
    return (f"to_datasheet(): key {key!r} is from version 0 of its shape (a dict of terms by "
            f"name); this is version {DATASHEET_VERSION}: the terms are the list 'terms', "
            "each with its 'key' ('N', 'B', ...) and 'status' (NoiseModel.to_datasheet's "
            "docstring)")


class Datasheet(dict):
    """The dict :meth:`NoiseModel.to_datasheet` returns: a plain dict (JSON-ready) whose
    version-0 keys (``"angle_random_walk"``, ``"model_fit"``, ...) raise a ``KeyError`` that
    names the new shape, by ``[]`` and by ``get``, where a caller written for that shape
    would otherwise read None."""

    def __missing__(self, key):
        if key in _VERSION0_KEYS:
            raise KeyError(_old_shape(key))
        raise KeyError(key)

    def get(self, key, default=None):
        if key in _VERSION0_KEYS and key not in self:
            raise KeyError(_old_shape(key))
        return super().get(key, default)


def check_datasheet(doc) -> dict:
    """``doc`` (a :meth:`NoiseModel.to_datasheet` dict, e.g. ``allan.json``'s ``noise``
    entry read back) when it has this version's shape; else a ``ValueError`` saying which
    shape it has.

    Raises
    ------
    ValueError
        For a dict without ``format``/``version`` (versions 0 and 1) or of another version.
    """
    if not isinstance(doc, dict):
        raise ValueError(f"datasheet: expected a dict, got {type(doc).__name__}")
    if doc.get("format") != DATASHEET_FORMAT or "version" not in doc:
        old = "0" if any(k in doc for k in _VERSION0_KEYS) else "1" if "terms" in doc else "?"
        raise ValueError(f"datasheet: no 'format': {DATASHEET_FORMAT!r} and 'version' keys: "
                         f"an older shape (version {old}); this reader takes version "
                         f"{DATASHEET_VERSION} (NoiseModel.to_datasheet's docstring)")
    if doc["version"] != DATASHEET_VERSION:
        raise ValueError(f"datasheet: version {doc['version']!r}; this reader takes version "
                         f"{DATASHEET_VERSION}")
    return doc


@dataclass(frozen=True)
class ModelTerm:
    """One term of an identified noise model.

    Attributes
    ----------
    term : str
        ``"Q"``, ``"N"``, ``"B"``, ``"K"``, ``"R"`` or ``"GM"`` (the process).
    status : str
        One meaning each, whether the model was selected or stated:

        - ``"identified"``: in the model and shown by the record (selected: significant at
          the selection's level; stated: fitted above zero), with ``value`` and its
          interval ``low``..``high``;
        - ``"upper bound"``: the record does not show it (in the model but not significant,
          stated and fitted as exactly zero, or left out of the model): ``bound`` is its
          one-sided 95 % upper bound, and ``low``, ``high``, ``sigma`` are None (no
          two-sided interval is claimed for a term the record does not show);
        - ``"not identified"``: neither shown nor bounded by the record.
    value : float or None
        The coefficient, SI (GM: its standard deviation, rad/s); for a term in the model
        (``in_model``) the fitted value, the one the model's curve holds, also when it is only
        bounded; None for a term outside the model.
    low, high : float or None
        The interval of probability content ``ci`` (the model's), SI: identified terms only.
    sigma : float or None
        One-sigma uncertainty of ``value`` (linearised, symmetric: for display), SI:
        identified terms only.
    tau : float or None
        GM: the correlation time, s (``tau_low``, ``tau_high``: its interval, inverted from
        J; None on a side the record does not bound).
    reason : str
        Why it is (not) in the model, in words.
    record_s_for_10pct : float or None
        For a term known to worse than 10 % (one sigma): the record length, s, that would give
        10 %, predicted from this model's covariance at longer records (same sample rate).
    bound : float or None
        One-sided 95 % upper bound of the coefficient, SI (None: the record does not bound it).
    in_model : bool
        Whether the term is part of the fitted model (the curve and the others' estimates).
    key : str
        The name :meth:`NoiseModel.term` finds it by: ``"Q"``, ``"N"``, ``"B"``, ``"K"``,
        ``"R"``; ``"GM1"``, ``"GM2"``, ... for the Gauss-Markov terms (the model's by
        correlation time, then the further term's bound).
    bound_by_tau : tuple of (float, float or None)
        A Gauss-Markov term outside the model: ``(T s, 95 % upper bound of sigma rad/s)`` at
        each correlation time of the grid the record can see (None where the record does not
        bound it); ``bound`` is the largest.
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
    key: str = ""
    bound_by_tau: tuple = ()

    @property
    def name(self) -> str:
        return TERM_NAMES[self.term]

    @property
    def label(self) -> str:
        if self.term == "GM":
            return f"GM({self.tau:.3g} s)" if self.tau is not None else (self.key or "GM")
        return self.term

    def to_datasheet(self) -> dict:
        """This term in datasheet units, the unit in every key (``arw_deg_rt_h``, its
        ``_low``, ``_high``, ``_sigma``; GM: ``gm_sigma_dph`` and ``gm_tau_s``): one entry of
        :meth:`NoiseModel.to_datasheet`'s ``terms`` (the shape is documented there)."""
        unit, key = DATASHEET[self.term]

        def ds(v):
            return None if v is None else float(v / unit)

        out = {"key": self.key or self.term, "term": self.term, "status": self.status,
               key: ds(self.value),
               f"{key}_low": ds(self.low), f"{key}_high": ds(self.high),
               f"{key}_sigma": ds(self.sigma), f"{key}_bound95": ds(self.bound),
               "in_model": self.in_model, "reason": self.reason}
        if self.term == "GM":
            out.update(gm_tau_s=self.tau, gm_tau_low_s=self.tau_low, gm_tau_high_s=self.tau_high)
            if self.bound_by_tau:
                out["gm_sigma_dph_bound95_by_tau"] = [
                    {"tau_s": float(T), "gm_sigma_dph": None if b is None else float(b / unit)}
                    for T, b in self.bound_by_tau]
        if self.record_s_for_10pct is not None:
            out["record_s_for_10pct"] = float(self.record_s_for_10pct)
        return out


@dataclass(frozen=True)
class NoiseModel:
    """The identified noise model of a record (:func:`identify_noise_model`).

    Attributes
    ----------
    terms : list of ModelTerm
        Every candidate term: the five IEEE Std 952 terms (``Q, N, B, K, R``, each
        identified, an upper bound or not identified), the model's Gauss-Markov terms by
        correlation time (``GM1``, ``GM2``, ...), and, when the model holds fewer than
        ``max_gm``, a further Gauss-Markov term outside it with its 95 % upper bound at the
        correlation times the record can see (the next ``GM<i>``). :meth:`term` finds each by
        name.
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
    alternative : NoiseModel or None
        The other reading of the same feature when the record cannot tell them apart (a
        Gauss-Markov term in place of the selected flicker, or flicker in place of a selected
        Gauss-Markov term, fitting as well: ``fogcomp.noise._select._alternative``), with all
        its terms and intervals; None when there is none or the model was stated.
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
    alternative: NoiseModel | None = None

    def term(self, name: str) -> ModelTerm:
        """The term called ``name`` (case and spaces ignored).

        ``"Q"``, ``"N"``, ``"B"``, ``"K"``, ``"R"``: the IEEE terms, always there.
        ``"GM1"``, ``"GM2"``, ...: the model's Gauss-Markov terms by correlation time, then the
        further one outside the model (its bound), as ``terms`` lists them.
        ``"GM"``: the Gauss-Markov term when that is unambiguous: the model's only one, or
        the further term's bound when the model holds none; a model with several raises
        (name one of them).

        Raises
        ------
        KeyError
            For a name the model does not hold, or ``"GM"`` with several Gauss-Markov terms
            in the model; the message lists the names it holds.
        """
        key = "".join(str(name).split()).upper()
        keyed = [(t.key or t.term, t) for t in self.terms]
        for k, t in keyed:
            if k == key:
                return t
        gms = [t for t in self.terms if t.term == "GM"]
        inside = [t for t in gms if t.in_model]
        names = ", ".join(k for k, _ in keyed)
        if key == "GM":
            if len(inside) == 1:
                return inside[0]
            if not inside and gms:
                return gms[0]
            if inside:
                which = ", ".join(f"{t.key} (tau {t.tau:.3g} s)" for t in inside)
                raise KeyError(f"term: 'GM' is ambiguous, this model holds {len(inside)} "
                               f"Gauss-Markov terms: {which}; name one")
        raise KeyError(f"term: no term {name!r} in this model; it holds {names}"
                       + (" ('GM': the Gauss-Markov term when there is one)" if gms else ""))

    @property
    def gm_terms(self) -> list:
        """The Gauss-Markov terms of the fitted model, by correlation time (a further term's
        bound, outside the model, is not among them: ``terms``, :meth:`term`)."""
        return [t for t in self.terms if t.term == "GM" and t.in_model]

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

    def to_datasheet(self) -> Datasheet:
        """The whole model in datasheet units: a JSON-ready dict of this shape, version
        ``DATASHEET_VERSION`` (2)::

            {"format": "fogcomp.noise datasheet", "version": 2,
             "model": "N + GM",             # the identified terms, as a model= string
             "stated": bool,                # model= given rather than selected
             "ci": float,                   # the intervals' probability content
             "terms": [                     # Q, N, B, K, R, then GM1, GM2, ... (NoiseModel.terms)
                 {"key": "N" | ... | "GM1" | ...,   # the name NoiseModel.term() takes
                  "term": "Q" | "N" | "B" | "K" | "R" | "GM",
                  "status": "identified" | "upper bound" | "not identified",
                  "<k>": value, "<k>_low", "<k>_high", "<k>_sigma",  # identified only
                  "<k>_bound95": one-sided 95 % upper bound,
                  "in_model": bool, "reason": str,
                  # GM only: "gm_tau_s", "gm_tau_low_s", "gm_tau_high_s" (either None
                  # where the record does not bound that side); outside the model
                  # "gm_sigma_dph_bound95_by_tau": [{"tau_s", "gm_sigma_dph"}, ...];
                  # where predicted: "record_s_for_10pct"
                 }, ...],
             "floor_reading": {"bias_instability_dph", "bias_instability_sigma_dph", "tau_s",
                               "convention", "reason"},
             "fit": {"J", "dof", "p_value", "scale", "alpha", "model_error"},
             "selection": [str, ...],
             "alternative": None | {...}}  # the other reading that fits as well, this shape

        ``<k>`` is the term's datasheet key with its unit (``DATASHEET``:
        ``quantisation_arcsec``, ``arw_deg_rt_h``, ``bias_instability_dph``, ``rrw_dph_rt_h``,
        ``rate_ramp_dph_per_h``, ``gm_sigma_dph``); a value the record does not give is None.
        The statuses are :class:`ModelTerm`'s.

        Earlier shapes, neither with ``format`` nor ``version``: version 1 (the composite
        identifier before this one) had the same ``terms`` list without ``key``, with a
        ``low``/``high`` for a term in the model but not significant, and no further
        Gauss-Markov term; version 0 (``fogcomp.allan``'s five-term fit) was a dict keyed by
        the terms' names in words (``"angle_random_walk": {"arw_deg_rt_h", "status", ...}``,
        ``"model_fit"``). The dict returned raises a ``KeyError`` that says so when one of
        version 0's keys is read, by ``[]`` or by ``get`` (not a silent None);
        :func:`check_datasheet` checks a dict read back from JSON.
        """
        fr = self.floor_reading
        return Datasheet({
            "format": DATASHEET_FORMAT, "version": DATASHEET_VERSION,
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
            "alternative": None if self.alternative is None else self.alternative.to_datasheet(),
        })

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
