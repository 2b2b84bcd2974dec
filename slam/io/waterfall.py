"""The side-scan waterfall shared by readers, normalization and segmentation.

Layout (ARCHITECTURE.md): ``intensity`` has shape ``(pings, 2 × samples_per_side)``; the
left half is port, the right half starboard, as the field displays it — so the nadir
(closest range on both sides) is at the centre column pair and far range at the outer
edges. Row 0 is the earliest ping (rows in acquisition-time order).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Waterfall:
    """A side-scan waterfall with per-ping metadata.

    intensity        : (P, 2·S) float32, linear sample values as recorded (no gain applied).
    samples_per_side : S.
    time_s           : (P,) float64, seconds since ``time_origin`` (increasing; nan when unknown).
    slant_range_m    : (P,) float64, maximum slant range of each ping, m.
    frequency_hz     : (P,) float64, sonar frequency, Hz (nan when unknown).
    sound_velocity_m_s : (P,) float64, sound speed the recorder used, m/s (nan when unknown).
    nav              : dict of (P,) float64 arrays (e.g. ``"x"``, ``"y"``, ``"heading_deg"``,
                       ``"altitude_m"``, ``"depth_m"``) holding only fields that are not all
                       zero in the file; empty when the file carries no navigation.
    time_origin      : ISO-8601 string of the first ping's time ('' when unknown).
    source           : where it came from (path), free text.
    """

    intensity: np.ndarray
    samples_per_side: int
    time_s: np.ndarray
    slant_range_m: np.ndarray
    frequency_hz: np.ndarray
    sound_velocity_m_s: np.ndarray
    nav: dict = field(default_factory=dict)
    time_origin: str = ""
    source: str = ""

    def __post_init__(self) -> None:
        img = np.asarray(self.intensity)
        if img.ndim != 2:
            raise ValueError(f"Waterfall.intensity must be 2-D (pings, 2*samples), got {img.shape}")
        s = int(self.samples_per_side)
        if s < 1 or img.shape[1] != 2 * s:
            raise ValueError(
                f"Waterfall.samples_per_side={s} does not match intensity width {img.shape[1]} "
                "(must be exactly half of it)"
            )
        p = img.shape[0]
        for name in ("time_s", "slant_range_m", "frequency_hz", "sound_velocity_m_s"):
            a = np.asarray(getattr(self, name), dtype=np.float64).reshape(-1)
            if a.shape != (p,):
                raise ValueError(f"Waterfall.{name} must have shape ({p},), got {a.shape}")
            object.__setattr__(self, name, a)
        for k, v in self.nav.items():
            if np.asarray(v).shape != (p,):
                raise ValueError(f"Waterfall.nav[{k!r}] must have shape ({p},)")
        object.__setattr__(self, "intensity", img.astype(np.float32, copy=False))
        object.__setattr__(self, "samples_per_side", s)

    @property
    def n_pings(self) -> int:
        return int(self.intensity.shape[0])

    @property
    def port(self) -> np.ndarray:
        """(P, S) port samples, near range first (column 0 = nadir side)."""
        return self.intensity[:, : self.samples_per_side][:, ::-1]

    @property
    def starboard(self) -> np.ndarray:
        """(P, S) starboard samples, near range first."""
        return self.intensity[:, self.samples_per_side :]

    def sample_spacing_m(self) -> np.ndarray:
        """(P,) slant-range size of one sample, m."""
        return self.slant_range_m / self.samples_per_side

    def with_intensity(self, intensity: np.ndarray) -> Waterfall:
        """Same metadata, new intensity of the same shape."""
        intensity = np.asarray(intensity)
        if intensity.shape != self.intensity.shape:
            raise ValueError(
                f"intensity shape {intensity.shape} differs from waterfall {self.intensity.shape}"
            )
        return Waterfall(
            intensity=intensity,
            samples_per_side=self.samples_per_side,
            time_s=self.time_s,
            slant_range_m=self.slant_range_m,
            frequency_hz=self.frequency_hz,
            sound_velocity_m_s=self.sound_velocity_m_s,
            nav=dict(self.nav),
            time_origin=self.time_origin,
            source=self.source,
        )


def waterfall_from_image(image: np.ndarray, *, source: str = "") -> Waterfall:
    """Wrap a plain 2-D image (e.g. a PNG of a waterfall) as a Waterfall with unknown
    metadata: left half port, right half starboard. The width must be even."""
    img = np.asarray(image)
    if img.ndim != 2 or img.shape[1] < 2 or img.shape[1] % 2:
        raise ValueError(
            f"a waterfall image must be 2-D with an even width >= 2, got shape {img.shape}"
        )
    p = img.shape[0]
    nan = np.full(p, np.nan)
    return Waterfall(
        intensity=img,
        samples_per_side=img.shape[1] // 2,
        time_s=nan,
        slant_range_m=nan,
        frequency_hz=nan,
        sound_velocity_m_s=nan,
        source=source,
    )
