"""The side-scan receive chain with the realism effects on (``AcousticConfig.realism``).

Per ping: mean seabed/object echo (from :func:`sim.sonar.echo.form_echo`) + target corner
returns + volume reverberation + sea-surface return + first surface multipath, times
correlated speckle (:mod:`sim.sonar.speckle`), plus ambient and electronic noise (each an
exponential intensity draw), then TVG, receiver gain, ADC bit depth and clipping, and the
optional display log compression. Each term is switched by its own RealismConfig field.
"""

from __future__ import annotations

import numpy as np

from sim.sonar.acoustics import compress_log, tvg_gain
from sim.sonar.mount import sensor_depth
from sim.sonar.receiver import (
    ambient_noise_db,
    digitise,
    ping_tvg,
    surface_multipath,
    surface_return,
    two_way_beam,
    volume_reverberation,
)
from sim.sonar.speckle import CorrelatedSpeckle
from sim.sonar.transmit_pulse import TransmitPulse


class SideScanChain:
    """Receive chain of one side-scan sonar (holds the speckle state across pings).

    config: SSSConfig whose ``acoustic.realism`` is set; mount: its SonarMount; ranges
    (S,) bin centres, m."""

    def __init__(self, config, mount, ranges: np.ndarray):
        c = config
        ac = c.acoustic
        rz = ac.realism
        self.c, self.ac, self.rz, self.m = c, ac, rz, mount
        self.ranges = ranges
        self.bin_width = c.bin_width
        self.beam_along = np.deg2rad(c.along_track_beamwidth_deg)
        self.vbw = np.deg2rad(c.vertical_beamwidth_deg)
        self.dep = np.deg2rad(c.depression_deg)
        self.psi = self.beam_along * self.vbw  # equivalent two-way solid angle, sr
        cell = rz.range_cell_m if rz.range_cell_m is not None else c.range_resolution
        self.range_cell = float(cell)
        self.speckle = (
            CorrelatedSpeckle(self.bin_width, cell, ranges, self.beam_along, rz.along_track_overlap)
            if rz.speckle_correlated
            else None
        )
        up_floor = min(c.sidelobe_db, rz.upward_sidelobe_db)
        self.beam = two_way_beam(self.vbw, self.dep, c.beam_pattern, up_floor)
        self.beam_down = two_way_beam(self.vbw, self.dep, c.beam_pattern, c.sidelobe_db)
        noise = 10.0 ** (ac.noise_level_db / 10.0)
        if rz.sea_state is not None:
            bw_hz = mount.sound_speed / (2.0 * self.range_cell)
            noise += 10.0 ** (
                ambient_noise_db(c.frequency_hz, rz.sea_state, bw_hz, self.psi) / 10.0
            )
        self.noise = noise
        self.volume = (
            volume_reverberation(
                ranges,
                ac.source_level_db,
                rz.volume_sv_db,
                self.psi,
                self.bin_width,
                mount.alpha_db_m,
            )
            if rz.volume_sv_db is not None
            else None
        )
        self.tvg = tvg_gain(ranges, mount.alpha_db_m, ac.tvg, rz.tvg_n)
        self.transmit = TransmitPulse(rz, ranges)

    def _beam_ratio(self, altitude, depth):
        """One-way vertical beam gain towards the surface image over the direct ray."""

        def ratio(g):
            down = np.arctan2(altitude, g)
            up = np.arctan2(altitude + 2.0 * depth, g)
            return np.sqrt(self.beam(up) / np.maximum(self.beam_down(-down), 1e-30))

        return ratio

    def water_column(self, mean: np.ndarray, altitude: float, z: float) -> np.ndarray:
        """mean (rows, S) plus volume, surface and multipath terms (µPa²); z: transducer
        world height, m."""
        rz, r = self.rz, self.ranges
        out = mean.copy()
        if self.volume is not None:
            out += self.volume[None, :]
        depth = sensor_depth(self.m.water, z)
        if rz.surface_wind_mps is not None:
            out += surface_return(
                r,
                depth,
                self.ac.source_level_db,
                rz.surface_wind_mps,
                self.c.frequency_hz,
                self.beam_along,
                self.bin_width,
                self.m.alpha_db_m,
                self.beam,
            )[None, :]
        if rz.surface_multipath_loss_db is not None:
            out += surface_multipath(
                mean,
                r,
                altitude,
                depth,
                rz.surface_multipath_loss_db,
                self.m.alpha_db_m,
                self._beam_ratio(altitude, depth),
            )
        return out

    def finish(self, mean, altitude, position, rng) -> np.ndarray:
        """Samples (rows, S) float32 of one ping from its mean echo (rows, S)."""
        rows = mean.shape[0]
        s = self.water_column(mean, altitude, float(position[2]))
        if self.speckle is not None:
            s = s * self.speckle.factors(rows, position, rng)
        elif self.ac.speckle != "none":
            if self.ac.speckle == "k":
                k = self.ac.k_shape
                s = s * rng.gamma(k, 1.0 / k, size=s.shape)
            s = s * rng.standard_exponential(size=s.shape)
        if self.speckle is None and self.ac.speckle == "none":
            s = s + self.noise  # mean intensities only: no draws (as the plain path)
        else:
            s = s + self.noise * rng.standard_exponential(size=s.shape)
        s = s * ping_tvg(self.tvg, altitude, self.rz, self.m.alpha_db_m, self.ac.tvg)[None, :]
        s = self.transmit(s)  # transmit pulse + ring-down (off: s unchanged)
        s = digitise(s, self.rz.receiver_gain_db, self.rz.bit_depth, self.rz.full_scale_db)
        if self.ac.log_compression:
            floor = self.ac.display_floor_db
            if floor is None:
                floor = self.ac.source_level_db + self.ac.lambert_mu_db - 60.0
            s = compress_log(s, floor, self.ac.dynamic_range_db)
        return s.astype(np.float32)
