"""Files written atomically (a crash leaves the old file or none): bytes, text, a matplotlib
figure as a PNG; values made JSON-ready; the versions of what produced a file."""

from __future__ import annotations

import io
import math
import platform
from pathlib import Path

import numpy as np

from fogcomp._persistence import atomic_write_bytes

__all__ = ["atomic_write_bytes", "atomic_write_text", "save_figure", "json_ready", "versions"]


def save_figure(fig, path: Path) -> None:
    """Write a matplotlib figure as a PNG atomically (a crash leaves the old file or none) and
    close it."""
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())


def atomic_write_text(path: Path, text: str) -> None:
    atomic_write_bytes(path, text.encode())


def json_ready(v):
    """``v`` with numpy scalars made Python numbers and non-finite floats made None (JSON)."""
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, dict):
        return {k: json_ready(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [json_ready(x) for x in v]
    if isinstance(v, np.generic):
        return json_ready(v.item())
    return v


def versions() -> dict:
    """Versions of what produced a file."""
    import mujoco
    import scipy

    try:
        from importlib.metadata import version

        fb = version("fogbench")
    except Exception:  # running from a source tree that is not installed
        fb = "unknown"
    return {"fogbench": fb, "python": platform.python_version(), "numpy": np.__version__,
            "scipy": scipy.__version__, "mujoco": mujoco.__version__}
