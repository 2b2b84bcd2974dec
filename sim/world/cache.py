"""On-disk cache of generated geometry, keyed by the generating parameters.

Location: ``$UNDERSEA_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/undersea`` or
``~/.cache/undersea``. Entries are ``.npz`` files (vertices, faces) named by the SHA-256 of
the canonical JSON of the parameters plus ``GEOMETRY_VERSION`` (bump it when a generator
changes). Writes are atomic (temp file + rename), so concurrent workers are safe.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

GEOMETRY_VERSION = 1


def cache_dir() -> Path:
    env = os.environ.get("UNDERSEA_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "undersea"


def cache_key(params: dict) -> str:
    blob = json.dumps({"v": GEOMETRY_VERSION, **params}, sort_keys=True, default=float)
    return hashlib.sha256(blob.encode()).hexdigest()[:24]


def cached_mesh(
    params: dict, build: Callable[[], tuple[np.ndarray, np.ndarray]]
) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (V,3) float64, faces (F,3) int32) from the cache or from ``build()``."""
    d = cache_dir() / "meshes"
    path = d / f"{params.get('kind', 'mesh')}-{cache_key(params)}.npz"
    if path.is_file():
        try:
            with np.load(path) as z:
                return z["vertices"].astype(np.float64), z["faces"].astype(np.int32)
        except (OSError, ValueError, KeyError):
            pass  # corrupt entry: rebuild
    v, f = build()
    v = np.asarray(v, dtype=np.float64)
    f = np.asarray(f, dtype=np.int32)
    try:
        d.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=d, suffix=".npz")
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, vertices=v, faces=f)
        os.replace(tmp, path)
    except OSError:
        pass  # read-only home: caching is an optimisation only
    return v, f
