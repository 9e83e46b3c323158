"""The rig: one power-on of the FOG on the rate table in the thermal chamber.

Given typed configuration (:class:`Rig`, :class:`Run`) and the run's seed, ``simulate_run``
returns truth (MuJoCo table + Earth rate), temperatures (chamber and coil) and the FOG's output
with its error breakdown. Nothing here knows of scenario files, methods or reports.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .fog import FogOutput, FogParams, simulate_fog
from .rate_table import TableConfig, Truth, simulate_truth
from .thermal import Thermal, ThermalModel, ThermalProgram, simulate_thermal

__all__ = ["Rig", "Run", "RunData", "simulate_run", "load_presets", "PRESETS_PATH"]

PRESETS_PATH = Path(__file__).with_name("presets.toml")


def load_presets(path: Path = PRESETS_PATH) -> dict[str, dict]:
    """The FOG presets: name -> table of [fog] keys (datasheet units, as a scenario writes them)."""
    with open(path, "rb") as f:
        return tomllib.load(f)


@dataclass(frozen=True)
class Rig:
    """The simulated rig: FOG output rate, table, FOG error model, sensitive axes, ambient, and
    the FOG's thermal build (housing and coil lags, temperature sensor)."""

    fs: float
    table: TableConfig
    fog: FogParams
    axes: tuple[str, ...]
    ambient_c: float = 20.0
    thermal: ThermalModel = ThermalModel()


@dataclass(frozen=True)
class Run:
    """One power-on of the FOG: its motion program, thermal program and seed."""

    name: str
    seed: int
    motion: tuple
    thermal: ThermalProgram | None
    tilt0: float = 0.0

    @property
    def duration(self) -> float:
        return float(sum(s.duration for s in self.motion))


@dataclass(frozen=True)
class RunData:
    """Everything one simulated power-on produced (SI; temperatures in deg C)."""

    run: Run
    fs: float
    truth: Truth
    thermal: Thermal
    fog: FogOutput
    axes: tuple[str, ...]

    @property
    def n(self) -> int:
        return self.truth.t.shape[0]

    def truth_axis(self, j: int) -> np.ndarray:
        """True inertial rate about sensitive axis j (rad/s)."""
        return self.truth.rate[:, "xyz".index(self.axes[j])]


def simulate_run(rig: Rig, run: Run, progress=None, seed: int | None = None,
                 truth: Truth | None = None) -> RunData:
    """Simulate one power-on. ``progress(fraction)`` is called as the table runs.

    ``seed`` (default ``run.seed``) seeds every random draw of the power-on: the FOG's switch-on
    draws and noise terms, and the temperature sensor's noise. The table's motion is
    deterministic: ``truth``, a :class:`~sim.rate_table.Truth` simulated before for the same
    ``rig`` and ``run``, is reused as it is (a Monte Carlo replicate then costs only the random
    draws).
    """
    seed = run.seed if seed is None else seed
    if truth is None:
        truth = simulate_truth(run.motion, rig.fs, rig.table, tilt0=run.tilt0,
                               progress=progress)
    program = run.thermal or ThermalProgram(start=rig.ambient_c, steps=())
    # the FOG's error model gets the true coil temperature and heat flux; the sensor's reading
    # (thermal.sensor, thermal.sensor_rate) is what a compensator may see
    thermal = simulate_thermal(program, truth.t, rig.thermal, seed=seed)
    fog = simulate_fog(rig.fog, rig.fs, truth.rate, truth.specific_force,
                       temp=thermal.coil, temp_rate=thermal.coil_rate, axes=rig.axes,
                       seed=seed)
    return RunData(run=run, fs=rig.fs, truth=truth, thermal=thermal, fog=fog, axes=rig.axes)
