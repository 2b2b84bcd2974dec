"""Which code produced a result: the package version plus the git commit of the source
tree when it is a git checkout. Resumable jobs (sweeps, datasets) key their plan on it,
so results of different code are never mixed."""

from __future__ import annotations

import functools
import importlib.metadata
import subprocess
from pathlib import Path


@functools.cache
def code_version() -> str:
    """``"<version>"`` or ``"<version>+g<commit>"`` (commit of HEAD, 12 hex digits)."""
    try:
        version = importlib.metadata.version("undersea")
    except importlib.metadata.PackageNotFoundError:
        version = "0+unknown"
    root = Path(__file__).resolve().parents[1]
    try:
        head = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "--short=12", "HEAD"],
            capture_output=True,
            text=True,
            timeout=5,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return version
    return f"{version}+g{head}" if head else version
