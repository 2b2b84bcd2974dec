"""The Wigley wreck hull and the seabed relief that makes the side-scan nadir wander."""

from __future__ import annotations

import numpy as np

from sim.world.objects import _shipwreck, wigley_hull
from sim.world.seabed import SeabedSpec, height_grid


def test_wigley_hull_half_breadth_follows_the_published_form():
    """Wigley (1934): y = (B/2)(1 − (2x/L)²)(1 − (z/T)²): B/2 amidships at the waterline,
    0 at the ends and the keel, 3B/8 at x = L/4 on the waterline."""
    L, B, T = 20.0, 4.0, 1.5
    v = np.asarray(wigley_hull(L, B, T, 0.8).vertices)
    wl = v[np.isclose(v[:, 2], 0.0)]
    mid = wl[np.isclose(wl[:, 0], np.min(np.abs(wl[:, 0])) * np.sign(wl[:, 0]))]
    assert (
        abs(np.abs(wl[:, 1]).max() - 0.5 * B * (1 - (2 * np.abs(mid[:, 0]).min() / L) ** 2)) < 1e-9
    )
    ends = v[np.isclose(np.abs(v[:, 0]), L / 2)]
    assert np.allclose(ends[:, 1], 0.0)
    keel = v[np.isclose(v[:, 2], -T)]
    assert np.allclose(keel[:, 1], 0.0)
    q = wl[np.argmin(np.abs(wl[:, 0] - L / 4))]
    assert abs(abs(q[1]) - 0.5 * B * (1 - (2 * q[0] / L) ** 2)) < 1e-9


def test_wreck_fills_its_bounding_box_with_superstructure_above_the_deck():
    """The wreck mesh spans the requested bbox and has structure (bridge, mast) above the
    hull: its top is at the bbox height, well above the hull's deck line."""
    size = (20.0, 5.0, 4.0)
    m = _shipwreck(size, np.random.default_rng(0))
    lo, hi = m.bounds
    assert np.allclose(hi - lo, size, atol=1e-6)
    assert len(m.faces) > 1000


def test_relief_adds_a_smooth_field_of_the_requested_rms_and_keeps_other_draws():
    """relief = 0 reproduces the grid bit for bit; relief > 0 adds a field of that rms whose
    lag-1 m correlation is high (gentle undulation, 25 m correlation length)."""
    base = SeabedSpec(kind="flat", size_xy=(200.0, 200.0), resolution=1.0, seed=3)
    z0 = height_grid(base)[2]
    assert np.array_equal(z0, height_grid(SeabedSpec(**{**base.__dict__, "relief": 0.0}))[2])
    z1 = height_grid(SeabedSpec(**{**base.__dict__, "relief": 0.5}))[2]
    dz = z1 - z0
    assert abs(dz.std() - 0.5) < 0.02
    c = np.corrcoef(dz[:, 1:].ravel(), dz[:, :-1].ravel())[0, 1]
    assert c > 0.99
