"""Autopilot: flies a :class:`~sim.guidance.missions.Mission` with LOS guidance and
depth/altitude, heading and speed PID loops, producing a body wrench demand.

Each control tick ``update(state, dt)`` takes the vehicle's :class:`sim.state.VehicleState`
and returns tau (6,) = [X, Y, Z, K, M, N] (N, N·m, body frame x fwd, y port, z up) for
``VehicleHandle.apply_wrench_demand``. The vehicle's allocation ignores the DOFs it
cannot actuate (a torpedo has no heave or sway authority: it dives by pitching, which
the autopilot then commands through the depth → pitch outer loop).

Loops (gains from sim.guidance.gains):
* course: LOS course χ_d (integral LOS when ``ilos_sigma`` > 0), turned into a heading
  demand ψ_d = χ_d − β with the crab angle β = atan2(v, u) of the velocity over ground,
  low-pass filtered (time constant ``crab_time_constant``; compensates a steady current;
  only above 0.2 m/s);
  heading PID → N, derivative on the measured yaw rate.
* speed: PI on surge speed over ground + damping feedforward → X. The speed demand
  is reduced near the final waypoint, in sharp turns (heading error > 45°; not for a
  finned vehicle, whose rudder needs the speed) and, for
  hovering vehicles, while more than 0.5 m off the depth demand (dive, then transit).
* depth: heave PID on the depth error + buoyancy feedforward → Z; and pitch PID → M to
  pitch 0 (hovering vehicles) or to θ_d from the depth → pitch loop (torpedo).
  Altitude missions set depth_d = depth + altitude − altitude_d from the state's
  altitude (holds the last depth demand while the altitude is unknown).
* sway: PI holding the sway velocity at zero in transit → Y (ignored by vehicles
  without lateral authority): a box hull otherwise crabs through turns.
* roll PD → K (only used by vehicles that actuate roll).
* waypoint switching: a waypoint is reached inside the acceptance radius (the
  mission's, at least the vehicle's turn radius at cruise speed) or
  when the along-track distance passes the leg end (so a vehicle pushed off the circle
  never circles back).
* after the last waypoint: a ``hold`` mission keeps station there (surge/sway PIDs on
  the body-frame position error) for ``hold_time``; others stop and hold depth/heading.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim.guidance.gains import AutopilotGains
from sim.guidance.los import integral_los_rate, los_guidance, wrap
from sim.guidance.missions import Mission
from sim.guidance.pid import PID
from sim.state import VehicleState

__all__ = ["Autopilot", "MissionStatus"]


@dataclass(frozen=True)
class MissionStatus:
    """Progress after one tick.

    t s; leg: index of the active leg (its end waypoint is ``leg + 1``; leg 0 of a
    mission starts at the vehicle's start position and ends at waypoint 0 —
    ``on_survey_leg`` is False there); n_legs: legs including that approach leg;
    progress: fraction of the planned path flown, [0, 1]; cross_track m (+ = left of
    the active leg); along_track m; distance_to_waypoint m; desired heading rad, depth m,
    speed m/s; done: mission complete.
    """

    t: float
    leg: int
    n_legs: int
    progress: float
    cross_track: float
    along_track: float
    distance_to_waypoint: float
    heading_desired: float
    depth_desired: float
    speed_desired: float
    on_survey_leg: bool
    done: bool


class Autopilot:
    """``Autopilot(mission, gains, ilos_sigma=0.0, crab_time_constant=10.0)``; call
    ``update(state, dt)`` every control tick; read ``status``. ``ilos_sigma`` > 0 turns on
    integral LOS; ``crab_time_constant`` (s) filters the crab angle (0: no crab
    compensation)."""

    def __init__(
        self,
        mission: Mission,
        gains: AutopilotGains,
        ilos_sigma: float = 0.0,
        crab_time_constant: float = 10.0,
    ) -> None:
        if not (math.isfinite(ilos_sigma) and ilos_sigma >= 0):
            raise ValueError(f"ilos_sigma must be >= 0, got {ilos_sigma!r}")
        if not (math.isfinite(crab_time_constant) and crab_time_constant >= 0):
            raise ValueError(f"crab_time_constant must be >= 0 s, got {crab_time_constant!r}")
        self.crab_time_constant = float(crab_time_constant)
        self._beta = 0.0
        self.mission = mission
        self.gains = gains
        self.ilos_sigma = float(ilos_sigma)
        self.pid_surge = PID(gains.surge)
        self.pid_sway = PID(gains.sway)
        self.pid_station = PID(gains.station_surge)
        self.pid_sway_speed = PID(gains.sway_speed)
        self._controlled = np.asarray(gains.controlled, bool)
        # waypoint acceptance: the mission's radius, at least the vehicle's turn radius
        # (except for the last waypoint of a station-keeping mission)
        self.acceptance = max(mission.acceptance_radius, gains.turn_radius)
        # speed demand: the mission's, capped at what the vehicle holds (gains.cruise_speed:
        # thrust and Munk-moment limits; autopilot_for warns when it caps)
        self.speed = min(mission.speed, gains.cruise_speed) if mission.speed > 0 else 0.0
        self.pid_heading = PID(gains.heading)
        self.pid_depth = PID(gains.depth)
        self.pid_pitch = PID(gains.pitch)
        self.pid_roll = PID(gains.roll)
        self.pid_depth_pitch = PID(gains.depth_to_pitch)
        self._path: np.ndarray | None = None  # start position + waypoints
        self._cum: np.ndarray | None = None
        self.leg = 0
        self._ilos = 0.0
        self._depth_d: float | None = None
        self._hold_start: float | None = None
        self.done = False
        self.status: MissionStatus | None = None

    # ------------------------------------------------------------------------------

    def _start(self, state: VehicleState) -> None:
        p0 = np.asarray(state.position[:2], float)
        w = self.mission.waypoints
        if np.hypot(*(w[0] - p0)) < 1e-6:  # exactly on waypoint 0: keep leg 0 non-degenerate
            yaw = float(state.euler[2])
            p0 = w[0] - 1e-3 * np.array([math.cos(yaw), math.sin(yaw)])
        if np.hypot(*(w[0] - p0)) < self.mission.acceptance_radius:
            path = np.vstack([p0, w[1:]]) if len(w) > 1 else np.vstack([p0, w])
        else:
            path = np.vstack([p0, w])
        self._path = path
        seg = np.hypot(*np.diff(path, axis=0).T) if len(path) > 1 else np.zeros(0)
        self._cum = np.concatenate([[0.0], np.cumsum(seg)])
        self._skip_first = len(path) == len(w)  # approach leg replaced by a survey leg
        self._depth_d = self.mission.depth if self.mission.depth is not None else state.depth

    def _depth_demand(self, state: VehicleState) -> float:
        m = self.mission
        if m.depth is not None:
            return m.depth
        if math.isfinite(state.altitude):
            self._depth_d = max(0.0, state.depth + state.altitude - m.altitude)
        return self._depth_d

    def update(self, state: VehicleState, dt: float) -> np.ndarray:
        """tau (6,) for this tick; updates ``status``."""
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"Autopilot.update dt must be > 0 s, got {dt!r}")
        if self._path is None:
            self._start(state)
        g = self.gains
        m = self.mission
        path = self._path
        pos = np.asarray(state.position[:2], float)
        roll, pitch, yaw = (float(a) for a in state.euler)
        vel = np.asarray(state.velocity_body, float)
        omega = np.asarray(state.angular_velocity_body, float)
        n_legs = len(path) - 1
        hold_mode = False

        # --- waypoint switching
        while not self.done and self.leg < n_legs:
            los = los_guidance(pos, path[self.leg], path[self.leg + 1], g.lookahead)
            reached = np.hypot(*(pos - path[self.leg + 1])) < self.acceptance or los.remaining <= 0
            if not reached:
                break
            self.leg += 1
            self._ilos = 0.0
        if self.leg >= n_legs:
            hold_mode = m.hold_time > 0 or m.kind == "hold"
            if self._hold_start is None:
                self._hold_start = state.t
            if state.t - self._hold_start >= m.hold_time:
                self.done = True

        # --- horizontal guidance
        leg = min(self.leg, n_legs - 1)
        los = los_guidance(pos, path[leg], path[leg + 1], g.lookahead, self._ilos, self.ilos_sigma)
        dist_wp = float(np.hypot(*(pos - path[leg + 1])))
        U = math.hypot(vel[0], vel[1])
        if self.crab_time_constant > 0 and U > 0.2 and vel[0] > 0:
            # crab angle over ground, low-pass filtered: unfiltered it couples the sway
            # of every turn back into the heading demand and sets up a yaw limit cycle
            a = 1.0 - math.exp(-dt / self.crab_time_constant)
            self._beta += a * (math.atan2(vel[1], vel[0]) - self._beta)
        beta = self._beta
        tau = np.zeros(6)
        if self.leg < n_legs:
            if self.ilos_sigma > 0:
                self._ilos += dt * integral_los_rate(
                    los.cross_track, self._ilos, g.lookahead, self.ilos_sigma
                )
            psi_d = wrap(los.course - beta)
            speed_d = self.speed
            # slow down for the final approach and for large heading errors
            if self.leg == n_legs - 1:
                speed_d = min(speed_d, max(0.3 * self.speed, 0.5 * dist_wp))
            if not g.depth_by_pitch:
                # hovering vehicles dive before they transit: the Munk moment
                # (A33 - A11) u w of a flat hull would otherwise out-muscle the pitch
                # authority of the vertical thrusters
                dz = abs(state.depth - self._depth_demand(state))
                speed_d *= min(1.0, max(0.2, 1.5 - dz))
            herr = abs(wrap(psi_d - yaw))
            if herr > math.pi / 4 and not g.finned:
                speed_d *= max(0.3, math.cos(herr))
            tau[0] = self._surge(speed_d, vel[0], dt)
            tau[1] = self.pid_sway_speed.update(-float(vel[1]), dt)
        else:
            psi_d = self.status.heading_desired if self.status is not None else yaw
            speed_d = 0.0
            if hold_mode and not self.done:
                # station keeping: body-frame position error to surge and sway forces
                e_w = path[-1] - pos
                c, s = math.cos(yaw), math.sin(yaw)
                e_b = np.array([c * e_w[0] + s * e_w[1], -s * e_w[0] + c * e_w[1]])
                tau[0] = self.pid_station.update(float(e_b[0]), dt, error_rate=-vel[0])
                tau[1] = self.pid_sway.update(float(e_b[1]), dt, error_rate=-vel[1])
            else:
                tau[0] = self._surge(0.0, vel[0], dt)
        tau[5] = self.pid_heading.update(wrap(psi_d - yaw), dt, error_rate=-omega[2])

        # --- vertical
        depth_d = self._depth_demand(state)
        vz = float(state.velocity_world[2])
        # heave (hovering vehicles): error in z (up) = depth - depth_d
        tau[2] = self.pid_depth.update(
            state.depth - depth_d, dt, error_rate=-vz, feedforward=-g.net_buoyancy
        )
        if g.depth_by_pitch:
            theta_d = self.pid_depth_pitch.update(depth_d - state.depth, dt, error_rate=vz)
        else:
            theta_d = 0.0
        tau[4] = self.pid_pitch.update(theta_d - pitch, dt, error_rate=-omega[1])
        tau[3] = self.pid_roll.update(-roll, dt, error_rate=-omega[0])

        tau[~self._controlled] = 0.0
        done_len = float(self._cum[min(self.leg, n_legs)]) if n_legs else 0.0
        if self.leg < n_legs:
            done_len += min(max(los.along_track, 0.0), los.leg_length)
        total = float(self._cum[-1])
        self.status = MissionStatus(
            t=float(state.t),
            leg=int(self.leg),
            n_legs=int(n_legs),
            progress=1.0 if self.done else (done_len / total if total > 0 else 0.0),
            cross_track=float(los.cross_track),
            along_track=float(los.along_track),
            distance_to_waypoint=dist_wp,
            heading_desired=float(psi_d),
            depth_desired=float(depth_d),
            speed_desired=float(speed_d),
            on_survey_leg=bool(self.leg >= 1 or self._skip_first),
            done=self.done,
        )
        return tau

    def _surge(self, speed_d: float, u: float, dt: float) -> float:
        dl, dq = self.gains.surge_damping
        ff = dl * speed_d + dq * speed_d * abs(speed_d)
        return self.pid_surge.update(speed_d - u, dt, feedforward=ff)
