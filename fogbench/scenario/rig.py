"""The rig part of a scenario file: ``[table]`` (the rate table and its imperfections),
``[thermal]`` programs, the ``[[runs.motion]]`` segments, and the memory a scenario may ask for."""

from __future__ import annotations

import math

from fogbench.scenario.tables import ScenarioError, _Table
from fogcomp import units as U
from sim.motion import ConstantRate, Hold, Positions, RateSteps, SineRate
from sim.rate_table import TableConfig
from sim.rig import Run
from sim.thermal import (
    ThermalHold,
    ThermalProgram,
    ThermalRamp,
)

# What a scenario may ask of memory: the runner holds every run's truth, temperatures, FOG output
# and error terms (float64) at once, and scoring copies the selected samples a few times.
MAX_SAMPLES = 50_000_000          # all runs together, at sample_rate_hz
BYTES_PER_SAMPLE = 8 * 70         # truth and table state (~45 columns) + terms and output per axis
MAX_ESTIMATED_BYTES = 8 * 2**30


def _table_cfg(tbl: _Table) -> TableConfig:
    cfg = TableConfig(
        radius=tbl.get("radius_m", "float", 0.0, lo=0.0, hi=0.14),
        height=tbl.get("height_m", "float", 0.06, lo=0.045, hi=0.5),
        latitude=math.radians(tbl.get("latitude_deg", "float", 45.0, lo=-90.0, hi=90.0)),
        heading=math.radians(tbl.get("heading_deg", "float", 0.0, lo=-360.0, hi=360.0)),
        gravity=tbl.get("gravity_mps2", "float", U.G0, lo=9.7, hi=9.84),
        physics_dt=tbl.get("physics_dt_s", "float", 1e-3, lo=1e-5, hi=5e-3),
        tilt_slew=math.radians(tbl.get("tilt_slew_dps", "float", 20.0, lo=0.1, hi=500.0)),
        settle_time=tbl.get("settle_time_s", "float", 5.0, lo=0.5, hi=600.0),
        turn_accel=math.radians(tbl.get("turn_accel_dps2", "float", 200.0, lo=1.0, hi=5000.0)),
        earth_rate=tbl.get("earth_rate", "bool", True),
        # the table's imperfections, default 0 (a perfect table); class values and their
        # sources: sim.lab.CLASS_VALUES (axis verticality 5 arcsec for a navigation-grade
        # turntable, Ruya-T ry119; rate error ~100 ppm, measured, XinLiGH/TurntableSpeedAndPosition)
        turn_axis_error=tbl.get("turn_axis_error_arcsec", "float", 0.0, lo=-3600.0,
                                hi=3600.0) * _ARCSEC,
        level_error=_level(tbl),
        # limit 1e4 ppm (1 %): beyond it no rate table (nor a hobby turntable) is used to
        # calibrate a gyro, so a value there is a typo
        rate_error=tbl.get("rate_error_ppm", "float", 0.0, lo=-1e4, hi=1e4) * 1e-6,
    )
    tbl.done()
    return cfg


_ARCSEC = math.pi / (180.0 * 3600.0)


def _level(tbl: _Table) -> tuple[float, float]:
    v = tbl.get("level_error_arcsec", "floats", [0.0, 0.0], lo=-3600.0, hi=3600.0)
    if len(v) != 2:
        raise tbl.err("level_error_arcsec", f"expected [about x, about y], got {len(v)} values")
    return v[0] * _ARCSEC, v[1] * _ARCSEC


def _thermal(tbl: _Table) -> ThermalProgram:
    start = tbl.get("start_c", "float", lo=-80.0, hi=150.0)
    # the FOG's own lags are [fog] keys; these override them for this set-up (fixture, air flow)
    tau = tbl.get("coil_time_constant_s", "float", None, lo=0.0, hi=1e5)
    tau_h = tbl.get("housing_time_constant_s", "float", None, lo=0.0, hi=1e5)
    steps = []
    for i, st in enumerate(tbl.get("steps", "tables", [])):
        s = _Table(st, f"{tbl.where} steps[{i}]", tbl.file)
        if s.has("hold_s"):
            steps.append(ThermalHold(s.get("hold_s", "float", lo=0.0, lo_open=True)))
        elif s.has("ramp_to_c"):
            steps.append(ThermalRamp(s.get("ramp_to_c", "float", lo=-80.0, hi=150.0),
                                     s.get("rate_c_per_min", "float", lo=0.0, lo_open=True,
                                           hi=30.0) / 60.0))
        else:
            raise s.err("hold_s", "a thermal step needs 'hold_s' (a hold) or 'ramp_to_c' with "
                        "'rate_c_per_min' (a ramp)")
        s.done()
    tbl.done()
    return ThermalProgram(start=start, steps=tuple(steps), coil_time_constant=tau,
                          housing_time_constant=tau_h)


