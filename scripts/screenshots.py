"""Screenshots of fogbench recordings in the real Rerun web viewer (for the README).

Runs a scenario, writes its recording, serves it with the viewer that ships with rerun-sdk
(``rerun --serve-web``, bound to 127.0.0.1 only), opens it in Debian's Chromium driven by
playwright, waits until the viewer has drawn the recording, fails on viewer errors in the browser
console, and saves one PNG per requested tab (the tab is opened by sending the recording's own
blueprint with that tab active, over the viewer's gRPC proxy).

Needs ``apt-get install chromium`` and ``pip install playwright`` (playwright's own browser
download is not used). Example (the README's images)::

    .venv/bin/python scripts/screenshots.py --out docs/img \\
        --shot paper002_acobp:Overview:overview_paper002.png \\
        --shot paper000_wnn:Overview:errors_paper000.png \\
        --shot "paper002_acobp:Allan deviation:allan_paper002.png"

A run directory of ``fogbench run`` in place of a scenario shows that run's own recording, with
its replicates (the Monte Carlo tab)::

    .venv/bin/python scripts/screenshots.py --out /tmp/shots \\
        --shot "reports/paper000_wnn:Monte Carlo:mc_paper000.png"

The functions :func:`serve`, :func:`open_viewer`, :func:`wait_until_drawn`,
:func:`show_tab` and :func:`viewer_errors` are used by ``tests/recording/test_viewer_browser.py`` too.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.parse
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_CHROMIUM = "/usr/bin/chromium"
# console messages of the viewer that are errors of the viewer (as opposed to the software
# rasteriser's notices); matched case-sensitively at the start of the text
_ERROR_TYPES = ("error",)
_BENIGN = (
    "Failed to load resource: the server responded with a status of 404",  # favicon
)


def chromium_path() -> str | None:
    """Debian's Chromium (or $FOGBENCH_CHROMIUM), or None."""
    p = os.environ.get("FOGBENCH_CHROMIUM") or DEFAULT_CHROMIUM
    if Path(p).is_file() and os.access(p, os.X_OK):
        return p
    return shutil.which("chromium")


def rerun_binary() -> str:
    """The viewer binary bundled with the installed rerun-sdk (same version as the recording)."""
    import importlib.util

    spec = importlib.util.find_spec("rerun_cli")
    if spec is None or not spec.origin:
        raise RuntimeError("rerun-sdk's viewer (rerun_cli) is not installed")
    exe = Path(spec.origin).with_name("rerun")
    if not exe.is_file():
        raise RuntimeError(f"no rerun binary at {exe}")
    return str(exe)


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def serve(rrd: Path, log: Path | None = None):
    """Serve ``rrd`` with ``rerun --serve-web`` on 127.0.0.1; yields (web url, grpc proxy url)."""
    web, grpc = _free_port(), _free_port()
    out = open(log, "w") if log else subprocess.DEVNULL
    proc = subprocess.Popen([rerun_binary(), "--serve-web", "--bind", "127.0.0.1",
                             "--web-viewer-port", str(web), "--port", str(grpc),
                             "--hide-welcome-screen", str(rrd)],
                            stdout=out, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                            start_new_session=True)
    try:
        proxy = f"rerun+http://127.0.0.1:{grpc}/proxy"
        url = f"http://127.0.0.1:{web}/?url={urllib.parse.quote(proxy, safe='')}"
        deadline = time.monotonic() + 30.0
        while True:
            try:
                urllib.request.urlopen(f"http://127.0.0.1:{web}/", timeout=2).read(64)
                break
            except OSError:
                if proc.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError(f"rerun --serve-web did not start (status "
                                       f"{proc.poll()}); see {log}") from None
                time.sleep(0.3)
        yield url, proxy
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(timeout=10)
        if log:
            out.close()


