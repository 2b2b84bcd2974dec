"""Tim Bailey's 2-D SLAM simulator (the one the reference used), reimplemented, plus the
reference's maps. See vehicle.py (vehicle, steering, true path), simulate.py (noisy runs)
and maps.py."""

from slam.sim2d.maps import (
    DENSE_LOOP_LANDMARKS_AB,
    LINE_LANDMARKS_ABCD,
    dense_loop_map,
    line_map,
    segmentation_loop_map,
)
from slam.sim2d.simulate import (
    Sim2DRun,
    compose_increments,
    range_bearing,
    simulate_run,
    step_odometry,
    visible_mask,
)
from slam.sim2d.vehicle import Sim2DConfig, TruePath, compute_steering, true_path, vehicle_step

__all__ = [
    "DENSE_LOOP_LANDMARKS_AB",
    "LINE_LANDMARKS_ABCD",
    "Sim2DConfig",
    "Sim2DRun",
    "TruePath",
    "compose_increments",
    "compute_steering",
    "dense_loop_map",
    "line_map",
    "range_bearing",
    "segmentation_loop_map",
    "simulate_run",
    "step_odometry",
    "true_path",
    "vehicle_step",
    "visible_mask",
]
