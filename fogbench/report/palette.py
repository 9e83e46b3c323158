"""One palette and one set of units for the PNG figures (:mod:`fogbench.report`) and the Rerun
recording (:mod:`fogbench.recording`): the same output has the same colour in both.

Colours (8-bit sRGB; each reads on a white page and on the viewer's dark theme: no near-black,
no near-white):

- ``raw`` grey, ``oracle`` cyan, the truth green: fixed, and no method gets them.
- A method's colour is its *family's* hue: the family is the built-in method it runs
  (``[[methods]] method``), so ``wnn_fitnorm`` and ``wnn_recnorm`` are both blue, ``kalman`` and
  ``kalman_datasheet`` red, every ``wavelet_band`` setting orange. The built-in families have
  fixed hues (:data:`FAMILY_HUES`: ``kalman`` is red in every scenario); other families (plugins)
  take the free hues of :data:`EXTRA_HUES` in their order in the scenario.
- The members of a family differ in shade (darker, lighter: :data:`SHADES`; a light hue, or
  one whose lighter shade nears raw or the oracle, only darker, :data:`SHADES_LIGHT`) and, in
  the PNGs,
  in line style (:data:`DASHES`); the viewer has no dashed series, so there the shade alone
  tells them apart.
- An in-sample protocol, drawn beside a held-out one in the viewer, is a lighter tint of the
  same colour (:func:`in_sample`), kept dark enough to read on white.

Units: rates (outputs, truth) in deg/s; errors against the truth, Allan deviations in deg/h;
PSDs of the error in (deg/h)^2/Hz; time in s, or in h for records longer than
:data:`HOURS_ABOVE_S` (:func:`time_unit`). Axis minimum spans (:data:`MIN_SPAN`): a 0.0625 C
step of the temperature sensor does not fill a temperature axis like a thermal pulse.

Allan deviations are drawn up to the longest averaging time with at least
:data:`ALLAN_MIN_CLUSTERS` non-overlapping clusters in the record (:func:`allan_drawn`).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["RAW", "ORACLE", "TRUTH", "FAMILY_HUES", "EXTRA_HUES", "SHADES", "SHADES_LIGHT",
           "DASHES", "Style", "lightness", "delta_e", "styles", "plan_styles", "rgb", "mpl", "in_sample", "ERROR_UNIT", "RATE_UNIT",
           "PSD_UNIT", "HOURS_ABOVE_S", "time_unit", "MIN_SPAN", "min_span",
           "ALLAN_MIN_CLUSTERS", "allan_drawn"]

RAW = (128, 128, 128)
ORACLE = (23, 190, 207)
TRUTH = (44, 160, 44)

#: Hue of each built-in method family (Tableau 10 without its grey, cyan and green, plus two).
FAMILY_HUES = {
    "wnn": (31, 119, 180),          # blue
    "kalman": (214, 39, 40),        # red
    "wavelet_soft": (255, 127, 14),  # orange
    "model_lstsq": (148, 103, 189),  # purple
    "poly_temp": (140, 86, 75),     # brown
    "bp": (227, 119, 194),          # pink
    "aco_bp": (188, 189, 34),       # olive
    "flnn": (0, 110, 50),           # dark green (teal lightened was nearly the oracle's cyan)
    "flnn_lstsq": (230, 171, 2),    # gold
}
#: Hues for other families (plugins), taken in order where not already used in the scenario.
EXTRA_HUES = [(160, 40, 160), (110, 110, 230), (150, 120, 0), (250, 150, 140),
              (90, 200, 160), (120, 60, 20)]

#: Shade of the k-th member of a family: the fraction it is blended towards black (< 0) or
#: white (> 0).
SHADES = (0.0, -0.3, 0.3, -0.5, 0.45)
#: The shades of a light hue (CIE L* above :data:`LIGHT_HUE_L`: orange, pink, olive, gold):
#: lightened, its members fade on a white page (olive +0.3 is L* 82), so they only darken; so
#: does a hue whose lighter shade is near raw or the oracle (:func:`_darken_only`). Steps far
#: enough apart that neighbours differ by CIE76 > 15 (paper002's aco_bp_lm and aco_bp_gd were 11).
SHADES_LIGHT = (0.0, -0.25, -0.45, -0.6, -0.72)
LIGHT_HUE_L = 60.0
NEAR_REFERENCE = 15.0    # CIE76: a member this close to raw or the oracle is confused with it
#: Line style of the k-th member of a family in the PNGs (matplotlib dash patterns).
DASHES = ("-", (0, (5, 2)), (0, (5, 2, 1, 2)), (0, (1, 1.5)))
IN_SAMPLE_TINT = 0.3


@dataclass(frozen=True)
class Style:
    """How one output is drawn: ``color`` 8-bit sRGB, ``dash`` a matplotlib line style (the PNGs
    only), ``family`` the method family (``raw``, ``oracle`` for those), ``member`` its index in
    the family."""

    color: tuple
    dash: object
    family: str
    member: int


def _shade(c, f: float) -> tuple:
    target = 0.0 if f < 0 else 255.0
    f = abs(f)
    return tuple(int(round(x + (target - x) * f)) for x in c[:3])


def _lab(c) -> tuple[float, float, float]:
    """CIE L*a*b* (D65) of an 8-bit sRGB colour: IEC 61966-2-1 linearisation, its XYZ matrix,
    CIE 15 (2004) eq. 8.3-8.5."""
    lin = [v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4
           for v in (x / 255.0 for x in c[:3])]
    x = (0.4124 * lin[0] + 0.3576 * lin[1] + 0.1805 * lin[2]) / 0.95047
    y = 0.2126 * lin[0] + 0.7152 * lin[1] + 0.0722 * lin[2]
    z = (0.0193 * lin[0] + 0.1192 * lin[1] + 0.9505 * lin[2]) / 1.08883

    def f(t):
        return t ** (1.0 / 3.0) if t > (6.0 / 29.0) ** 3 else t * (29.0 / 6.0) ** 2 / 3.0 \
            + 4.0 / 29.0

    return 116.0 * f(y) - 16.0, 500.0 * (f(x) - f(y)), 200.0 * (f(y) - f(z))


def lightness(c) -> float:
    """CIE L* (0 black .. 100 white) of an 8-bit sRGB colour (IEC 61966-2-1 linearisation,
    CIE 15 lightness of the luminance Y)."""
    return _lab(c)[0]


def delta_e(c1, c2) -> float:
    """CIE76 colour difference of two 8-bit sRGB colours (Euclidean in L*a*b*)."""
    return sum((a - b) ** 2 for a, b in zip(_lab(c1), _lab(c2))) ** 0.5


def _darken_only(hue) -> bool:
    """A family whose members only darken (:data:`SHADES_LIGHT`): a light hue (its lighter
    shades fade on the page), or one whose lighter shade comes within NEAR_REFERENCE (CIE76)
    of raw's grey or the oracle's cyan (a teal lightened is nearly the oracle: flnn's hue was
    teal until its third member, flnn_dwell_means, read as the oracle)."""
    return lightness(hue) > LIGHT_HUE_L or any(
        delta_e(_shade(hue, f), ref) < NEAR_REFERENCE for f in SHADES if f > 0
        for ref in (RAW, ORACLE))


def styles(methods) -> dict[str, Style]:
    """The style of ``raw``, ``oracle`` and every method.

    Parameters
    ----------
    methods : iterable of (label, family)
        The methods in the scenario's order; ``family`` is the method's name (its built-in or
        plugin class), or the label itself where that is not known.

    Returns
    -------
    dict
        label -> :class:`Style` (``raw`` and ``oracle`` included).
    """
    out = {"raw": Style(RAW, (0, (4, 2)), "raw", 0),
           "oracle": Style(ORACLE, "-", "oracle", 0)}
    methods = [(str(lab), str(fam)) for lab, fam in methods if lab not in out]
    families = list(dict.fromkeys(fam for _, fam in methods))
    used = {FAMILY_HUES[f] for f in families if f in FAMILY_HUES}
    free = [h for h in EXTRA_HUES + list(FAMILY_HUES.values()) if h not in used]
    hue = {}
    for i, f in enumerate(families):
        if f in FAMILY_HUES:
            hue[f] = FAMILY_HUES[f]
        else:
            hue[f] = free.pop(0) if free else EXTRA_HUES[i % len(EXTRA_HUES)]
    count: dict[str, int] = {}
    for lab, fam in methods:
        if lab in out:
            continue
        k = count.get(fam, 0)
        count[fam] = k + 1
        shades = SHADES_LIGHT if _darken_only(hue[fam]) else SHADES
        out[lab] = Style(_shade(hue[fam], shades[k % len(shades)]), DASHES[k % len(DASHES)],
                         fam, k)
    return out


def plan_styles(plan, labels=()) -> dict[str, Style]:
    """:func:`styles` of a scenario's plan (family: each method's name), plus any of ``labels``
    the plan does not list (each its own family)."""
    methods = [(m.label, m.name) for m in getattr(plan, "methods", ())] if plan is not None \
        else []
    known = {lab for lab, _ in methods}
    methods += [(lab, lab) for lab in labels if lab not in known]
    return styles(methods)


def rgb(st: dict, label: str) -> tuple:
    """The 8-bit colour of ``label`` (a label missing from ``st`` is grey-blue)."""
    s = st.get(label)
    return s.color if s is not None else (100, 100, 140)


def mpl(c) -> tuple:
    """An 8-bit sRGB colour as matplotlib's 0..1 floats."""
    return tuple(x / 255.0 for x in c[:3])


