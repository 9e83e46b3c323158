"""Input checks shared by fogcomp.allan and fogcomp.metrics."""

import numpy as np


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
