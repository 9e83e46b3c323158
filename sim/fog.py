"""The FOG error model: what a real fiber-optic gyro adds to the true rate.

Every term is computed separately, in rad/s per sample, from its own random stream, and the
output is their sum plus the truth, sampled as angle increments over each sample interval and
quantised (the quantisation is itself reported as a term). So

    raw = truth + sum(terms)            (exactly, up to floating-point rounding)

and the runner can tell what an ideal compensator of the deterministic terms reaches (the oracle).

Terms (name: model), for each sensitive axis a with true rate w_a (rad/s), specific force
f = (fx, fy, fz) (g), coil temperature T (deg C) and its rate Tdot (deg C/s):

- ``constant_bias``: b0.
- ``switch_on_bias``: b_s ~ N(0, sigma_s^2), a new draw at each power-on (each run).
- ``arw``: white rate noise; angle random walk N: the per-sample mean rate has std N sqrt(fs).
- ``bias_instability``: flicker (1/f) rate noise with one-sided PSD B^2/(pi f) over a band of
  frequencies, made as a sum of first-order Gauss-Markov processes with log-spaced corner
  frequencies and equal variances (a flat Allan floor of sqrt(2 ln 2 / pi) B = 0.664 B,
  IEEE Std 952-1997, Annex C), each started from zero at power-on. The run-to-run part of the
  bias is the labelled ``switch_on_bias`` (a datasheet's turn-on repeatability); starting the
  in-run process from its stationary distribution would add a second, unlabelled switch-on bias
  (the slow components' initial values) that the oracle counts as noise. Started from zero, the
  slow components grow as random walks: the Allan curve inside a record is unchanged, only the
  unlabelled offset is gone.
- ``gm_drift``: a first-order Gauss-Markov drift of standard deviation s and correlation time tc
  (seconds to minutes: the slow wander of a low-grade open-loop FOG's output, which a Kalman
  filter on a constant rate keeps and a Mallat split puts in its trend), exact discretisation
  x[k+1] = phi x[k] + sqrt(1 - phi^2) s e[k], phi = exp(-1 / (fs tc)), started stationary (its
  memory is far shorter than a record: it is noise, not a switch-on bias).
- ``rrw``: rate random walk K: the rate's increments per sample have std K sqrt(1/fs).
- ``rate_ramp``: R t.
- ``scale_factor``: (k0 + kT (T - T_ref)) w_a + k_nl w_a ``abs(w_a)`` / w_fs  (k_nl at full scale).
- ``misalignment``: sum over the other two axes b of M[a, b] w_b (small angles, rad).
- ``g_sensitivity``: d1 fx + d2 fy + d3 fz (paper 004, eq. 8, the linear terms).
- ``g2_sensitivity``: d4 fx^2 + d5 fy^2 + d6 fz^2 + d7 fx fy + d8 fy fz + d9 fx fz (paper 004,
  eq. 8, the quadratic terms), with optional switch-on variation of d1..d9.
- ``temperature``: c1 (T - T_ref) + c2 (T - T_ref)^2 + a (c3 + c4 (T - T_ref)) Tdot: the Shupe
  bias, driven by the heat flux into the coil (paper 002, eq. 1: the bias follows dT/dt along the
  fiber); Tdot is the coil's dTc/dt = (T_housing - T_coil) / tau_coil (``sim.thermal``), so the
  Shupe bias is zero when there is no gradient between housing and coil. a = 1 while the coil
  warms and a = ``temp_rate_cooling_ratio`` while it cools (a wound coil's asymmetry between
  heating and cooling, which gives hysteresis over a heat-and-cool cycle). Plus the static
  thermal sensitivity in T.
- ``saturation``: the rate the FOG can measure is limited to +-range (``range_dps``): beyond it
  the output is clipped (before the pulse counter) and the sample flagged in
  ``FogOutput.saturated``; the term is the clipped minus the unclipped sum.
- ``quantization``: the output is the whole number of quanta Q of the accumulated angle, as a
  pulse counter outputs it; the term is the difference this makes.

Each term's random stream is ``SeedSequence(seed, spawn_key=(crc32(term name), axis))``, so that
switching one term on or off never changes another term's draws.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, field

import numpy as np
from scipy.signal import lfilter

__all__ = ["FogParams", "FogOutput", "TERMS", "simulate_fog", "bias_instability_components"]

TERMS = ("constant_bias", "switch_on_bias", "arw", "bias_instability", "gm_drift", "rrw", "rate_ramp",
         "scale_factor", "misalignment", "g_sensitivity", "g2_sensitivity", "temperature",
         "saturation", "quantization")
AXES = {"x": 0, "y": 1, "z": 2}


@dataclass(frozen=True)
class FogParams:
    """FOG error parameters in SI units (the scenario loader converts from datasheet units).

    Attributes
    ----------
    bias : rad/s.  switch_on_bias_sigma : rad/s.  arw : rad/sqrt(s).
    bias_instability : B, rad/s (Allan floor 0.664 B).  bi_band : (f_low, f_high), Hz, the corner
    frequencies spanned by the flicker model. A real FOG's flicker floor runs on to the longest
    averaging times (until rate random walk takes over): keep f_low far below 1 / record length
    (default 1e-6 Hz), or the Allan curve falls again past tau ~ 1 / (2 pi f_low).  bi_per_decade : Gauss-Markov components per decade.
    gm_drift : s, rad/s.  gm_time_constant : tc, s.
    rrw : rad/s/sqrt(s).  rate_ramp : rad/s^2.  quantization : rad per output quantum.
    scale_factor : k0 (dimensionless).  sf_nonlinearity : k_nl at full scale (dimensionless).
    full_scale : rad/s.  sf_temp_coeff : kT, 1/degC.
    misalignment : shape (3, 3), rad; row a gives axis a's sensitivity to the rates about x, y, z
    (the diagonal must be zero).
    g_sens : shape (3,) or (n_axes, 3), rad/s/g (d1..d3).  g2_sens : shape (6,) or (n_axes, 6),
    rad/s/g^2 (d4..d9 in the order fx^2, fy^2, fz^2, fx fy, fy fz, fx fz).
    g_sens_switch_on_sigma : rad/s/g.  g2_sens_switch_on_sigma : rad/s/g^2.
    temp_ref : degC.  temp_coeff : rad/s/degC.  temp_coeff2 : rad/s/degC^2.
    temp_rate_coeff : rad/s per (degC/s).  temp_cross_coeff : rad/s per (degC * degC/s).
    temp_rate_cooling_ratio : the Shupe coefficients' factor while the coil cools (1: symmetric).
    range : measurement range, rad/s (inf: none); the output is clipped to +-range.
    """

    bias: float = 0.0
    switch_on_bias_sigma: float = 0.0
    arw: float = 0.0
    bias_instability: float = 0.0
    bi_band: tuple[float, float] = (1e-6, 0.1)
    bi_per_decade: int = 3
    gm_drift: float = 0.0
    gm_time_constant: float = 60.0
    rrw: float = 0.0
    rate_ramp: float = 0.0
    quantization: float = 0.0
    scale_factor: float = 0.0
    sf_nonlinearity: float = 0.0
    full_scale: float = math.radians(500.0)
    sf_temp_coeff: float = 0.0
    misalignment: tuple = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    g_sens: tuple = (0.0, 0.0, 0.0)
    g2_sens: tuple = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    g_sens_switch_on_sigma: float = 0.0
    g2_sens_switch_on_sigma: float = 0.0
    temp_ref: float = 20.0
    temp_coeff: float = 0.0
    temp_coeff2: float = 0.0
    temp_rate_coeff: float = 0.0
    temp_cross_coeff: float = 0.0
    temp_rate_cooling_ratio: float = 1.0
    range: float = math.inf
    disabled: tuple[str, ...] = field(default=())


@dataclass(frozen=True)
class FogOutput:
    """FOG output for n samples and the given axes.

    raw : shape (n, n_axes), rad/s (angle increment / sample interval).
    terms : term name -> shape (n, n_axes), rad/s; raw = truth + sum of terms. A term that is
    switched off or has zero parameters is absent (its contribution is zero). The arrays may be
    read-only views (a constant term is a broadcast scalar): copy before changing them.
    draws : the switch-on values of this power-on (SI): ``switch_on_bias`` (n_axes,),
    ``g_sens`` (n_axes, 3), ``g2_sens`` (n_axes, 6).
    saturated : shape (n, n_axes), bool: the rate was beyond the measurement range (clipped).
    """

    raw: np.ndarray
    terms: dict[str, np.ndarray]
    draws: dict[str, np.ndarray]
    axes: tuple[str, ...]
    saturated: np.ndarray | None = None

    def deterministic_error(self, exclude=("arw", "bias_instability", "gm_drift", "rrw",
                                           "quantization",
                                           "saturation")):
        """Sum of the terms a model of the inputs can predict (all but the noises), rad/s."""
        return sum(v for k, v in self.terms.items() if k not in exclude)


def _stream(seed: int, term: str, axis: int) -> np.random.Generator:
    ss = np.random.SeedSequence(seed, spawn_key=(zlib.crc32(term.encode()), axis))
    return np.random.default_rng(ss)


def bias_instability_components(B: float, band: tuple[float, float], per_decade: int):
    """Corner frequencies (Hz) and the common standard deviation (rad/s) of the Gauss-Markov
    components whose sum has the one-sided PSD B^2 / (pi f) inside ``band``.

    A Gauss-Markov process of variance s^2 and correlation time tc has one-sided PSD
    4 s^2 tc / (1 + (2 pi f tc)^2). With rho components per unit of ln(tc), all of variance s^2,
    the sum is rho s^2 / f. With rho = per_decade / ln 10 and rho s^2 = B^2 / pi the PSD is
    B^2 / (pi f), whose Allan floor is sqrt(2 ln 2 h) = sqrt(2 ln 2 / pi) B = 0.664 B.
    """
    f_lo, f_hi = band
    n = max(1, int(round(per_decade * math.log10(f_hi / f_lo)))) + 1
    corners = np.geomspace(f_lo, f_hi, n)
    rho = (n - 1) / math.log(f_hi / f_lo) if n > 1 else per_decade / math.log(10)
    sigma = math.sqrt(B * B / math.pi / rho)
    return corners, sigma


def _bias_instability(n, fs, B, band, per_decade, rng):
    """Sum of stationary Gauss-Markov processes, generated at a reduced rate when the band's top
    is far below fs and linearly interpolated: their power lies below the top corner."""
    corners, sigma = bias_instability_components(B, band, per_decade)
    dec = max(1, int(fs / (20.0 * band[1])))
    fsd = fs / dec
    m = n // dec + 2
    total = np.zeros(m)
    for fc in corners:
        phi = math.exp(-2.0 * math.pi * fc / fsd)
        w = rng.standard_normal(m) * sigma * math.sqrt(1.0 - phi * phi)
        w[0] = 0.0   # every component starts from zero at power-on (see the module doc)
        total += lfilter([1.0], [1.0, -phi], w)
    if dec == 1:
        return total[:n]
    return np.interp(np.arange(n) / dec, np.arange(m), total)


def simulate_fog(params: FogParams, fs: float, truth_rate: np.ndarray, specific_force: np.ndarray,
                 temp: np.ndarray | None = None, temp_rate: np.ndarray | None = None,
                 axes: tuple[str, ...] = ("z",), seed: int = 0) -> FogOutput:
    """FOG output for the truth of one power-on.

    Parameters
    ----------
    params : FogParams, or a tuple of FogParams (one per axis of ``axes``)
        Error parameters, SI: one set for every axis, or each axis its own (a triad device
        file's axes): then each axis is simulated with its own set, exactly as it would be
        alone (every stream is keyed by the body axis, not by the position in ``axes``).
    fs : float
        Sample rate, Hz.
    truth_rate : ndarray, shape (n, 3)
        True inertial angular rate about the sensor's x, y, z, averaged over each sample, rad/s.
    specific_force : ndarray, shape (n, 3)
        Specific force along x, y, z, in g.
    temp, temp_rate : ndarray, shape (n,), optional
        Coil temperature, degC, and its rate, degC/s (default: T_ref and 0).
    axes : tuple of str
        Sensitive axes, among "x", "y", "z" (one FOG each).
    seed : int
        Seed of this power-on; each term and axis has its own stream derived from it.
    """
    if isinstance(params, (tuple, list)):
        return _simulate_triad(params, fs, truth_rate, specific_force, temp, temp_rate, axes,
                               seed)
    truth_rate = np.asarray(truth_rate, dtype=float)
    f = np.asarray(specific_force, dtype=float)
    n = truth_rate.shape[0]
    if truth_rate.shape != (n, 3) or f.shape != (n, 3):
        raise ValueError(f"truth_rate and specific_force must have shape (n, 3); got "
                         f"{truth_rate.shape} and {f.shape}")
    for a in axes:
        if a not in AXES:
            raise ValueError(f"axes: {a!r} is not one of 'x', 'y', 'z'")
    p = params
    na = len(axes)
    dT = None if temp is None else np.asarray(temp, dtype=float) - p.temp_ref
    Tdot = None if temp_rate is None else np.asarray(temp_rate, dtype=float)
    enabled = set(TERMS) - set(p.disabled)
    draws = {"switch_on_bias": np.zeros(na),
             "g_sens": np.array(np.broadcast_to(np.asarray(p.g_sens, dtype=float), (na, 3))),
             "g2_sens": np.array(np.broadcast_to(np.asarray(p.g2_sens, dtype=float), (na, 6)))}
    per_axis: dict[str, list] = {}  # term -> [array (n,) or None per axis]
    # the rate and force components as contiguous rows, made only where a term needs them:
    # elementwise work on a column of an (n, 3) array strides through memory, 2-4 times slower
    # (the same operations, the same sums), and copying all six columns up front was a tenth
    # of the error model's time when no term reads them
    f_rows = _Rows(f)
    w_rows = _Rows(truth_rate)
    for j, name in enumerate(axes):
        ai = AXES[name]
        axis_terms = (_noise_terms(p, fs, n, seed, ai, enabled)
                      + _bias_and_scale_terms(p, fs, n, seed, ai, j, truth_rate, dT, draws,
                                              w_rows)
                      + _g_terms(p, seed, ai, j, f, draws, f_rows)
                      + _temperature_terms(p, dT, Tdot))
        for term, value in axis_terms:
            if term in enabled:
                per_axis.setdefault(term, [None] * na)[j] = value
    terms = _stack_terms(per_axis, n, na)
    cont = truth_rate[:, [AXES[a] for a in axes]].copy()
    for k, v in terms.items():
        if k != "quantization":
            cont += v
    cont, saturated = _saturate(cont, p, enabled, terms)
    raw = _quantize(cont, p, enabled, terms, axes, fs, seed)
    return FogOutput(raw=raw, terms=terms, draws=draws, axes=tuple(axes), saturated=saturated)


class _Rows:
    """The columns of an (n, 3) array as contiguous rows, each copied on first use."""

    def __init__(self, a: np.ndarray):
        self._a, self._rows = a, {}

    def __getitem__(self, i: int) -> np.ndarray:
        if i not in self._rows:
            self._rows[i] = np.ascontiguousarray(self._a[:, i])
        return self._rows[i]


def _simulate_triad(params, fs, truth_rate, specific_force, temp, temp_rate, axes, seed
                    ) -> FogOutput:
    """:func:`simulate_fog` with one FogParams per axis: each axis simulated alone with its
    own, the outputs set side by side (a term an axis does not have is zero there)."""
    if len(params) != len(axes) or not all(isinstance(p, FogParams) for p in params):
        raise ValueError(f"params: expected one FogParams per axis of {tuple(axes)}, got "
                         f"{len(params)} item(s)")
    outs = [simulate_fog(p, fs, truth_rate, specific_force, temp, temp_rate, axes=(a,),
                         seed=seed) for p, a in zip(params, axes)]
    n = outs[0].raw.shape[0]
    terms = {t: np.column_stack([o.terms[t][:, 0] if t in o.terms else np.zeros(n)
                                 for o in outs])
             for t in TERMS if any(t in o.terms for o in outs)}
    draws = {k: np.concatenate([o.draws[k] for o in outs], axis=0) for k in outs[0].draws}
    sat = [o.saturated for o in outs]
    saturated = (None if any(s is None for s in sat) else np.column_stack([s[:, 0] for s in sat]))
    return FogOutput(raw=np.column_stack([o.raw[:, 0] for o in outs]), terms=terms, draws=draws,
                     axes=tuple(axes), saturated=saturated)


def _noise_terms(p: FogParams, fs: float, n: int, seed: int, ai: int, enabled) -> list:
    """(term, rate error (n,)) of the noises of axis ``ai``, each from its own stream: white
    rate, flicker, Gauss-Markov drift, rate random walk (only those switched on are drawn)."""
    out = []
    if p.arw and "arw" in enabled:
        out.append(("arw", _stream(seed, "arw", ai).standard_normal(n) * (p.arw * math.sqrt(fs))))
    if p.bias_instability and "bias_instability" in enabled:
        out.append(("bias_instability", _bias_instability(
            n, fs, p.bias_instability, p.bi_band, p.bi_per_decade,
            _stream(seed, "bias_instability", ai))))
    if p.gm_drift and "gm_drift" in enabled:
        rng = _stream(seed, "gm_drift", ai)
        phi = math.exp(-1.0 / (fs * p.gm_time_constant))
        e = rng.standard_normal(n) * (p.gm_drift * math.sqrt(1.0 - phi * phi))
        e[0] = rng.standard_normal() * p.gm_drift
        out.append(("gm_drift", lfilter([1.0], [1.0, -phi], e)))
    if p.rrw and "rrw" in enabled:
        steps = _stream(seed, "rrw", ai).standard_normal(n) * (p.rrw * math.sqrt(1.0 / fs))
        out.append(("rrw", np.cumsum(steps) - 0.5 * steps))  # mean over each interval
    return out


def _bias_and_scale_terms(p: FogParams, fs: float, n: int, seed: int, ai: int, j: int,
                          truth_rate: np.ndarray, dT, draws: dict, w_rows: _Rows) -> list:
    """(term, rate error (n,)) of the biases (constant, switch-on: its draw is kept in
    ``draws``, ramp) and of the rate's own errors (scale factor, misalignment) of axis ``ai``,
    the ``j``-th output (``w_rows[ai]``: its true rate, contiguous)."""
    out = []
    if p.bias:
        out.append(("constant_bias", np.broadcast_to(p.bias, (n,))))
    if p.switch_on_bias_sigma:
        b = _stream(seed, "switch_on_bias", ai).standard_normal() * p.switch_on_bias_sigma
        draws["switch_on_bias"][j] = b
        out.append(("switch_on_bias", np.broadcast_to(b, (n,))))
    if p.rate_ramp:
        out.append(("rate_ramp", p.rate_ramp * (np.arange(n) + 0.5) * (1.0 / fs)))
    if p.scale_factor or p.sf_nonlinearity or (p.sf_temp_coeff and dT is not None):
        k = p.scale_factor if dT is None else p.scale_factor + p.sf_temp_coeff * dT
        w = w_rows[ai]
        e = k * w
        if p.sf_nonlinearity:
            e = e + p.sf_nonlinearity * w * np.abs(w) / p.full_scale
        out.append(("scale_factor", e))
    M = np.asarray(p.misalignment, dtype=float)
    if np.any(M[ai]):
        others = [b for b in range(3) if b != ai]
        out.append(("misalignment", truth_rate[:, others] @ M[ai, others]))
    return out


def _g_terms(p: FogParams, seed: int, ai: int, j: int, f: np.ndarray, draws: dict,
             f_rows: _Rows) -> list:
    """(term, rate error (n,)) of the g and g^2 sensitivities of axis ``ai`` (the ``j``-th
    output), their switch-on draws added to ``draws`` first (``f_rows``: f's components as
    contiguous rows)."""
    out = []
    if p.g_sens_switch_on_sigma:
        draws["g_sens"][j] += (_stream(seed, "g_switch_on", ai).standard_normal(3)
                               * p.g_sens_switch_on_sigma)
    if p.g2_sens_switch_on_sigma:
        draws["g2_sens"][j] += (_stream(seed, "g2_switch_on", ai).standard_normal(6)
                                * p.g2_sens_switch_on_sigma)
    if np.any(draws["g_sens"][j]):
        out.append(("g_sensitivity", f @ draws["g_sens"][j]))
    if np.any(draws["g2_sens"][j]):
        d = draws["g2_sens"][j]
        fx, fy, fz = f_rows[0], f_rows[1], f_rows[2]
        out.append(("g2_sensitivity", (d[0] * fx + d[3] * fy + d[5] * fz) * fx
                    + (d[1] * fy + d[4] * fz) * fy + d[2] * fz * fz))
    return out


def _temperature_terms(p: FogParams, dT, Tdot) -> list:
    """[("temperature", rate error (n,))]: the temperature and its rate's (Shupe) terms, with
    the cooling ratio where the coil cools; [] when neither applies."""
    shupe = None
    if Tdot is not None and (p.temp_rate_coeff or p.temp_cross_coeff):
        cross = 0.0 if dT is None else p.temp_cross_coeff * dT
        shupe = (p.temp_rate_coeff + cross) * Tdot
        if p.temp_rate_cooling_ratio != 1.0:
            shupe = np.where(Tdot < 0.0, p.temp_rate_cooling_ratio * shupe, shupe)
    if dT is not None and (p.temp_coeff or p.temp_coeff2):
        return [("temperature", (p.temp_coeff + p.temp_coeff2 * dT) * dT
                 + (0.0 if shupe is None else shupe))]
    if shupe is not None:
        return [("temperature", shupe)]
    return []


def _stack_terms(per_axis: dict, n: int, na: int) -> dict:
    """term -> (n, na) in the order of ``TERMS``; an axis a term does not touch is zero."""
    terms = {}
    for t in TERMS:
        if t not in per_axis:
            continue
        cols = per_axis[t]
        if na == 1:   # a view, no copy (read-only where the term is a constant)
            terms[t] = cols[0][:, None]
        else:
            terms[t] = np.stack([np.zeros(n) if v is None else v for v in cols], axis=1)
    return terms


def _saturate(cont: np.ndarray, p: FogParams, enabled, terms: dict):
    """(output clipped to the measurement range, where it was beyond it (n, na)); the clipping
    is added to ``terms`` as "saturation"."""
    saturated = np.zeros(cont.shape, dtype=bool)
    if math.isfinite(p.range):
        saturated = np.abs(cont) > p.range
        if saturated.any() and "saturation" in enabled:
            clipped = np.clip(cont, -p.range, p.range)
            terms["saturation"] = clipped - cont
            cont = clipped
    return cont, saturated


def _quantize(cont: np.ndarray, p: FogParams, enabled, terms: dict, axes, fs: float,
              seed: int) -> np.ndarray:
    """The output counted in angle quanta (a random phase per axis at power-on), its error
    added to ``terms`` as "quantization"; ``cont`` unchanged when that term is off."""
    if not ("quantization" in enabled and p.quantization):
        return cont
    Q = p.quantization
    dt = 1.0 / fs
    qterm = np.empty(cont.shape)
    for j, name in enumerate(axes):
        phase = _stream(seed, "quantization", AXES[name]).uniform(0.0, 1.0)
        counts = np.floor(np.cumsum(cont[:, j]) * (dt / Q) + phase)
        inc = np.diff(counts, prepend=0.0) * Q
        qterm[:, j] = inc * fs - cont[:, j]
    terms["quantization"] = qterm
    return cont + qterm
