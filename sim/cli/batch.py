"""Batch processing for file commands: expand folders, one result per file, a progress
bar, and a failed file reported without losing the others.

A command's ``run`` calls :func:`run_batch` with a per-file function returning a JSON-able
dict; ``ValueError`` / ``OSError`` raised for one file become ``{"file", "ok": False,
"error"}`` in the results and one line on stderr, and the batch goes on. The exit code is
0 when every file succeeded, 2 when any failed (bad input), so scripts notice.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

from tqdm import tqdm


def expand_inputs(items: Sequence[str], suffixes: Iterable[str]) -> list[Path]:
    """Files named directly, plus the files of each named folder whose suffix (any case)
    is in ``suffixes`` (not recursive; sorted). A folder with no such file, or a missing
    path, raises ValueError naming it."""
    allowed = {s.lower() for s in suffixes}
    out: list[Path] = []
    for item in items:
        p = Path(item)
        if p.is_dir():
            found = sorted(f for f in p.iterdir() if f.is_file() and f.suffix.lower() in allowed)
            if not found:
                raise ValueError(
                    f"folder {str(p)!r} holds no file with suffix in {sorted(allowed)}"
                )
            out.extend(found)
        else:
            out.append(p)  # a missing/bad file is reported by the per-file function
    return out


def run_batch(
    files: Sequence[Path],
    process: Callable[[Path], dict],
    *,
    command: str,
    progress: bool | None = None,
) -> tuple[list[dict], int]:
    """Run ``process`` on each file; returns ``(results, exit_code)``.

    progress : show a tqdm bar on stderr (default: when there is more than one file).
    """
    show = len(files) > 1 if progress is None else progress
    results: list[dict] = []
    failed = 0
    bar = tqdm(files, desc=f"undersea {command}", unit="file", disable=not show, file=sys.stderr)
    for f in bar:
        try:
            res = {"file": str(f), "ok": True, **process(f)}
        except (ValueError, OSError) as exc:
            failed += 1
            text = str(exc) if str(f) in str(exc) else f"{f}: {exc}"
            res = {"file": str(f), "ok": False, "error": text}
            msg = f"undersea {command}: {text}"
            if show:
                bar.write(msg, file=sys.stderr)
            else:
                print(msg, file=sys.stderr)
        results.append(res)
    if show and failed:
        print(
            f"undersea {command}: {failed} of {len(files)} file(s) failed, "
            f"{len(files) - failed} processed",
            file=sys.stderr,
        )
    return results, 2 if failed else 0
