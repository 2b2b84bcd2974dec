"""The fused map for a given association: the MAP of every map frame, vehicle pose and
world landmark given all maps, the frame priors and the GPS fixes (Gauss–Newton on the
whitened residuals, analytic Jacobians; covariance ``(JᵀJ)⁻¹``). The model is stated in
:mod:`slam.fleet.fusion`."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from slam.fleet.maps import FleetFusionConfig, FusedMap, GpsFix, VehicleMap, to_world
from slam.types import wrap_angle

__all__ = ["solve_fused"]


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


def _whiteners(maps, gps, jitter, weights=None):
    """Whitening matrices of the maps (scaled by ``sqrt(weights[k])``: covariance
    intersection), the frame priors and the fixes."""
    out = []
    w = np.ones(len(maps)) if weights is None else np.asarray(weights, float)
    for mp, wk in zip(maps, w, strict=True):
        P = mp.P + np.eye(mp.P.shape[0]) * jitter * max(1.0, float(np.trace(mp.P)) / mp.P.shape[0])
        try:
            L = np.linalg.cholesky(P)
        except np.linalg.LinAlgError as exc:
            raise ValueError(f"map {mp.name!r}: P is not positive definite") from exc
        out.append(math.sqrt(wk) * np.linalg.inv(L))
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
        e[2] = wrap_angle(V[2] - T[2])
        e[3:] = (pts[1:] @ Rt.T).reshape(-1)
        e -= mp.x
        e[2] = wrap_angle(e[2])
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
            e[2] = wrap_angle(e[2])
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


def _initial(maps, assignment, n_landmarks, lay: _Layout) -> np.ndarray:
    theta = np.zeros(lay.n)
    G = np.full((n_landmarks, 2), np.nan)
    for k, mp in enumerate(maps):
        T = mp.frame
        if lay.fcol[k] >= 0:
            theta[lay.fcol[k] : lay.fcol[k] + 3] = T
        theta[lay.pcol[k] : lay.pcol[k] + 2] = to_world(T, mp.x[None, :2])[0]
        theta[lay.pcol[k] + 2] = wrap_angle(T[2] + mp.x[2])
        a = assignment[k]
        fresh = np.isnan(G[a, 0])
        G[a[fresh]] = to_world(T, mp.x[3:].reshape(-1, 2)[fresh])
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
    weights: Sequence[float] | None = None,
) -> FusedMap:
    """The MAP fused map for a given association: ``assignment[k] (m_k,)`` the fused
    landmark index (0..M-1, every index used) of each landmark of map k. ``weights (K,)``:
    each map's information scaled by ``weights[k]`` in (0, 1] (covariance intersection
    when they sum to 1; default all 1: independent maps)."""
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
    if weights is not None:
        weights = np.asarray(weights, float).reshape(-1)
        if weights.shape != (len(maps),) or not np.all((weights > 0) & (weights <= 1)):
            raise ValueError(f"weights must be {len(maps)} numbers in (0, 1], got {weights!r}")
    W = _whiteners(maps, gps, cfg.jitter, weights)
    theta = _initial(maps, assignment, M, lay)
    for _ in range(cfg.iterations):  # Gauss–Newton; converges in a few steps
        r, J = _residuals(theta, maps, assignment, gps, lay, W)
        step = np.linalg.lstsq(J, -r, rcond=None)[0]
        theta += step
        theta[lay.angles] = wrap_angle(theta[lay.angles])
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
