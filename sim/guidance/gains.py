"""Controller gains derived from a vehicle's rigid-body + added mass, damping, restoring
stiffness and actuator authority.

Per degree of freedom the plant is  M ν̇ = τ − (d_l + d_q |ν|) ν − k x  (Fossen 2011,
diagonal model), with M = m_RB + m_A. The design rules (Fossen 2011 §12.2.2 pole placement
for a mass–damper–spring plant; Åström & Murray §11.3 for the PI):

* speed (surge, first order): PI with pole–zero cancellation, kp = M ω_u,
  ki = kp d / M with d = d_l + 2 d_q U the damping linearised at the cruise speed U; the
  closed loop is then first order with time constant 1/ω_u. ω_u = clip(2 d / M, 0.1, 1)
  (twice the open-loop bandwidth). Feedforward X_ff = d_l u_d + d_q u_d|u_d|.
* heading, depth (heave), pitch, roll (second order): PID with kp = M ω_n² − k,
  kd = 2 sqrt(kp M) − d (= 2 ζ ω_n M − d, ζ = 1, when k >= 0; for a destabilising
  Munk stiffness k < 0 it is critically damped at sqrt(kp/M), the frequency the loop
  has when the sway/heave loops suppress the sideslip the Munk moment needs),
  ki = kp ω_n / 10. ω_n is set by actuator authority:
  ω_n = sqrt(τ_max / (M e_sat)) — the P term alone just saturates the actuator at an
  error e_sat (0.5 rad heading, 2 m depth, 0.3 rad pitch/roll) — clipped to
  [0.1, 1.0] rad/s (the thrusters' ~0.2 s lag bounds the loop bandwidth).
* depth of a vehicle without heave authority (torpedo): outer loop depth → pitch
  demand θ_d = clip(kp_z e + ki_z ∫e, ±θ_max), kp_z = 1/Δ_z rad/m with the vertical
  lookahead Δ_z = 2 L, ki_z = kp_z (U/Δ_z)/10 (trims out residual buoyancy).
* LOS lookahead Δ = clip(3 L, 3, 10) m (Fossen recommends 1.5–2.5 L for ships; a little
  more for slow, under-actuated AUVs), at least the steady turn radius at cruise speed
  (a shorter lookahead demands turns the vehicle cannot fly), cruise speed = min(nominal, U_T) with the steady
  drag d_l U_T + d_q U_T² = 0.8 X_max (``THRUST_RESERVE``: 20 % of the surge authority
  left for acceleration and current changes), and, for vehicles without fins, low
  enough that the net destabilising moment at a 0.3 rad heading/pitch error takes at
  most half the yaw/pitch authority: (A22 − A11) U² · 0.3 in yaw, and in pitch the Munk
  moment less the hydrostatic righting moment, ((A33 − A11) U² − ρ g V BG) · 0.3 (both
  act on the same angle). A box hull has no fins to stabilise it, so above that speed
  the heading/pitch loop saturates and limit-cycles.
* Munk moment as a negative stiffness (Fossen 2011 §6.4): k_yaw = −(A22 − A11) U²,
  k_pitch = ρ g V BG − (A33 − A11) U²; fins add their passive lift as a positive
  stiffness ½ρ S C_Lα |x_f| U² (``fin_stiffness``); the P gain beats the rest
  (kp = M ω² − k).

τ_max per DOF is what the vehicle's thrust allocation (least squares over its controlled
DOFs, as sim.thrusters.ThrusterBank.allocate) delivers for a pure demand in that DOF
before any channel saturates, fins evaluated at the cruise speed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim.guidance.pid import PIDGains

__all__ = [
    "NOMINAL_SPEED",
    "AutopilotGains",
    "VehiclePlant",
    "design_gains",
    "fin_damping",
    "fin_stiffness",
    "max_wrench",
    "max_wrench_from_columns",
    "split_authority",
]

DOF = ("X", "Y", "Z", "K", "M", "N")
GRAVITY = 9.80665

#: nominal survey speed per vehicle kind, m/s (capped by thrust in design_gains); sources
#: in each vehicle's README (assets/vehicles/<kind>/README.md, "Nominal speed")
NOMINAL_SPEED = {"alister9": 1.5, "ixn": 1.0, "naiad": 0.6, "saga": 0.5, "rexrov": 0.5}
#: share of the surge authority the steady drag at cruise speed may take
THRUST_RESERVE = 0.8


@dataclass(frozen=True)
class VehiclePlant:
    """Diagonal plant of one vehicle, body frame (x fwd, y port, z up).

    kind; length m; inertia (6,) M_RB + M_A; linear_damping, quadratic_damping (6,);
    stiffness (6,) restoring, N·m/rad (roll: ρ g V BG; pitch: that minus the Munk term
    (A33 − A11) U²; yaw: −(A22 − A11) U²; negative = destabilising); net_buoyancy B − W, N;
    max_effort (6,) N / N·m (inf = unknown); controlled (6,) bool; cruise_speed m/s;
    finned: steered by control surfaces whose authority needs speed (torpedo, IXN).
    """

    kind: str
    length: float
    inertia: np.ndarray
    linear_damping: np.ndarray
    quadratic_damping: np.ndarray
    stiffness: np.ndarray
    net_buoyancy: float
    max_effort: np.ndarray
    controlled: np.ndarray
    cruise_speed: float
    finned: bool = False

    @classmethod
    def from_hydro(
        cls,
        kind: str,
        length: float,
        hydro,
        max_effort,
        controlled,
        rho: float = 1025.0,
        cruise_speed: float | None = None,
        finned: bool = False,
        fin_stiffness=None,
        fin_damping=None,
    ) -> VehiclePlant:
        """From a ``sim.hydrodynamics.HydroParams`` (mass, inertia (3,), volume, r_cb,
        added_mass, linear_damping, quadratic_damping). fin_stiffness (6,): restoring
        moment of the fins' passive lift per rad and per (m/s)² (see ``fin_stiffness``);
        fin_damping (6,): their damping per m/s of surge speed (``fin_damping``), added to
        the linear damping at the cruise speed."""
        m_rb = np.concatenate([[hydro.mass] * 3, np.asarray(hydro.inertia, float)])
        am = np.asarray(hydro.added_mass, float)
        B = rho * GRAVITY * hydro.volume
        bg = float(hydro.r_cb[2])
        max_effort = np.asarray(max_effort, float)
        controlled = np.asarray(controlled, bool)
        dl = np.asarray(hydro.linear_damping, float)
        dq = np.asarray(hydro.quadratic_damping, float)
        u_thrust = _max_speed(dl[0], dq[0], THRUST_RESERVE * max_effort[0])
        u = NOMINAL_SPEED.get(kind, 1.0) if cruise_speed is None else cruise_speed
        u = float(min(u, u_thrust))
        righting = max(0.0, B * bg)
        if not finned:
            # the net destabilising moment at a 0.3 rad heading/pitch error, Munk
            # (A_jj - A_11) U² less the hydrostatic righting B·BG (pitch), may take at most
            # half the yaw/pitch authority (propeller-driven authority does not grow with
            # speed; fin authority does, so a finned vehicle is exempt)
            for dof, a_side, k0 in ((5, am[1], 0.0), (4, am[2], righting)):
                munk = a_side - am[0]
                if munk > 0 and controlled[dof] and math.isfinite(max_effort[dof]):
                    u = min(u, math.sqrt((0.5 * max_effort[dof] / 0.3 + k0) / munk))
        # restoring stiffness: hydrostatic B·BG in roll and pitch, minus the Munk moment
        # (A_33 - A_11) U² θ in pitch and (A_22 - A_11) U² ψ in yaw (Fossen 2011 §6.4),
        # linearised at the cruise speed — destabilising for bodies that are longer than
        # they are high/wide, and it must be beaten by the P gain.
        k = np.zeros(6)
        k[3] = righting
        k[4] = righting - (am[2] - am[0]) * u * u
        k[5] = -(am[1] - am[0]) * u * u
        if fin_stiffness is not None:
            # fins restore the angle of attack. In pitch a hovering vehicle flies level
            # (angle of attack ≈ pitch), so it counts; in yaw it acts on the sideslip, not
            # on the heading error (a turn rotates the velocity with the hull), so it may
            # only cancel the Munk term, never stiffen the heading loop.
            kf = np.asarray(fin_stiffness, float) * u * u
            k[4] += kf[4]
            k[5] = min(0.0, k[5] + kf[5])
        if fin_damping is not None:
            dl = dl + np.asarray(fin_damping, float) * u
        return cls(
            kind=kind,
            length=float(length),
            inertia=m_rb + am,
            linear_damping=dl,
            quadratic_damping=dq,
            stiffness=k,
            net_buoyancy=B - hydro.mass * GRAVITY,
            max_effort=max_effort,
            controlled=np.asarray(controlled, bool),
            cruise_speed=u,
            finned=bool(finned),
        )


def _max_speed(dl: float, dq: float, x_max: float) -> float:
    if not math.isfinite(x_max):
        return math.inf
    if dq <= 0:
        return x_max / dl if dl > 0 else math.inf
    return (-dl + math.sqrt(dl * dl + 4 * dq * x_max)) / (2 * dq)


def fin_stiffness(columns, is_fin, lift_gain) -> np.ndarray:
    """(6,) restoring moment per rad of incidence and per (m/s)² of the fins' passive lift.

    A fin channel with column c = [d; r × d] and lift gain g = ½ρ S C_Lα produces the
    wrench −g |u| (c·ν_r) c (sim.thrusters.ThrusterBank.step). At surge speed U with a
    sideslip (heave) angle β the cross-flow is c_y U β (c_z U β), so the yaw (pitch)
    moment is −g c_y c_N U² β (−g c_z c_M U² β); as a restoring stiffness in the sign
    convention of the Munk term (yaw: N per sideslip rad, positive = weathercock; pitch:
    M per heave-incidence rad, positive = restoring) that is
    k_N = −Σ g c_y c_N and k_M = +Σ g c_z c_M — positive for fins aft of the CG."""
    cols = np.asarray(columns, float)
    fin = np.asarray(is_fin, bool)
    g = np.asarray(lift_gain, float)
    out = np.zeros(6)
    c = cols[fin]
    out[5] = -float(np.sum(g[fin] * c[:, 1] * c[:, 5]))
    out[4] = float(np.sum(g[fin] * c[:, 2] * c[:, 4]))
    return out


def fin_damping(columns, is_fin, lift_gain) -> np.ndarray:
    """(6,) linear damping of the fins' passive lift per m/s of surge speed: the wrench
    −g |u| (c·ν_r) c has the diagonal terms g |u| c_j² (N·s/m, N·m·s/rad per m/s) — e.g.
    the yaw damping g U x_f² of a rudder at lever x_f, which bounds a finned vehicle's
    turn rate."""
    cols = np.asarray(columns, float)
    fin = np.asarray(is_fin, bool)
    g = np.asarray(lift_gain, float)
    return (g[fin, None] * cols[fin] ** 2).sum(axis=0) if fin.any() else np.zeros(6)


def max_wrench(specs, controlled, speed: float) -> np.ndarray:
    """(6,) largest pure demand per DOF that the least-squares allocation over the
    ``controlled`` DOFs maps to channel commands within [-1, 1] (0 for uncontrolled).

    specs: sequence of ``sim.thrusters.ThrusterSpec``; fins scaled by speed|speed|.
    """
    return max_wrench_from_columns(
        np.array([s.column() for s in specs]),
        np.array([s.kind == "fin" for s in specs]),
        np.array([s.max_forward for s in specs]),
        np.array([s.max_reverse for s in specs]),
        controlled,
        speed,
    )


def max_wrench_from_columns(columns, is_fin, max_forward, max_reverse, controlled, speed):
    """As :func:`max_wrench` from the channel arrays of a ``ThrusterBank``: columns (k, 6)
    [d; r × d], is_fin (k,), max_forward / max_reverse (k,)."""
    dofs = np.asarray(controlled, bool)
    cols = np.asarray(columns, float).T.copy()  # (6, k)
    fin = np.asarray(is_fin, bool)
    cols[:, fin] *= speed * abs(speed)
    fwd = np.asarray(max_forward, float)
    rev = np.asarray(max_reverse, float)
    pinv = np.linalg.pinv(cols[dofs], rcond=1e-6)  # (k, ndof)
    out = np.zeros(6)
    for j, dof_index in enumerate(np.flatnonzero(dofs)):
        f = pinv[:, j]
        lim = np.where((f >= 0) | fin, fwd, rev)
        nz = np.abs(f) > 1e-12
        out[dof_index] = float(np.min(lim[nz] / np.abs(f[nz]))) if nz.any() else 0.0
    return out


#: share of each DOF's pure authority it may demand (surge, sway, heave, roll, pitch, yaw)
AUTHORITY_WEIGHTS = (0.5, 0.3, 0.3, 0.3, 0.7, 0.5)


def split_authority(
    columns, is_fin, max_forward, max_reverse, controlled, speed, weights=AUTHORITY_WEIGHTS
) -> np.ndarray:
    """(6,) demand limits such that ANY simultaneous demand within them is allocated
    without saturating a channel. With U_ij = |f_ij| τmax_j / F_i the load that a pure
    full demand in DOF j puts on channel i (the allocation is linear in tau) and the
    priority shares p_j = ``weights``, channel i carries load_i = Σ_j U_ij p_j; each DOF
    gets limit_j = min(1, p_j min_{i used by j} 1/load_i) τmax_j, so Σ_j U_ij limit_j/τmax_j
    <= 1 on every channel. A dedicated channel (a torpedo's rudder) keeps its full
    authority; shared ones (a hovering vehicle's vertical thrusters doing heave and
    pitch) are divided — clipping one channel of a saturated pseudo-inverse solution
    would otherwise destroy e.g. the pitch moment while diving."""
    dofs = np.asarray(controlled, bool)
    tmax = max_wrench_from_columns(columns, is_fin, max_forward, max_reverse, dofs, speed)
    cols = np.asarray(columns, float).T.copy()
    fin = np.asarray(is_fin, bool)
    cols[:, fin] *= speed * abs(speed)
    lim = np.where(fin, max_forward, np.minimum(max_forward, max_reverse))
    pinv = np.linalg.pinv(cols[dofs], rcond=1e-6)  # (k, ndof)
    p = np.asarray(weights, float)[dofs]
    U = np.abs(pinv) * tmax[dofs][None, :] / lim[:, None]  # (k, ndof)
    load = U @ p  # (k,)
    used = U > 1e-9
    inv = np.where(used, 1.0 / np.maximum(load, 1e-12)[:, None], np.inf)
    share = np.minimum(1.0, p * inv.min(axis=0))
    out = np.zeros(6)
    out[dofs] = share * tmax[dofs]
    return out


@dataclass(frozen=True)
class AutopilotGains:
    """Everything the autopilot needs; see the module docstring for the derivation.

    surge (speed), sway_speed (sway velocity held at 0 in transit by vehicles with
    lateral thrusters: stops crabbing), heading, depth (heave force), pitch, roll,
    station_surge and sway (station keeping on the body-frame position error, N per m):
    PIDGains with output limits in N / N·m. depth_to_pitch: PIDGains from depth error (m)
    to pitch demand (rad), used when ``depth_by_pitch``. lookahead m (LOS Δ), cruise_speed
    m/s, surge damping (d_l, d_q) for the speed feedforward, net_buoyancy N (heave
    feedforward −(B − W)); controlled (6,) DOFs the vehicle actuates (others are output
    as 0); finned: keeps its speed in turns (its rudder needs it); turn_radius m at
    cruise speed with full yaw authority (U / r_ss, d_l r + d_q r² = N_max), used as the
    least waypoint acceptance radius so that the turn starts before the corner."""

    surge: PIDGains
    heading: PIDGains
    depth: PIDGains
    pitch: PIDGains
    roll: PIDGains
    sway: PIDGains
    sway_speed: PIDGains
    station_surge: PIDGains
    depth_to_pitch: PIDGains
    depth_by_pitch: bool
    lookahead: float
    cruise_speed: float
    surge_damping: tuple[float, float]
    net_buoyancy: float = 0.0
    controlled: tuple[bool, ...] = (True,) * 6
    finned: bool = False
    turn_radius: float = 0.0


def _second_order(
    M: float, d: float, k: float, tau_max: float, e_sat: float, integral: bool = True
) -> PIDGains:
    if math.isfinite(tau_max) and tau_max > 0:
        wn = math.sqrt(tau_max / (M * e_sat))
    else:
        wn = 0.5
    wn = min(max(wn, 0.1), 1.0)
    kp = max(M * wn * wn - k, 0.05 * M * wn * wn)
    # critical damping of the loop WITHOUT the destabilising stiffness (ω = sqrt(kp/M)):
    # the Munk moment needs a sideslip / incidence that the sway and depth loops keep
    # small, and when it is absent an underdamped loop (ζ = ω_n / sqrt(kp/M)) limit-cycles
    # with the thruster lag. With k present the loop is then overdamped (ζ >= 1).
    kd = max(2.0 * math.sqrt(kp * M) - d, 0.0)
    ki = kp * wn / 10.0 if integral else 0.0
    lim = tau_max if math.isfinite(tau_max) and tau_max > 0 else math.inf
    return PIDGains(kp=kp, ki=ki, kd=kd, u_min=-lim, u_max=lim)


def design_gains(plant: VehiclePlant) -> AutopilotGains:
    """Gains for ``plant`` by the rules of the module docstring."""
    M, dl, dq, k = plant.inertia, plant.linear_damping, plant.quadratic_damping, plant.stiffness
    tmax = np.where(plant.controlled, plant.max_effort, 0.0)
    U = plant.cruise_speed
    # surge PI with pole-zero cancellation
    d_u = dl[0] + 2.0 * dq[0] * U
    w_u = min(max(2.0 * d_u / M[0], 0.1), 1.0)
    kp_u = M[0] * w_u
    x_lim = tmax[0] if tmax[0] > 0 else math.inf
    surge = PIDGains(kp=kp_u, ki=kp_u * d_u / M[0], u_min=-x_lim, u_max=x_lim)
    r_ref = 0.2  # rad/s, linearisation rate for rotational damping
    w_ref = 0.2  # m/s, for heave/sway
    heading = _second_order(M[5], dl[5] + 2 * dq[5] * r_ref, k[5], tmax[5], 0.5)
    depth = _second_order(M[2], dl[2] + 2 * dq[2] * w_ref, k[2], tmax[2], 2.0)
    sway = _second_order(M[1], dl[1] + 2 * dq[1] * w_ref, k[1], tmax[1], 2.0)
    d_v = dl[1] + 2.0 * dq[1] * w_ref
    w_v = min(max(2.0 * d_v / M[1], 0.1), 1.0)
    y_lim = tmax[1] if tmax[1] > 0 else math.inf
    sway_speed = PIDGains(kp=M[1] * w_v, ki=M[1] * w_v * d_v / M[1], u_min=-y_lim, u_max=y_lim)
    station_surge = _second_order(M[0], dl[0] + 2 * dq[0] * w_ref, k[0], tmax[0], 2.0)
    pitch = _second_order(M[4], dl[4] + 2 * dq[4] * r_ref, k[4], tmax[4], 0.3)
    roll = _second_order(M[3], dl[3] + 2 * dq[3] * r_ref, k[3], tmax[3], 0.3, integral=False)
    depth_by_pitch = not plant.controlled[2]
    dz = 2.0 * plant.length
    kp_z = 1.0 / dz
    theta_max = 0.35
    depth_to_pitch = PIDGains(
        kp=kp_z, ki=kp_z * (max(U, 0.1) / dz) / 10.0, u_min=-theta_max, u_max=theta_max
    )
    n_max = tmax[5] if tmax[5] > 0 else math.inf
    r_ss = _max_speed(dl[5], dq[5], n_max)
    turn_radius = U / r_ss if r_ss > 0 and math.isfinite(r_ss) else 0.0
    return AutopilotGains(
        surge=surge,
        heading=heading,
        depth=depth,
        pitch=pitch,
        roll=roll,
        sway=sway,
        sway_speed=sway_speed,
        station_surge=station_surge,
        depth_to_pitch=depth_to_pitch,
        depth_by_pitch=bool(depth_by_pitch),
        lookahead=float(max(min(max(3.0 * plant.length, 3.0), 10.0), turn_radius)),
        cruise_speed=U,
        surge_damping=(float(dl[0]), float(dq[0])),
        net_buoyancy=float(plant.net_buoyancy),
        controlled=tuple(bool(c) for c in plant.controlled),
        finned=bool(plant.finned),
        turn_radius=float(turn_radius),
    )
