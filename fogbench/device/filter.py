"""The bias filter a device file (or a preset, or any :class:`sim.fog.FogParams`) implies:
:func:`filter_model`, the same :class:`fogcomp.consistency.BiasFilterModel` an identified noise
model gives, from the device's configured noise terms."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["filter_model", "params_filter_model"]


def params_filter_model(params, fs: float, *, flicker: str = "components", taus=None,
                        label: str = "device"):
    """The filter of the noise terms of ``params`` (:class:`sim.fog.FogParams`, SI) at ``fs``.

    Parameters
    ----------
    flicker : {"components", "fit"}
        The flicker B as the simulator makes it (its Gauss-Markov components over the device's
        band, ``sim.fog.bias_instability_components``: the exact structure, many states) or as
        :func:`fogcomp.consistency.flicker_as_gm` fits it over ``taus`` (s, the record's
        averaging times; few states).
    """
    from fogcomp.consistency import BiasFilterModel, flicker_as_gm
    from sim.fog import bias_instability_components

    p = params
    fl = ()
    if p.bias_instability:
        if flicker == "components":
            corners, sigma = bias_instability_components(p.bias_instability, p.bi_band,
                                                         p.bi_per_decade)
            fl = tuple((float(sigma), float(1.0 / (2.0 * math.pi * fc))) for fc in corners)
        elif flicker == "fit":
            if taus is None:
                raise ValueError("taus: flicker='fit' needs the record's averaging times")
            fl = flicker_as_gm(p.bias_instability, fs, np.asarray(taus, dtype=float))[0]
        else:
            raise ValueError(f"flicker: expected 'components' or 'fit', got {flicker!r}")
    gm = ((p.gm_drift, p.gm_time_constant),) if p.gm_drift else ()
    return BiasFilterModel(fs=fs, N=p.arw, K=p.rrw, R=abs(p.rate_ramp),
                           Q=p.quantization / math.sqrt(12.0), gm=gm, flicker=fl, label=label)


def filter_model(path, fs: float, **kwargs):
    """The filter of a device file (``path``: a device TOML or a preset's name) at ``fs``."""
    from fogbench.device.file import _device_params

    params, _ = _device_params(path, fs)
    return params_filter_model(params, fs, label=str(path), **kwargs)
