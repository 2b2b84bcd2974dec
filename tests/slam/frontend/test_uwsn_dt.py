"""UWSN-DT (thesis Ch. 4.3): node discovery, Delaunay mesh, rigid transform recovery."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slam.frontend.uwsn import (
    UWSNConfig,
    communication_range,
    discover_nodes,
    fuse_scans,
    rigid_transform,
    thesis_demo,
    transform_error,
    true_b_to_a,
)


def test_comm_range_reproduces_thesis_447_m():
    """Eq. 4.19 with the scan rectangle implied by Table 4.5 (800 m × 400 m, H = 0)."""
    assert UWSNConfig().comm_range_m == pytest.approx(447.2, abs=0.1)
    assert communication_range(3.0, 4.0, 0.0) == pytest.approx(2.5)  # half diagonal
    assert communication_range(0.0, 0.0, 7.0) == pytest.approx(7.0)


def test_thesis_table_4_5_nodes_are_found_as_published():
    """The thesis's listed node coordinates, placed in a field, are discovered exactly as
    Table 4.5 reports: 6 at (500, 500), 9 at (600, 600), shared {14, 23, 39, 42}."""
    table = {
        4: (990.8, 473.1),
        11: (349.5, 331.2),
        14: (600, 607.3),
        15: (703, 765.7),
        23: (875.8, 606.1),
        24: (750.6, 724.2),
        39: (561.6, 468.7),
        41: (518.3, 764.7),
        42: (471, 663.6),
        45: (920.1, 431.1),
        84: (259.7, 347.7),
    }
    nodes = np.full((100, 2), 2900.0)  # others far away
    for k, xy in table.items():
        nodes[k - 1] = xy
    cfg = UWSNConfig(position_sigma_m=0.0)
    rng = np.random.default_rng(0)
    a = discover_nodes(nodes, (500, 500), cfg, rng)
    b = discover_nodes(nodes, (600, 600), cfg, rng)
    assert set(a.ids.tolist()) == {11, 14, 23, 39, 42, 84}
    assert set(b.ids.tolist()) == {4, 14, 15, 23, 24, 39, 41, 42, 45}
    fus = fuse_scans(a, b)
    assert set(fus.common_ids.tolist()) == {14, 23, 39, 42}
    assert fus.matched
    dt, dr = transform_error(fus.transform, true_b_to_a(a, b))
    assert dt < 1e-9 and dr < 1e-9  # noise-free: exact


@settings(max_examples=25, deadline=None)
@given(
    dx=st.floats(-150, 150),
    dy=st.floats(-100, 100),
    heading_a=st.floats(-np.pi, np.pi),
    heading_b=st.floats(-np.pi, np.pi),
    seed=st.integers(0, 2**16),
)
def test_recovers_known_rigid_transform(dx, dy, heading_a, heading_b, seed):
    """Two overlapping scans with arbitrary headings: the Umeyama transform from the shared
    nodes equals the true relative pose within the node-position noise (σ 0.5 m; the
    error of a mean over K ≥ 5 nodes is ≲ 3σ/√K + lever-arm)."""
    rng = np.random.default_rng(seed)
    d = thesis_demo(
        rng,
        auv_a=(1500, 1500),
        auv_b=(1500 + dx, 1500 + dy),
        heading_a_rad=heading_a,
        heading_b_rad=heading_b,
    )
    assert d.fusion.common_ids.size >= 5  # overlap >= 650 m × 300 m always holds nodes
    assert d.translation_error_m < 3.0
    assert d.rotation_error_deg < 1.0
    assert d.fusion.rms_residual_m < 3 * 0.5 * np.sqrt(2)


def test_delaunay_is_invariant_under_the_rigid_map(rng):
    """Without noise both scans triangulate the shared nodes identically (a rigid map
    preserves empty-circumcircle tests), and every triangle is non-degenerate."""
    cfg = UWSNConfig(position_sigma_m=0.0)
    d = thesis_demo(rng, config=cfg, heading_b_rad=0.7)
    assert d.fusion.triangles.shape[0] > 0
    assert d.fusion.shared_triangle_fraction == 1.0


def test_thesis_setup_reports_counts(rng):
    """1000 nodes over 3000 m × 3000 m ⇒ on average 1000·(800·400)/9e6 ≈ 35.6 nodes per
    scan and ≈ 23 shared (overlap 700 m × 300 m); the thesis reports 6, 9 and 4 (see notes)."""
    counts = [thesis_demo(np.random.default_rng(s)) for s in range(20)]
    mean_a = np.mean([c.scan_a.ids.size for c in counts])
    mean_shared = np.mean([c.fusion.common_ids.size for c in counts])
    assert 30 < mean_a < 42
    assert 18 < mean_shared < 29


def test_degenerate_cases():
    cfg = UWSNConfig(n_nodes=0)
    d = thesis_demo(np.random.default_rng(1), config=cfg)
    assert d.fusion.transform is None and not d.fusion.matched
    assert np.isnan(d.translation_error_m)
    with pytest.raises(ValueError, match="n_nodes"):
        UWSNConfig(n_nodes=-1)
    with pytest.raises(ValueError, match="point sets"):
        rigid_transform(np.zeros((1, 2)), np.zeros((1, 2)))
