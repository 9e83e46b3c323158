"""How an identified noise model (``fogcomp.noise.NoiseModel``) is shown to a person: the table
``fogbench allan`` prints, the JSON entry it writes, and the Allan figure with the model and each
term's contribution over the measured curve and its interval.

Units at this edge are the datasheet's: deg/sqrt(h), deg/h, deg/h/sqrt(h), arcsec, deg/h/h.
"""

from __future__ import annotations

import math

import numpy as np

from fogcomp.noise import DATASHEET, avar_gm, avar_term

__all__ = ["UNITS", "term_text", "table", "notes", "model_json", "figure"]

#: Datasheet unit of each term's coefficient (the GM's is its standard deviation).
UNITS = {"N": "deg/sqrt(h)", "B": "deg/h", "K": "deg/h/sqrt(h)", "Q": "arcsec", "R": "deg/h/h",
         "GM": "deg/h"}
_HEAD = {"N": "ARW deg/sqrt(h)", "B": "BI deg/h", "K": "RRW deg/h/sqrt(h)", "Q": "Q arcsec",
         "R": "ramp deg/h/h"}
DPH = math.pi / 180.0 / 3600.0


def _num(x: float | None, open_side: str = "-") -> str:
    """A number to 4 significant digits; ``open_side`` for None (an interval's side the record
    does not bound)."""
    return open_side if x is None else f"{x:.4g}"


def term_text(t) -> str:
    """One term as a cell: ``value [low, high]``, ``< bound`` or ``-``."""
    unit = DATASHEET[t.term][0]
    if t.status == "identified":
        hi = "inf" if t.high is None else _num(t.high / unit)
        return f"{_num(t.value / unit)} [{_num(t.low / unit)}, {hi}]"
    if t.status == "upper bound" and t.bound is not None:
        if t.in_model and t.value is not None:  # kept in the model, not significant
            return f"< {_num(t.bound / unit)} (fit {_num(t.value / unit)})"
        return f"< {_num(t.bound / unit)}"
    return "-"


def _gm_text(model) -> str:
    gms = [t for t in model.gm_terms if t.status == "identified"]
    if not gms:
        return "-"
    return "; ".join(f"{_num(t.value / DPH)} [{_num(t.low / DPH)}, "
                     f"{'inf' if t.high is None else _num(t.high / DPH)}] deg/h, "
                     f"tau {_num(t.tau)} [{_num(t.tau_low, '0')}, {_num(t.tau_high, 'inf')}] s"
                     for t in gms)


def _floor_text(model) -> str:
    fr = model.floor_reading
    if fr.get("value") is None:
        return "-"
    v = fr["value"] / DPH
    if fr.get("sigma") is None:
        return f"< {_num(v)}"
    return f"{_num(v)} +- {fr['sigma'] / DPH:.2g} (tau {fr['tau_s']:g} s)"


def table(rows) -> str:
    """The table of ``[(column name, NoiseModel), ...]``: the selected model, every IEEE term
    with its interval (``[low, high]``, the model's probability content) or upper bound, the
    Gauss-Markov terms, and the IEEE Std 952 floor reading of the bias instability."""
    head = ["column", "model", *(_HEAD[t] for t in ("N", "B", "K", "Q", "R")),
            "Gauss-Markov (sigma, tau)", "BI floor reading deg/h"]
    body = []
    for name, m in rows:
        body.append([name, m.spec(), *(term_text(m.term(t)) for t in ("N", "B", "K", "Q", "R")),
                     _gm_text(m), _floor_text(m)])
    widths = [max(len(r[i]) for r in [head] + body) for i in range(len(head))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in [head] + body]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def notes(rows) -> list[str]:
    """Lines under the table: the intervals' content, each fit's agreement with its error
    bars, and the record lengths the limited terms would need for 10 %."""
    out = []
    if rows:
        m = rows[0][1]
        out.append(f"[low, high]: {m.ci:.1%} interval; '< x': 95 % upper bound of a term the "
                   "record does not show; BI floor reading: the IEEE Std 952 datasheet "
                   "convention (the curve's minimum / 0.664), biased where white noise or a "
                   "random walk still adds to the minimum")
    for name, m in rows:
        fit = (f"{name}: fit J = {m.J:.3g} on {m.dof} degrees of freedom (p = {m.p_value:.2g}"
               + (f"; the curve departs from the model, intervals scaled by "
                  f"{math.sqrt(m.scale):.2g}" if m.scale > 1 else "") + ")")
        longer = []
        for t in m.terms:
            if t.record_s_for_10pct is not None and t.in_model:
                longer.append(f"{t.label} to 10 % from {t.record_s_for_10pct / 3600:.3g} h")
        out.append(fit + ("; record needed: " + ", ".join(longer) if longer else ""))
        if m.alternative is not None:
            a = m.alternative
            out.append(f"{name}: the record cannot tell {m.spec()} from {a.spec()} (J "
                       f"{m.J:.3g} and {a.J:.3g}): the alternative's terms "
                       + ", ".join(f"{t.label} {term_text(t)} {UNITS[t.term]}"
                                   for t in a.identified if t.term != "GM")
                       + ("; Gauss-Markov " + _gm_text(a) if a.gm_terms else "")
                       + " (allan.json: alternative)")
    return out


