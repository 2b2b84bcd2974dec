"""The MuJoCo world: water, seabed, objects, the SWARMs vehicles and their hydrodynamics.

from sim.world import build_world, World, WorldSpec, VehicleSpec
world = build_world(WorldSpec(vehicles=("alister9",)))
world.vehicles["alister9"].set_thruster_commands([0.5, 0.0, 0.0])
world.step(100)
world.vehicles["alister9"].state()
"""

from sim.world.builder import ObjectInfo, VehicleSpec, World, WorldSpec, build_world
from sim.world.currents import CurrentField, CurrentSpec
from sim.world.objects import OBJECT_CLASSES, OBJECT_KINDS, ObjectSpec, scatter_objects
from sim.world.seabed import SEABED_KINDS, Seabed, SeabedSpec
from sim.world.vehicle import VehicleHandle
from sim.world.vehicles import SWARMS_VEHICLES, VEHICLE_KINDS, VEHICLES
from sim.world.water import Water, mackenzie_sound_speed, seawater_density

__all__ = [
    "OBJECT_CLASSES",
    "OBJECT_KINDS",
    "SEABED_KINDS",
    "SWARMS_VEHICLES",
    "VEHICLES",
    "VEHICLE_KINDS",
    "CurrentField",
    "CurrentSpec",
    "ObjectInfo",
    "ObjectSpec",
    "Seabed",
    "SeabedSpec",
    "VehicleHandle",
    "VehicleSpec",
    "Water",
    "World",
    "WorldSpec",
    "build_world",
    "mackenzie_sound_speed",
    "scatter_objects",
    "seawater_density",
]
