"""One Monte Carlo run of Bailey's simulator, generated vectorized.

The true path is deterministic (cached); a run draws the control noise of every step and
the observation noise of every scan from the ``numpy.random.Generator`` passed in, and
turns the noisy controls into odometry increments. Between two scans the per-step
increments are composed into one increment per scan with its first-order covariance
(exactly what the sequence of EKF predictions would give, see
:func:`slam.estimators.aekf.compose_odometry` and the tests), so an estimator is
predicted once per scan.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam.sim2d.vehicle import Sim2DConfig, TruePath, true_path
from slam.types import Odometry, RangeBearing

__all__ = [
    "Sim2DRun",
    "compose_increments",
    "range_bearing",
    "simulate_run",
    "step_odometry",
    "visible_mask",
]


def visible_mask(poses, landmarks, max_range: float) -> np.ndarray:
    """``(S, n)`` bool: landmark inside the forward half-disc of radius ``max_range`` of
    each pose (Bailey's ``get_visible_landmarks``: bounding box, ``d · heading > 0``,
    ``|d| < max_range``). ``poses (S, 3)``, ``landmarks (n, 2)``."""
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    lm = np.asarray(landmarks, dtype=float).reshape(-1, 2)
    dx = lm[None, :, 0] - poses[:, None, 0]
    dy = lm[None, :, 1] - poses[:, None, 1]
    c = np.cos(poses[:, 2])[:, None]
    s = np.sin(poses[:, 2])[:, None]
    return (
        (np.abs(dx) < max_range)
        & (np.abs(dy) < max_range)
        & (dx * c + dy * s > 0)
        & (dx**2 + dy**2 < max_range**2)
    )


def range_bearing(pose, landmarks) -> np.ndarray:
    """Exact ``[range m, bearing rad]`` (n, 2) of landmarks from one pose (3,); bearing
    counter-clockwise from the body x axis, wrapped to [-pi, pi)."""
    lm = np.asarray(landmarks, dtype=float).reshape(-1, 2)
    d = lm - np.asarray(pose, dtype=float)[:2]
    b = np.arctan2(d[:, 1], d[:, 0]) - pose[2]
    return np.stack([np.hypot(d[:, 0], d[:, 1]), np.mod(b + np.pi, 2 * np.pi) - np.pi], axis=1)


def step_odometry(V, G, cfg: Sim2DConfig) -> tuple[np.ndarray, np.ndarray]:
    """Body-frame increments ``(T, 3)`` and covariances ``(T, 3, 3)`` of bicycle steps
    with (noisy) speed ``V (T,)`` and steer ``G (T,)``: ``[V dt cos G, V dt sin G,
    V dt sin G / L]``, covariance ``J diag(σ_v², σ_G²) Jᵀ`` with ``J = ∂u/∂(V, G)``
    (Bailey's ``Gu Q Guᵀ`` expressed in the body frame)."""
    V = np.asarray(V, dtype=float)
    G = np.asarray(G, dtype=float)
    dt, L = cfg.dt_s, cfg.wheelbase_m
    c, s = np.cos(G), np.sin(G)
    u = np.stack([V * dt * c, V * dt * s, V * dt * s / L], axis=-1)
    J = np.empty((*V.shape, 3, 2))
    J[..., 0, 0] = dt * c
    J[..., 0, 1] = -V * dt * s
    J[..., 1, 0] = dt * s
    J[..., 1, 1] = V * dt * c
    J[..., 2, 0] = dt * s / L
    J[..., 2, 1] = V * dt * c / L
    sv2, sg2 = cfg.sigma_v_mps**2, cfg.sigma_steer_rad**2
    Q = (
        sv2 * J[..., :, 0, None] * J[..., None, :, 0]
        + sg2 * J[..., :, 1, None] * J[..., None, :, 1]
    )
    return u, Q


def compose_increments(u, Q, starts) -> tuple[np.ndarray, np.ndarray]:
    """Compose consecutive increments ``u (T, 3)``, ``Q (T, 3, 3)`` over the segments that
    begin at ``starts`` (sorted, ``starts[0] == 0``), vectorized over all steps.

    Within a segment with relative heading ``θ_k`` before step k and position ``p_k``
    after it, the composed increment is ``[p_N, Σ dphi]`` and its covariance
    ``Σ_k M_k Q_k M_kᵀ`` with ``M_k = (I + E(p_N - p_k)) blockdiag(Rot(θ_k), 1)`` — the
    linearized error recursion ``e_k = F_k e_{k-1} + G_k ε_k`` unrolled, identical to
    composing pairwise with :func:`slam.estimators.aekf.compose_odometry`.
    """
    u = np.asarray(u, dtype=float)
    Q = np.asarray(Q, dtype=float)
    starts = np.asarray(starts, dtype=np.intp)
    T = u.shape[0]
    seg = np.zeros(T, dtype=np.intp)
    seg[starts[1:]] = 1
    seg = np.cumsum(seg)
    # heading before each step, relative to its segment start
    cum_phi = np.cumsum(u[:, 2])
    phi_before = cum_phi - u[:, 2]
    theta = phi_before - phi_before[starts][seg]
    c, s = np.cos(theta), np.sin(theta)
    dxy = np.stack([c * u[:, 0] - s * u[:, 1], s * u[:, 0] + c * u[:, 1]], axis=1)
    cum_xy = np.cumsum(dxy, axis=0)
    base = (cum_xy - dxy)[starts]  # cumulative sum before each segment
    p_after = cum_xy - base[seg]  # position after step k in segment frame
    ends = np.append(starts[1:], T) - 1
    pN = p_after[ends]  # (S, 2)
    dphi = cum_phi[ends] - phi_before[starts]
    d = pN[seg] - p_after  # (T, 2)
    M = np.zeros((T, 3, 3))
    M[:, 0, 0] = c
    M[:, 0, 1] = -s
    M[:, 1, 0] = s
    M[:, 1, 1] = c
    M[:, 0, 2] = -d[:, 1]
    M[:, 1, 2] = d[:, 0]
    M[:, 2, 2] = 1.0
    MQM = M @ Q @ np.swapaxes(M, 1, 2)
    Qs = np.add.reduceat(MQM, starts, axis=0)
    Qs = 0.5 * (Qs + np.swapaxes(Qs, 1, 2))
    us = np.concatenate([pN, (np.mod(dphi + np.pi, 2 * np.pi) - np.pi)[:, None]], axis=1)
    return us, Qs


@dataclass(frozen=True)
class Sim2DRun:
    """One simulated run, per scan i = 0..S-1.

    true_poses (S, 3) : true pose at each scan; path (T+1, 3): the full true path.
    odom_u (S, 3), odom_Q (S, 3, 3) : odometry increment from the previous scan (or the
        start) to scan i, body frame, composed from the noisy control steps.
    obs_z (K, 2), obs_label (K,), obs_offsets (S+1,) : observations of scan i are rows
        ``obs_offsets[i]:obs_offsets[i+1]``; label = 0-based landmark column in the map
        (known-answer data association).
    R (2, 2) : observation covariance. landmarks (n, 2): the true map.
    step_u (T, 3), step_Q (T, 3, 3) : per-control-step odometry (for checks).
    scan_steps (S,) : control step index of each scan.
    """

    true_poses: np.ndarray
    path: np.ndarray
    odom_u: np.ndarray
    odom_Q: np.ndarray
    obs_z: np.ndarray
    obs_label: np.ndarray
    obs_offsets: np.ndarray
    R: np.ndarray
    landmarks: np.ndarray
    step_u: np.ndarray
    step_Q: np.ndarray
    scan_steps: np.ndarray
    dt_s: float

    @property
    def n_scans(self) -> int:
        return self.odom_u.shape[0]

    def odometry(self, i: int) -> Odometry:
        return Odometry(
            self.odom_u[i], self.odom_Q[i], t=float((self.scan_steps[i] + 1) * self.dt_s)
        )

    def scan(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """``(z (k, 2), labels (k,))`` of scan i."""
        a, b = self.obs_offsets[i], self.obs_offsets[i + 1]
        return self.obs_z[a:b], self.obs_label[a:b]

    def observations(self, i: int) -> list[RangeBearing]:
        z, lab = self.scan(i)
        t = float((self.scan_steps[i] + 1) * self.dt_s)
        return [RangeBearing(zz, self.R, t=t, label=int(ll)) for zz, ll in zip(z, lab)]


def simulate_run(
    landmarks,
    waypoints,
    cfg: Sim2DConfig,
    rng: np.random.Generator,
    *,
    control_noise: bool = True,
    sensor_noise: bool = True,
) -> Sim2DRun:
    """Generate one run: noisy odometry and observations along the true path.

    Every random draw comes from ``rng``. Observations whose noisy range is <= 0 (only
    possible for a landmark closer than a few σ_r) are dropped.
    """
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    lm = np.asarray(landmarks, dtype=float)
    if lm.ndim != 2 or lm.shape[1] != 2 or not np.all(np.isfinite(lm)):
        raise ValueError(f"landmarks must be finite with shape (n, 2), got {lm.shape}")
    tp: TruePath = true_path(waypoints, cfg)
    T = tp.n_steps
    noise = rng.standard_normal((T, 2)) if control_noise else np.zeros((T, 2))
    Vn = cfg.speed_mps + cfg.sigma_v_mps * noise[:, 0]
    Gn = tp.steer + cfg.sigma_steer_rad * noise[:, 1]
    step_u, step_Q = step_odometry(Vn, Gn, cfg)
    if cfg.unbiased_odometry:
        f = np.exp(0.5 * cfg.sigma_steer_rad**2)
        step_u *= f
        step_Q *= f * f
    scans = tp.scan_steps
    starts = np.concatenate([[0], scans[:-1] + 1])
    used = scans[-1] + 1 if scans.size else 0
    if scans.size:
        odom_u, odom_Q = compose_increments(step_u[:used], step_Q[:used], starts)
    else:
        odom_u, odom_Q = np.zeros((0, 3)), np.zeros((0, 3, 3))
    poses = tp.poses[scans + 1]
    vis = visible_mask(poses, lm, cfg.max_range_m)
    si, li = np.nonzero(vis)  # row-major: grouped by scan, landmark order within a scan
    d = lm[li] - poses[si, :2]
    z = np.empty((si.size, 2))
    z[:, 0] = np.hypot(d[:, 0], d[:, 1])
    z[:, 1] = np.arctan2(d[:, 1], d[:, 0]) - poses[si, 2]
    if sensor_noise:
        e = rng.standard_normal((si.size, 2))
        z[:, 0] += cfg.sigma_r_m * e[:, 0]
        z[:, 1] += cfg.sigma_b_rad * e[:, 1]
    z[:, 1] = np.mod(z[:, 1] + np.pi, 2 * np.pi) - np.pi
    ok = z[:, 0] > 0.0
    z, si, li = z[ok], si[ok], li[ok]
    offsets = np.searchsorted(si, np.arange(scans.size + 1))
    return Sim2DRun(
        true_poses=poses,
        path=tp.poses,
        odom_u=odom_u,
        odom_Q=odom_Q,
        obs_z=z,
        obs_label=li.astype(np.int64),
        obs_offsets=offsets,
        R=cfg.R,
        landmarks=lm,
        step_u=step_u,
        step_Q=step_Q,
        scan_steps=scans,
        dt_s=cfg.dt_s,
    )
