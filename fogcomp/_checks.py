"""Input checks shared across fogcomp."""

import numpy as np
import pywt


def _signal(name: str, x, min_len: int = 1) -> np.ndarray:
    try:
        arr = np.asarray(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: cannot be read as a float array ({exc})") from None
    if arr.ndim != 1:
        raise ValueError(f"{name}: expected a 1-D array of samples, got shape {arr.shape}")
    if arr.shape[0] < min_len:
        raise ValueError(f"{name}: expected at least {min_len} samples, got {arr.shape[0]}")
    bad = ~np.isfinite(arr)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"{name}: non-finite value {arr[i]} at index {i}; expected finite "
                         "samples (fill or cut gaps first)")
    return arr


def _wavelet(wavelet) -> pywt.Wavelet:
    """A PyWavelets discrete wavelet from its name (or the wavelet itself)."""
    if isinstance(wavelet, pywt.Wavelet):
        return wavelet
    if not isinstance(wavelet, str):
        raise ValueError(f"wavelet: expected the name of a discrete wavelet (a string, e.g. "
                         f"'db6') or a pywt.Wavelet, got {type(wavelet).__name__} {wavelet!r}")
    try:
        return pywt.Wavelet(wavelet)
    except (ValueError, TypeError):
        raise ValueError(f"wavelet: unknown discrete wavelet {wavelet!r}; choose one of "
                         "pywt.wavelist(kind='discrete'), e.g. 'db6' (paper 000's)") from None


def _mode(mode) -> str:
    """A PyWavelets signal extension mode, checked."""
    if mode not in pywt.Modes.modes:
        raise ValueError(f"mode: unknown signal extension mode {mode!r}; choose one of "
                         f"{pywt.Modes.modes}")
    return mode


def _sample_rate(fs) -> float:
    """A sample rate in Hz: a positive finite number (not a bool)."""
    if isinstance(fs, bool) or not isinstance(fs, (int, float, np.integer, np.floating)) \
            or not np.isfinite(fs) or fs <= 0:
        raise ValueError(f"fs: sample rate must be a positive finite number in Hz, got {fs!r}")
    return float(fs)


def _random_state(rs) -> None:
    """None (refused at fit by Compensator._rng), a non-negative integer, or what
    ``numpy.random.default_rng`` takes besides: a Generator, BitGenerator or SeedSequence."""
    if rs is None or isinstance(rs, (np.random.Generator, np.random.BitGenerator,
                                     np.random.SeedSequence)):
        return
    if isinstance(rs, (int, np.integer)) and not isinstance(rs, (bool, np.bool_)) and rs >= 0:
        return
    raise ValueError(f"random_state: must be a non-negative integer seed, a numpy "
                     f"SeedSequence, BitGenerator or Generator, or None; got {rs!r}")