_MOTION_TYPES = ("hold", "rate", "rate_steps", "sine", "positions")


def _motion(tbl: _Table, fs: float):
    kind = tbl.get("type", "str", choices=set(_MOTION_TYPES))
    tilt_deg = tbl.get("tilt_deg", "float", None, lo=-360.0, hi=360.0) if kind != "positions" else None
    tilt = None if tilt_deg is None else math.radians(tilt_deg)
    if kind == "hold":
        seg = Hold(tbl.get("duration_s", "float", lo=0.0, lo_open=True), tilt=tilt)
    elif kind == "rate":
        seg = ConstantRate(tbl.get("duration_s", "float", lo=0.0, lo_open=True),
                           math.radians(tbl.get("rate_dps", "float", lo=-1000.0, hi=1000.0)),
                           tilt=tilt)
    elif kind == "rate_steps":
        seg = RateSteps(tuple(math.radians(r) for r in tbl.get("rates_dps", "floats", lo=-1000.0,
                                                               hi=1000.0)),
                        tbl.get("step_s", "float", lo=0.0, lo_open=True), tilt=tilt)
    elif kind == "sine":
        seg = SineRate(tbl.get("duration_s", "float", lo=0.0, lo_open=True),
                       math.radians(tbl.get("amplitude_dps", "float", lo=0.0, hi=1000.0)),
                       tbl.get("frequency_hz", "float", lo=0.0, lo_open=True, hi=fs / 4),
                       math.radians(tbl.get("offset_dps", "float", 0.0, lo=-1000.0, hi=1000.0)),
                       tilt=tilt)
    else:
        seg = Positions(
            tuple(math.radians(x) for x in tbl.get("tilts_deg", "floats", lo=-360.0, hi=360.0)),
            tuple(math.radians(x) for x in tbl.get("headings_deg", "floats", lo=-720.0,
                                                   hi=720.0)),
            dwell=tbl.get("dwell_s", "float", lo=0.0, lo_open=True),
            move_time=tbl.get("move_s", "float", lo=0.0, lo_open=True),
            max_rate=math.radians(tbl.get("move_rate_dps", "float", 30.0, lo=0.1, hi=1000.0)),
            max_accel=math.radians(tbl.get("move_accel_dps2", "float", 60.0, lo=0.1,
                                           hi=5000.0)),
        )
    tbl.done()
    return seg


def _check_whole_samples(tbl: _Table, seg, fs: float):
    parts = {"hold": [("duration_s", seg.duration)], "rate": [("duration_s", seg.duration)],
             "sine": [("duration_s", seg.duration)],
             "rate_steps": [("step_s", getattr(seg, "step_duration", 0.0))],
             "positions": [("dwell_s", getattr(seg, "dwell", 0.0)),
                           ("move_s", getattr(seg, "move_time", 0.0))]}[seg.kind]
    for key, val in parts:
        n = val * fs
        if not math.isfinite(n) or n > MAX_SAMPLES:
            raise tbl.err(key, f"{val:g} s is {n:g} samples at sample_rate_hz = {fs:g}; the "
                          f"limit is {MAX_SAMPLES:.3g} samples in all")
        if abs(n - round(n)) > 1e-6 * max(1.0, n):
            raise tbl.err(key, f"expected a whole number of samples at sample_rate_hz = {fs:g}, "
                          f"got {val:g} s = {n:g} samples")


def _check_size(runs: list[Run], fs: float, n_axes: int, file: str) -> None:
    """Refuse, before any simulation, a scenario whose runs cannot fit in memory."""
    per_run = [(r.name, r.duration * fs) for r in runs]
    total = sum(n for _, n in per_run)
    est = total * (BYTES_PER_SAMPLE + 8 * 16 * n_axes)
    if total > MAX_SAMPLES or est > MAX_ESTIMATED_BYTES:
        big = max(per_run, key=lambda x: x[1])
        raise ScenarioError(
            f"{file}: the runs ask for {total:.3g} samples in all (largest: run {big[0]!r}, "
            f"{big[1]:.3g} samples), about {est / 2**30:.3g} GiB of memory; the limit is "
            f"{MAX_SAMPLES:.3g} samples and {MAX_ESTIMATED_BYTES / 2**30:g} GiB: shorten the "
            "runs' duration_s or lower sample_rate_hz")
