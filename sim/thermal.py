"""Thermal chamber programs, the FOG's thermal nodes and its temperature sensor.

A program starts at ``start_c`` and is a list of holds (``duration_s``) and ramps (``to_c`` at
``rate_c_per_min``). The chamber air temperature is piecewise linear; past the end of the program
the chamber holds its last temperature.

The FOG is two thermal nodes in a chain, chamber -> housing -> coil, each a first-order lag::

    dTh/dt = (Tch - Th) / tau_h          dTc/dt = (Th - Tc) / tau_c

(a lumped model of a FOG package: housing and mount, then the fiber coil inside it). The heat
flux into the coil is proportional to the gradient Th - Tc, and so is dTc/dt: it is the Shupe
bias's driver (paper 002, eq. 1: the bias follows dT/dt along the fiber), zero when the coil is
in equilibrium with its housing. The chain is solved exactly for a piecewise-linear chamber
(first-order-hold discretisation of each lag; the coil as the partial-fraction sum of the two
lags), so the result does not depend on the sample rate. The FOG starts soaked at the chamber's
start temperature.

A lab does not know the coil temperature: it reads a sensor. :class:`TempSensor` sits on the
housing or the coil, follows it through its own lag, is read at its own rate with white noise
and quantised to its resolution (e.g. 0.0625 C, a 12-bit digital sensor); the lab takes dT/dt as
the least-squares slope of the readings over a window (:func:`window_slope`). Compensators get
the sensor's reading and that slope; the true coil temperature stays in the truth.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, field

import numpy as np
from scipy.signal import fftconvolve, lfilter

__all__ = ["ThermalHold", "ThermalRamp", "ThermalProgram", "TempSensor", "ThermalModel",
           "Thermal", "simulate_thermal", "read_sensor", "window_slope", "SENSOR_LOCATIONS"]

SENSOR_LOCATIONS = ("housing", "coil")


@dataclass(frozen=True)
class ThermalHold:
    duration: float  # s


@dataclass(frozen=True)
class ThermalRamp:
    to: float        # deg C
    rate: float      # deg C per second (> 0; the direction follows from the temperatures)


@dataclass(frozen=True)
class ThermalProgram:
    """A chamber program. ``coil_time_constant`` and ``housing_time_constant`` (s), when given,
    override the FOG's own (:class:`ThermalModel`) for this program's set-up (a fixture, the
    chamber's air flow); None keeps the device's."""

    start: float = 20.0             # deg C
    steps: tuple = ()
    coil_time_constant: float | None = None
    housing_time_constant: float | None = None

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
class TempSensor:
    """The temperature sensor a lab reads (SI; temperatures in deg C).

    Attributes
    ----------
    location : {"housing", "coil"}
        The node it is bonded to.
    time_constant : float
        Its own first-order lag behind that node, s (0: none).
    noise : float
        White noise per reading, deg C (1 sigma).
    resolution : float
        Quantisation step, deg C (0: none); 0.0625 C is a 12-bit digital sensor's LSB.
    rate : float
        Readings per second, Hz (0: one per FOG sample). Between readings the last is held.
    rate_window : float
        dT/dt is the least-squares slope of the readings in a window of this length centred on
        each reading, s (``2 h + 1`` readings, ``h = max(1, round(rate_window / dt / 2))`` at
        reading spacing ``dt``), as a lab fits its log; see :func:`read_sensor` for the ends of
        a record and for records shorter than the window.
    """

    location: str = "coil"
    time_constant: float = 0.0
    noise: float = 0.0
    resolution: float = 0.0
    rate: float = 0.0
    rate_window: float = 0.0

    def __post_init__(self):
        if self.location not in SENSOR_LOCATIONS:
            raise ValueError(f"TempSensor.location must be one of {SENSOR_LOCATIONS}, "
                             f"got {self.location!r}")
        for k in ("time_constant", "noise", "resolution", "rate", "rate_window"):
            if not getattr(self, k) >= 0.0:
                raise ValueError(f"TempSensor.{k} must be >= 0, got {getattr(self, k)!r}")


@dataclass(frozen=True)
class ThermalModel:
    """The FOG's thermal build: lags chamber -> housing -> coil (s) and its sensor."""

    housing_time_constant: float = 0.0
    coil_time_constant: float = 600.0
    sensor: TempSensor = field(default_factory=TempSensor)


@dataclass(frozen=True)
class Thermal:
    """Temperatures at the sample times (deg C; rates deg C/s), each shape (n,).

    chamber, housing, coil : the true node temperatures.  coil_rate : true dTc/dt, which is the
    heat flux into the coil over its heat capacity, (Th - Tc) / tau_c.  sensor : what the
    temperature sensor reads (held between readings).  sensor_rate : dT/dt, the least-squares
    slope of the readings over the sensor's rate window.
    """

    chamber: np.ndarray
    coil: np.ndarray
    coil_rate: np.ndarray
    housing: np.ndarray | None = None
    sensor: np.ndarray | None = None
    sensor_rate: np.ndarray | None = None

    def __post_init__(self):
        if self.housing is None:
            object.__setattr__(self, "housing", self.chamber)
        if self.sensor is None:
            object.__setattr__(self, "sensor", self.coil)
        if self.sensor_rate is None:
            object.__setattr__(self, "sensor_rate", self.coil_rate)


def _lag(u: np.ndarray, h: float, tau: float, x0: float) -> np.ndarray:
    """First-order lag of u sampled every h (s), exact for u linear between samples."""
    if tau <= 0.0:
        return u.copy()
    a = math.exp(-h / tau)
    # x[k+1] = a x[k] + u[k+1] - a u[k] - tau (1 - a) (u[k+1] - u[k]) / h
    v = u[1:] - a * u[:-1] - tau * (1.0 - a) * (u[1:] - u[:-1]) / h
    rest, _ = lfilter([1.0], [1.0, -a], v, zi=[a * x0])
    return np.concatenate([[x0], rest])


def _chain(u: np.ndarray, h: float, tau_h: float, tau_c: float):
    """Housing and coil temperature and dTc/dt for chamber samples u (spacing h, s)."""
    x0 = float(u[0])
    housing = _lag(u, h, tau_h, x0)
    if tau_c <= 0.0:
        coil = housing
        rate = (u - housing) / tau_h if tau_h > 0 else np.gradient(u, h)
        return housing, coil.copy(), rate
    if tau_h <= 0.0:
        coil = _lag(u, h, tau_c, x0)
    else:
        # 1 / ((1 + s th)(1 + s tc)) = (th L_th - tc L_tc) / (th - tc); for th = tc the limit,
        # taken here by separating the two by 1e-6 relative (an error of order 1e-6 of the
        # transient, far below the sensor's resolution)
        th, tc = tau_h, tau_c
        if abs(th - tc) < 1e-6 * max(th, tc):
            th = tc * (1.0 + 1e-6)
        coil = (th * _lag(u, h, th, x0) - tc * _lag(u, h, tc, x0)) / (th - tc)
    return housing, coil, (housing - coil) / tau_c


def _stream(seed: int, name: str) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(zlib.crc32(name.encode()),)))


