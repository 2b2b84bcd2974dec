"""The pipeline's settings, in one frozen dataclass, and the builders that read them.

:class:`PipelineConfig`'s defaults are the scenario file's defaults (``[frontend]`` and
``[slam]`` tables of sim.scenario.schema), so the scenario runner, the gym envs, the
dataset exporter and ``undersea sss-slam`` give the same detections and updates for the
same frames unless a caller changes a field on purpose (:data:`REAL_SIDESCAN` is the
preset for recorded side-scan data; ``ActiveSLAM-v0`` uses shorter windows).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from slam.estimators import make_estimator
from slam.frontend.extended_objects import make_shadow_db
from slam.frontend.polar import FLS_FRONTEND, MSIS_FRONTEND, PolarFrontend, PolarFrontendConfig
from slam.frontend.segmentation.artefacts import first_return_edge_from_altitude
from slam.frontend.segmentation.methods import segment
from slam.frontend.sidescan_prepare import make_sss_prepare
from slam.frontend.sidescan_windows import SidescanProcessor
from slam.pipeline.frame import SonarGeometry

#: SLAM timing modes: "lagged" feeds each delayed observation at the pose of its ping
#: (slam.pipeline.lagged); "naive" at the time it is produced, as if seen from there
TIMING_MODES = ("lagged", "naive")
#: side-scan normalizations (slam.frontend.sidescan_prepare.make_sss_prepare)
NORMALIZATIONS = ("mira", "column-median")


@dataclass(frozen=True)
class PipelineConfig:
    """Settings of :class:`slam.pipeline.SonarSlam` and its front ends.

    method, preset: segmentation (slam.frontend.segmentation; method "none" = no front
    end). window_pings, hop_pings: side-scan waterfall windows. merge_radius_m: regions
    of one object closer than this are merged (the scenario's ``association_gate_m``).
    min_area_m2: side-scan regions smaller on the ground are speckle. max_extent_m:
    side-scan regions longer (along track or across, m) are seabed patches, not point
    landmarks (a single region, before merging fragments). min_ground_range_m:
    side-scan nadir band. looks: side-scan incoherent average (px). normalization: "mira"
    or "column-median". min_speed_mps: floor of the along-track speed for the side-scan
    pixel size. fls, msis: the polar front end's settings. timing: "lagged" | "naive".
    pose0_var_xy_m2, pose0_sigma_yaw_deg: the initial pose's variance in x and y and
    1-sigma in yaw. drop_first_return_edge: side-scan detections centred on the water
    column or the first-bottom-return edge (the frames' altitudes plus a margin,
    slam.frontend.segmentation.artefacts.first_return_edge_from_altitude) or mirrored
    across nadir (artefacts.mirrored_across_nadir) are dropped — the symmetric bright rim
    of the first return on recorded data is not an object.
    extended_objects: side-scan objects are located at their centres from highlight and
    shadow and assembled across windows (slam.frontend.extended_objects); False: at
    their highlight's centroid. require_shadow: side-scan objects without a shadow on
    ``ShadowConfig.min_shadow_rows`` of their rows give no detection (recorded data: an
    object standing proud of the seabed casts one; bright sediment and the lit rim of a
    larger object whose shadow lies farther than ``ShadowConfig.max_gap_m`` do not).
    """

    method: str = "improved-otsu"
    preset: str = "auto"
    window_pings: int = 200
    hop_pings: int = 100
    merge_radius_m: float = 3.0
    min_area_m2: float = 0.0
    max_extent_m: float = math.inf
    min_ground_range_m: float = 2.0
    looks: int = 3
    normalization: str = "mira"
    min_speed_mps: float = 0.1
    fls: PolarFrontendConfig = FLS_FRONTEND
    msis: PolarFrontendConfig = MSIS_FRONTEND
    timing: str = "lagged"
    pose0_var_xy_m2: float = 0.01
    pose0_sigma_yaw_deg: float = 0.5
    drop_first_return_edge: bool = False
    extended_objects: bool = True
    require_shadow: bool = False

    def __post_init__(self) -> None:
        if not 1 <= self.hop_pings <= self.window_pings:
            raise ValueError(
                f"PipelineConfig.hop_pings = {self.hop_pings!r}: must be in "
                f"[1, window_pings = {self.window_pings}]"
            )
        if self.looks < 1:
            raise ValueError(f"PipelineConfig.looks = {self.looks!r}: must be >= 1")
        if self.normalization not in NORMALIZATIONS:
            raise ValueError(
                f"PipelineConfig.normalization = {self.normalization!r}; "
                f"allowed: {', '.join(NORMALIZATIONS)}"
            )
        if self.timing not in TIMING_MODES:
            raise ValueError(
                f"PipelineConfig.timing = {self.timing!r}; allowed: {', '.join(TIMING_MODES)}"
            )
        for name in (
            "merge_radius_m",
            "min_area_m2",
            "min_ground_range_m",
            "min_speed_mps",
            "pose0_var_xy_m2",
            "pose0_sigma_yaw_deg",
        ):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"PipelineConfig.{name} = {v!r}: must be finite and >= 0")
        if not self.max_extent_m > 0:
            raise ValueError(
                f"PipelineConfig.max_extent_m = {self.max_extent_m!r}: must be > 0 (m)"
            )

    def initial_covariance(self) -> np.ndarray:
        """(3, 3) covariance of the initial pose [x, y, yaw]."""
        v = self.pose0_var_xy_m2
        return np.diag([v, v, math.radians(self.pose0_sigma_yaw_deg) ** 2])


#: recorded side-scan data (undersea sss-slam): along-track column-median normalization
#: (MIRA's two exponentials do not follow the bright band beyond the first return of the
#: Scotsman recording), a ground-area speckle filter, single regions longer than twice the
#: association gate (2 × 3 m) dropped (their centroid moves with the view: not a point
#: landmark), objects without a shadow dropped, the navigation's own speed, a start pose
#: known to 1 cm
REAL_SIDESCAN = replace(
    PipelineConfig(),
    normalization="column-median",
    min_area_m2=0.15,
    max_extent_m=6.0,
    min_speed_mps=0.0,
    pose0_var_xy_m2=1e-4,
    drop_first_return_edge=True,
    require_shadow=True,
)

#: the image rules of REAL_SIDESCAN, which a simulated scenario's ``[frontend] profile =
#: "real-sidescan"`` takes (its pose prior, speed floor and speckle area stay its own)
REAL_SIDESCAN_IMAGE_RULES = (
    "normalization",
    "max_extent_m",
    "drop_first_return_edge",
    "require_shadow",
)


def with_real_sidescan_rules(config: PipelineConfig) -> PipelineConfig:
    """``config`` with REAL_SIDESCAN's image rules (REAL_SIDESCAN_IMAGE_RULES)."""
    return replace(config, **{f: getattr(REAL_SIDESCAN, f) for f in REAL_SIDESCAN_IMAGE_RULES})


def segmenter(method: str, preset: str) -> Callable[[np.ndarray], tuple[np.ndarray, list]]:
    """Adapter image -> (labels, regions) over slam.frontend.segmentation. Preset
    ``"auto"`` is the front end's size rule for the actual image, for every sonar."""

    def run(img: np.ndarray):
        res = segment(img, method=method, params=preset)
        return res.labels, list(res.regions)

    return run


Frontend = SidescanProcessor | PolarFrontend


def make_frontend(
    geometry: SonarGeometry,
    config: PipelineConfig,
    *,
    class_of: Callable[[int], int] | None = None,
) -> Frontend | None:
    """The front end for one sonar (None when ``config.method`` is "none").

    class_of: object id -> display class id of the side-scan overlay (scoring display
    only; default 1 for any object)."""
    if config.method == "none":
        return None
    seg = segmenter(config.method, config.preset)
    g = geometry
    if g.kind == "sss":
        return SidescanProcessor(
            seg,
            config.window_pings,
            config.hop_pings,
            merge_radius=config.merge_radius_m,
            min_area_m2=config.min_area_m2,
            max_extent_m=config.max_extent_m,
            min_ground_range=config.min_ground_range_m,
            edge_mask=first_return_edge_from_altitude if config.drop_first_return_edge else None,
            drop_mirrored=config.drop_first_return_edge,
            shadow=(
                make_shadow_db(g.log_compressed, g.dynamic_range_db)
                if config.extended_objects
                else None
            ),
            require_shadow=config.require_shadow and config.extended_objects,
            along_track_beamwidth_deg=g.along_track_beamwidth_deg,
            class_of=class_of,
            prepare=make_sss_prepare(
                g.log_compressed,
                g.dynamic_range_db,
                looks=config.looks,
                normalization=config.normalization,
            ),
        )
    return PolarFrontend(
        g.kind,
        seg,
        ranges=g.ranges,
        angles=g.bearings,
        bin_width=g.bin_width,
        angular_cell=g.angular_cell,
        log_compressed=g.log_compressed,
        dynamic_range_db=g.dynamic_range_db,
        config=config.fls if g.kind == "fls" else config.msis,
        mount_xy=g.mounting_xy,
    )


@dataclass(frozen=True)
class EstimatorSpec:
    """An estimator by name (slam.estimators.ESTIMATORS) and its parameters."""

    name: str = "aekf"
    params: Mapping[str, Any] = field(default_factory=dict)


def build_estimator(
    spec: EstimatorSpec, pose0, config: PipelineConfig, rng: np.random.Generator | None = None
):
    """The estimator at ``pose0`` [x, y, yaw] with the config's initial covariance;
    ``rng`` reaches estimators that draw (FastSLAM 2.0) unless the params carry one."""
    params = dict(spec.params)
    if spec.name == "fastslam2" and rng is not None:
        params.setdefault("rng", rng)
    return make_estimator(
        spec.name,
        x0=np.asarray(pose0, float).copy(),
        P0=config.initial_covariance(),
        **params,
    )
