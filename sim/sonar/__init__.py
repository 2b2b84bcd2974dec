"""Ray-cast sonar simulators: side-scan (SSS), forward-looking (FLS) and mechanically
scanned (MSIS), with per-sample ground truth.

Sonars take ``(model, data, site_id, geom_object_id, geom_reflectivity, water, rng)``
rather than a World, so they work on any MuJoCo scene. Presets by name via
:func:`preset`: "deepeye340d", "deepeye680d", "klein3500", "blueview_p900_90", "msis".
"""

from sim.sonar.config import (
    PRESETS,
    AcousticConfig,
    FLSConfig,
    MSISConfig,
    SSSConfig,
    Water,
    WaterLike,
    preset,
)
from sim.sonar.effects import RealismConfig
from sim.sonar.fls import FanImage, FLSFrame, ForwardLookingSonar, fan_image, fls_frame
from sim.sonar.msis import MSISPing, MSISScan, MSISSonar, msis_scan
from sim.sonar.rays import EmbreeRays, MujocoRays, RayHits, make_backend, static_mesh_from_model
from sim.sonar.sidescan import RayFan, SideScanSonar, sss_ping
from sim.sonar.waterfall import (
    GroundRangeImage,
    Mosaic,
    SideScanWaterfall,
    SSSPing,
    ground_range,
    mosaic,
    sample_ground_positions,
    slant_to_ground,
)

__all__ = [
    "PRESETS",
    "AcousticConfig",
    "EmbreeRays",
    "FLSConfig",
    "FLSFrame",
    "FanImage",
    "ForwardLookingSonar",
    "GroundRangeImage",
    "MSISConfig",
    "MSISPing",
    "MSISScan",
    "MSISSonar",
    "Mosaic",
    "MujocoRays",
    "RayFan",
    "RayHits",
    "RealismConfig",
    "SSSConfig",
    "SSSPing",
    "SideScanSonar",
    "SideScanWaterfall",
    "Water",
    "WaterLike",
    "fan_image",
    "fls_frame",
    "ground_range",
    "make_backend",
    "mosaic",
    "msis_scan",
    "preset",
    "sample_ground_positions",
    "slant_to_ground",
    "sss_ping",
    "static_mesh_from_model",
]
