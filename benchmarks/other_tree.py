"""Run a snippet of Python under another checkout's own code (for ratios against the
previous commit measured in one run): a subprocess with that tree first on the path."""

from __future__ import annotations

import json
import os
import subprocess
import sys


def json_from_tree(tree: str, code: str, what: str):
    """The JSON value printed on the last stdout line of ``code`` run in ``tree``; a failed
    run stops the benchmark with ``what`` and the end of its stderr."""
    env = {**os.environ, "PYTHONPATH": tree}
    r = subprocess.run(
        [sys.executable, "-c", code], cwd=tree, env=env, capture_output=True, text=True
    )
    if r.returncode != 0:
        raise SystemExit(f"--against {tree}: its {what} failed:\n{r.stderr[-2000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])
