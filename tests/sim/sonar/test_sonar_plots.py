"""Quick-look figures render to PNG files (smoke test of the plotting helpers)."""

from __future__ import annotations

import numpy as np

from sim.sonar import ForwardLookingSonar, SideScanWaterfall, preset
from sim.sonar.plots import plot_fls, plot_waterfall
from sim.sonar.scenes import SceneObject, build_scene


def test_plots_write_png(tmp_path):
    sc = build_scene(
        altitude=8.0,
        objects=[SceneObject("box", (0.0, 12.0, 1.0), (1.0, 1.0, 1.0))],
        seabed_cells=10,
    )
    son = sc.sidescan(preset("deepeye680d", max_range=30.0, samples_per_side=300))
    rng = np.random.default_rng(0)
    pings = []
    for x in np.arange(-2, 2, 0.25):
        sc.move_vehicle(x)
        pings.append(son.ping(sc.data, rng))
    plot_waterfall(SideScanWaterfall.from_pings(pings), tmp_path / "wf.png")
    fls = ForwardLookingSonar(
        preset("blueview_p900_90", max_range=30.0, n_bins=200, n_beams=64),
        sc.model,
        sc.data,
        sc.sites["fls"],
        sc.geom_object_id,
        sc.geom_reflectivity,
        sc.water,
    )
    plot_fls(fls.frame(sc.data, rng), tmp_path / "fls.png")
    for name in ("wf.png", "fls.png"):
        data = (tmp_path / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000
