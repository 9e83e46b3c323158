"""``fogbench view``: a run directory's recording opened in the native Rerun viewer, or served
to a browser (``--web``, on 127.0.0.1 unless told otherwise)."""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path

from fogbench.recording.blueprint import _how_to

__all__ = ["view"]

#: Where ``fogbench view --web`` listens unless ``--bind`` says otherwise: this machine only
#: (rerun's own default, 0.0.0.0, serves the recording to the whole network).
WEB_BIND = "127.0.0.1"
WEB_PORT = 9090
GRPC_PORT = 9876


def _recording_and_viewer(run_dir: Path):
    """(recording path, viewer command); (None, None) when there is no recording and (path,
    None) when no viewer is installed, each said on stderr."""
    rrd = Path(run_dir) / "recording.rrd"
    if not rrd.is_file():
        print(f"fogbench view: no recording at {rrd} (written by `fogbench run` unless "
              "--no-recording)", file=sys.stderr)
        return None, None
    cmd = _viewer_command()
    if cmd is None:
        print(f"fogbench view: no Rerun viewer found. {_how_to(rrd, _has_display())}",
              file=sys.stderr)
    return rrd, cmd


def bind_address(bind: str) -> tuple[str, str]:
    """``--bind``'s address (rerun wants an IP address: a host name is resolved, its first IPv4
    address taken if it has one) and what listening on it opens the recording to. A name that
    does not resolve is a ValueError (one line)."""
    import ipaddress
    import socket

    try:
        addr = ipaddress.ip_address(bind)
        text = bind                          # an address: handed to rerun as written
    except ValueError:
        try:
            found = [a[4][0] for a in socket.getaddrinfo(bind, None, proto=socket.IPPROTO_TCP)
                     if a[0] in (socket.AF_INET, socket.AF_INET6)]
        except (socket.gaierror, ValueError) as exc:   # ValueError: a NUL, a bad IDNA label
            raise ValueError(f"--bind {bind!r}: not an IP address, and the name does not "
                             f"resolve ({getattr(exc, 'strerror', None) or exc})") from None
        if not found:
            raise ValueError(f"--bind {bind!r}: not an IP address, and the name resolves to "
                             "no IPv4 or IPv6 address") from None
        text = next((a for a in found if ":" not in a), found[0])
        addr = ipaddress.ip_address(text.split("%")[0])
    if addr.is_unspecified:
        scope = "EVERY network interface: anyone who can reach this machine can open it"
    elif addr.is_loopback:
        scope = "this machine only"
    else:
        scope = f"the interface with that address: anyone who can reach {addr} can open it"
    return text, scope


def view_web(run_dir: Path, bind: str = WEB_BIND, web_port: int = WEB_PORT,
             grpc_port: int = GRPC_PORT) -> int:
    """Serve ``run_dir/recording.rrd`` to a browser (Rerun's web viewer) until Ctrl-C; says
    where it listens. 2: no recording; 1: no viewer installed or it failed. ``bind`` is an IP
    address or a host name (resolved here: rerun wants an address); one that does not resolve
    is a ValueError."""
    addr, scope = bind_address(bind)
    rrd, cmd = _recording_and_viewer(run_dir)
    if cmd is None:
        return 2 if rrd is None else 1
    host = f"[{addr}]" if ":" in addr else addr
    named = f"{addr}, {bind}" if addr != bind else addr
    print(f"fogbench view: serving {rrd} at http://{host}:{web_port} (listening on {named}, "
          f"{scope}; gRPC port {grpc_port}); Ctrl-C stops it", flush=True)
    try:
        proc = subprocess.Popen([*cmd, str(rrd), "--web-viewer", "--bind", addr,
                                 "--web-viewer-port", str(web_port), "--port", str(grpc_port)],
                                stdin=subprocess.DEVNULL)
    except OSError as exc:
        print(f"fogbench view: cannot start {cmd[0]}: {exc}", file=sys.stderr)
        return 1
    try:
        rc = proc.wait()
    except BaseException:
        proc.terminate()
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
        raise
    if rc != 0:
        print(f"fogbench view: the web viewer exited with status {rc} (is port {web_port} or "
              f"{grpc_port} in use? --web-port and --grpc-port choose others)", file=sys.stderr)
        return 1
    return 0


def _viewer_command() -> list[str] | None:
    """How to start the Rerun viewer of the installed rerun-sdk, or None."""
    spec = importlib.util.find_spec("rerun_cli")
    if spec is not None and spec.origin:
        exe = Path(spec.origin).with_name("rerun.exe" if os.name == "nt" else "rerun")
        if exe.is_file() and os.access(exe, os.X_OK):
            return [str(exe)]  # the binary bundled with this rerun-sdk: same version
    venv = Path(sys.executable).with_name("rerun")
    if venv.is_file() and os.access(venv, os.X_OK):
        return [str(venv)]
    found = shutil.which("rerun")
    return [found] if found else None


def _has_display() -> bool:
    if sys.platform.startswith("linux"):
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True


def view(run_dir: Path) -> int:
    """Open ``run_dir/recording.rrd`` in the Rerun viewer.

    Returns 0 when the viewer was started or the file was handed to a viewer already running
    (a message says which), 2 when there is no recording, 1 when no viewer can be started here
    (no viewer installed, no display, or the viewer failed at once): a message then says how to
    open the file.
    """
    rrd, cmd = _recording_and_viewer(run_dir)
    if cmd is None:
        return 2 if rrd is None else 1
    if not _has_display():
        print(f"fogbench view: no display (DISPLAY and WAYLAND_DISPLAY unset). "
              f"{_how_to(rrd, False)}", file=sys.stderr)
        return 1
    try:
        proc = subprocess.Popen([*cmd, str(rrd)], stdin=subprocess.DEVNULL,
                                start_new_session=True)
    except OSError as exc:
        print(f"fogbench view: cannot start {cmd[0]}: {exc}. {_how_to(rrd)}", file=sys.stderr)
        return 1
    try:
        rc = proc.wait(timeout=2.0)
    except subprocess.TimeoutExpired:
        print(f"fogbench view: opened {rrd} in the Rerun viewer")
        return 0
    if rc == 0:
        # the rerun binary hands a file to a viewer already listening on its port (9876) and
        # exits at once with status 0; a viewer it started itself keeps running
        print(f"fogbench view: handed {rrd} to a Rerun viewer that was already running (the "
              "new viewer process exited at once); look for the recording in that viewer's "
              f"window, or run `rerun --new {rrd}` for a viewer of its own")
        return 0
    print(f"fogbench view: the viewer exited with status {rc}. {_how_to(rrd)}", file=sys.stderr)
    return 1