def model_json(model) -> dict:
    """The JSON entry of a model: ``noise`` (every term, its interval, bound, status and
    reason; the floor reading; the fit and the selection's steps) and ``filter`` (each
    identified term's continuous and discrete-time form, SI)."""
    return {**model.to_datasheet(), "filter": model.filter_parameters()}


def figure(title: str, taus, adev, low, high, model, interval_label: str):
    """The Allan plot of one column (a matplotlib Figure): the measured curve and its interval,
    the fitted model, each term's contribution (identified solid-dashed, in-model but not
    significant dash-dotted, out-of-model upper bounds dotted at the bound), and the IEEE 952
    floor reading marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.asarray(taus, dtype=float)
    a = np.asarray(adev, dtype=float)
    fig, ax = plt.subplots(figsize=(7.5, 5.2))
    if low is not None:
        lo = np.maximum(np.asarray(low, dtype=float), 1e-300)
        ax.fill_between(t, lo / DPH, np.asarray(high) / DPH, color="C0", alpha=0.25,
                        label=interval_label)
    ax.loglog(t, a / DPH, "o-", color="C0", ms=3, label="Allan deviation")
    tt = np.logspace(math.log10(t.min()), math.log10(t.max()), 200)
    if model.fs:
        tt = np.unique(np.maximum(np.round(tt * model.fs), 1) / model.fs)
    ax.loglog(tt, model.model_adev(tt) / DPH, "-", color="k", lw=1.2,
              label=f"fitted model: {model.spec()}")
    slopes = {"Q": "-1", "N": "-1/2", "B": "0", "K": "+1/2", "R": "+1"}
    for k, term in enumerate(model.terms):
        if term.term == "GM":
            if not term.in_model:       # a further term's bound, over correlation times
                continue
            y = np.sqrt(avar_gm(tt, term.tau, model.fs)) * term.value
            ax.loglog(tt, y / DPH, "--", lw=1, color=f"C{3 + k % 6}",
                      label=f"GM: {_num(term.value / DPH)} deg/h, tau {_num(term.tau)} s")
            continue
        if term.status == "not identified":
            continue
        shape = np.sqrt(avar_term(term.term, tt))
        if term.in_model:
            style = "--" if term.status == "identified" else "-."
            note = "" if term.status == "identified" else " (not significant)"
            ax.loglog(tt, shape * term.value / DPH, style, lw=1, color=f"C{1 + k}",
                      label=f"{term.term} (slope {slopes[term.term]}): {term_text(term)} "
                            f"{UNITS[term.term]}{note}")
        elif term.bound is not None:
            ax.loglog(tt, shape * term.bound / DPH, ":", lw=1.2, color=f"C{1 + k}",
                      label=f"{term.term} (slope {slopes[term.term]}) {term_text(term)} "
                            f"{UNITS[term.term]} (upper bound)")
    fr = model.floor_reading
    if fr.get("value") is not None and fr.get("tau_s"):
        y = fr["value"] * math.sqrt(2.0 * math.log(2.0) / math.pi) / DPH
        ax.plot([fr["tau_s"]], [y], marker="_", ms=22, mew=2, color="C3", ls="none",
                label=f"IEEE 952 floor reading: BI {_floor_text(model)} deg/h")
    ax.set_ylim(max(np.min(a) / DPH / 5, 1e-12), np.max(a) / DPH * 3)
    ax.set_xlabel("averaging time tau, s")
    ax.set_ylabel("Allan deviation, deg/h")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6.5, loc="best")
    fig.tight_layout()
    return fig

