"""The held-out procedure on a log where the truth is not known (:func:`held_out`): identify
the noise model on the first part, run the filter it implies over the rest, and measure the
inflation factor that makes the filter's NIS consistent there."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["HeldOut", "held_out"]


@dataclass
class HeldOut:
    """:func:`held_out`: the identified ``noise_model`` (:class:`fogcomp.noise.NoiseModel`), the
    ``filter_model`` it implies, the sample index ``split`` where the held-out part starts, the
    samples identified on and held out (``n_fit``, ``n_held``), the flicker approximation's
    largest relative Allan-variance error (``flicker_error``), and ``inflation``: {terms:
    InflationResult}."""

    noise_model: object
    filter_model: object
    split: int
    n_fit: int
    n_held: int
    flicker_error: float
    inflation: dict


def _clip(segments, a, b):
    out = []
    for s, e in segments:
        s2, e2 = max(s, a), min(e, b)
        if e2 - s2 > 0:
            out.append((s2, e2))
    return out


def held_out(rate, fs: float, *, split: float = 0.5, known_rate=0.0, segments=None,
             terms=("all", "bias"), model=None, per_decade: int = 1, grid=None,
             min_piece: int = 64) -> HeldOut:
    """Identify the noise model on ``rate[:split n]``, filter ``rate[split n:]``, and measure
    the inflation factor of each kind in ``terms``.

    Parameters
    ----------
    rate : array_like, shape (n,)
        The gyro's rate, rad/s.
    fs : float
        Sample rate, Hz.
    split : float
        Fraction of the samples identified on (default 0.5); the rest is held out.
    known_rate : float or array_like, shape (n,)
        The true rate the log measured (static: the Earth rate's projection on the axis, when
        known), rad/s, subtracted before the filter. What remains of it (an unknown Earth rate
        projection, the turn-on bias) is a constant the filter's bias state carries from a
        diffuse prior (``BiasFilterModel.bias_prior``): it does not change the NIS beyond the
        first samples. Neither changes the Allan variance.
    segments : list of (int, int), optional
        Gap-free pieces [start, stop) (default: the whole record); the identification pools the
        pieces before the split, the filter restarts on each piece after it.
    terms : sequence of {"all", "bias"}
        Which inflation factors to measure (:func:`fogcomp.consistency.inflation_factor`).
    model : str, optional
        A stated noise model (default: selected by the identifier).
    """
    from fogcomp.allan import allan_analysis

    from ._filter import flicker_as_gm, from_noise_model
    from ._verdicts import inflation_factor

    y = np.asarray(rate, dtype=float)
    n = y.shape[0]
    if not 0.05 <= split <= 0.95:
        raise ValueError(f"split: expected a fraction from 0.05 to 0.95, got {split!r}")
    z = y - np.broadcast_to(np.asarray(known_rate, dtype=float), y.shape)
    segs = [(0, n)] if segments is None else [(int(a), int(b)) for a, b in segments]
    s = int(split * n)
    fit_segs = [p for p in _clip(segs, 0, s) if p[1] - p[0] >= 3]
    held = [p for p in _clip(segs, s, n) if p[1] - p[0] >= min_piece]
    if not fit_segs or not held:
        raise ValueError(f"rate: no gap-free piece of at least {min_piece} samples on each side "
                         f"of the split at sample {s}")
    _, nm = allan_analysis(z[:s], fs, segments=fit_segs, model=model, alternative=False)
    fm = from_noise_model(nm, per_decade=per_decade)
    co = {t.term: t.value for t in nm.identified}
    ferr = flicker_as_gm(co.get("B") or 0.0, fs, nm.taus, per_decade)[1]
    pieces = [z[a:b] for a, b in held]
    infl = {t: inflation_factor(fm, pieces, terms=t, grid=grid) for t in terms}
    return HeldOut(noise_model=nm, filter_model=fm, split=s,
                   n_fit=sum(b - a for a, b in fit_segs), n_held=sum(b - a for a, b in held),
                   flicker_error=ferr, inflation=infl)
