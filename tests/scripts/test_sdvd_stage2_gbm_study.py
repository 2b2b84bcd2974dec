"""scripts/sdvd_stage2_gbm_study.py (issue 14): the local-contrast features of a region
against its own surroundings, checked on a synthetic tile whose annulus, strips and
percentile ranks are counted by hand, and the selection rule on a hand-made grid."""

from __future__ import annotations

import math

import numpy as np
import pytest
from script_module import load_script

from slam.frontend.segmentation.fragments import regions_from_labels

S = load_script("sdvd_stage2_gbm_study")


@pytest.fixture
def tile():
    """100 x 120 tile at level 50; a 10 x 10 target at level 150 (rows 40–49, columns
    40–49) with a 24 px shadow at level 10 right of it (same rows); a second region,
    10 x 10 at level 60, in the top-left corner (touching the tile edge)."""
    g = np.full((100, 120), 50, np.uint8)
    g[40:50, 40:50] = 150
    g[40:50, 50:74] = 10
    g[0:10, 0:10] = 60
    labels = np.zeros(g.shape, np.int32)
    labels[40:50, 40:50] = 1
    labels[0:10, 0:10] = 2
    return g, labels, regions_from_labels(labels)


def test_local_features_by_hand(tile):
    g, labels, regions = tile
    f = S.local_features(g, labels, regions, ring_px=8, strip_px=24)
    assert f.shape == (2, len(S.LOCAL))
    col = {name: i for i, name in enumerate(S.LOCAL)}
    # Annulus of the target: the 26 x 26 box around it less the target: 576 pixels, of
    # which 10 rows x 8 columns lie on the shadow (level 10), the rest at 50.
    ring = np.r_[np.full(80, 10.0), np.full(576 - 80, 50.0)]
    m, s = ring.mean(), ring.std()
    t = f[0]
    assert t[col["ring_z"]] == pytest.approx((150 - m) / (s + 1))
    assert t[col["ring_rank"]] == 1.0
    # Tile pixels below 150: all but the target's 100.
    assert t[col["tile_rank_mean"]] == pytest.approx((g.size - 100) / g.size)
    # Darker strip: the shadow (mean 10); the left strip is seabed (50).
    assert t[col["shadow_z"]] == pytest.approx((10 - m) / (s + 1))
    assert t[col["shadow_rank"]] == 0.0  # no annulus pixel darker than 10
    # Corner region: annulus all seabed, 60 vs 50 with std 0: z = 10, above the
    # target's (about 7.1, its annulus holds part of the shadow), so the corner is best.
    c = f[1]
    assert c[col["ring_z"]] == pytest.approx(10.0)
    assert t[col["ring_z"]] < 10.0
    assert (t[col["ring_z_below_best"]], c[col["ring_z_below_best"]]) == pytest.approx(
        (t[col["ring_z"]] - 10.0, 0.0)
    )
    assert (t[col["ring_z_order"]], c[col["ring_z_order"]]) == (0.5, 0.0)
    assert f[:, col["log_n_candidates"]] == pytest.approx([math.log(2)] * 2)
    assert f[:, col["touches_edge"]].tolist() == [0.0, 1.0]


def test_local_features_invariant_to_display_gain(tile):
    """Percentile ranks do not change when the tile's levels are scaled (a dimmer
    display of the same seabed); the z-scores (and so the order by them) change through
    the +1 in their denominator."""
    g, labels, regions = tile
    a = S.local_features(g, labels, regions)
    b = S.local_features((g // 2).astype(np.uint8), labels, regions)
    for name in ("ring_rank", "tile_rank_mean", "tile_rank_p90", "shadow_rank"):
        i = S.LOCAL.index(name)
        assert a[:, i] == pytest.approx(b[:, i])


def test_local_features_empty():
    g = np.full((20, 20), 50, np.uint8)
    assert S.local_features(g, np.zeros(g.shape, np.int32), ()).shape == (0, len(S.LOCAL))


def test_rule_prefers_hits_then_fewer_false_detections():
    def e(hit, ppv, dn):
        return {"hit_rate": hit, "ppv": ppv, "detections_per_negative_tile": dn}

    grid = [e(0.9, 0.45, 0.1), e(0.8, 0.6, 0.5), e(0.8, 0.55, 0.4), e(0.85, 0.6, 0.8)]
    assert S.rule(grid) is grid[2]  # 0.9 fails PPV, 0.85 fails det/neg; tie -> fewer det
    assert S.rule([grid[0], grid[3]]) is None
