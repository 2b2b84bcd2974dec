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
are parallel, each in its own frame, so the joint state is solved here as one least-squares
problem (the same MAP; tested against scipy's least_squares).

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
from dataclasses import dataclass, field

import numpy as np

from slam.estimators.aekf import AEKFSlam
from slam.fleet.association import pair_maps

__all__ = [
    "FleetFusionConfig",
    "FusedMap",
    "GpsFix",
    "VehicleMap",
    "fuse_maps",
    "solve_fused",
    "vehicle_map_from",
]


def _wrap(a):
    return (np.asarray(a, float) + math.pi) % (2 * math.pi) - math.pi


def _check_cov(name: str, C: np.ndarray, n: int) -> np.ndarray:
    C = np.asarray(C, dtype=float)
    if C.shape != (n, n):
        raise ValueError(f"{name} must have shape ({n}, {n}), got {C.shape}")
    if not np.all(np.isfinite(C)):
        raise ValueError(f"{name} must be finite (got nan or inf)")
    if np.abs(C - C.T).max() > 1e-9 * max(1.0, float(np.abs(C).max())):
        raise ValueError(f"{name} must be symmetric")
    if n and np.linalg.eigvalsh(0.5 * (C + C.T)).min() < -1e-9 * max(1.0, float(np.abs(C).max())):
        raise ValueError(f"{name} must be positive semi-definite")
    return 0.5 * (C + C.T)


@dataclass(frozen=True)
class VehicleMap:
    """One vehicle's map. ``x (3 + 2m,)`` ``[x_v m, y_v m, φ_v rad, x_1, y_1, ...]`` in the
    map frame, ``P`` its covariance; ``frame (3,)`` the map frame's pose in the world frame
    (default the world frame itself), ``frame_cov (3, 3)`` its prior covariance or None
    (known: the map's covariance already holds the start uncertainty)."""

    x: np.ndarray
    P: np.ndarray
    name: str = ""
    frame: np.ndarray = field(default=None)  # type: ignore[assignment]
    frame_cov: np.ndarray | None = None

    def __post_init__(self) -> None:
        x = np.asarray(self.x, dtype=float).reshape(-1)
        who = f"VehicleMap {self.name!r}" if self.name else "VehicleMap"
        if x.size < 3 or (x.size - 3) % 2:
            raise ValueError(f"{who}.x must have shape (3 + 2m,), got {x.shape}")
        if not np.all(np.isfinite(x)):
            raise ValueError(f"{who}.x must be finite (got nan or inf)")
        object.__setattr__(self, "x", x)
        object.__setattr__(self, "P", _check_cov(f"{who}.P", self.P, x.size))
        f = np.zeros(3) if self.frame is None else np.asarray(self.frame, float).reshape(-1)
        if f.shape != (3,) or not np.all(np.isfinite(f)):
            raise ValueError(f"{who}.frame must be finite [x, y, phi], got {self.frame!r}")
        object.__setattr__(self, "frame", f)
        if self.frame_cov is not None:
            C = _check_cov(f"{who}.frame_cov", self.frame_cov, 3)
            if np.linalg.eigvalsh(C).min() <= 0.0:
                raise ValueError(f"{who}.frame_cov must be positive definite (or None: known)")
            object.__setattr__(self, "frame_cov", C)

    @property
    def n_landmarks(self) -> int:
        return (self.x.size - 3) // 2


@dataclass(frozen=True)
class GpsFix:
    """A GPS fix of vehicle ``vehicle`` (index into the maps) at its map's pose:
    ``xy (2,)`` world m, ``cov (2, 2)`` m²."""

    vehicle: int
    xy: np.ndarray
    cov: np.ndarray

    def __post_init__(self) -> None:
        xy = np.asarray(self.xy, float).reshape(-1)
        if xy.shape != (2,) or not np.all(np.isfinite(xy)):
            raise ValueError(f"GpsFix.xy must be finite (2,), got {self.xy!r}")
        C = _check_cov("GpsFix.cov", self.cov, 2)
        if np.linalg.eigvalsh(C).min() <= 0.0:
            raise ValueError("GpsFix.cov must be positive definite")
        object.__setattr__(self, "xy", xy)
        object.__setattr__(self, "cov", C)


@dataclass(frozen=True)
class FleetFusionConfig:
    """``confidence``: χ² quantile of the joint-compatibility test between maps;
    ``max_nodes``: JCBB search budget; ``iterations``/``tolerance``: Gauss–Newton (stop when
    the largest step is below ``tolerance``, m or rad); ``jitter``: relative diagonal added
    to each map covariance before whitening (a filter's P can be singular to rounding)."""

    confidence: float = 0.99
    max_nodes: int = 20000
    iterations: int = 50
    tolerance: float = 1e-10
    jitter: float = 1e-10

    def __post_init__(self) -> None:
        if not 0.0 < self.confidence < 1.0:
            raise ValueError(f"confidence must be in (0, 1), got {self.confidence!r}")
        if not (isinstance(self.iterations, int) and self.iterations >= 1):
            raise ValueError(f"iterations must be an integer >= 1, got {self.iterations!r}")
        for n in ("tolerance", "jitter"):
            if not (math.isfinite(getattr(self, n)) and getattr(self, n) >= 0.0):
                raise ValueError(f"{n} must be a finite number >= 0, got {getattr(self, n)!r}")


@dataclass(frozen=True)
class FusedMap:
    """The fleet's map, world frame. ``landmarks (M, 2)`` m and marginal covariances
    ``(M, 2, 2)``; ``frames (K, 3)``/``frame_cov`` the map frames (known ones with zero
    covariance); ``poses (K, 3)``/``pose_cov`` each vehicle's pose at hand-over;
    ``assignment[k] (m_k,)`` the fused landmark of each landmark of map k; ``theta``/``cov``
    the full solution; ``n_paired`` landmarks fused across maps, ``n_ambiguous`` left
    apart as ambiguous; ``chi2``/``dof`` the weighted residual (≈ dof if maps are consistent)."""

    landmarks: np.ndarray
    landmark_cov: np.ndarray
    frames: np.ndarray
    frame_cov: np.ndarray
    poses: np.ndarray
    pose_cov: np.ndarray
    assignment: tuple[np.ndarray, ...]
    theta: np.ndarray
    cov: np.ndarray
    n_paired: int
    n_ambiguous: int
    chi2: float
    dof: int

    @property
    def n_landmarks(self) -> int:
        return len(self.landmarks)


class _Layout:
    """Columns of θ: variable frames, then the K poses, then the M landmarks."""

    def __init__(self, maps: Sequence[VehicleMap], n_landmarks: int):
        var = [mp.frame_cov is not None for mp in maps]
        self.fcol = np.full(len(maps), -1)
        self.fcol[np.nonzero(var)[0]] = 3 * np.arange(sum(var))
        self.pcol = 3 * sum(var) + 3 * np.arange(len(maps))
        self.lcol = 3 * sum(var) + 3 * len(maps)
        self.n = self.lcol + 2 * n_landmarks
        self.angles = np.concatenate([self.fcol[self.fcol >= 0] + 2, self.pcol + 2])

    def frame(self, theta, maps, k) -> np.ndarray:
        return theta[self.fcol[k] : self.fcol[k] + 3] if self.fcol[k] >= 0 else maps[k].frame


def _whiteners(maps, gps, jitter):
    out = []
    for mp in maps:
        P = mp.P + np.eye(mp.P.shape[0]) * jitter * max(1.0, float(np.trace(mp.P)) / mp.P.shape[0])
        try:
            L = np.linalg.cholesky(P)
        except np.linalg.LinAlgError as exc:
            raise ValueError(f"map {mp.name!r}: P is not positive definite") from exc
        out.append(np.linalg.inv(L))
    priors = [
        None if mp.frame_cov is None else np.linalg.inv(np.linalg.cholesky(mp.frame_cov))
        for mp in maps
    ]
    fixes = [np.linalg.inv(np.linalg.cholesky(f.cov)) for f in gps]
    return out, priors, fixes


def _residuals(theta, maps, assignment, gps, lay: _Layout, W):
    """Whitened residuals ``r`` and Jacobian ``J`` (rows: maps, frame priors, fixes)."""
    Wm, Wp, Wg = W
    blocks_r, blocks_J = [], []
    G = theta[lay.lcol :].reshape(-1, 2)
    for k, mp in enumerate(maps):  # one block per vehicle (few)
        T = lay.frame(theta, maps, k)
        c, s = math.cos(T[2]), math.sin(T[2])
        Rt = np.array([[c, s], [-s, c]])
        dRt = np.array([[-s, c], [-c, -s]])
        a = assignment[k]
        V = theta[lay.pcol[k] : lay.pcol[k] + 3]
        pts = np.vstack([V[:2], G[a]]) - T[:2]  # (1 + m, 2) world offsets from the frame
        e = np.empty(mp.x.size)
        e[:2] = Rt @ pts[0]
        e[2] = _wrap(V[2] - T[2])
        e[3:] = (pts[1:] @ Rt.T).reshape(-1)
        e -= mp.x
        e[2] = _wrap(e[2])
        H = np.zeros((mp.x.size, lay.n))
        pc = lay.pcol[k]
        H[:2, pc : pc + 2] = Rt
        H[2, pc + 2] = 1.0
        rows = 3 + 2 * np.arange(a.size)
        cols = lay.lcol + 2 * a
        for r_, c_ in ((0, 0), (0, 1), (1, 0), (1, 1)):
            H[rows + r_, cols + c_] = Rt[r_, c_]
        if lay.fcol[k] >= 0:
            fc = lay.fcol[k]
            H[:, fc : fc + 2] = np.vstack([-Rt, [0.0, 0.0], np.tile(-Rt, (a.size, 1))])
            dphi = pts @ dRt.T  # (1 + m, 2)
            H[:2, fc + 2] = dphi[0]
            H[2, fc + 2] = -1.0
            H[3:, fc + 2] = dphi[1:].reshape(-1)
        blocks_r.append(Wm[k] @ e)
        blocks_J.append(Wm[k] @ H)
        if Wp[k] is not None:
            fc = lay.fcol[k]
            e = T - mp.frame
            e[2] = _wrap(e[2])
            H = np.zeros((3, lay.n))
            H[:, fc : fc + 3] = np.eye(3)
            blocks_r.append(Wp[k] @ e)
            blocks_J.append(Wp[k] @ H)
    for f, Wf in zip(gps, Wg, strict=True):
        pc = lay.pcol[f.vehicle]
        H = np.zeros((2, lay.n))
        H[:, pc : pc + 2] = np.eye(2)
        blocks_r.append(Wf @ (theta[pc : pc + 2] - f.xy))
        blocks_J.append(Wf @ H)
    return np.concatenate(blocks_r), np.vstack(blocks_J)


def _compose(T, p):
    """World points ``T ⊕ p`` for local points ``p (n, 2)``."""
    c, s = math.cos(T[2]), math.sin(T[2])
    return p @ np.array([[c, s], [-s, c]]) + T[:2]


def _initial(maps, assignment, n_landmarks, lay: _Layout) -> np.ndarray:
    theta = np.zeros(lay.n)
    G = np.full((n_landmarks, 2), np.nan)
    for k, mp in enumerate(maps):
        T = mp.frame
        if lay.fcol[k] >= 0:
            theta[lay.fcol[k] : lay.fcol[k] + 3] = T
        theta[lay.pcol[k] : lay.pcol[k] + 2] = _compose(T, mp.x[None, :2])[0]
        theta[lay.pcol[k] + 2] = _wrap(T[2] + mp.x[2])
        a = assignment[k]
        fresh = np.isnan(G[a, 0])
        G[a[fresh]] = _compose(T, mp.x[3:].reshape(-1, 2)[fresh])
    theta[lay.lcol :] = G.reshape(-1)
    return theta


def solve_fused(
    maps: Sequence[VehicleMap],
    assignment: Sequence[np.ndarray],
    gps: Sequence[GpsFix] = (),
    config: FleetFusionConfig | None = None,
    *,
    n_paired: int = 0,
    n_ambiguous: int = 0,
) -> FusedMap:
    """The MAP fused map for a given association: ``assignment[k] (m_k,)`` the fused
    landmark index (0..M-1, every index used) of each landmark of map k."""
    cfg = config or FleetFusionConfig()
    maps = list(maps)
    if not maps:
        raise ValueError("maps must hold at least one VehicleMap")
    assignment = [np.asarray(a, dtype=np.intp).reshape(-1) for a in assignment]
    if len(assignment) != len(maps):
        raise ValueError(
            f"assignment must have one array per map ({len(maps)}), got {len(assignment)}"
        )
    for k, (a, mp) in enumerate(zip(assignment, maps, strict=True)):
        if a.size != mp.n_landmarks or (a.size and a.min() < 0):
            raise ValueError(f"assignment[{k}] must hold {mp.n_landmarks} indices >= 0")
        if np.unique(a).size != a.size:
            raise ValueError(
                f"assignment[{k}] pairs two landmarks of map {k} with one fused landmark"
            )
    M = int(max((a.max() + 1 for a in assignment if a.size), default=0))
    if M and np.setdiff1d(np.arange(M), np.concatenate(assignment)).size:
        raise ValueError("assignment must use every fused landmark index 0..M-1")
    for f in gps:
        if not 0 <= f.vehicle < len(maps):
            raise ValueError(f"GpsFix.vehicle {f.vehicle} out of range 0..{len(maps) - 1}")
    lay = _Layout(maps, M)
    W = _whiteners(maps, gps, cfg.jitter)
    theta = _initial(maps, assignment, M, lay)
    for _ in range(cfg.iterations):  # Gauss–Newton; converges in a few steps
        r, J = _residuals(theta, maps, assignment, gps, lay, W)
        step = np.linalg.lstsq(J, -r, rcond=None)[0]
        theta += step
        theta[lay.angles] = _wrap(theta[lay.angles])
        if float(np.abs(step).max()) < cfg.tolerance:
            break
    r, J = _residuals(theta, maps, assignment, gps, lay, W)
    Hs = J.T @ J
    if np.linalg.matrix_rank(Hs) < lay.n:
        raise ValueError(
            "the fused map is not determined: give every estimated frame a prior "
            "(frame_cov) or keep at least one frame known"
        )
    cov = np.linalg.inv(Hs)
    cov = 0.5 * (cov + cov.T)
    return _result(theta, cov, r, maps, assignment, lay, M, n_paired, n_ambiguous)


def _result(theta, cov, r, maps, assignment, lay, M, n_paired, n_ambiguous) -> FusedMap:
    K = len(maps)
    ar = np.arange(M)
    Lc = cov[lay.lcol :, lay.lcol :].reshape(M, 2, M, 2)[ar, :, ar, :] if M else np.zeros((0, 2, 2))
    frames = np.array([lay.frame(theta, maps, k) for k in range(K)])
    fcov = np.zeros((K, 3, 3))
    pcov = np.zeros((K, 3, 3))
    for k in range(K):  # per vehicle (few)
        if lay.fcol[k] >= 0:
            sl = slice(lay.fcol[k], lay.fcol[k] + 3)
            fcov[k] = cov[sl, sl]
        sl = slice(lay.pcol[k], lay.pcol[k] + 3)
        pcov[k] = cov[sl, sl]
    return FusedMap(
        landmarks=theta[lay.lcol :].reshape(-1, 2).copy(),
        landmark_cov=Lc.copy(),
        frames=frames,
        frame_cov=fcov,
        poses=np.array([theta[p : p + 3] for p in lay.pcol]),
        pose_cov=pcov,
        assignment=tuple(assignment),
        theta=theta,
        cov=cov,
        n_paired=n_paired,
        n_ambiguous=n_ambiguous,
        chi2=float(r @ r),
        dof=int(r.size - lay.n),
    )


def _incoming(mp: VehicleMap) -> tuple[np.ndarray, np.ndarray]:
    """Map ``mp``'s landmarks in the world frame through its frame prior, with their joint
    covariance (map covariance rotated, plus the frame prior's through its Jacobian)."""
    m = mp.n_landmarks
    T = mp.frame
    c, s = math.cos(T[2]), math.sin(T[2])
    Rm = np.array([[c, -s], [s, c]])
    loc = mp.x[3:].reshape(m, 2)
    g = _compose(T, loc)
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
    return fused


def vehicle_map_from(estimator, name: str = "") -> tuple[VehicleMap, bool]:
    """A vehicle's map in the world frame from its estimator, and whether its covariance is
    the joint one: the AEKF's full ``(x, P)``, the sub-map AEKF's joined global map; for
    other estimators (FastSLAM, iSAM2, robocentric) the pose and landmark marginals
    side by side, their cross-correlations unknown (``False``: an approximation)."""
    if callable(getattr(estimator, "join", None)):
        gm = estimator.join()
        return VehicleMap(gm.x, 0.5 * (gm.P + gm.P.T), name), True
    if isinstance(estimator, AEKFSlam):
        x, P = estimator.state()
        return VehicleMap(x, 0.5 * (P + P.T), name), True
    xv, Pv = estimator.pose()
    means, covs = estimator.landmarks()
    m = len(means)
    P = np.zeros((3 + 2 * m, 3 + 2 * m))
    P[:3, :3] = Pv
    for i in range(m):  # block diagonal (few landmarks)
        P[3 + 2 * i : 5 + 2 * i, 3 + 2 * i : 5 + 2 * i] = covs[i]
    x = np.r_[np.asarray(xv, float)[:3], np.asarray(means, float).reshape(-1)]
    return VehicleMap(x, 0.5 * (P + P.T), name), False
