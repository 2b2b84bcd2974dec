"""Sonar mounting: site validation, pose at acquisition, ray backend and absorption set-up."""

from __future__ import annotations

import mujoco
import numpy as np

from sim.sonar.acoustics import absorption_db_per_m
from sim.sonar.config import WaterLike
from sim.sonar.rays import RayBackend, make_backend
from sim.sonar.sediment import SedimentField


def check_mount(model: mujoco.MjModel, data: mujoco.MjData, site_id: int, tolerance: float) -> int:
    """Validate a sonar site and return its vehicle's root body id.

    The site must exist, belong to a body other than the world body, and lie within
    ``tolerance`` m of the bounding sphere of one of its vehicle's geoms (needs ``data``
    after ``mj_forward``). Raises ValueError naming ``site_id`` otherwise.
    """
    if not isinstance(site_id, int | np.integer) or not 0 <= int(site_id) < model.nsite:
        raise ValueError(
            f"site_id = {site_id!r} is not a site of the model; allowed 0 .. {model.nsite - 1}"
        )
    site_id = int(site_id)
    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SITE, site_id)
    body = int(model.site_bodyid[site_id])
    if body == 0:
        raise ValueError(
            f"site_id = {site_id} ({name!r}) is attached to the world body; a sonar site must be "
            "on a vehicle body (a body other than the world)"
        )
    root = int(model.body_rootid[body])
    geoms = np.flatnonzero(model.body_rootid[model.geom_bodyid] == root)
    if geoms.size == 0:
        raise ValueError(
            f"site_id = {site_id} ({name!r}): its vehicle (root body {root}) has no geoms"
        )
    p = data.site_xpos[site_id]
    gap = np.linalg.norm(data.geom_xpos[geoms] - p, axis=1) - model.geom_rbound[geoms]
    if float(gap.min()) > tolerance:
        raise ValueError(
            f"site_id = {site_id} ({name!r}) lies {float(gap.min()):.3f} m outside its vehicle's geoms; "
            f"allowed ≤ mount_tolerance = {tolerance} m"
        )
    return root


def sensor_depth(water: WaterLike, z: float) -> float:
    """Depth (m, ≥ 0) of world height z: ``water.depth − z`` (WaterLike), or
    ``water.surface_z − z`` for a water object that states the surface height instead."""
    if hasattr(water, "depth"):
        return max(0.0, float(water.depth) - z)
    if hasattr(water, "surface_z"):
        return max(0.0, float(water.surface_z) - z)
    raise ValueError(
        "water has neither 'depth' (datum depth) nor 'surface_z'; allowed: a WaterLike object"
    )


class SonarMount:
    """Common set-up of a sonar on one or more sites: validation, root body, ray backend,
    absorption coefficient α (dB/m) at the sonar's initial depth (``water.depth − z``)."""

    def __init__(
        self,
        config,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        site_ids: tuple[int, ...],
        geom_object_id: np.ndarray,
        geom_reflectivity: np.ndarray,
        water: WaterLike,
        backend: str | RayBackend = "embree",
        static_mesh=None,
    ):
        self.config = config
        self.model = model
        self.site_ids = tuple(int(s) if isinstance(s, int | np.integer) else s for s in site_ids)
        roots = {check_mount(model, data, s, config.mount_tolerance) for s in self.site_ids}
        if len(roots) != 1:
            raise ValueError(f"site_id = {site_ids!r}: sonar sites must be on the same vehicle")
        self.root_body = roots.pop()
        self.geom_object_id = np.asarray(geom_object_id, np.int32)
        self.geom_reflectivity = np.asarray(geom_reflectivity, np.float64)
        for name, arr in (
            ("geom_object_id", self.geom_object_id),
            ("geom_reflectivity", self.geom_reflectivity),
        ):
            if arr.shape != (model.ngeom,):
                raise ValueError(
                    f"{name} has shape {arr.shape}; allowed: ({model.ngeom},) (one per geom)"
                )
        if np.any(~np.isfinite(self.geom_reflectivity)) or np.any(self.geom_reflectivity < 0):
            raise ValueError(
                "geom_reflectivity must be finite and ≥ 0 (linear factor, usually in [0, 1])"
            )
        self.water = water
        self.sound_speed = float(water.sound_speed)
        depth = sensor_depth(water, float(data.site_xpos[self.site_ids[0], 2]))
        self.alpha_db_m = absorption_db_per_m(
            config.frequency_hz, water, depth, config.acoustic.absorption_model
        )
        if isinstance(backend, str):
            self.backend = make_backend(backend, model, data, self.root_body, static_mesh)
        else:
            self.backend = backend
        self.mu = 10.0 ** (config.acoustic.lambert_mu_db / 10.0)
        self.sl = 10.0 ** (config.acoustic.source_level_db / 10.0)
        ac = config.acoustic
        self.specular = (
            None
            if ac.specular_db is None
            else (
                10.0 ** (ac.specular_db / 10.0) / self.mu,
                float(np.deg2rad(ac.specular_width_deg)),
            )
        )
        rz = ac.realism
        self.realism = rz
        self.seabed = (
            SedimentField(rz, self.mu) if rz is not None and rz.seabed_model == "sediment" else None
        )
        self.object_specular = (
            None
            if rz is None or rz.facet_specular_db is None
            else (
                10.0 ** (rz.facet_specular_db / 10.0) / self.mu,
                float(np.deg2rad(rz.facet_width_deg)),
            )
        )
        self.object_gain = (
            1.0
            if rz is None or rz.object_mu_db is None
            else 10.0 ** ((rz.object_mu_db - ac.lambert_mu_db) / 10.0)
        )
        # rays slightly beyond max_range still spread part of their footprint inside it
        self.cutoff = 1.25 * config.max_range

    def pose(self, data: mujoco.MjData, site: int) -> tuple[np.ndarray, np.ndarray]:
        """Site position (3,) and rotation (3, 3) world-from-sensor (columns = sensor axes)."""
        return data.site_xpos[site].copy(), data.site_xmat[site].reshape(3, 3).copy()
