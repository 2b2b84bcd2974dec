"""One map for a fleet: the vehicles' SLAM maps fused into one global stochastic map.

Every vehicle hands over its map as a Gaussian ``(x_k, P_k)``, ``x_k = [v, l_1, ..., l_m]``
(its pose and its landmarks, m, m, rad, m ...) in the vehicle's own map frame ``F_k``;
``F_k``'s pose ``T_k = [t_x, t_y, φ]`` in the fused (world) frame is either known (the map
was built from a surface GPS fix and heading alignment and its covariance already holds
that start uncertainty: ``frame_cov=None``) or estimated, from a prior ``(frame,
frame_cov)``. Maps of different vehicles are independent (own sensors, own start fix).

The fused map is the maximum a-posteriori estimate of ``θ = [T_k (variable frames), V_k
(every vehicle's pose, world frame), G_1, ..., G_M (world landmarks)]`` given every map as
a measurement of ``h_k(θ) = [T_k⁻¹ ⊕ V_k, T_k⁻¹ ⊕ G_{a_k(1)}, ...]`` (covariance P_k), the
frame priors, and GPS fixes of vehicles at the surface as absolute measurements of their
pose, ``V_k[:2] = z`` (a fix taken when the map was handed over, i.e. at the pose ``v``):
Gauss–Newton on the whitened residuals (analytic Jacobians, few tens of unknowns), the
covariance ``(JᵀJ)⁻¹`` at the solution. A landmark that several maps hold (``a_k(i) =
a_q(j)``) is one unknown, which is map joining's exact constraint ``x_i = x_j`` (Tardós et
al. 2002) for maps side by side instead of in a chain: ``slam.estimators.aekf_submap``
joins a sequence of local maps each based on the previous one's last pose; a fleet's maps
are parallel, each in its own frame, so the joint state is solved as one least-squares
problem in :mod:`slam.fleet.solve` (the same MAP; tested against scipy's least_squares).

Association between vehicles (:mod:`slam.fleet.association`): the maps are added in order;
each incoming map's landmarks are put into the world frame through its frame prior and
paired with the fused map so far by joint compatibility (JCBB); unpaired ones become new
landmarks, and the whole problem is re-solved.

Weak (stated): association needs a frame prior good enough that the individual gates
hold (no appearance or constellation matching for unknown frames); a GPS fix constrains
the pose at hand-over only (a mid-run fix belongs in the vehicle's own filter);
duplicates inside one vehicle's map are left as the vehicle made them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.optimize import minimize

from slam.fleet.association import pair_maps
from slam.fleet.maps import FleetFusionConfig, FusedMap, GpsFix, VehicleMap, to_world
from slam.fleet.solve import solve_fused

__all__ = ["fuse_maps"]


def _incoming(mp: VehicleMap) -> tuple[np.ndarray, np.ndarray]:
    """Map ``mp``'s landmarks in the world frame through its frame prior, with their joint
    covariance (map covariance rotated, plus the frame prior's through its Jacobian)."""
    m = mp.n_landmarks
    T = mp.frame
    c, s = math.cos(T[2]), math.sin(T[2])
    Rm = np.array([[c, -s], [s, c]])
    loc = mp.x[3:].reshape(m, 2)
    g = to_world(T, loc)
    B = np.kron(np.eye(m), Rm)
    C = B @ mp.P[3:, 3:] @ B.T
    if mp.frame_cov is not None:
        JT = np.zeros((2 * m, 3))
        JT[0::2, 0] = 1.0
        JT[1::2, 1] = 1.0
        d = g - T[:2]
        JT[0::2, 2] = -d[:, 1]
        JT[1::2, 2] = d[:, 0]
        C = C + JT @ mp.frame_cov @ JT.T
    return g, 0.5 * (C + C.T)


def fuse_maps(
    maps: Sequence[VehicleMap],
    gps: Sequence[GpsFix] = (),
    config: FleetFusionConfig | None = None,
) -> FusedMap:
    """Fuse the vehicles' maps into one (association between maps by joint compatibility,
    then the MAP of all maps, frame priors and GPS fixes; see the module docstring)."""
    cfg = config or FleetFusionConfig()
    maps = list(maps)
    if not maps:
        raise ValueError("maps must hold at least one VehicleMap")
    for f in gps:
        if not 0 <= f.vehicle < len(maps):
            raise ValueError(f"GpsFix.vehicle {f.vehicle} out of range 0..{len(maps) - 1}")
    assignment = [np.arange(maps[0].n_landmarks)]
    M = maps[0].n_landmarks
    n_paired = n_ambiguous = 0
    fused = solve_fused(maps[:1], assignment, [f for f in gps if f.vehicle == 0], cfg)
    for k in range(1, len(maps)):  # one association and one solve per vehicle (few)
        g, Cg = _incoming(maps[k])
        lc = fused.theta.size - 2 * M
        SG = fused.cov[lc:, lc:]
        pm = pair_maps(
            fused.landmarks, SG, g, Cg, confidence=cfg.confidence, max_nodes=cfg.max_nodes
        )
        a = pm.pairs.copy()
        new = a < 0
        a[new] = M + np.arange(int(new.sum()))
        M += int(new.sum())
        n_paired += int((~new).sum())
        n_ambiguous += int(pm.ambiguous.sum())
        assignment.append(a)
        fused = solve_fused(
            maps[: k + 1],
            assignment,
            [f for f in gps if f.vehicle <= k],
            cfg,
            n_paired=n_paired,
            n_ambiguous=n_ambiguous,
        )
    if cfg.cross_correlation == "unknown" and len(maps) > 1:
        fused = _intersect(maps, assignment, gps, cfg, n_paired, n_ambiguous)
    return fused


def _intersect(maps, assignment, gps, cfg, n_paired, n_ambiguous) -> FusedMap:
    """Covariance intersection of the maps that share a fused landmark with another map:
    their weights ``softmax(u)`` minimize the trace of the covariance of every fused
    position, landmarks and vehicles (Nelder–Mead over their number − 1, few); a map that shares nothing keeps weight 1
    (nothing of it is combined with another map)."""
    counts = np.bincount(np.concatenate(assignment), minlength=1)
    linked = np.array([bool(a.size) and bool((counts[a] > 1).any()) for a in assignment])
    if linked.sum() < 2:
        return solve_fused(maps, assignment, gps, cfg, n_paired=n_paired, n_ambiguous=n_ambiguous)

    def solve(u):
        e = np.exp(np.r_[0.0, u] - np.max(np.r_[0.0, u]))
        w = np.ones(len(maps))
        w[linked] = np.clip(e / e.sum(), 1e-6, 1.0)
        return solve_fused(
            maps, assignment, gps, cfg, n_paired=n_paired, n_ambiguous=n_ambiguous, weights=w
        )

    def cost(u):  # m²: every fused position, landmarks and vehicles
        f = solve(u)
        return float(
            np.trace(f.landmark_cov, axis1=1, axis2=2).sum()
            + np.trace(f.pose_cov[:, :2, :2], axis1=1, axis2=2).sum()
        )

    res = minimize(
        cost,
        np.zeros(int(linked.sum()) - 1),
        method="Nelder-Mead",
        options={"xatol": 1e-3, "fatol": 1e-9},
    )
    return solve(res.x)
