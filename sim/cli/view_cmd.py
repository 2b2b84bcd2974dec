"""``undersea view PATH``: open a recording (.rrd, or a run directory holding recording.rrd)
in the rerun viewer. Without a display it says so and offers ``--web`` (serve the web
viewer over HTTP) instead of failing obscurely."""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
from pathlib import Path

HELP = "open a recording (.rrd or a run directory) in the rerun viewer"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("path", help="recording.rrd, or a run directory containing recording.rrd")
    parser.add_argument(
        "--web",
        action="store_true",
        help="serve the web viewer over HTTP instead of a native window",
    )
    parser.add_argument(
        "--port", type=int, default=9090, help="web viewer port with --web (default 9090)"
    )


def resolve_recording(path: str | Path) -> Path:
    """The .rrd file a user means: the path itself, or DIR/recording.rrd."""
    p = Path(path)
    if p.is_dir():
        p = p / "recording.rrd"
    if not p.is_file():
        raise SystemExit(
            f"undersea view: no recording at {str(path)!r} (expected an .rrd file or a run directory)"
        )
    return p


def has_display() -> bool:
    """True when a native window can open (macOS/Windows, or X11/Wayland on Linux)."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def viewer_command(rrd: Path, web: bool, port: int) -> list[str]:
    exe = shutil.which("rerun") or str(Path(sys.executable).with_name("rerun"))
    cmd = [exe, str(rrd)]
    if web:
        cmd += ["--web-viewer", "--web-viewer-port", str(port)]
    return cmd


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
    cmd = viewer_command(rrd, args.web, args.port)
    if args.web:
        print(
            f"undersea view: serving the web viewer on http://localhost:{args.port} (Ctrl-C to stop)"
        )
    try:
        return subprocess.call(cmd)
    except FileNotFoundError:
        print(
            "undersea view: the 'rerun' viewer executable was not found (pip install rerun-sdk)",
            file=sys.stderr,
        )
        return 2
    except KeyboardInterrupt:
        return 0
