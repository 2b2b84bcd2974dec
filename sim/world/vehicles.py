"""The vehicle library: MJCF files under ``assets/vehicles/<kind>/`` plus the parameters
the hydrodynamics and the thrusters need (sources: each vehicle's README.md).

Mass and inertia are read from the MJCF (one source of truth). Added mass comes from
Lamb's ellipsoid formulas on the vehicle envelope (``ellipsoid_added_mass``) unless a
published matrix exists (RexROV: UUV Simulator). For open-frame vehicles (water flows
through the frame: the enclosing ellipsoid overestimates the entrained fluid) the
translational terms are scaled by ``OPEN_FRAME_ADDED_MASS_SCALE``, the ratio of the
published added mass of an open-frame ROV of the same class (BlueROV2 Heavy) to the Lamb
ellipsoid on its own envelope. Fin lift slopes come from low-aspect-ratio wing theory
(``fin_lift_slope``). Quadratic damping comes from drag
coefficients by strip theory (``strip_theory_quadratic_damping``); linear damping is
the quadratic damping linearised at a low reference speed (an assumption stated per
vehicle). Buoyancy: the vehicles are trimmed (ballasted) to the requested net buoyancy
fraction, V = m (1 + f) / ρ, with the centre of buoyancy at ``r_cb``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sim.hydrodynamics import HydroParams, ellipsoid_added_mass, strip_theory_quadratic_damping
from sim.thrusters import ThrusterSpec

ASSETS = Path(__file__).resolve().parents[2] / "assets" / "vehicles"

# BlueROV2 Heavy (open aluminium/HDPE frame, 13.5 kg, 0.4571 x 0.575 x 0.2539 m, fill
# V_disp / V_envelope = 0.0134 / 0.0667 = 0.20): added mass [X_u', Y_v', Z_w'] in kg from
# von Benzon et al. (2022), "An Open-Source Benchmark Simulator: Control of a BlueROV2
# Underwater Robot", J. Mar. Sci. Eng. 10(12) 1898, parameter table (fresh water).
_BLUEROV2_HEAVY_ENVELOPE = (0.4571, 0.575, 0.2539)
_BLUEROV2_HEAVY_ADDED_MASS = (6.3567, 7.1206, 18.6863)


def _open_frame_scale() -> tuple[float, ...]:
    """Per-DOF ratio published / Lamb-ellipsoid added mass of the BlueROV2 Heavy
    (translations: ≈ [0.49, 0.81, 0.48]); rotations 1 (its near-square planform makes the
    Lamb yaw term ~0 and the ratio meaningless; rotational added mass does not enter the
    Munk moment)."""
    L, W, H = _BLUEROV2_HEAVY_ENVELOPE
    lamb = ellipsoid_added_mass(L / 2, W / 2, H / 2, 1000.0)
    return (*(float(a / b) for a, b in zip(_BLUEROV2_HEAVY_ADDED_MASS, lamb[:3])), 1.0, 1.0, 1.0)


#: per-DOF factor on the Lamb-ellipsoid added mass of an open-frame vehicle (fill ≈ 20–26 %)
OPEN_FRAME_ADDED_MASS_SCALE = _open_frame_scale()


def fin_lift_slope(span: float, chord: float) -> float:
    """Lift-curve slope C_Lα (1/rad) of a low-aspect-ratio fin mounted on a hull.

    Whicker & Fehlner (1958, DTMB Report 933), unswept planform:
        C_Lα = 1.8 π A_e / (1.8 + sqrt(A_e² + 4)),
    with the effective aspect ratio A_e = 2 span / chord (the hull acts as a reflection
    plane at the fin root, doubling the geometric aspect ratio). Tends to 1.8 π A_e / 3.8
    (within 6 % of Jones' slender-wing π A_e / 2) for A_e → 0 and to 1.8 π (thin-airfoil
    2π less viscous losses) for A_e → ∞. span, chord in m (> 0)."""
    if not (np.isfinite(span) and span > 0 and np.isfinite(chord) and chord > 0):
        raise ValueError(f"fin span and chord must be > 0 m, got span={span!r}, chord={chord!r}")
    ae = 2.0 * span / chord
    return float(1.8 * np.pi * ae / (1.8 + np.sqrt(ae * ae + 4.0)))


SENSOR_SITES = ("sss_port", "sss_starboard", "fls", "msis", "dvl", "imu", "pressure")
DOF_NAMES = ("X", "Y", "Z", "K", "M", "N")


@dataclass(frozen=True)
class PropellerDef:
    max_forward: float  # N at command +1
    max_reverse: float  # N at command −1
    time_constant: float  # s


@dataclass(frozen=True)
class FinDef:
    area: float  # m², both fins of the pair
    lift_slope: float  # C_Lα, 1/rad
    max_deflection: float  # rad
    time_constant: float  # s


@dataclass(frozen=True)
class VehicleModel:
    """Static description of a vehicle kind (see the vehicle's README for sources)."""

    kind: str
    display_name: str
    envelope: tuple[float, float, float]  # L, W, H, m (REFERENCE.md)
    reference_mass: float  # kg (REFERENCE.md or source)
    r_cb: tuple[float, float, float]  # centre of buoyancy relative to the CG, body frame, m
    drag_coefficients: tuple[float, float, float]  # Cd_x, Cd_y, Cd_z
    frontal: str  # "ellipse" (body of revolution) or "box"
    linear_reference_speed: tuple[float, float]  # (m/s, rad/s) where D_l v = D_q v²
    actuators: dict[str, PropellerDef | FinDef]  # keyed by MJCF site name, in channel order
    controlled_dofs: tuple[str, ...]
    added_mass: tuple[float, ...] | None = None  # published diag (6,), else Lamb ellipsoid
    added_mass_scale: tuple[float, ...] | None = None  # factor (6,) on the Lamb ellipsoid
    linear_damping: tuple[float, ...] | None = None  # published (6,), else derived
    quadratic_damping: tuple[float, ...] | None = None  # published (6,), else derived

    @property
    def xml_path(self) -> Path:
        return ASSETS / self.kind / f"{self.kind}.xml"

    @property
    def dof_mask(self) -> np.ndarray:
        return np.array([d in self.controlled_dofs for d in DOF_NAMES])

    def hydro_params(
        self, mass: float, inertia: np.ndarray, rho: float, net_buoyancy: float = 0.0
    ) -> HydroParams:
        L, W, H = self.envelope
        am = (
            np.array(self.added_mass)
            if self.added_mass is not None
            else ellipsoid_added_mass(L / 2, W / 2, H / 2, rho)
        )
        if self.added_mass is None and self.added_mass_scale is not None:
            am = am * np.array(self.added_mass_scale)
        dq = (
            np.array(self.quadratic_damping)
            if self.quadratic_damping is not None
            else strip_theory_quadratic_damping(
                L, W, H, np.array(self.drag_coefficients), rho, self.frontal
            )
        )
        if self.linear_damping is not None:
            dl = np.array(self.linear_damping)
        else:
            sv, sw = self.linear_reference_speed
            dl = dq * np.array([sv, sv, sv, sw, sw, sw])
        return HydroParams(
            mass=mass,
            inertia=inertia,
            volume=mass * (1.0 + net_buoyancy) / rho,
            r_cb=np.array(self.r_cb),
            added_mass=am,
            linear_damping=dl,
            quadratic_damping=dq,
            height=H,
        )

    def thruster_specs(self, positions: dict, directions: dict, rho: float) -> list[ThrusterSpec]:
        out = []
        for name, a in self.actuators.items():
            if isinstance(a, FinDef):
                gain = 0.5 * rho * a.area * a.lift_slope * a.max_deflection
                out.append(
                    ThrusterSpec(
                        name,
                        "fin",
                        gain,
                        gain,
                        a.time_constant,
                        tuple(positions[name]),
                        tuple(directions[name]),
                        lift_gain=0.5 * rho * a.area * a.lift_slope,
                    )
                )
            else:
                out.append(
                    ThrusterSpec(
                        name,
                        "propeller",
                        a.max_forward,
                        a.max_reverse,
                        a.time_constant,
                        tuple(positions[name]),
                        tuple(directions[name]),
                    )
                )
        return out


# BlueRobotics T200 data sheet at 16 V: 5.1 kgf forward, 4.1 kgf reverse
_T200 = PropellerDef(5.1 * 9.80665, 4.1 * 9.80665, 0.15)
_IXN_FIN_AREA = 2 * 0.2 * 0.25  # m², a pair of fins of span 0.2 m and chord 0.25 m

VEHICLES: dict[str, VehicleModel] = {
    "alister9": VehicleModel(
        kind="alister9",
        display_name="Alister 9 (ECA Group) torpedo AUV",
        envelope=(2.0, 0.22, 0.22),
        reference_mass=70.0,
        r_cb=(0.0, 0.0, 0.02),
        drag_coefficients=(0.27, 1.1, 1.1),
        frontal="ellipse",
        linear_reference_speed=(0.15, 0.5),
        actuators={
            "thruster_stern": PropellerDef(45.0, 20.0, 0.2),
            "fin_rudder": FinDef(
                area=0.024, lift_slope=3.12, max_deflection=0.35, time_constant=0.1
            ),
            "fin_elevator": FinDef(
                area=0.024, lift_slope=3.12, max_deflection=0.35, time_constant=0.1
            ),
        },
        controlled_dofs=("X", "M", "N"),
    ),
    "ixn": VehicleModel(
        kind="ixn",
        display_name="IXN hovering AUV",
        envelope=(1.9, 0.5, 0.3),
        reference_mass=150.0,
        r_cb=(0.0, 0.0, 0.03),
        drag_coefficients=(0.5, 1.05, 1.05),
        frontal="box",
        linear_reference_speed=(0.15, 0.5),
        actuators={
            "thruster_stern_port": PropellerDef(60.0, 30.0, 0.2),
            "thruster_stern_starboard": PropellerDef(60.0, 30.0, 0.2),
            "thruster_vertical_fore": PropellerDef(40.0, 32.0, 0.2),
            "thruster_vertical_aft": PropellerDef(40.0, 32.0, 0.2),
            "thruster_lateral_fore": PropellerDef(20.0, 20.0, 0.2),
            "thruster_lateral_aft": PropellerDef(20.0, 20.0, 0.2),
            # stern control surfaces (README: sized by the yaw static-stability criterion
            # ½ρ S C_Lα |x_f| ≥ A22 − A11); per fin chord 0.25 m, span 0.2 m
            "fin_rudder": FinDef(
                area=_IXN_FIN_AREA,
                lift_slope=fin_lift_slope(0.2, 0.25),
                max_deflection=0.35,
                time_constant=0.1,
            ),
            "fin_elevator": FinDef(
                area=_IXN_FIN_AREA,
                lift_slope=fin_lift_slope(0.2, 0.25),
                max_deflection=0.35,
                time_constant=0.1,
            ),
        },
        controlled_dofs=("X", "Y", "Z", "M", "N"),
    ),
    "naiad": VehicleModel(
        kind="naiad",
        display_name="Naiad hovering AUV (Mälardalen University)",
        envelope=(0.84, 0.6, 0.25),
        reference_mass=30.0,
        r_cb=(0.0, 0.0, 0.05),
        drag_coefficients=(1.05, 1.05, 1.05),
        frontal="box",
        linear_reference_speed=(0.15, 0.5),
        actuators={
            "thruster_front_port": _T200,
            "thruster_front_starboard": _T200,
            "thruster_rear_port": _T200,
            "thruster_rear_starboard": _T200,
            "thruster_vertical_fore": _T200,
            "thruster_vertical_aft": _T200,
        },
        controlled_dofs=("X", "Y", "Z", "M", "N"),
        added_mass_scale=OPEN_FRAME_ADDED_MASS_SCALE,
    ),
    "saga": VehicleModel(
        kind="saga",
        display_name="SAGA mini ROV (Desistek)",
        envelope=(0.42, 0.33, 0.27),
        reference_mass=10.0,
        r_cb=(0.0, 0.0, 0.06),
        drag_coefficients=(1.05, 1.05, 1.05),
        frontal="box",
        linear_reference_speed=(0.15, 0.5),
        actuators={
            "thruster_front_port": PropellerDef(20.0, 15.0, 0.1),
            "thruster_front_starboard": PropellerDef(20.0, 15.0, 0.1),
            "thruster_rear_port": PropellerDef(20.0, 15.0, 0.1),
            "thruster_rear_starboard": PropellerDef(20.0, 15.0, 0.1),
            "thruster_vertical": PropellerDef(20.0, 15.0, 0.1),
        },
        controlled_dofs=("X", "Y", "Z", "N"),
        added_mass_scale=OPEN_FRAME_ADDED_MASS_SCALE,
    ),
    "rexrov": VehicleModel(
        kind="rexrov",
        display_name="RexROV-like work-class ROV (UUV Simulator parameters)",
        envelope=(2.6, 1.5, 1.6),
        reference_mass=1862.87,
        r_cb=(0.0, 0.0, 0.3),
        drag_coefficients=(1.05, 1.05, 1.05),
        frontal="box",
        linear_reference_speed=(0.15, 0.5),
        actuators={
            "thruster_front_port": PropellerDef(1000.0, 800.0, 0.2),
            "thruster_front_starboard": PropellerDef(1000.0, 800.0, 0.2),
            "thruster_rear_port": PropellerDef(1000.0, 800.0, 0.2),
            "thruster_rear_starboard": PropellerDef(1000.0, 800.0, 0.2),
            "thruster_vertical_front_port": PropellerDef(1000.0, 800.0, 0.2),
            "thruster_vertical_front_starboard": PropellerDef(1000.0, 800.0, 0.2),
            "thruster_vertical_rear_port": PropellerDef(1000.0, 800.0, 0.2),
            "thruster_vertical_rear_starboard": PropellerDef(1000.0, 800.0, 0.2),
        },
        controlled_dofs=("X", "Y", "Z", "K", "M", "N"),
        added_mass=(779.79, 1222.0, 3659.9, 534.9, 842.69, 224.32),
        linear_damping=(74.82, 69.48, 728.4, 268.8, 309.77, 105.0),
        quadratic_damping=(748.22, 992.53, 1821.01, 672.0, 774.44, 523.27),
    ),
}

VEHICLE_KINDS = tuple(VEHICLES)
SWARMS_VEHICLES = ("alister9", "ixn", "naiad", "saga")


def vehicle_model(kind: str) -> VehicleModel:
    if kind not in VEHICLES:
        raise ValueError(f"vehicle kind must be one of {VEHICLE_KINDS}, got {kind!r}")
    return VEHICLES[kind]
