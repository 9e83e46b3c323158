"""What a view of the errors takes out so that the methods' differences show.

Shared by the PNG time series (``fogbench.report.fig_timeseries``) and the recording's
Overview (``fogbench.recording``), so that both take out the same thing. No plotting here.

Under a wander no denoiser removes (paper000's +-1000 deg/h Gauss-Markov drift), the methods'
errors are raw's wander plus a small difference; drawn as they are, the difference is a line
width. :func:`kept_alike` finds what every output keeps alike, by correlation against raw's
error, and says what to take out.
"""

from __future__ import annotations

import numpy as np

from fogbench.report import palette as PAL

DWARF = 3.0          # raw (oracle) gets its own panel (PNG), or is left off the zoom (viewer),
#                      when an axis holding it and the methods' errors would span more than
#                      this many times the methods' errors
TREND_FRACTION = 1 / 50   # raw's trend: centred moving mean over this fraction of the piece
TREND_CORR = 0.9     # ... taken out of every curve when every method keeps raw's slow error:
#                      over TREND_TEST times that window, each method's moving mean correlates
#                      with raw's by >= this, its std within a factor 2: a wander no method
#                      removes (denoisers) is not what the methods differ on
TREND_TEST = 5
SAME_FRACTION = 1e-3  # two outputs this close (of an error span) look the same: an ideal twin
#                       like its lab protocol gets no own figures (fogbench.report.same_as_lab),
#                       outputs that are raw plus a constant no Allan or PSD (offsets_only)


def moving_mean(y: np.ndarray, k: int) -> np.ndarray:
    """Centred moving mean over ``k`` samples; near the ends, the mean of the samples there
    are (the window shrinks: no padding)."""
    y = np.asarray(y, dtype=float)
    n = y.size
    h = max(1, int(k)) // 2
    c = np.concatenate(([0.0], np.cumsum(y)))
    i = np.arange(n)
    a, b = np.maximum(i - h, 0), np.minimum(i + h + 1, n)
    return (c[b] - c[a]) / (b - a)


def kept_alike(errs: dict, methods: list[str]):
    """What every output keeps alike, to take out of the methods' panels: ``(kind, trend, k)``.

    ``k`` is TREND_FRACTION of the piece (samples); raw's trend is the centred moving mean of
    its error over ``k``.

    - ``"trend"``: every method keeps raw's slow error (a denoiser under a wander: over
      TREND_TEST k, each method's moving mean correlates with raw's by >= TREND_CORR, its std
      within a factor 2 of raw's): raw's trend about its mean (returned) is taken out of every
      curve.
    - ``"fast"``: every method keeps raw's fast error (a drift model under white noise: what is
      left after the k-sample moving mean correlates with raw's by >= TREND_CORR, std within a
      factor 2): every curve is drawn as its k-sample moving mean.
    - ``"both"``: every method keeps both (each is raw less about a constant: a bias
      correction; lab_references' bias_lab, whose 2 deg/h lay under +-10 deg/h of white noise
      with raw's trend taken out): every curve is drawn as its k-sample moving mean less raw's
      trend about its mean (returned), which leaves each output's constant apart.
    - ``None``: the methods differ in both; errors are drawn as they are.
    """
    raw = errs.get("raw")
    if raw is None or not methods or raw.size < 20:
        return None, None, 0
    k = max(3, round(raw.size * TREND_FRACTION))

    def alike(part):
        ref = part(raw)
        s = float(np.std(ref))
        if not s > 0:
            return False
        for lab in methods:
            x = part(errs[lab])
            sx = float(np.std(x))
            if not (sx > 0 and 0.5 <= sx / s <= 2.0
                    and float(np.corrcoef(ref, x)[0, 1]) >= TREND_CORR):
                return False
        return True

    slow = alike(lambda e: moving_mean(e, TREND_TEST * k))
    fast = alike(lambda e: e - moving_mean(e, k))
    # raw's variation only: a method that removes raw's constant part (a bias) keeps its own
    # level (lab_references: 2 deg/h of bias removed, drawn at -2 deg/h when raw's mean went)
    trend = moving_mean(raw, k) - float(np.mean(raw))
    if slow and fast:
        return "both", trend, k
    if slow:
        return "trend", trend, k
    if fast:
        return "fast", None, k
    return None, None, k


