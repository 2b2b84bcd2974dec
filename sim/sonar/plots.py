"""Quick-look figures of sonar products (matplotlib, Agg backend): waterfall with labels,
mosaic, FLS polar + fan. Functions return the figure; ``path`` saves a PNG."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sim.sonar.fls import FLSFrame, fan_image
from sim.sonar.waterfall import SideScanWaterfall, mosaic


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_waterfall(
    wf: SideScanWaterfall, path: str | Path | None = None, mosaic_resolution: float = 0.1
):
    """Waterfall (port left, nadir centre), its labels, and the north-up mosaic."""
    plt = _plt()
    fig, ax = plt.subplots(1, 3, figsize=(18, 7))
    S = wf.samples_per_side
    r = float(wf.slant_range[-1])
    ext = [-r, r, wf.intensity.shape[0], 0]
    ax[0].imshow(wf.intensity, cmap="gray", aspect="auto", extent=ext, vmin=0, vmax=1)
    ax[0].set(
        title="waterfall (port | starboard)", xlabel="slant range, m (port < 0)", ylabel="ping"
    )
    ax[1].imshow(
        np.where(wf.labels < 0, np.nan, wf.labels),
        cmap="tab10",
        aspect="auto",
        extent=ext,
        interpolation="nearest",
    )
    ax[1].set(title="labels (0 seabed, k object, blank none)", xlabel="slant range, m")
    mo = mosaic(wf, mosaic_resolution)
    H, W = mo.image.shape
    ax[2].imshow(
        mo.image,
        cmap="gray",
        vmin=0,
        vmax=1,
        extent=[mo.x_min, mo.x_min + W * mo.resolution, mo.y_max - H * mo.resolution, mo.y_max],
    )
    ax[2].set(title="mosaic (north up)", xlabel="x (east), m", ylabel="y (north), m")
    fig.suptitle(f"{wf.intensity.shape[0]} pings × {2 * S} samples")
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=80)
    return fig


def plot_fls(frame: FLSFrame, path: str | Path | None = None):
    """FLS polar image (bins × beams), Cartesian fan, and labels."""
    plt = _plt()
    fig, ax = plt.subplots(1, 3, figsize=(18, 6))
    b = np.rad2deg(frame.bearings)
    ext = [b[0], b[-1], frame.ranges[0], frame.ranges[-1]]
    ax[0].imshow(
        frame.image, cmap="gray", aspect="auto", origin="lower", extent=ext, vmin=0, vmax=1
    )
    ax[0].set(title="polar (bins × beams)", xlabel="bearing, deg (port left)", ylabel="range, m")
    fan = fan_image(frame)
    H, W = fan.image.shape
    ax[1].imshow(
        fan.image,
        cmap="gray",
        vmin=0,
        vmax=1,
        extent=[
            fan.y_max,
            fan.y_max - W * fan.resolution,
            fan.x_max - H * fan.resolution,
            fan.x_max,
        ],
    )
    ax[1].set(title="fan", xlabel="lateral y, m (port left)", ylabel="forward x, m")
    ax[2].imshow(
        np.where(frame.labels < 0, np.nan, frame.labels),
        cmap="tab10",
        aspect="auto",
        origin="lower",
        extent=ext,
        interpolation="nearest",
    )
    ax[2].set(title="labels", xlabel="bearing, deg")
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=80)
    return fig