def in_sample(c) -> tuple:
    """The tint of an in-sample protocol's output: ``c`` blended by :data:`IN_SAMPLE_TINT`
    towards white."""
    return _shade(c, IN_SAMPLE_TINT)


# ---------------------------------------------------------------------------------------------
# units and axes
ERROR_UNIT = "deg/h"            # output - truth, Allan deviation
RATE_UNIT = "deg/s"             # outputs, truth
PSD_UNIT = "(deg/h)^2/Hz"       # PSD of output - truth
HOURS_ABOVE_S = 3 * 3600.0      # time axes in h for records longer than this, else s

#: Least span of a y axis per unit: the data are centred in it when they span less.
MIN_SPAN = {"deg C": 1.0, "deg C/min": 0.5, "deg/s": 0.01, "deg/h": 0.01}


def time_unit(duration_s: float) -> tuple[float, str]:
    """(seconds per unit, unit name) of a time axis over ``duration_s``: h above
    :data:`HOURS_ABOVE_S`, else s."""
    return (3600.0, "h") if duration_s > HOURS_ABOVE_S else (1.0, "s")


def min_span(lo: float, hi: float, unit: str) -> tuple[float, float]:
    """(lo, hi) widened about its centre to :data:`MIN_SPAN` of ``unit`` (unchanged when wider
    or when the unit has none)."""
    span = MIN_SPAN.get(unit)
    if span is None or not (hi - lo < span):
        return lo, hi
    c = 0.5 * (lo + hi)
    return c - 0.5 * span, c + 0.5 * span


#: Allan deviation figures stop at the longest tau with at least this many non-overlapping
#: clusters ``floor(n / m)`` in the record: there the chi-square interval (IEEE Std 952-1997
#: Annex C; Riley, NIST SP 1065, 5.2-5.3) is still about +-25 % at one sigma; beyond it the
#: last two or three octaves rest on two to seven clusters and the curve "plunges" or jumps.
ALLAN_MIN_CLUSTERS = 8
PSD_PER_DECADE = 10      # PSD figures and plots: Welch ordinates averaged in this many bands a decade


def allan_drawn(m, n: int):
    """Boolean mask of the averaging factors ``m`` (samples per cluster) of a record of ``n``
    samples that a figure draws: ``n // m >= ALLAN_MIN_CLUSTERS``."""
    import numpy as np

    return (int(n) // np.asarray(m, dtype=np.int64)) >= ALLAN_MIN_CLUSTERS
