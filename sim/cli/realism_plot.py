"""The figure of ``undersea realism --plot``: both waterfalls in one dB scale (re each one's
median seabed intensity, so a gain difference does not hide the texture) and the seabed
intensity and LBP-texture histograms of both."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from slam.realism.recordings import Recording
from slam.realism.statistics import WaterfallStatistics, seabed_reference
from slam.realism.textures import LBP_BINS, intensity_centres

#: colour scale of both waterfalls, dB re median seabed intensity.
DB_RANGE = (-30.0, 20.0)


def plot_realism(
    path: str | Path,
    sim: Recording,
    real: Recording,
    sim_stats: WaterfallStatistics,
    real_stats: WaterfallStatistics,
) -> None:
    """Write the PNG: SIM and REAL waterfalls (top), histograms (bottom)."""
    fig, ax = plt.subplots(2, 2, figsize=(13, 9), gridspec_kw={"height_ratios": [3, 2]})
    for a, rec, name in ((ax[0, 0], sim, "SIM"), (ax[0, 1], real, "REAL")):
        ref = seabed_reference(rec.intensity)
        db = 10.0 * np.log10(np.maximum(rec.intensity, ref * 1e-12) / ref)
        im = a.imshow(db, cmap="gray", vmin=DB_RANGE[0], vmax=DB_RANGE[1], aspect="auto")
        a.set_title(f"{name}: {Path(rec.source).name}", fontsize=9)
        a.set_xlabel("sample (port | starboard)")
        a.set_ylabel("ping")
    fig.colorbar(im, ax=ax[0, :], label="dB re median seabed intensity", shrink=0.8)
    c = intensity_centres()
    for stats, name, colour in ((sim_stats, "SIM", "tab:orange"), (real_stats, "REAL", "k")):
        for side, style in (("port", "-"), ("starboard", "--")):
            s = stats.sides()[side]
            ax[1, 0].plot(c, s.hist_intensity, style, color=colour, label=f"{name} {side}")
    ax[1, 0].set_xlabel("seabed intensity, dB re median")
    ax[1, 0].set_ylabel("fraction per 0.5 dB")
    ax[1, 0].legend(fontsize=8)
    codes = np.arange(LBP_BINS)
    width = 0.2
    for i, (stats, name) in enumerate(((sim_stats, "SIM"), (real_stats, "REAL"))):
        for j, side in enumerate(("port", "starboard")):
            off = (2 * i + j - 1.5) * width
            ax[1, 1].bar(codes + off, stats.sides()[side].hist_lbp, width, label=f"{name} {side}")
    ax[1, 1].set_xlabel("uniform LBP code (P=8, R=1)")
    ax[1, 1].set_ylabel("fraction")
    ax[1, 1].legend(fontsize=8)
    fig.savefig(path, dpi=90)
    plt.close(fig)
