"""The recording in the real Rerun web viewer, in Chromium driven by playwright.

Serves a small scenario's recording with ``rerun --serve-web`` on 127.0.0.1, opens it, waits
until the viewer has drawn it, switches to each tab of the recording's blueprint, and fails on
viewer errors in the browser console (requests the viewer makes to the internet fail on a machine
without network, and are not counted: see ``scripts/screenshots.py``). Marked ``browser`` and
skipped where Chromium or playwright is missing; it takes about a minute.

It also opens the recording of every bundled scenario that is quick to make (at most
``QUICK_SAMPLES`` samples over its runs) and checks, in the pixels of the first view the viewer
shows (tab Overview, as the recording opens), that the error view is not empty (coloured
lines, not the background alone) and that the temperature view opens on the whole run (the
traces of the longest run span the plot's width).

Run it with ``.venv/bin/python -m pytest -m browser tests/recording/test_viewer_browser.py`` (needs
``apt-get install chromium`` and ``pip install playwright``).
"""

from __future__ import annotations

import importlib.util
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
pytestmark = [pytest.mark.browser, pytest.mark.slow]


def _screenshots():
    spec = importlib.util.spec_from_file_location("fogbench_screenshots",
                                                  ROOT / "scripts" / "screenshots.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def shots():
    if importlib.util.find_spec("playwright") is None:
        pytest.skip("playwright is not installed (pip install playwright)")
    mod = _screenshots()
    if mod.chromium_path() is None:
        pytest.skip("no Chromium at /usr/bin/chromium or $FOGBENCH_CHROMIUM "
                    "(apt-get install chromium)")
    return mod


def test_the_recording_loads_in_the_web_viewer_without_errors_on_every_tab(shots, tmp_path):
    from test_recording import TINY

    from fogbench.recording import write_recording
    from fogbench.run.runner import run_scenario

    (tmp_path / "tiny.toml").write_text(TINY)
    res = run_scenario(tmp_path / "tiny.toml")
    reps = {"held_out": {"rmse_dph": {"raw": [490.0, 491.0], "kalman": [12.0, 13.0]}}}
    rrd = tmp_path / "recording.rrd"
    write_recording(res, rrd, replicates=reps)
    tabs = ["Overview", "Table and chamber", "FOG error terms", "Allan deviation", "PSD",
            "Monte Carlo", "Report"]
    with shots.serve(rrd, tmp_path / "rerun.log") as (url, proxy), \
            shots.open_viewer(url, shots.chromium_path(), 1280, 800) as (page, msgs):
        shots.wait_until_drawn(page, min_s=5.0, timeout_s=180.0)
        before = page.screenshot()
        for tab in tabs:
            shots.show_tab(proxy, res, tab, replicates=reps)
            shots.wait_until_drawn(page, min_s=2.0, timeout_s=60.0, still_s=2.0)
            page.screenshot(path=str(tmp_path / f"{tab.replace(' ', '_')}.png"))
        after = page.screenshot()
        errors = shots.viewer_errors(msgs)
    assert before != after, "switching tabs changed nothing on the page"
    assert not errors, "viewer errors in the browser console:\n" + "\n".join(errors)


# ---------------------------------------------------------------------------------------------
# the first view of every bundled scenario that is quick to make
QUICK_SAMPLES = 50_000          # samples over a scenario's runs (sum of duration * fs)
WIDTH, HEIGHT = 1600, 1000
# where the Overview's plots are on a 1600 x 1000 page (the blueprint panel left, the
# selection panel right and the time panel below kept open; the Overview's right column, 3/5
# of the viewport, holds the error view above the temperatures): fractions of the page, the
# plot areas without their titles and tick labels
ERROR_PLOT = (0.45, 0.12, 0.78, 0.55)           # x0, y0, x1, y1
TEMPERATURE_PLOT = (0.43, 0.675, 0.80, 0.815)
SATURATED = 40                  # max - min of a pixel's RGB: a coloured line, not grey or white
PALE = 25                       # the same for the temperatures' tinted traces: a run's chamber
                                # line at a constant 20 C draws as (192, 226, 192), 34; the
                                # background and the grid are grey, 0


def _quick_scenarios() -> list[Path]:
    from fogbench.scenario.load import RUNNER_SECTIONS
    from fogbench.scenario import load_scenario

    out = []
    for f in sorted((ROOT / "scenarios").glob("*.toml")):
        sc = load_scenario(f, extra_sections=RUNNER_SECTIONS)
        if sum(r.duration for r in sc.runs) * sc.fs <= QUICK_SAMPLES:
            out.append(f)
    return out


def _coloured(png: bytes, box, threshold: int = SATURATED) -> "np.ndarray":
    """Mask of the coloured (saturated) pixels of a screenshot inside ``box`` (fractions)."""
    import io

    import numpy as np
    from PIL import Image

    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    h, w, _ = img.shape
    x0, y0, x1, y1 = box
    crop = img[int(y0 * h):int(y1 * h), int(x0 * w):int(x1 * w)]
    return crop.max(axis=2) - crop.min(axis=2) > threshold


def test_quick_scenarios_are_listed():
    names = {p.stem for p in _quick_scenarios()}
    assert {"paper000_wnn", "dynamic_rates"} <= names, names
    assert "paper002_acobp" not in names       # 310,000 samples and 20 ACO-BP starts


@pytest.mark.parametrize("scenario", [p.stem for p in _quick_scenarios()])
def test_the_first_view_of_each_quick_scenario_shows_the_whole_run_and_is_not_empty(
        shots, tmp_path, scenario):
    import numpy as np

    from fogbench.recording import write_recording
    from fogbench.run.runner import run_scenario

    res = run_scenario(ROOT / "scenarios" / f"{scenario}.toml")
    rrd = tmp_path / "recording.rrd"
    write_recording(res, rrd)
    with shots.serve(rrd, tmp_path / "rerun.log") as (url, _proxy), \
            shots.open_viewer(url, shots.chromium_path(), WIDTH, HEIGHT) as (page, msgs):
        # the software-rasterised viewer can sit still for seconds while the recording still
        # streams in ('Timeline not found' until the time series arrive): wait for stillness
        # again, up to 4 minutes in all, while the error view is empty
        t0 = time.monotonic()
        while True:
            shots.wait_until_drawn(page, min_s=5.0, timeout_s=240.0)
            png = page.screenshot()
            if _coloured(png, ERROR_PLOT).sum() >= 300 or time.monotonic() - t0 > 240.0:
                break
        errors = shots.viewer_errors(msgs)
    (tmp_path / "first_view.png").write_bytes(png)
    where = f"(screenshot: {tmp_path / 'first_view.png'})"
    assert not errors, "viewer errors in the browser console:\n" + "\n".join(errors)
    # not empty: the methods' coloured lines in the error view
    err = _coloured(png, ERROR_PLOT)
    assert err.sum() >= 300, f"{scenario}: the error view is empty {where}"
    # the whole run: the temperatures of the longest run go from the plot's left edge to its
    # right edge (a view opened on twice the run would leave half of it blank)
    temps = _coloured(png, TEMPERATURE_PLOT, PALE)
    cols = np.flatnonzero(temps.any(axis=0))
    width = temps.shape[1]
    assert cols.size, f"{scenario}: the temperature view is empty {where}"
    span = (cols.max() - cols.min() + 1) / width
    assert span >= 0.9, (f"{scenario}: the temperatures span {100 * span:.0f} % of the "
                         f"plot's width, not the whole run {where}")
