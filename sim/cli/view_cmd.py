"""``undersea view PATH``: open a recording (.rrd, or a run directory holding recording.rrd)
in the rerun viewer.

Native window when a display exists; ``--web`` serves rerun's web viewer instead and
prints the one URL that opens *this* recording (the web page plus ``?url=`` of the gRPC
proxy that streams it). Both ports are free ones picked at start (so two viewers can run
side by side) unless ``--port`` / ``--grpc-port`` say otherwise; servers bind 127.0.0.1
unless ``--bind`` says otherwise. SIGTERM or SIGINT (Ctrl-C) stops the viewer process
and waits for it, so no server is left behind.
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import socket
import subprocess
import sys
import urllib.parse
from pathlib import Path

from sim.cli.common import CliError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("path", help="recording.rrd, or a run directory containing recording.rrd")
    parser.add_argument(
        "--web",
        action="store_true",
        help="serve the web viewer over HTTP instead of a native window; prints its URL",
    )
    parser.add_argument(
        "--port", type=int, default=0, help="web viewer HTTP port with --web (default: a free one)"
    )
    parser.add_argument(
        "--grpc-port", type=int, default=0, help="gRPC proxy port (default: a free one)"
    )
    parser.add_argument(
        "--bind",
        default="127.0.0.1",
        help="address the servers listen on (default 127.0.0.1: this machine only; "
        "0.0.0.0 to share on the network)",
    )


def resolve_recording(path: str | Path) -> Path:
    """The .rrd file a user means: the path itself, or DIR/recording.rrd."""
    p = Path(path)
    if p.is_dir():
        p = p / "recording.rrd"
    if not p.is_file():
        raise CliError(
            f"no recording at {str(path)!r}; allowed: an .rrd file or a run directory "
            "holding recording.rrd (make one with `undersea demo`)"
        )
    return p


def has_display() -> bool:
    """True when a native window can open (macOS/Windows, or X11/Wayland on Linux)."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def free_port(bind: str) -> int:
    """A TCP port nothing listens on at ``bind`` now (the OS picks it)."""
    family = socket.AF_INET6 if ":" in bind else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as s:
        s.bind((bind, 0))
        return int(s.getsockname()[1])


def _host_for_url(bind: str) -> str:
    if bind in ("0.0.0.0", "::", ""):
        return "localhost"
    return f"[{bind}]" if ":" in bind else bind


def viewer_url(bind: str, web_port: int, grpc_port: int) -> str:
    """The web viewer URL that opens the recording served by the gRPC proxy."""
    host = _host_for_url(bind)
    proxy = f"rerun+http://{host}:{grpc_port}/proxy"
    return f"http://{host}:{web_port}/?url={urllib.parse.quote(proxy, safe='')}"


def viewer_command(
    rrd: Path, web: bool, port: int, grpc_port: int, bind: str = "127.0.0.1"
) -> list[str]:
    exe = shutil.which("rerun") or str(Path(sys.executable).with_name("rerun"))
    cmd = [exe, str(rrd), "--bind", bind, "--port", str(grpc_port)]
    if web:
        cmd += ["--web-viewer", "--web-viewer-port", str(port)]
    return cmd


def run_until_signal(cmd: list[str]) -> int:
    """Run the viewer; on SIGTERM/SIGINT stop it (terminate, then kill after 5 s)."""
    try:
        child = subprocess.Popen(cmd, start_new_session=True)
    except FileNotFoundError:
        raise CliError(
            "the 'rerun' viewer executable was not found (pip install rerun-sdk)"
        ) from None
    stop = {"signal": None}

    def signal_group(sig: int) -> None:
        # the `rerun` entry point is a Python wrapper around the viewer binary: signal the
        # whole process group (its own session) so the binary stops too
        try:
            os.killpg(child.pid, sig)
        except ProcessLookupError:
            pass

    def on_signal(signum, _frame):
        stop["signal"] = signum
        signal_group(signal.SIGTERM)

    old = {s: signal.signal(s, on_signal) for s in (signal.SIGTERM, signal.SIGINT)}
    try:
        while True:
            try:
                rc = child.wait(timeout=0.5)
                break
            except subprocess.TimeoutExpired:
                if stop["signal"] is not None:
                    try:
                        rc = child.wait(timeout=5.0)
                    except subprocess.TimeoutExpired:
                        signal_group(signal.SIGKILL)
                        rc = child.wait()
                    break
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        signal_group(signal.SIGKILL)  # whatever is left of the group (normally nothing)
        child.wait()
    return 0 if stop["signal"] is not None else rc


def run(args: argparse.Namespace) -> int:
    rrd = resolve_recording(args.path)
    if not args.web and not has_display():
        print(
            "undersea view: no display found (DISPLAY / WAYLAND_DISPLAY unset), so no native "
            f"viewer window can open.\n  - serve it to a browser:   undersea view {args.path} --web\n"
            f"  - or copy {rrd} to a machine with a display and run:  rerun {rrd.name}",
            file=sys.stderr,
        )
        return 2
    for name, port in (("--port", args.port), ("--grpc-port", args.grpc_port)):
        if not 0 <= port <= 65535:
            raise CliError(f"{name} {port}: allowed: 0 (a free port) or 1..65535")
    grpc_port = args.grpc_port or free_port(args.bind)
    web_port = args.port or free_port(args.bind)
    cmd = viewer_command(rrd, args.web, web_port, grpc_port, args.bind)
    if args.web:
        print(
            f"undersea view: open {viewer_url(args.bind, web_port, grpc_port)}\n"
            f"  (serving {rrd} on {args.bind}; Ctrl-C to stop)",
            flush=True,
        )
    return run_until_signal(cmd)
