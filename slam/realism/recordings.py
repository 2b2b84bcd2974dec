"""Load a side-scan waterfall as linear intensity for the realism statistics.

Formats (by suffix) and what is taken as intensity (``scale`` overrides it):

* ``.xtf``  — ``slam.io.xtf.read_xtf``; samples are amplitudes → intensity = sample².
* ``.npy``  — a 2-D array, taken as linear intensity (the project's float32 waterfalls).
* ``.npz``  — key ``intensity`` (else the only array); as ``.npy``. Optional keys
  ``altitude_m`` (P,) and ``slant_range_m`` (scalar or (P,)) are kept.
* images (``slam.io.images.SUPPORTED_SUFFIXES``) — grey levels are display amplitudes →
  intensity = grey².
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from slam.io.images import SUPPORTED_SUFFIXES, read_image
from slam.io.xtf import read_xtf

SCALES = ("intensity", "amplitude")
_DEFAULT_SCALE = {".xtf": "amplitude", ".npy": "intensity", ".npz": "intensity"}


@dataclass(frozen=True)
class Recording:
    """A waterfall ready for the statistics.

    intensity     : (P, 2S) float64 linear intensity, port left (far range at column 0).
    source        : path it came from.
    kind          : "xtf", "npy", "npz", "image" (or what a caller sets).
    altitude_m    : (P,) altitude over the seabed, m, or None when unknown.
    slant_range_m : maximum slant range, m (median over pings), or None when unknown.
    """

    intensity: np.ndarray
    source: str
    kind: str
    altitude_m: np.ndarray | None = None
    slant_range_m: float | None = None

    def __post_init__(self) -> None:
        a = np.asarray(self.intensity, dtype=np.float64)
        if a.ndim != 2 or a.shape[1] < 2 or a.shape[1] % 2:
            raise ValueError(
                f"{self.source}: a waterfall must be 2-D (pings, 2*samples) with an even "
                f"width, got shape {a.shape}"
            )
        if not np.isfinite(a).all():
            raise ValueError(f"{self.source}: waterfall holds NaN or inf samples")
        if (a < 0).any():
            raise ValueError(f"{self.source}: linear intensity must be >= 0, min {a.min()}")
        object.__setattr__(self, "intensity", a)

    @property
    def n_pings(self) -> int:
        return int(self.intensity.shape[0])

    def pings(self, start: int, stop: int) -> Recording:
        """The pings [start, stop) as a recording."""
        alt = None if self.altitude_m is None else self.altitude_m[start:stop]
        return Recording(
            self.intensity[start:stop], self.source, self.kind, alt, self.slant_range_m
        )


def _to_intensity(values: np.ndarray, scale: str) -> np.ndarray:
    v = np.asarray(values, dtype=np.float64)
    return v * v if scale == "amplitude" else v


def _from_npz(path: Path) -> tuple[np.ndarray, dict]:
    with np.load(path) as z:
        keys = list(z.keys())
        if "intensity" in z:
            arr = z["intensity"]
        elif len(keys) == 1:
            arr = z[keys[0]]
        else:
            raise ValueError(f"{path}: .npz needs a key 'intensity' (keys: {keys})")
        meta = {
            k: np.asarray(z[k], dtype=np.float64) for k in ("altitude_m", "slant_range_m") if k in z
        }
    return arr, meta


def load_recording(path: str | Path, scale: str | None = None) -> Recording:
    """Read a waterfall file as linear intensity (see the module docstring).

    Raises ValueError for a missing file, an unknown suffix, a bad ``scale`` or an array
    that is not a (P, 2S) non-negative waterfall.
    """
    path = Path(path)
    if scale is not None and scale not in SCALES:
        raise ValueError(f"scale must be one of {SCALES}, got {scale!r}")
    if not path.is_file():
        raise ValueError(f"recording {str(path)!r} is not a file")
    suffix = path.suffix.lower()
    alt, srange = None, None
    if suffix == ".xtf":
        w = read_xtf(path)
        raw, kind = w.intensity, "xtf"
        if "altitude_m" in w.nav:
            alt = np.asarray(w.nav["altitude_m"], dtype=np.float64)
        if np.isfinite(w.slant_range_m).any():
            srange = float(np.nanmedian(w.slant_range_m))
    elif suffix == ".npy":
        raw, kind = np.load(path, allow_pickle=False), "npy"
    elif suffix == ".npz":
        raw, meta = _from_npz(path)
        kind = "npz"
        alt = meta.get("altitude_m")
        if "slant_range_m" in meta:
            srange = float(np.median(meta["slant_range_m"]))
    elif suffix in SUPPORTED_SUFFIXES:
        raw, kind = read_image(path).image, "image"
    else:
        raise ValueError(
            f"{path}: unknown recording type {suffix!r}; use .xtf, .npy, .npz or an image "
            f"({', '.join(SUPPORTED_SUFFIXES)})"
        )
    use = scale or _DEFAULT_SCALE.get(suffix, "amplitude")
    if alt is not None and (alt.shape != (np.shape(raw)[0],) or not np.any(alt > 0)):
        alt = None
    return Recording(_to_intensity(raw, use), str(path), kind, alt, srange)