def shown_error(kind: str | None, err: np.ndarray, trend, k: int,
                centre: bool = False) -> np.ndarray:
    """An error as the methods' panels draw it, by :func:`kept_alike`'s ``kind``; with
    ``centre`` (:func:`mean_blind`), less its own mean as well."""
    if kind == "trend":
        out = err - trend
    elif kind == "fast":
        out = moving_mean(err, k)
    elif kind == "both":
        out = moving_mean(err, k) - trend
    else:
        out = np.asarray(err, dtype=float)
    if not (centre and np.any(np.isfinite(out))):
        return out
    return out - float(np.nanmean(out))    # (a NaN sample leaves the rest of the curve)


#: Metrics that take each output's mean out before they measure it (``std_dps``, ``std_dph``:
#: the sample standard deviation, fogcomp.metrics.summary).
MEAN_BLIND_PREFIX = "std_"


def mean_blind(plan, run: str) -> bool:
    """Whether every claim scored on ``run`` (a ``[[claims]]`` entry with this ``run``, or with
    none) uses a metric blind to each output's mean (:data:`MEAN_BLIND_PREFIX`): then the error
    views draw every curve less its own mean, since the verdict cannot see it. paper000's
    test_m60 is scored by the output's std: under its Gauss-Markov wander the oracle (raw less
    the true deterministic terms) drew 100 deg/h above raw in a draw where the true terms
    offset part of the wander, which read as an oracle worse than raw. False when no claim
    is scored on the run."""
    claims = [c for c in getattr(plan, "claims", ()) or ()
              if getattr(c, "run", None) in (None, run)]
    return bool(claims) and all(str(c.metric).startswith(MEAN_BLIND_PREFIX) for c in claims)


def method_entries(labels: list[str], plan) -> list[dict]:
    """The methods among ``labels`` as they are drawn, in families: a method alone, or the
    members of a sweep (``MethodSpec.group``, a ``[[methods]]`` table with ``sweep``) as one
    entry drawn as an envelope with its default (paper) setting's line.

    Returns
    -------
    list of dict
        ``group`` (the sweep's label, or None), ``members`` (labels), ``default`` (the label
        drawn as a line: the member with ``paper_setting``, else the first).
    """
    specs = {m.label: m for m in getattr(plan, "methods", ())}
    out, groups = [], {}
    for lab in labels:
        if lab in ("raw", "oracle"):
            continue
        m = specs.get(lab)
        g = getattr(m, "group", None)
        if g:
            if g not in groups:
                groups[g] = {"group": g, "members": [], "default": None}
                out.append(groups[g])
            groups[g]["members"].append(lab)
            if getattr(m, "paper_setting", False) and groups[g]["default"] is None:
                groups[g]["default"] = lab
        else:
            out.append({"group": None, "members": [lab], "default": lab})
    for e in out:
        e["default"] = e["default"] or e["members"][0]
        if len(e["members"]) == 1:
            e["group"] = None
    pal = PAL.plan_styles(plan, labels)
    fams = list(dict.fromkeys(pal[e["default"]].family for e in out))
    return sorted(out, key=lambda e: fams.index(pal[e["default"]].family))


def sweep_names(e: dict) -> tuple[str, str]:
    """The legend names of a sweep entry (:func:`method_entries`) drawn as its default
    setting's line and its members' envelope: ``("<group> default (<setting>)", "<group>: <n>
    settings, best..worst")``."""
    d, g = e["default"], e["group"]
    setting = d[len(g) + 1:] if d.startswith(g + ".") else d
    return f"{g} default ({setting})", f"{g}: {len(e['members'])} settings, best..worst"


def offsets_only(it) -> bool:
    """Whether every output of a scored piece differs from raw by a constant alone: each
    output's error less its mean is raw's error less its mean to SAME_FRACTION of the span of
    raw's error (a bias correction: switch_on_repeatability, lab_references' one-dwell bias).
    An Allan deviation is blind to a constant and the PSD removes the mean, so both would draw
    every output on raw's curve: the PNGs and the recording draw raw's alone."""
    raw = it.outputs.get("raw")
    if raw is None or len(it.outputs) < 2:
        return False
    e0 = (raw - it.piece.truth) - np.mean(raw - it.piece.truth)
    span = float(np.ptp(e0))
    if not np.isfinite(span) or span == 0.0:
        return False
    for out in it.outputs.values():
        e = out - it.piece.truth
        if not np.all(np.isfinite(e)) or \
                float(np.max(np.abs(e - np.mean(e) - e0))) > SAME_FRACTION * span:
            return False
    return True
