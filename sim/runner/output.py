"""Run output directories that never look complete while they are not.

A run writes into a hidden sibling ``.<name>.partial-<pid>`` and renames it to ``<name>``
only at the end (complete, or interrupted with ``metrics.json`` saying ``"complete":
false``). A crash leaves only the ``.partial`` directory, which no reader mistakes for a
finished run. Rename within one parent directory is atomic on POSIX.
"""

from __future__ import annotations

import json
import math
import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np


class OutputExistsError(FileExistsError):
    """The output directory exists and overwrite was not asked for."""


def _jsonable(o: Any) -> Any:
    if isinstance(o, dict):
        return {str(k): _jsonable(v) for k, v in o.items()}
    if isinstance(o, list | tuple):
        return [_jsonable(v) for v in o]
    if isinstance(o, np.ndarray):
        return _jsonable(o.tolist())
    if isinstance(o, np.integer | np.bool_):
        return o.item()
    if isinstance(o, float | np.floating):
        f = float(o)
        return f if math.isfinite(f) else None  # JSON has no NaN; null means "not available"
    return o


def dumps_canonical(obj: Any) -> str:
    """Deterministic JSON: sorted keys, NaN/inf as null, floats as Python repr."""
    return json.dumps(_jsonable(obj), sort_keys=True, indent=2, allow_nan=False) + "\n"


class RunDirectory:
    """Stage files in a hidden partial directory; ``finalize()`` renames it into place."""

    def __init__(self, out: str | Path, *, overwrite: bool = False) -> None:
        self.final = Path(out).resolve()
        if self.final.exists() and not self.final.is_dir():
            raise OutputExistsError(
                f"output path {str(self.final)!r} is a file; allowed: a directory path"
            )
        if self.final.exists() and any(self.final.iterdir()) and not overwrite:
            raise OutputExistsError(
                f"output directory {str(self.final)!r} exists and is not empty; "
                "allowed: a new directory, or pass --overwrite"
            )
        self.final.parent.mkdir(parents=True, exist_ok=True)
        self.staging = self.final.parent / f".{self.final.name}.partial-{os.getpid()}"
        if self.staging.exists():
            shutil.rmtree(self.staging)
        self.staging.mkdir()
        self.overwrite = overwrite
        self.finalized = False

    def path(self, name: str) -> Path:
        return self.staging / name

    def write_json(self, name: str, obj: Any) -> Path:
        p = self.path(name)
        tmp = p.with_suffix(p.suffix + ".tmp")
        tmp.write_text(dumps_canonical(obj))
        tmp.replace(p)
        return p

    def finalize(self) -> Path:
        """Move the staged directory to its final name (replacing an old one if allowed)."""
        if self.final.exists():
            old = self.final.parent / f".{self.final.name}.old-{os.getpid()}"
            self.final.replace(old)
            self.staging.replace(self.final)
            shutil.rmtree(old, ignore_errors=True)
        else:
            self.staging.replace(self.final)
        self.finalized = True
        return self.final
