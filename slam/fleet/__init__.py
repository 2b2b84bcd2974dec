"""A fleet's maps fused into one (SWARMs use case 5): map-to-map joint-compatibility
association (:mod:`slam.fleet.association`), the maps as data (:mod:`slam.fleet.maps`),
the joint MAP of every vehicle's map, frame priors and surface GPS fixes
(:mod:`slam.fleet.solve`) and the fusion of a fleet's maps (:mod:`slam.fleet.fusion`).
Arrays in, arrays out: no simulator types."""

from slam.fleet.association import MapPairing, pair_maps
from slam.fleet.fusion import fuse_maps
from slam.fleet.maps import FleetFusionConfig, FusedMap, GpsFix, VehicleMap, vehicle_map_from
from slam.fleet.solve import solve_fused

__all__ = [
    "FleetFusionConfig",
    "FusedMap",
    "GpsFix",
    "MapPairing",
    "VehicleMap",
    "fuse_maps",
    "pair_maps",
    "solve_fused",
    "vehicle_map_from",
]
