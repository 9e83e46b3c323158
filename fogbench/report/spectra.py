"""The noise of one piece as a person reads it: its power spectral density
(``figures/psd__...``) and its Allan deviation with intervals and the identified model
(``figures/allan__...``)."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from fogbench.outputs import files
from fogbench.report import palette as PAL
from fogbench.report.style import _styles
from fogbench.report.timeseries import LEGEND, MAX_LINES, _chunks, _draw_entry
from fogbench.report.views import method_entries as _method_entries
from fogcomp import metrics as M
from fogcomp.allan import oadev_ci
from fogcomp.units import DPH

PSD_DECADES_BELOW_RAW = 6      # PSD axis: at most this many decades below the raw/oracle floor
PSD_MAX_DECADES = 10           # ... and never more than this many decades in all


def _psd_ylim(curves: dict[str, np.ndarray]) -> tuple[float, float]:
    """The PSD range that matters: from PSD_DECADES_BELOW_RAW decades below the lowest raw or
    oracle value (a compensator removing more than that is off the scale anyway) up to the top,
    never more than PSD_MAX_DECADES decades; a curve that falls to numerical zero (a smoother's
    output) does not stretch the axis."""
    pos = {k: v[np.isfinite(v) & (v > 0)] for k, v in curves.items()}
    top = max(float(np.max(v)) for v in pos.values() if v.size) * 2.0
    refs = [float(np.min(pos[k])) for k in ("raw", "oracle") if k in pos and pos[k].size]
    low = min(float(np.min(v)) for v in pos.values() if v.size) / 2.0
    if refs:
        low = max(low, min(refs) * 10.0 ** -PSD_DECADES_BELOW_RAW)
    low = max(low, top * 10.0 ** -PSD_MAX_DECADES)
    return low, top


def _log_ticks(ax) -> None:
    """Tick labels of a log-log panel that never collide: minor ticks unlabelled (matplotlib
    labels them on an axis spanning about a decade, where paper002's PSD printed 3x10^-4 into
    4x10^-4); an axis spanning under LOG_LABEL_DECADES decades gets majors at 1, 2 and 5 per
    decade instead, so that it keeps at least two labels."""
    from matplotlib import ticker

    for axis, lim in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
        lo, hi = sorted(lim)
        if axis.get_scale() != "log" or not lo > 0:
            continue
        if math.log10(hi / lo) < LOG_LABEL_DECADES:
            axis.set_major_locator(ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
        axis.set_major_formatter(ticker.LogFormatterSciNotation(   # every major labelled
            labelOnlyBase=False, minor_thresholds=(math.inf, math.inf)))
        axis.set_minor_formatter(ticker.NullFormatter())


LOG_LABEL_DECADES = 2.0


def fig_psd(it, path: Path, plan=None):
    """PSD of each output's error against the truth (mean removed), (deg/h)^2/Hz, averaged in
    fogbench.report.palette.PSD_PER_DECADE log-spaced bands (fogcomp.metrics.psd_bands: Welch, Hann, 8 half-overlapping
    segments), with each band's one-sigma chi-square interval from its EDF as a band around raw,
    oracle and each method's (default) line; a sweep as the envelope of its members' spectra
    with its default's line, at most MAX_LINES lines a panel (raw and oracle in each)."""
    p = it.piece
    labels = list(it.outputs)
    sty = _styles(labels, markers=True, plan=plan)
    curves, ints = {}, {}
    for lab, y in it.outputs.items():
        e = (y - p.truth) / DPH
        f, s, edf = M.psd_bands(e, p.fs, per_decade=PAL.PSD_PER_DECADE)
        curves[lab] = s
        ints[lab] = M.psd_band_interval(s, edf, ALLAN_CI)
    lo, hi = _psd_ylim(curves)
    fixed = [lab for lab in ("raw", "oracle") if lab in labels]
    panels = _chunks(_method_entries(labels, plan), MAX_LINES - len(fixed), plan)
    fig, axes = plt.subplots(len(panels), 1, figsize=(9.2, 0.8 + 3.9 * len(panels)),
                             sharex=True, sharey=True, squeeze=False)
    shown = {lab: np.where(s > 0, s, np.nan) for lab, s in curves.items()}

    def band(ax, lab):
        low, high = ints[lab]
        ax.fill_between(f, np.maximum(low, lo), high, color=sty[lab]["color"], alpha=0.13,
                        lw=0, zorder=1.0)

    for ax, chunk in zip(axes[:, 0], panels):
        ax.set_xscale("log")
        ax.set_yscale("log")
        for lab in fixed:
            ax.plot(f, shown[lab], **sty[lab], label=lab)
            band(ax, lab)
        for e in chunk:
            below = any(bool(np.any(curves[m] < lo)) for m in e["members"])
            for ln in _draw_entry(ax, f, shown, e, sty):
                if below:
                    ln.set_label(ln.get_label() + " (falls below the axis)")
            band(ax, e["default"])
        ax.set_ylim(lo, hi)
        ax.set_ylabel(f"PSD of output - truth, {PAL.PSD_UNIT}", fontsize=9)
        ax.grid(True, which="both", lw=0.3)
        ax.legend(**LEGEND)
    for ax in axes[:, 0]:
        _log_ticks(ax)
    axes[-1, 0].set_xlabel("frequency, Hz")
    axes[0, 0].set_title(f"{it.protocol} / {it.run}: PSD of the error (Welch, 8 segments, mean "
                         f"removed), averaged in {PAL.PSD_PER_DECADE} bands a decade\n"
                         f"bands: {100 * ALLAN_CI:.0f} % interval (chi-square, EDF of each "
                         "band: the Welch average's times the ordinates it holds)", fontsize=9)
    files.save_figure(fig, path)


