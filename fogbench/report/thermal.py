"""The thermal run's figure (``figures/thermal.png``): temperatures, the raw bias over time and
the hysteresis loop of bias against the temperature a lab reads."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from fogbench.outputs import files
from fogbench.report import palette as PAL
from fogbench.report.timeseries import _min_span
from fogbench.run.runner import ScenarioResult
from fogcomp import metrics as M
from fogcomp.units import DPH


def thermal_run(res: ScenarioResult) -> str:
    """The run ``thermal.png`` shows: the first scored run with a thermal program (the run the
    verdicts are about), else the first run."""
    for it in res.scored:
        for run in it.run.split("+"):
            rd = res.data.get(run)
            if rd is not None and rd.run.thermal is not None and rd.run.thermal.steps:
                return run
    return next(iter(res.data))


STEADY_FRACTION = 0.1    # thermal.png's loop: |dT/dt| below this fraction of the run's largest
#                          (100 s means) is "steady", neither heating nor cooling


def fig_thermal(res: ScenarioResult, run: str, path: Path) -> bool:
    """The thermal run ``run``: top left, the chamber program, the FOG's node temperatures and
    the sensor reading, with the coil's dT/dt; bottom left, the raw bias (raw output less the
    truth, 100 s means, deg/h) against time; bottom right, the same bias against the
    temperature a lab reads (the sensor, 100 s means; the true coil temperature where the run
    has no sensor), each point coloured by the coil's dT/dt: heating, cooling or steady
    (|dT/dt| under STEADY_FRACTION of the run's largest). The loop this draws is the part of
    the bias a model in temperature alone cannot fit: the Shupe term in dT/dt (the heating and
    cooling branches sit apart by about twice its coefficient times the ramp rate) and the
    sensor's lag behind the coil."""
    rd = res.data[run]
    if rd.run.thermal is None or not rd.run.thermal.steps:
        return False
    j = res.scenario.axes.index(res.plan.axis)
    k = max(1, int(round(100.0 * rd.fs)))
    ts, tname = PAL.time_unit(float(rd.truth.t[-1]))
    t = M.smooth(rd.truth.t, rd.fs, 100.0) / ts
    bias = M.smooth(rd.fog.raw[:, j] - rd.truth_axis(j), rd.fs, 100.0) / DPH
    fig = plt.figure(figsize=(13.5, 6.5))
    gs = fig.add_gridspec(2, 2, width_ratios=(2.3, 1.0), wspace=0.22, hspace=0.12)
    ax = fig.add_subplot(gs[0, 0])
    ax_b = fig.add_subplot(gs[1, 0], sharex=ax)
    ax_l = fig.add_subplot(gs[1, 1], sharey=ax_b)
    ax_key = fig.add_subplot(gs[0, 1])
    ax_key.axis("off")
    ax2, has_sensor = _panel_temperatures(ax, res, run, rd.truth.t / ts)
    ax_b.plot(t, bias, lw=0.8, color="0.4",
              label=f"raw output - truth (100 s means of {k} samples)")
    ax_b.set_ylabel(f"bias, {PAL.ERROR_UNIT}")
    _min_span(ax_b, PAL.ERROR_UNIT)
    ax_b.set_xlabel(f"time since power-on, {tname}")
    _panel_loop(ax_l, rd, j, bias, has_sensor)
    handles = []
    labels = []
    for a in (ax, ax2, ax_b, ax_l):
        h, lab = a.get_legend_handles_labels()
        handles += h
        labels += lab
    ax_key.legend(handles, labels, loc="upper left", fontsize=8, frameon=False)
    files.save_figure(fig, path)
    return True


def _panel_temperatures(ax, res: ScenarioResult, run: str, th_h):
    """fig_thermal's top panel: the chamber program, the FOG's node temperatures and the
    sensor reading (where it differs from the coil) against time ``th_h``, the coil's dT/dt
    on a right axis. Returns that right axis and whether the run has a sensor of its own."""
    th = res.data[run].thermal
    ax.plot(th_h, th.chamber, color="tab:blue", lw=1.4, label="chamber")
    if th.housing is not None and not np.array_equal(th.housing, th.chamber):
        ax.plot(th_h, th.housing, color="tab:purple", lw=2.6, alpha=0.6, label="housing")
    ax.plot(th_h, th.coil, color="tab:orange", lw=1.6, label="coil (true)")
    has_sensor = th.sensor is not None and not np.array_equal(th.sensor, th.coil)
    if has_sensor:
        ax.plot(th_h, th.sensor, color="black", lw=0.8, ls=":", label="sensor reading")
    ax.set_ylabel("temperature, deg C")
    _min_span(ax, "deg C")
    ax.tick_params(labelbottom=False)
    ax2 = ax.twinx()
    ax2.plot(th_h, th.coil_rate * 60, color="tab:red", lw=0.8, label="coil dT/dt (right axis)")
    ax2.set_ylabel("coil dT/dt, deg C/min")
    _min_span(ax2, "deg C/min")
    scored = sorted({it.protocol for it in getattr(res, "scored", ()) if run in it.run.split("+")})
    ax.set_title(f"{run}" + (f" (scored by {', '.join(scored)})" if scored else "")
                 + ": chamber program, FOG temperatures and raw bias", fontsize=10)
    return ax2, has_sensor


def _panel_loop(ax_l, rd, j: int, bias, has_sensor: bool) -> None:
    """fig_thermal's loop: the bias against the temperature a lab reads, each point by the
    direction of the coil's drift, with the simulated thermal term alone beside it."""
    th = rd.thermal
    temp = M.smooth(th.sensor if has_sensor else th.coil, rd.fs, 100.0)
    rate = M.smooth(th.coil_rate * 60.0, rd.fs, 100.0)
    steady = STEADY_FRACTION * max(float(np.max(np.abs(rate))), 1e-12)
    ax_l.plot(temp, bias, color="0.75", lw=0.6, zorder=1)
    for name, sel, c in (("heating", rate > steady, "tab:red"),
                         ("cooling", rate < -steady, "tab:blue"),
                         ("steady", np.abs(rate) <= steady, "0.45")):
        if np.any(sel):
            ax_l.plot(temp[sel], bias[sel], "o", ms=3, color=c, zorder=2, gid=f"loop:{name}",
                      label=f"bias vs temperature, {name}"
                            + (f" (|dT/dt| <= {steady:.2g} deg C/min)" if name == "steady"
                               else ""))
    # beside it, the simulation's own thermal term (its truth: the temperature law and the
    # Shupe term in dT/dt), where the bias carries more (thermal_with_motion's g terms by
    # position scatter the raw points about it)
    terms = getattr(rd.fog, "terms", None) or {}
    if "temperature" in terms:
        th_term = M.smooth(terms["temperature"][:, j], rd.fs, 100.0) / DPH
        rest = float(np.mean(bias - th_term))
        ax_l.plot(temp, th_term + rest, color="black", lw=1.2, zorder=3, gid="loop:true_term",
                  label="the simulated thermal term alone (the truth; 100 s means), plus "
                        f"the rest's mean ({rest:.3g} {PAL.ERROR_UNIT})")
    ax_l.set_xlabel("sensor reading, deg C (100 s means)" if has_sensor
                    else "coil temperature (true), deg C (100 s means)")
    lo, hi = PAL.min_span(*ax_l.get_xlim(), "deg C")
    ax_l.set_xlim(lo, hi)
    ax_l.tick_params(labelleft=False)
    ax_l.set_title("the same bias against temperature", fontsize=9)
