"""Vehicle display meshes (sim.viz.meshes)."""

from __future__ import annotations

import numpy as np
import pytest

from sim.viz.meshes import vehicle_body_mesh
from sim.world import SeabedSpec, WorldSpec, build_world


@pytest.mark.parametrize("kind", ["alister9", "saga"])
def test_vehicle_display_mesh_matches_reference_dimensions(kind):
    """The rerun mesh built from the vehicle's MuJoCo geoms spans the REFERENCE.md
    length/width/height (Table 6.5: Alister 9 2.0 x 0.22 x 0.22 m, SAGA 0.42 x 0.33 x 0.27 m)."""
    w = build_world(
        WorldSpec(seabed=SeabedSpec(size_xy=(20.0, 20.0), resolution=2.0), vehicles=(kind,))
    )
    v, f, c = vehicle_body_mesh(w.model, w.data, w.vehicles[kind].body_id)
    ext = v.max(axis=0) - v.min(axis=0)
    ref = {"alister9": (2.0, 0.22, 0.22), "saga": (0.42, 0.33, 0.27)}[kind]
    assert np.allclose(ext, ref, rtol=0.1)
    assert f.max() < len(v) and c.shape == (len(v), 3)
