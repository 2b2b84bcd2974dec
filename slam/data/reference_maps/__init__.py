"""Loader of the reference landmark maps (see README.md beside this file for the source).

The files hold blocks ``<type> <columns> <rows>`` (``lm 2 N`` landmarks, ``wp 2 M``
waypoints) followed by ``rows`` lines of ``columns`` numbers (metres, 2-D world frame).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["REFERENCE_MAPS", "ReferenceMap", "load_map_file", "load_reference_map"]

_DIR = Path(__file__).resolve().parent
REFERENCE_MAPS = ("example_webmap", "example_loop1", "example_loop2", "example_loop902")


@dataclass(frozen=True)
class ReferenceMap:
    """Landmarks ``(n, 2)`` and waypoints ``(m, 2)`` in metres; ``name`` of the map."""

    name: str
    landmarks: np.ndarray
    waypoints: np.ndarray


def load_map_file(path: str | Path) -> ReferenceMap:
    """Parse one map text file (format above)."""
    path = Path(path)
    lines = [ln.strip() for ln in path.read_text().splitlines()]
    blocks: dict[str, np.ndarray] = {}
    i = 0
    while i < len(lines):
        ln = lines[i]
        if not ln or ln.startswith("#"):
            i += 1
            continue
        parts = ln.split()
        if len(parts) != 3 or not parts[1].isdigit() or not parts[2].isdigit():
            raise ValueError(
                f"{path}: line {i + 1}: expected '<type> <columns> <rows>', got {ln!r}"
            )
        kind, cols, rows = parts[0], int(parts[1]), int(parts[2])
        body = lines[i + 1 : i + 1 + rows]
        if len(body) != rows:
            raise ValueError(f"{path}: block {kind!r} promises {rows} rows, file has {len(body)}")
        arr = np.array([[float(v) for v in row.split()] for row in body], dtype=float)
        if arr.shape != (rows, cols):
            raise ValueError(
                f"{path}: block {kind!r} has shape {arr.shape}, header says {(rows, cols)}"
            )
        blocks[kind] = arr
        i += 1 + rows
    for kind in ("lm", "wp"):
        if kind not in blocks:
            raise ValueError(f"{path}: no {kind!r} block")
    return ReferenceMap(path.stem, blocks["lm"], blocks["wp"])


def load_reference_map(name: str) -> ReferenceMap:
    """Load one of :data:`REFERENCE_MAPS` by name (e.g. ``"example_webmap"``)."""
    if name not in REFERENCE_MAPS:
        raise ValueError(f"unknown reference map {name!r}; allowed: {', '.join(REFERENCE_MAPS)}")
    return load_map_file(_DIR / f"{name}.txt")
