"""The rig: one power-on of the FOG on the rate table in the thermal chamber.

``simulate_run`` turns a scenario's run into truth (MuJoCo table + Earth rate), temperatures
(chamber and coil) and the FOG's output with its error breakdown.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .fog import FogOutput, simulate_fog
from .rate_table import Truth, simulate_truth
from .scenario import Run, Scenario
from .thermal import Thermal, ThermalProgram, simulate_thermal

__all__ = ["RunData", "simulate_run"]


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


def simulate_run(scenario: Scenario, run: Run, progress=None) -> RunData:
    """Simulate one run of ``scenario``. ``progress(fraction)`` is called as the table runs."""
    truth = simulate_truth(run.motion, scenario.fs, scenario.table, tilt0=run.tilt0,
                           progress=progress)
    program = run.thermal or ThermalProgram(start=scenario.ambient_c, steps=(),
                                            coil_time_constant=0.0)
    thermal = simulate_thermal(program, truth.t)
    fog = simulate_fog(scenario.fog, scenario.fs, truth.rate, truth.specific_force,
                       temp=thermal.coil, temp_rate=thermal.coil_rate, axes=scenario.axes,
                       seed=run.seed)
    return RunData(run=run, fs=scenario.fs, truth=truth, thermal=thermal, fog=fog,
                   axes=scenario.axes)
