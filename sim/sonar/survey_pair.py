"""Two side-scan passes over one wreck, mosaicked on one north-up grid.

A test image pair for keypoint matching (thesis Ch. 4.2, Table 4.3) whose true transform
is known: both passes are georeferenced by the simulator's exact sensor poses onto the
same grid, so pixel (x, y) of mosaic A and of mosaic B are the same place on the seabed.
Like two lines of a real survey, both passes head east on parallel tracks south of the
wreck at different offsets, with independent speckle, so its highlights and shadows
differ between the images (longer shadows from the farther line).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from sim.sonar.config import preset
from sim.sonar.scenes import SceneObject, build_scene
from sim.sonar.sidescan import SideScanSonar
from sim.sonar.waterfall import SideScanWaterfall, mosaic

# A ~20 m wreck lying 25° off north-east: hull, deck house, mast, two debris pieces.
WRECK_PARTS = (
    SceneObject("box", (0.0, 0.0, 1.2), (10.0, 2.5, 1.2), euler_deg=(0.0, 0.0, 25.0)),
    SceneObject("box", (-2.0, -1.0, 3.0), (2.5, 1.5, 0.8), euler_deg=(0.0, 0.0, 25.0)),
    SceneObject("cylinder", (3.0, 1.4, 4.0), (0.25, 2.0)),
    SceneObject("box", (8.0, -6.0, 0.3), (1.0, 0.6, 0.3), euler_deg=(0.0, 0.0, 70.0)),
    SceneObject("box", (-9.0, 5.0, 0.4), (0.8, 0.8, 0.4), euler_deg=(0.0, 0.0, 10.0)),
)


@dataclass(frozen=True)
class SurveyPair:
    """Mosaics ``a`` and ``b`` of two passes heading east, ``offsets`` m south of the
    wreck, both (H, W) float32 linear intensity on the
    grid of ``bounds`` (x_min, y_min, x_max, y_max, world m) at ``resolution`` m; the
    true transform from a to b is the identity."""

    a: np.ndarray
    b: np.ndarray
    bounds: tuple[float, float, float, float]
    resolution: float


def _set_pose(scene, x: float, y: float, yaw: float) -> None:
    adr = scene.qpos_adr(scene.vehicle_body)
    scene.data.qpos[adr : adr + 2] = (x, y)
    scene.data.qpos[adr + 3 : adr + 7] = (np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2))
    mujoco.mj_kinematics(scene.model, scene.data)


def wreck_survey_pair(
    seed: int = 0,
    *,
    altitude: float = 8.0,
    offsets: tuple[float, float] = (14.0, 20.0),
    half_extent: float = 20.0,
    ping_spacing: float = 0.15,
    resolution: float = 0.2,
) -> SurveyPair:
    """Fly the two passes with a DeepEye 680D (Embree backend) and mosaic them.

    offsets: m between each track and the wreck (south of it); half_extent: m, half the side of the
    square mosaic around the wreck; ping_spacing: m along track; seeded speckle.
    """
    if not 0 < ping_spacing < half_extent:
        raise ValueError(f"ping_spacing = {ping_spacing!r}; allowed (0, half_extent) m")
    scene = build_scene(altitude=altitude, objects=WRECK_PARTS, seabed_cells=40)
    sonar = SideScanSonar(
        preset("deepeye680d"),
        scene.model,
        scene.data,
        (scene.sites["sss_port"], scene.sites["sss_starboard"]),
        scene.geom_object_id,
        scene.geom_reflectivity,
        scene.water,
        backend="embree",
    )
    rng = np.random.default_rng(seed)
    along = np.arange(-half_extent - 5.0, half_extent + 5.0, ping_spacing)
    bounds = (-half_extent, -half_extent, half_extent, half_extent)
    passes = []
    for offset in offsets:
        pings = []
        for s in along:
            _set_pose(scene, s, -offset, 0.0)
            pings.append(sonar.ping(scene.data, rng))
        wf = SideScanWaterfall.from_pings(pings)
        passes.append(mosaic(wf, resolution=resolution, bounds=bounds).image)
    return SurveyPair(passes[0], passes[1], bounds, resolution)
