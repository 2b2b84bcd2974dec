"""The README is a manual whose commands work (issue 15): every fenced ``sh`` and
``python`` block runs, in order, in one scratch folder beside a link to the real data.

A trailing ``# ci: ...`` on a shell line says how CI runs it: ``+ ARGS`` appends short
settings (argparse keeps the last value), ``background`` starts a server, waits for its
URL and stops it with SIGTERM, ``skip (reason)`` does not run it (installs, the full
evaluations). Commands on ``../shared/data`` skip with a message when the data is absent.

Running them all takes minutes (simulations, the real recordings), so that test is marked
``slow``; its CI variant parses every ``undersea`` line with the real argument parser,
checks that every input file it names exists, and compiles every Python block.
"""

from __future__ import annotations

import glob
import os
import re
import select
import shlex
import signal
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"


def shared_data_dir() -> Path | None:
    """Where the real data is: $UNDERSEA_SHARED_DATA or ../shared/data (as conftest)."""
    env = os.environ.get("UNDERSEA_SHARED_DATA")
    for c in ([Path(env)] if env else []) + [REPO.parent / "shared" / "data"]:
        if c.is_dir():
            return c
    return None


FENCE = re.compile(r"^```(sh|python)\n(.*?)^```", re.M | re.S)


def blocks() -> list[tuple[str, str]]:
    return [(m.group(1), m.group(2)) for m in FENCE.finditer(README.read_text())]


def _lines(code: str) -> list[tuple[str, str]]:
    """(command, ci directive) of each shell line."""
    out = []
    for line in code.splitlines():
        if not line.strip():
            continue
        cmd, _, ci = line.partition("# ci:")
        out.append((cmd.strip(), ci.strip()))
    return out


def test_readme_has_runnable_blocks_and_every_skip_gives_a_reason():
    kinds = [k for k, _ in blocks()]
    assert kinds.count("sh") >= 8 and "python" in kinds
    for kind, code in blocks():
        if kind == "sh":
            for cmd, ci in _lines(code):
                assert cmd, code
                assert not ci.startswith("skip") or re.match(r"skip \(.+\)", ci), ci


def test_readme_commands_parse_and_name_existing_files():
    """CI variant: each `undersea ...` line parses with the real parser (options, choices,
    number formats) and its ../shared/data inputs exist; Python blocks compile."""
    from sim.cli.main import build_parser

    data = shared_data_dir()
    n = 0
    for kind, code in blocks():
        if kind == "python":
            compile(code, "README.md", "exec")
            continue
        for cmd, ci in _lines(code):
            if not cmd.startswith("undersea ") or ci.startswith("skip"):
                continue
            argv = shlex.split(cmd.partition(" > ")[0])[1:]
            if ci.startswith("+"):
                argv += shlex.split(ci[1:])
            for i, a in enumerate(argv):
                if a.startswith("../shared/data/"):
                    if data is None:
                        continue
                    hits = glob.glob(str(data / a.removeprefix("../shared/data/")))
                    assert hits, (cmd, a)
                    argv[i] = hits[0]
            build_parser(argv).parse_args(argv)  # SystemExit(2) on a bad option
            n += 1
    assert n >= 12


@pytest.fixture(scope="module")
def workdir(tmp_path_factory) -> Path:
    """A scratch folder with ``../shared`` pointing at the real data when present."""
    root = tmp_path_factory.mktemp("readme")
    work = root / "clone"
    work.mkdir()
    data = shared_data_dir()
    if data is not None:
        (root / "shared").mkdir()
        (root / "shared" / "data").symlink_to(data, target_is_directory=True)
    return work


def _env() -> dict:
    bindir = str(Path(sys.executable).parent)
    return {
        **os.environ,
        "PATH": f"{bindir}{os.pathsep}{os.environ.get('PATH', '')}",
        "PYTHONPATH": str(REPO),
        "CI": "1",
        "MPLBACKEND": "Agg",
    }


def _background(cmd: str, cwd: Path) -> None:
    proc = subprocess.Popen(
        ["bash", "-c", f"exec {cmd}"],
        cwd=cwd,
        env=_env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        ready, _, _ = select.select([proc.stdout], [], [], 120)
        line = proc.stdout.readline() if ready else ""
        assert "http://" in line, (cmd, line, proc.poll())
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=60)


@pytest.mark.slow
@pytest.mark.parametrize("index", range(len(blocks())))
def test_readme_block_runs(index, workdir):
    kind, code = blocks()[index]
    env = _env()
    if kind == "python":
        r = subprocess.run(
            [sys.executable, "-c", code],
            cwd=workdir,
            env=env,
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert r.returncode == 0, r.stderr[-3000:]
        return
    ran = 0
    for cmd, ci in _lines(code):
        if ci.startswith("skip"):
            continue
        if "../shared/data" in cmd and shared_data_dir() is None:
            pytest.skip("../shared/data not found (set UNDERSEA_SHARED_DATA): real-data commands")
        if ci == "background":
            _background(cmd, workdir)
        else:
            if ci.startswith("+"):
                head, redirect, tail = cmd.partition(" > ")
                cmd = f"{head} {ci[1:].strip()}" + (f" > {tail}" if redirect else "")
            r = subprocess.run(
                ["bash", "-c", f"set -o pipefail; {cmd}"],
                cwd=workdir,
                env=env,
                capture_output=True,
                text=True,
                timeout=900,
            )
            assert r.returncode == 0, (cmd, r.stderr[-3000:])
        ran += 1
    if not ran:
        pytest.skip("every command of this block is marked `# ci: skip (...)`")