ALLAN_CI = 0.6826894921370859      # one sigma, as the recording's bars
ALLAN_DECADES_BELOW_RAW = 3         # Allan figure: its axis stops this far below raw / oracle


def _has_noise_model(p) -> bool:
    """The bench identifies the noise terms of this piece (fogbench.run.runner.score's rule: a
    contiguous record of at least 1000 s and 512 samples at 1 Hz or more)."""
    return (p.raw.size / p.fs >= 1000.0 and p.raw.size >= 512 and p.fs >= 1.0
            and not np.any(np.diff(p.t) > 1.5 / p.fs))


def _noise_model(err, fs: float):
    """The noise model the bench identifies from an error record (fogcomp.metrics.noise_terms:
    identify_noise_model on the octave Allan variance), or None."""
    from fogcomp.allan import oadev_details
    from fogcomp.noise import identify_noise_model

    if np.ptp(err) == 0:
        return None
    d = oadev_details(err, fs)
    if not np.all(d.adev > 0) or d.taus.shape[0] < 3:
        return None
    return identify_noise_model(d.taus, d.adev**2, fs, err.shape[0], record_length=False,
                                alternative=False)


def fig_allan(it, path: Path, plan=None) -> bool:
    """Overlapping Allan deviation of each output's error against the truth, deg/h, with its
    one-sigma chi-square interval as a band (EDF of the noise type leading each tau,
    fogcomp.allan.oadev_ci), drawn up to the longest tau with at least
    fogbench.report.palette.ALLAN_MIN_CLUSTERS non-overlapping clusters; over raw and oracle the noise
    model the bench identified (dotted) where it identifies one. A sweep: the envelope of its
    members' curves and its default's line with its band; at most MAX_LINES lines a panel."""
    p = it.piece
    if p.raw.size < 64:
        return False
    labels = list(it.outputs)
    sty = _styles(labels, markers=True, plan=plan)
    cut = None
    ads, keeps = {}, {}
    for lab, y in it.outputs.items():
        ad = oadev_ci(y - p.truth, p.fs, ci=ALLAN_CI)
        keep = PAL.allan_drawn(ad.m, ad.n) & np.isfinite(ad.adev) & (ad.adev > 0)
        cut = ad.taus[keep][-1] if keep.any() else cut
        ads[lab], keeps[lab] = ad, keep
    models = _allan_models(it)
    fixed = [lab for lab in ("raw", "oracle") if lab in labels]
    panels = _chunks(_method_entries(labels, plan), MAX_LINES - len(fixed) - len(models), plan)
    fig, axes = plt.subplots(len(panels), 1, figsize=(9.2, 0.8 + 4.0 * len(panels)),
                             sharex=True, sharey=True, squeeze=False)
    last = max((int(np.flatnonzero(k)[-1]) for k in keeps.values() if k.any()), default=0)
    taus = ads[labels[0]].taus[:last + 1]      # one record length: every output's taus
    shown = {lab: np.where(keeps[lab], ads[lab].adev / DPH, np.nan)[:last + 1]
             for lab in labels}
    floor = _allan_floor(shown, fixed)
    # the identified models are drawn up to the last tau drawn (else the cluster limit)
    tt = np.geomspace(1.0 / p.fs, cut or p.raw.size / p.fs / PAL.ALLAN_MIN_CLUSTERS, 60)
    for ax, chunk in zip(axes[:, 0], panels):
        _panel_allan(ax, taus, shown, fixed, chunk, ads, keeps, sty, floor, models, tt)
    for ax in axes[:, 0]:
        _log_ticks(ax)
    axes[-1, 0].set_xlabel("averaging time tau, s")
    axes[0, 0].set_title(f"{it.protocol} / {it.run}: overlapping Allan deviation\n"
                         f"bands: {100 * ALLAN_CI:.0f} % interval (chi-square, EDF of the leading "
                         f"noise type); drawn while >= {PAL.ALLAN_MIN_CLUSTERS} non-overlapping "
                         "clusters remain", fontsize=9)
    files.save_figure(fig, path)
    return True


