"""The MuJoCo world: water, seabed, objects, the SWARMs vehicles and their hydrodynamics.

from sim.world import build_world, World, WorldSpec, VehicleSpec
world = build_world(WorldSpec(vehicles=("alister9",)))
world.vehicles["alister9"].set_thruster_commands([0.5, 0.0, 0.0])
world.step(100)
world.vehicles["alister9"].state()

Conventions of a built world:
- geom groups: 0 seabed mesh and vehicle hulls, 1 objects, 2 vehicle details (fins,
  ducts), 3 the seabed contact hfield (alpha 0: ``mj_ray`` ignores it), 4 sensor sites,
  5 actuator sites. Sonar rays may use groups 0–2.
- contacts: vehicles contype 1 / conaffinity 3 (they hit each other), seabed hfield and
  objects contype 2 / conaffinity 1 (they hit vehicles, never each other).
- labels: ``geom_object_id`` 0 seabed, k >= 1 object k, −1 vehicles and the rest;
  ``geom_reflectivity`` linear backscatter factor in [0, 1].
- vehicles: body ``"<name>/base"`` with a free joint, origin at the CG; sites
  ``"<name>/<site>"``; actuator force along each actuator site's z axis.
- MuJoCo fluid model off, gravity on; buoyancy, added mass, damping, currents and thrust
  through ``xfrc_applied`` (``sim.hydrodynamics``, ``sim.thrusters``).
"""

from sim.world.builder import ObjectInfo, VehicleSpec, World, WorldSpec, build_world
from sim.world.currents import CurrentField, CurrentSpec
from sim.world.objects import OBJECT_CLASSES, OBJECT_KINDS, ObjectSpec, scatter_objects
from sim.world.seabed import SEABED_KINDS, Seabed, SeabedSpec
from sim.world.vehicle import VehicleHandle
from sim.world.vehicles import SWARMS_VEHICLES, VEHICLE_KINDS, VEHICLES
from sim.world.water import SonarWater, Water, mackenzie_sound_speed, seawater_density

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
    "SonarWater",
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