def window_slope(val: np.ndarray, dt: float, half: int) -> np.ndarray:
    """Least-squares slope of ``val`` (uniformly spaced by ``dt``) in the window of readings
    ``[k - half, k + half]`` around each reading k, cut to the record: shape of ``val``, per dt.

    The window is centred (it uses ``half`` readings after k: an offline fit of a log, as the
    central difference it replaces was, not an online filter). Near the ends it is cut to the
    readings there are (``[0, k + half]``, ``[k - half, m - 1]``), so a record of ``m <= half + 1``
    readings gets the one slope of the whole record at every reading. Each slope is the ordinary
    least-squares one, ``sum((t - tbar) v) / sum((t - tbar)^2)`` over its window: exact for a
    straight line (and, in the full centred window, for a parabola), and for readings with
    independent errors of variance s^2 its variance is ``s^2 / S_tt`` with
    ``S_tt = dt^2 n (n^2 - 1) / 12`` for the window's n readings. ``half = 1`` in the interior is
    the central difference ``(v[k+1] - v[k-1]) / (2 dt)``; at the ends, the adjacent one.
    """
    v = np.asarray(val, dtype=float)
    m = v.size
    out = np.zeros(m)
    if m < 2:
        return out
    half = max(1, int(half))
    v = v - v.mean()                   # the slope does not depend on an offset; keeps sums small

    def from_start(x: np.ndarray, hi: np.ndarray) -> np.ndarray:
        # slopes of x[0 .. hi] (inclusive) for each hi >= 1, from prefix sums; index j = 0..hi
        j = np.arange(x.size, dtype=float)
        sv, sjv = np.cumsum(x), np.cumsum(j * x)
        n = hi + 1.0
        sj = hi * n / 2.0
        sxx = n * (n * n - 1.0) / 12.0         # sum (j - jbar)^2
        return (sjv[hi] - sj / n * sv[hi]) / sxx

    k = np.arange(m)
    left = k < half
    right = ~left & (k > m - 1 - half)
    mid = ~left & ~right
    if left.any():
        hi = np.minimum(k[left] + half, m - 1)
        out[left] = from_start(v[: int(hi.max()) + 1], hi)
    if right.any():
        # in reversed time the window [k - half, m - 1] starts at 0; the slope changes sign
        lo = np.maximum(k[right] - half, 0)
        out[right] = -from_start(v[::-1][: m - int(lo.min())], m - 1 - lo)
    if mid.any():
        # a fixed centred window: sum_i i v[k + i] / sum_i i^2, i = -half..half
        i = np.arange(-half, half + 1, dtype=float)
        num = fftconvolve(v, i[::-1], mode="valid") if half > 64 else \
            np.convolve(v, i[::-1], mode="valid")
        out[mid] = num / (half * (half + 1.0) * (2.0 * half + 1.0) / 3.0)
    return out / dt


