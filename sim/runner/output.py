"""Run output directories that never look complete while they are not.

A run writes into a hidden sibling ``.<name>.partial-<pid>`` and renames it to ``<name>``
only at the end (complete, or interrupted with ``metrics.json`` saying ``"complete":
false``). A crash leaves only the ``.partial`` directory, which no reader mistakes for a
finished run. Rename within one parent directory is atomic on POSIX.

Nothing partial outlives its process: an exception inside a function decorated with
:func:`discard_partial_on_error` removes the staging directories it opened and did not
finalize, and every new ``RunDirectory`` removes the ``.partial-<pid>`` / ``.old-<pid>``
siblings of its ``--out`` whose process is gone (SIGKILL, power loss).
"""

from __future__ import annotations

import functools
import os
import re
import shutil
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from sim.jsonsafe import dumps


class OutputExistsError(FileExistsError):
    """The output directory exists and overwrite was not asked for."""


class OutputPathError(OSError):
    """The output directory cannot be created or written (the message names the path)."""


_F = TypeVar("_F", bound=Callable[..., Any])
_open = threading.local()  # RunDirectory objects created and not yet finalized, this thread


def _opened() -> list[RunDirectory]:
    if not hasattr(_open, "dirs"):
        _open.dirs = []
    return _open.dirs


def pid_alive(pid: int) -> bool:
    """True if a process with this id exists (on this host)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    return True


def remove_stale_partials(final: Path) -> list[Path]:
    """Remove ``.<name>.partial-<pid>`` / ``.<name>.old-<pid>`` siblings of ``final`` whose
    process no longer runs; returns the removed paths."""
    pattern = re.compile(rf"^\.{re.escape(final.name)}\.(partial|old)-(\d+)$")
    removed = []
    if not final.parent.is_dir():
        return removed
    for p in final.parent.iterdir():
        m = pattern.match(p.name)
        if m and int(m.group(2)) != os.getpid() and not pid_alive(int(m.group(2))):
            shutil.rmtree(p, ignore_errors=True)
            removed.append(p)
    return removed


def discard_partial_on_error(fn: _F) -> _F:
    """Decorator: if ``fn`` raises, remove the staging directories of the RunDirectory
    objects it created and did not finalize (then re-raise)."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        before = len(_opened())
        try:
            return fn(*args, **kwargs)
        except BaseException:
            for d in _opened()[before:]:
                d.discard()
            raise
        finally:
            del _opened()[before:]

    return wrapper  # type: ignore[return-value]


def dumps_canonical(obj: Any) -> str:
    """Deterministic JSON: sorted keys, NaN/inf as null, floats as Python repr."""
    return dumps(obj, sort_keys=True, indent=2) + "\n"


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
        self.staging = self.final.parent / f".{self.final.name}.partial-{os.getpid()}"
        try:
            self.final.parent.mkdir(parents=True, exist_ok=True)
            remove_stale_partials(self.final)
            if self.staging.exists():
                shutil.rmtree(self.staging)
            self.staging.mkdir()
        except OSError as exc:
            raise OutputPathError(
                f"output directory {str(self.final)!r}: cannot write there "
                f"({exc.strerror or exc}); allowed: a path in a writable directory"
            ) from exc
        self.overwrite = overwrite
        self.finalized = False
        _opened().append(self)

    def discard(self) -> None:
        """Remove the staging directory (nothing of this run is kept) unless finalized."""
        if not self.finalized:
            shutil.rmtree(self.staging, ignore_errors=True)

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
