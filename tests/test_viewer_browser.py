"""The recording in the real Rerun web viewer, in Chromium driven by playwright.

Serves a small scenario's recording with ``rerun --serve-web`` on 127.0.0.1, opens it, waits
until the viewer has drawn it, switches to each tab of the recording's blueprint, and fails on
viewer errors in the browser console (requests the viewer makes to the internet fail on a machine
without network, and are not counted: see ``scripts/screenshots.py``). Marked ``browser`` and
skipped where Chromium or playwright is missing; it takes about a minute.

Run it with ``.venv/bin/python -m pytest -m browser tests/test_viewer_browser.py`` (needs
``apt-get install chromium`` and ``pip install playwright``).
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
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
    from fogbench.runner import run_scenario

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