def read_sensor(node: np.ndarray, t: np.ndarray, sensor: TempSensor, seed: int = 0):
    """The sensor's readings of ``node`` (deg C at times t, s, uniform) and the dT/dt a lab
    fits to them (deg C/s), both held at the sample times.

    dT/dt at each reading is the least-squares slope of the readings in the window of
    ``sensor.rate_window`` centred on it (:func:`window_slope`, ``half = max(1, round(rate_window
    / dt / 2))`` readings either side at reading spacing dt; 0 gives the central difference of
    the neighbouring readings). At the ends of a record the window is cut to the readings there
    are, and a record no longer than half the window (n <= half + 1 readings) gets the
    least-squares slope of the whole record at every sample: unbiased for a linear trend, with
    standard deviation ``s sqrt(12 / (n (n^2 - 1))) / dt`` for n readings of independent error s
    (12 readings 1 s apart: 0.084 s / s x s, i.e. 0.1 C/min for readings that scatter by 0.02 C;
    the window asked for is not there to average over)."""
    n = t.size
    h = t[1] - t[0] if n > 1 else 1.0
    lagged = _lag(node, h, sensor.time_constant, float(node[0])) if n > 1 else node.copy()
    if sensor.rate > 0.0 and sensor.rate < 1.0 / h:
        tr = np.arange(0.0, t[-1] - t[0] + 1e-9 * h, 1.0 / sensor.rate)
        val = np.interp(tr, t - t[0], lagged)
        held = np.minimum(np.floor((t - t[0]) * sensor.rate + 1e-9).astype(int), tr.size - 1)
        dtr = 1.0 / sensor.rate
    else:
        val = lagged.copy()
        held = np.arange(n)
        dtr = h
    if sensor.noise > 0.0:
        val = val + _stream(seed, "temp_sensor").standard_normal(val.size) * sensor.noise
    if sensor.resolution > 0.0:
        val = np.round(val / sensor.resolution) * sensor.resolution
    if val.size < 2:
        return val[held], np.zeros(n)
    half = max(1, int(round(sensor.rate_window / dtr / 2.0)))
    rate = window_slope(val, dtr, half)
    return val[held], rate[held]


def simulate_thermal(program: ThermalProgram, t: np.ndarray, model: ThermalModel | None = None,
                     seed: int = 0) -> Thermal:
    """Chamber, housing, coil and sensor temperatures at the (uniformly spaced) times ``t`` (s).

    Parameters
    ----------
    program : ThermalProgram
        The chamber program; its time constants, when set, override the model's.
    t : ndarray, shape (n,)
        Sample times, s.
    model : ThermalModel, optional
        The FOG's thermal nodes and sensor (default: one coil lag of 600 s, an ideal sensor on
        the coil).
    seed : int
        Seed of the power-on; the sensor's noise has its own stream derived from it.
    """
    model = model or ThermalModel()
    tau_c = model.coil_time_constant if program.coil_time_constant is None \
        else program.coil_time_constant
    tau_h = model.housing_time_constant if program.housing_time_constant is None \
        else program.housing_time_constant
    bt, btemp = program.breakpoints()
    chamber = np.interp(t, bt, btemp)
    if t.size < 2:
        z = np.zeros_like(t)
        return Thermal(chamber, chamber.copy(), z, chamber.copy(), chamber.copy(), z)
    h = t[1] - t[0]
    housing, coil, coil_rate = _chain(chamber, h, tau_h, tau_c)
    node = housing if model.sensor.location == "housing" else coil
    sensor, sensor_rate = read_sensor(node, t, model.sensor, seed)
    return Thermal(chamber, coil, coil_rate, housing, sensor, sensor_rate)
