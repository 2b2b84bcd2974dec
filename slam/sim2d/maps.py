"""The reference's simulated maps (thesis ch. 6) as :class:`ReferenceMap` objects.

* ``dense_loop_map()`` — Bailey's ``example_webmap`` (the thesis's dense loop map).
* ``line_map(rng)`` — 1000 m × 800 m (x 0..1000, y -400..400), 27 landmarks, 4 waypoints
  along y = 0; landmarks A–D at the thesis's positions, the other 23 generated evenly
  along the line (the thesis does not list them).
* ``segmentation_loop_map(rng)`` — the 17 dense-loop waypoints and 54 landmarks: the 8
  ship, branch and body centroids of thesis Table 6.3 plus 46 "background centroids"
  generated near the path (the thesis does not list them).

Generated parts draw from the ``numpy.random.Generator`` passed in; the defaults use a
fixed seed so that the experiments' maps are the same in every run.
"""

from __future__ import annotations

import numpy as np

from slam.data.reference_maps import ReferenceMap, load_reference_map

__all__ = [
    "DENSE_LOOP_LANDMARKS_AB",
    "LINE_LANDMARKS_ABCD",
    "SEGMENTATION_CENTROIDS",
    "dense_loop_map",
    "line_map",
    "segmentation_loop_map",
]

#: thesis §6.1.1: the two tabulated landmarks of the dense loop map (m)
DENSE_LOOP_LANDMARKS_AB = np.array([[-55.8863, -55.9190], [-92.9579, -77.7259]])
#: thesis §6.1.2: the four tabulated landmarks of the line map (m)
LINE_LANDMARKS_ABCD = np.array([[886.8, -19.04], [905.7, 10.68], [965.1, 16.08], [989.4, -19.04]])
#: thesis Table 6.3, true centroids (m): ship ×2, branch, body ×5
SEGMENTATION_CENTROIDS = {
    "ship": np.array([[53.5, 60.3], [54.23, 65.39]]),
    "branch": np.array([[18.73, -11.56]]),
    "body": np.array(
        [[-94.98, -66.29], [-96.69, -66.06], [-102.12, -61.57], [-102.41, -70.3], [-106.55, -81.13]]
    ),
}


def dense_loop_map() -> ReferenceMap:
    """Bailey's ``example_webmap``: 35 landmarks, 17 waypoints (landmarks A, B are the
    thesis's, see :data:`DENSE_LOOP_LANDMARKS_AB`)."""
    m = load_reference_map("example_webmap")
    return ReferenceMap("dense-loop", m.landmarks, m.waypoints)


def _near_path(
    path: np.ndarray, n: int, rng: np.random.Generator, offset=(4.0, 22.0), min_sep=4.0, avoid=None
) -> np.ndarray:
    """n points at a perpendicular offset U(offset) on either side of the polyline
    ``path`` (m, 2), at least ``min_sep`` apart from each other and from ``avoid``."""
    seg = np.diff(path, axis=0)
    seglen = np.hypot(seg[:, 0], seg[:, 1])
    cum = np.concatenate([[0.0], np.cumsum(seglen)])
    out = [] if avoid is None else [np.asarray(a, dtype=float) for a in np.asarray(avoid)]
    n0 = len(out)
    tries = 0
    while len(out) - n0 < n:
        tries += 1
        if tries > 100_000:
            raise ValueError(f"cannot place {n} landmarks {min_sep} m apart near the path")
        s = rng.uniform(0.0, cum[-1])
        i = min(int(np.searchsorted(cum, s, side="right")) - 1, seg.shape[0] - 1)
        t = (s - cum[i]) / seglen[i]
        p = path[i] + t * seg[i]
        normal = np.array([-seg[i, 1], seg[i, 0]]) / seglen[i]
        q = p + normal * rng.uniform(*offset) * rng.choice([-1.0, 1.0])
        if out and np.min(np.hypot(*(np.asarray(out) - q).T)) < min_sep:
            continue
        out.append(q)
    return np.asarray(out[n0:])


def line_map(rng: np.random.Generator | None = None) -> ReferenceMap:
    """The reference's line map: 4 waypoints along y = 0 up to x = 1000 m, 27 landmarks:
    A–D of the thesis and 23 generated ones evenly along x in 15..860 m (± 5 m jitter),
    alternating sides of the line at |y| in 5..20 m (the thesis shows a partial view only;
    even spacing keeps a landmark in view most of the way, as its figure suggests)."""
    rng = np.random.default_rng(20180601) if rng is None else rng
    wp = np.array([[250.0, 0.0], [500.0, 0.0], [750.0, 0.0], [1000.0, 0.0]])
    xs = np.linspace(15.0, 860.0, 23) + rng.uniform(-5.0, 5.0, 23)
    side = np.where(np.arange(23) % 2 == 0, 1.0, -1.0)
    others = np.stack([xs, side * rng.uniform(5.0, 20.0, 23)], axis=1)
    lm = np.concatenate([others, LINE_LANDMARKS_ABCD])
    return ReferenceMap("line", lm, wp)


def segmentation_loop_map(rng: np.random.Generator | None = None) -> ReferenceMap:
    """The reference's segmentation-landmark loop: dense-loop waypoints, the 8 centroids of
    Table 6.3 (listed first: ship, ship, branch, body ×5) and 46 background centroids."""
    rng = np.random.default_rng(20180602) if rng is None else rng
    wp = load_reference_map("example_webmap").waypoints
    fixed = np.concatenate(list(SEGMENTATION_CENTROIDS.values()))
    loop = np.concatenate([[[0.0, 0.0]], wp, wp[:1]])
    bg = _near_path(loop, 54 - fixed.shape[0], rng, min_sep=4.0, avoid=fixed)
    return ReferenceMap("segmentation-loop", np.concatenate([fixed, bg]), wp)