@contextlib.contextmanager
def open_viewer(url: str, chromium: str, width: int = 1600, height: int = 1000):
    """A playwright page on ``url`` in ``chromium``; yields (page, console messages list)."""
    from playwright.sync_api import sync_playwright

    msgs: list[tuple[str, str]] = []   # (type, text); failed requests as ("requestfailed", url)
    with sync_playwright() as pw:
        browser = pw.chromium.launch(
            executable_path=chromium,
            args=["--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                  "--ignore-gpu-blocklist"])
        try:
            page = browser.new_page(viewport={"width": width, "height": height})
            page.on("console", lambda m: msgs.append((m.type, m.text)))
            page.on("pageerror", lambda e: msgs.append(("error", f"page error: {e}")))
            page.on("requestfailed", lambda r: msgs.append(("requestfailed", r.url)))
            page.goto(url)
            yield page, msgs
        finally:
            browser.close()


def wait_until_drawn(page, min_s: float = 8.0, timeout_s: float = 240.0,
                     still_s: float = 4.0) -> float:
    """Wait until the page has not changed for ``still_s`` seconds (the recording is loaded
    and drawn), at least ``min_s`` after the start; returns the seconds waited."""
    t0 = time.monotonic()
    last, since = None, time.monotonic()
    while True:
        time.sleep(1.0)
        shot = page.screenshot()
        now = time.monotonic()
        if shot != last:
            last, since = shot, now
        elif now - since >= still_s and now - t0 >= min_s:
            return now - t0
        if now - t0 > timeout_s:
            raise TimeoutError(f"the viewer was still changing after {timeout_s:.0f} s")


def show_tab(proxy: str, res, tab: str, replicates=None) -> None:
    """Make ``tab`` the active tab in the viewers connected to ``proxy`` (the recording's own
    blueprint, sent again with that tab active)."""
    import rerun as rr

    from fogbench.recording import APPLICATION_ID, blueprint_for

    bp = blueprint_for(res, replicates, active_tab=tab)
    rec = rr.RecordingStream(application_id=APPLICATION_ID, recording_id=res.scenario.name,
                             send_properties=False)
    rec.connect_grpc(proxy)
    try:
        rec.send_blueprint(bp, make_active=True, make_default=False)
        rec.flush()
    finally:
        rec.disconnect()


def run_replicates(run_dir: Path):
    """The replicates a run directory's recording holds (``metrics.json``, key ``montecarlo``),
    as :func:`fogbench.recording.write_recording` takes them, or None without Monte Carlo."""
    import json

    from fogbench.report.montecarlo import recording_replicates

    mc = json.loads((Path(run_dir) / "metrics.json").read_text()).get("montecarlo")
    return recording_replicates(mc) if mc else None


def _external(url: str) -> bool:
    host = urllib.parse.urlsplit(url).hostname or ""
    return host not in ("127.0.0.1", "localhost", "::1")


def viewer_errors(msgs: list[tuple[str, str]]) -> list[str]:
    """The console messages that are errors of the viewer.

    Requests to hosts other than this machine fail here (no network): the viewer's own checks
    (fonts, version, analytics) then log "Failed to load resource: net::ERR_NAME_NOT_RESOLVED"
    and "Failed to fetch". Those are left out when every failed request went off this machine;
    a failed request to the local server, or any other console error, is kept.
    """
    failed = [text for typ, text in msgs if typ == "requestfailed"]
    offline = bool(failed) and all(_external(u) for u in failed)
    out = []
    for typ, text in msgs:
        if typ == "requestfailed" and not _external(text):
            out.append(f"request failed: {text}")
        if typ not in _ERROR_TYPES or text.startswith(_BENIGN):
            continue
        if offline and (text.startswith("Failed to load resource: net::ERR_NAME_NOT_RESOLVED")
                        or text.startswith("TypeError: Failed to fetch")):
            continue
        out.append(f"{typ}: {text}")
    return out


def external_requests(msgs: list[tuple[str, str]]) -> list[str]:
    """Failed requests to other hosts (the viewer tried the network)."""
    return sorted({u for typ, u in msgs if typ == "requestfailed" and _external(u)})


def _save_small(png: bytes, path: Path) -> None:
    """Save a screenshot as a 256-colour PNG (a third of the size; the viewer's flat colours
    survive the palette)."""
    from PIL import Image

    img = Image.open(io.BytesIO(png)).convert("RGB")
    img.quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(path, optimize=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--shot", action="append", required=True,
                    help="SCENARIO:TAB:FILE.png (a scenario name in scenarios/, a path, or a "
                         "run directory of `fogbench run`: its own recording, with replicates)")
    ap.add_argument("--out", default=str(ROOT / "docs" / "img"))
    ap.add_argument("--chromium", default=None, help=f"default {DEFAULT_CHROMIUM}")
    ap.add_argument("--width", type=int, default=1600)
    ap.add_argument("--height", type=int, default=1000)
    args = ap.parse_args(argv)
    chromium = args.chromium or chromium_path()
    if chromium is None:
        print("screenshots: no Chromium (apt-get install chromium, or --chromium PATH)",
              file=sys.stderr)
        return 2
    from fogbench.recording import write_recording
    from fogbench.run.runner import run_scenario

    shots: dict[str, list[tuple[str, str]]] = {}
    for s in args.shot:
        parts = s.split(":")
        if len(parts) != 3:
            ap.error(f"--shot {s!r}: expected SCENARIO:TAB:FILE.png")
        shots.setdefault(parts[0], []).append((parts[1], parts[2]))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    failed = False
    for scen, items in shots.items():
        run_dir = Path(scen) if (Path(scen) / "recording.rrd").is_file() else None
        reps = None
        if run_dir is not None:       # a run directory: its own recording and replicates
            path = run_dir / "scenario.toml"
            reps = run_replicates(run_dir)
        else:
            path = Path(scen) if scen.endswith(".toml") else ROOT / "scenarios" / f"{scen}.toml"
        with contextlib.redirect_stderr(io.StringIO()):
            res = run_scenario(path)
        with tempfile.TemporaryDirectory() as tmp:
            rrd = Path(tmp) / "recording.rrd"
            if run_dir is not None:
                shutil.copyfile(run_dir / "recording.rrd", rrd)
            else:
                write_recording(res, rrd)
            with serve(rrd, Path(tmp) / "rerun.log") as (url, proxy), \
                    open_viewer(url, chromium, args.width, args.height) as (page, msgs):
                waited = wait_until_drawn(page)
                print(f"{scen}: loaded and drawn after {waited:.0f} s "
                      f"({rrd.stat().st_size / 1e6:.1f} MB)")
                for tab, fname in items:
                    show_tab(proxy, res, tab, replicates=reps)
                    wait_until_drawn(page, min_s=3.0)
                    _save_small(page.screenshot(), out / fname)
                    print(f"  {tab}: {out / fname}")
                ext = external_requests(msgs)
                if ext:
                    print(f"  (offline: the viewer's requests to {ext} failed; ignored)")
                errs = viewer_errors(msgs)
                if errs:
                    failed = True
                    print(f"{scen}: viewer errors in the browser console:", file=sys.stderr)
                    for e in errs:
                        print(f"  {e[:500]}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