def _allan_models(it) -> list:
    """The noise models the bench identifies in raw's and the oracle's errors, as (label,
    model), where the piece allows one and the model holds."""
    p = it.piece
    models = []
    if _has_noise_model(p):
        for lab in ("raw", "oracle"):
            if lab in it.outputs:
                nm = _noise_model(it.outputs[lab] - p.truth, p.fs)
                if nm is not None and nm.in_model:
                    models.append((lab, nm))
    return models


def _allan_floor(shown: dict, fixed: list[str]) -> float | None:
    """The Allan axis' bottom: ALLAN_DECADES_BELOW_RAW decades below raw's and the oracle's
    lowest, where some curve falls below it (else None: the axis as drawn)."""
    # (static_allan's wavelet_soft, a smoother, ran to 2e-6 deg/h and squeezed raw into the
    # top two of seven decades); a curve below is named so
    refs = [float(np.nanmin(shown[lab])) for lab in fixed if np.any(np.isfinite(shown[lab]))]
    floor = min(refs) * 10.0 ** -ALLAN_DECADES_BELOW_RAW if refs else None
    if floor is not None and not any(np.nanmin(v) < floor for v in shown.values()
                                     if np.any(np.isfinite(v))):
        floor = None
    return floor


def _panel_allan(ax, taus, shown: dict, fixed: list[str], chunk: list[dict], ads: dict,
                 keeps: dict, sty: dict, floor: float | None, models: list, tt) -> None:
    """One Allan panel: raw and oracle, the chunk's methods and sweeps (a curve under the
    ``floor`` named so), each with its interval band, and the identified models over ``tt``."""

    def band(lab):
        ad, keep = ads[lab], keeps[lab]
        ax.fill_between(ad.taus[keep], ad.low[keep] / DPH, ad.high[keep] / DPH,
                        color=sty[lab]["color"], alpha=0.13, lw=0, zorder=1.0)

    ax.set_xscale("log")
    ax.set_yscale("log")
    for lab in fixed:
        ax.plot(taus, shown[lab], label=lab, **sty[lab])
        band(lab)
    for e in chunk:
        below = floor is not None and any(
            bool(np.nanmin(shown[m]) < floor) for m in e["members"]
            if np.any(np.isfinite(shown[m])))
        for ln in _draw_entry(ax, taus, shown, e, sty):
            if below:
                ln.set_label(ln.get_label() + " (falls below the axis)")
        band(e["default"])
    for lab, nm in models:
        ax.plot(tt, nm.model_adev(tt) / DPH, color=sty[lab]["color"], lw=1.0, ls=":",
                zorder=9.0, label=f"{lab}: identified model {nm.spec()}")
    ax.set_ylabel(f"Allan deviation of (output - truth), {PAL.ERROR_UNIT}", fontsize=9)
    if floor is not None:
        ax.set_ylim(bottom=floor)
    ax.grid(True, which="both", lw=0.3)
    ax.legend(**LEGEND)


def shows_time_structure(p) -> bool:
    """Whether a scored piece gets Allan deviation and PSD figures: only a contiguous record.

    The rule: a piece of separate static dwells (samples joined across gaps, a multi-position
    test) is scored by the mean error of each dwell (``drift_rms_dph``: a constant bias, a
    g-dependent drift at each position), and the bench computes no noise metric on it
    (fogbench.run.runner.score: ARW, bias instability, 100 s bias stability only on a contiguous
    record). An Allan deviation or a PSD of stitched dwells cannot show a per-dwell constant
    (the PSD removes the mean; within a dwell a constant has no Allan deviation) and measures
    the jumps at the joins instead, so neither is drawn; the dwell-means figure shows the
    effect."""
    return not np.any(np.diff(p.t) > 1.5 / p.fs)
