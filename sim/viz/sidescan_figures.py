"""Figures of a real side-scan recording: the bottom track over the waterfall, and a
display PNG of a georeferenced mosaic (the GeoTIFF itself keeps linear intensity)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from slam.frontend.bottom_track import BottomTrack
from slam.frontend.mosaic import Mosaic
from slam.io.recording import SidescanRecording


def display_db(image: np.ndarray, low: float = 1.0, high: float = 99.0) -> np.ndarray:
    """float image in [0, 1]: 10·log10 intensity stretched between two percentiles of the
    finite values; nan stays nan."""
    img = np.asarray(image, dtype=np.float64)
    db = 10 * np.log10(np.maximum(img, 1e-6))
    fin = np.isfinite(img)
    if not fin.any():
        return np.full(img.shape, np.nan)
    lo, hi = np.percentile(db[fin], [low, high])
    out = np.clip((db - lo) / max(hi - lo, 1e-9), 0, 1)
    return np.where(fin, out, np.nan)


def plot_bottom_track(
    rec: SidescanRecording, track: BottomTrack, path: str | Path, max_range_m: float | None = None
) -> Path:
    """Starboard waterfall near range (ping vs slant range) with the bottom track and the
    file's altitude/depth field, and both altitudes against ping number."""
    wf = rec.waterfall
    dr = float(np.nanmedian(wf.sample_spacing_m()))
    top = max_range_m or min(wf.slant_range_m.max(), 2.5 * np.nanmax(track.altitude_m))
    n = max(1, min(wf.samples_per_side, round(top / dr)))
    fig, ax = plt.subplots(2, 1, figsize=(11, 6), sharex=True)
    ax[0].imshow(display_db(wf.starboard[:, :n].T), cmap="gray", aspect="auto",
                 extent=[0, wf.n_pings, n * dr, 0])
    ax[0].plot(track.altitude_m, "r.", ms=1.5, label="bottom track (first return)")
    ref = rec.nav.altitude_m
    if np.isfinite(ref).any():
        ax[0].plot(ref, "c-", lw=0.6, label="file altitude / depth field")
    ax[0].set_ylabel("slant range, m")
    ax[0].legend(loc="lower right", fontsize=8)
    ax[0].set_title(f"{Path(wf.source).name}: starboard near range")
    ax[1].plot(ref, "c-", lw=0.8, label="file altitude / depth field")
    ax[1].plot(track.altitude_m, "r-", lw=0.8, label="bottom track")
    ax[1].invert_yaxis()
    ax[1].set_xlabel("ping")
    ax[1].set_ylabel("altitude, m")
    ax[1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def plot_mosaic(mosaic: Mosaic, path: str | Path, title: str = "") -> Path:
    """The mosaic in dB with metre axes (east, north relative to the grid's corner)."""
    h, w = mosaic.image.shape
    fig, ax = plt.subplots(figsize=(8, 8 * h / max(w, 1) + 0.8))
    cmap = plt.get_cmap("copper").copy()
    cmap.set_bad("white")
    ax.imshow(display_db(mosaic.image), cmap=cmap, extent=[0, w * mosaic.cell_m, 0, h * mosaic.cell_m])
    ax.set_xlabel(f"east, m (+{mosaic.west_m:.1f}, {mosaic.crs or 'local'})")
    ax.set_ylabel(f"north, m (+{mosaic.north_m - h * mosaic.cell_m:.1f})")
    ax.set_title(title or f"slant-range-corrected mosaic, {mosaic.cell_m:.2f} m cells")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)
