"""``fogbench view DIR``: a run directory's recording in the Rerun viewer
(:mod:`fogbench.recording.viewer`)."""

from __future__ import annotations

from pathlib import Path

from fogbench.cli._common import number


def add_parser(sub) -> None:
    v = sub.add_parser("view", help="open a run directory's recording in the Rerun viewer")
    v.add_argument("dir", help="run directory (holding recording.rrd)")
    v.add_argument("--web", action="store_true", help="serve it to a browser (Rerun's web "
                   "viewer) instead of opening a native window; listens on 127.0.0.1 only "
                   "unless --bind says otherwise")
    v.add_argument("--bind", default=None, help="--web: the address to listen on, or a host "
                   "name (resolved to its address) (default 127.0.0.1, this machine; only "
                   "0.0.0.0 or :: serves every network interface)")
    v.add_argument("--web-port", type=number(int, 1, hi=65535), default=None,
                   help="--web: the web viewer's HTTP port (default 9090)")
    v.add_argument("--grpc-port", type=number(int, 1, hi=65535), default=None,
                   help="--web: the viewer's gRPC port (default 9876)")
    v.set_defaults(func=_view)


def _view(args) -> int:
    from fogbench.recording.viewer import GRPC_PORT, WEB_BIND, WEB_PORT, view, view_web

    if not args.web:
        given = [f for f, v in (("--bind", args.bind), ("--web-port", args.web_port),
                                ("--grpc-port", args.grpc_port)) if v is not None]
        if given:
            raise ValueError(f"{given[0]}: only with --web")
        return view(Path(args.dir))
    return view_web(Path(args.dir), bind=args.bind or WEB_BIND,
                    web_port=args.web_port or WEB_PORT, grpc_port=args.grpc_port or GRPC_PORT)
