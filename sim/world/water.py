"""Sea water: density and sound speed.

Density: the UNESCO 1981 one-atmosphere international equation of state of sea water
(EOS-80; Millero & Poisson 1981, Deep-Sea Research 28A, 625–629; UNESCO technical papers
in marine science 36 and 44), temperature in °C and practical salinity in psu. The
pressure (compressibility) term is left out: at 100 m it adds about 0.45 kg/m³
(0.04 %), far below the accuracy of the hydrodynamic coefficients it feeds.

Sound speed: Mackenzie (1981), "Nine-term equation for sound speed in the oceans",
J. Acoust. Soc. Am. 70(3), 807–812; valid for 2–30 °C, 25–40 psu, 0–8000 m.

Both are hand-written because they are short published polynomials that no installed
library provides (gsw/seawater are not dependencies).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

GRAVITY = 9.81  # m/s², the value MuJoCo's default option uses


def _check_range(name: str, value: float, lo: float, hi: float) -> float:
    v = float(value)
    if not np.isfinite(v) or v < lo or v > hi:
        raise ValueError(f"{name} must be a finite number in [{lo}, {hi}], got {value!r}")
    return v


def seawater_density(temperature_c, salinity_psu) -> np.ndarray | float:
    """EOS-80 one-atmosphere density of sea water, kg/m³.

    Published check values (UNESCO 1981): ρ(S=0, t=5) = 999.96675,
    ρ(S=35, t=5) = 1027.67547, ρ(S=35, t=25) = 1023.34306 kg/m³.
    """
    t = np.asarray(temperature_c, dtype=float)
    s = np.asarray(salinity_psu, dtype=float)
    rho_w = (
        999.842594
        + 6.793952e-2 * t
        - 9.095290e-3 * t**2
        + 1.001685e-4 * t**3
        - 1.120083e-6 * t**4
        + 6.536332e-9 * t**5
    )
    a = 8.24493e-1 - 4.0899e-3 * t + 7.6438e-5 * t**2 - 8.2467e-7 * t**3 + 5.3875e-9 * t**4
    b = -5.72466e-3 + 1.0227e-4 * t - 1.6546e-6 * t**2
    c = 4.8314e-4
    rho = rho_w + a * s + b * s**1.5 + c * s**2
    return float(rho) if rho.ndim == 0 else rho


def mackenzie_sound_speed(temperature_c, salinity_psu, depth_m) -> np.ndarray | float:
    """Mackenzie (1981) nine-term sound speed, m/s. Check value: c(25 °C, 35 psu, 1000 m)
    = 1550.744 m/s (Mackenzie 1981, Table I)."""
    t = np.asarray(temperature_c, dtype=float)
    s = np.asarray(salinity_psu, dtype=float)
    d = np.asarray(depth_m, dtype=float)
    c = (
        1448.96
        + 4.591 * t
        - 5.304e-2 * t**2
        + 2.374e-4 * t**3
        + 1.340 * (s - 35.0)
        + 1.630e-2 * d
        + 1.675e-7 * d**2
        - 1.025e-2 * t * (s - 35.0)
        - 7.139e-13 * t * d**3
    )
    return float(c) if c.ndim == 0 else c


@dataclass(frozen=True)
class Water:
    """The water body of a world.

    density           : kg/m³ used for buoyancy, added mass and drag (default 1025, the
                        usual sea-water value; ``Water.from_ts`` computes it with EOS-80).
    temperature_c     : °C, salinity_psu : practical salinity (≈ g/kg).
    reference_depth_m : depth at which ``sound_speed`` is quoted, m.
    sound_speed       : m/s; None -> Mackenzie (1981) at the reference depth.
    surface_z         : world z of the free surface (the depth datum), m.
    gravity           : m/s².
    """

    density: float = 1025.0
    temperature_c: float = 10.0
    salinity_psu: float = 35.0
    reference_depth_m: float = 30.0
    sound_speed: float | None = field(default=None)
    surface_z: float = 0.0
    gravity: float = GRAVITY

    def __post_init__(self) -> None:
        _check_range("water.density", self.density, 900.0, 1100.0)
        _check_range("water.temperature_c", self.temperature_c, -2.0, 40.0)
        _check_range("water.salinity_psu", self.salinity_psu, 0.0, 42.0)
        _check_range("water.reference_depth_m", self.reference_depth_m, 0.0, 11000.0)
        _check_range("water.surface_z", self.surface_z, -1e4, 1e4)
        _check_range("water.gravity", self.gravity, 0.0, 20.0)
        if self.sound_speed is None:
            c = mackenzie_sound_speed(self.temperature_c, self.salinity_psu, self.reference_depth_m)
            object.__setattr__(self, "sound_speed", float(c))
        else:
            _check_range("water.sound_speed", self.sound_speed, 1300.0, 1700.0)

    @classmethod
    def from_ts(
        cls, temperature_c: float, salinity_psu: float, reference_depth_m: float = 30.0, **kw
    ) -> Water:
        """Water whose density (EOS-80) and sound speed (Mackenzie) follow from T and S."""
        _check_range("water.temperature_c", temperature_c, -2.0, 40.0)
        _check_range("water.salinity_psu", salinity_psu, 0.0, 42.0)
        return cls(
            density=float(seawater_density(temperature_c, salinity_psu)),
            temperature_c=temperature_c,
            salinity_psu=salinity_psu,
            reference_depth_m=reference_depth_m,
            **kw,
        )

    @property
    def depth(self) -> float:
        """Depth of the world z = 0 datum below the sea surface, m (= surface_z); a point at
        world z lies at depth ``depth - z`` (the sonar's WaterLike protocol)."""
        return float(self.surface_z)

    def sound_speed_at(self, depth_m) -> np.ndarray | float:
        """Mackenzie sound speed at the given depth(s) below the surface, m/s."""
        return mackenzie_sound_speed(self.temperature_c, self.salinity_psu, depth_m)


class SonarWater:
    """A :class:`Water` seen through the sonar simulators' WaterLike protocol: ``depth``
    is that of the datum (z = 0 lies ``surface_z`` below the surface), m."""

    def __init__(self, water: Water) -> None:
        self.temperature_c = water.temperature_c
        self.salinity_psu = water.salinity_psu
        self.sound_speed = water.sound_speed
        self.depth = float(water.surface_z)
