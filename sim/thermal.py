"""Thermal chamber programs and the fiber coil's first-order lag.

A program starts at ``start_c`` and is a list of holds (``duration_s``) and ramps (``to_c`` at
``rate_c_per_min``). The chamber air temperature is piecewise linear; the coil follows through a
first-order lag with time constant ``tau`` (s), solved exactly for a piecewise-linear input
(first-order-hold discretisation), so the result does not depend on the sample rate.
Past the end of the program the chamber holds its last temperature.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

__all__ = ["ThermalHold", "ThermalRamp", "ThermalProgram", "Thermal", "simulate_thermal"]


@dataclass(frozen=True)
class ThermalHold:
    duration: float  # s


@dataclass(frozen=True)
class ThermalRamp:
    to: float        # deg C
    rate: float      # deg C per second (> 0; the direction follows from the temperatures)


@dataclass(frozen=True)
class ThermalProgram:
    start: float = 20.0             # deg C
    steps: tuple = ()
    coil_time_constant: float = 600.0  # s

    def breakpoints(self) -> tuple[np.ndarray, np.ndarray]:
        """Times (s) and chamber temperatures (deg C) of the piecewise-linear program."""
        t, temp = [0.0], [self.start]
        for st in self.steps:
            if isinstance(st, ThermalHold):
                t.append(t[-1] + st.duration)
                temp.append(temp[-1])
            else:
                t.append(t[-1] + abs(st.to - temp[-1]) / st.rate)
                temp.append(st.to)
        return np.array(t), np.array(temp)

    @property
    def duration(self) -> float:
        return float(self.breakpoints()[0][-1])


@dataclass(frozen=True)
class Thermal:
    """Temperatures at the sample times: chamber and coil in deg C, coil rate in deg C/s."""

    chamber: np.ndarray
    coil: np.ndarray
    coil_rate: np.ndarray


def simulate_thermal(program: ThermalProgram, t: np.ndarray) -> Thermal:
    """Chamber and coil temperature at the (uniformly spaced) times ``t`` (s)."""
    bt, btemp = program.breakpoints()
    chamber = np.interp(t, bt, btemp)
    tau = program.coil_time_constant
    if tau <= 0:
        return Thermal(chamber, chamber.copy(), np.gradient(chamber, t) if t.size > 1 else
                       np.zeros_like(t))
    if t.size < 2:
        return Thermal(chamber, chamber.copy(), np.zeros_like(t))
    h = t[1] - t[0]
    a = math.exp(-h / tau)
    u = chamber
    # x[k+1] = a x[k] + u[k+1] - a u[k] - tau (1 - a) (u[k+1] - u[k]) / h, exact for linear u
    # between samples. Breakpoints between samples are approximated by linear interpolation.
    v = u[1:] - a * u[:-1] - tau * (1.0 - a) * (u[1:] - u[:-1]) / h
    x0 = np.interp(t[0], bt, btemp)  # the coil starts soaked at the chamber temperature
    rest, _ = lfilter([1.0], [1.0, -a], v, zi=[a * x0])
    coil = np.concatenate([[x0], rest])
    return Thermal(chamber, coil, (chamber - coil) / tau)
