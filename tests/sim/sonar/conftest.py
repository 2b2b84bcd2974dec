"""Fixtures for the sonar tests: small self-contained MJCF scenes (sim.sonar.scenes)."""

from __future__ import annotations

import pytest

from sim.sonar.scenes import SceneObject, build_scene


@pytest.fixture(scope="module")
def flat_scene():
    """Vehicle 10 m above a flat 200 m mesh seabed, no objects."""
    return build_scene(altitude=10.0, seabed_cells=20)


@pytest.fixture(scope="module")
def box_scene():
    """Box 2 m high, 4 m along-track, top far edge at ground range 15 m (port side)."""
    return build_scene(
        altitude=10.0,
        objects=[SceneObject("box", (0.0, 14.0, 1.0), (2.0, 1.0, 1.0))],
        seabed_cells=20,
    )


__all__ = ["SceneObject", "build_scene"]
