"""What every figure of a run shares: the colours and line styles of raw, oracle, truth and the
methods (from :mod:`fogbench.report.palette`), and decimation for display."""

from __future__ import annotations

from fogbench.report import palette as PAL
from fogbench.report.fmt import decimation

MAX_PLOT_POINTS = 4000
# colours, line styles and units: fogbench.report.palette, shared with the recording
COLORS = {"raw": PAL.mpl(PAL.RAW), "oracle": PAL.mpl(PAL.ORACLE), "truth": PAL.mpl(PAL.TRUTH)}
NOT_IDENTIFIED = "not identified"


def _color(label: str, labels: list[str], plan=None):
    """The colour of ``label`` (matplotlib floats): its method family's shade
    (:func:`fogbench.report.palette.plan_styles` of the scenario's plan; without a plan every label is
    its own family)."""
    if label in ("raw", "oracle", "truth"):
        return COLORS[label]
    return PAL.mpl(PAL.rgb(PAL.plan_styles(plan, labels), label))


def _styles(labels: list[str], widest: float = 3.2, thinnest: float = 1.0,
            markers: bool = False, dashed_raw: bool = True, plan=None) -> dict[str, dict]:
    """Line properties of every output, so that none hides another.

    Curves are stacked oracle (bottom), raw, then the methods in their order; each is drawn
    narrower than every curve below it, so where two curves coincide (raw and oracle at short
    taus, two identical least-squares models) the upper one runs inside the lower one and both
    stay visible. Raw is also dashed (the oracle shows between its dashes) and, with
    ``markers``, carries open circles where oracle has filled dots.

    Colours and the line styles of the members of a method family come from
    :func:`fogbench.report.palette.plan_styles` (``plan``: the scenario's; None: every label its own
    family).

    Returns
    -------
    dict
        label -> keyword arguments for ``Axes.plot`` (color, lw, ls, zorder, and marker keys).
    """
    order = [x for x in ("oracle", "raw") if x in labels] + \
        [x for x in labels if x not in ("oracle", "raw")]
    pal = PAL.plan_styles(plan, labels)
    n = len(order)
    out = {}
    for i, lab in enumerate(order):
        lw = widest - (widest - thinnest) * (i / (n - 1) if n > 1 else 0.0)
        ps = pal.get(lab)
        st = {"color": PAL.mpl(PAL.rgb(pal, lab)), "lw": lw,
              "ls": ps.dash if ps is not None and lab not in ("raw", "oracle") else "-",
              "zorder": 2.0 + 0.1 * i}
        if lab == "raw" and dashed_raw:
            st["ls"] = (0, (4, 2))
        if markers and lab == "raw":
            st.update(marker="o", ms=6, mfc="none", mew=1.0)
        elif markers and lab == "oracle":
            st.update(marker="o", ms=3.5)
        out[lab] = st
    return out


def _decimate(t, *ys):
    step = decimation(t.size, MAX_PLOT_POINTS)
    return (t[::step],) + tuple(y[::step] for y in ys), step
