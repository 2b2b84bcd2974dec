"""Switches and levels of the image-realism effects (sediment backscatter, correlated
speckle, water column, receiver, target glints, FLS azimuth sidelobes).

``AcousticConfig.realism = None`` (the default of the analytic presets) turns every effect
off and leaves the old echo model bit for bit. A :class:`RealismConfig` turns each effect
on or off by its own field (``None`` or ``False`` = off). Levels in dB (re 1 µPa² for
intensities, re 1 m² / m² for scattering strengths), lengths in m, angles in degrees at
this boundary. Flat scalar fields so that scenario files can override any of them
(``[[vehicles.sonars]] overrides = { texture_db = 2.0 }``); see docs/sonar_realism.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from sim.sonar.transmit_pulse import TransmitPulseFields
from sim.sonar.validate import check_optional_range, check_range

SeabedModel = Literal["lambert", "sediment"]
TvgReference = Literal["transducer", "bottom"]
SEDIMENT_NAMES = ("mud", "sand", "gravel", "rock")


@dataclass(frozen=True)
class RealismConfig(TransmitPulseFields):
    """Image-realism effects of one sonar (all fields validated; ``None``/``False`` = off).

    Seabed (item 1): seabed_model "sediment" replaces Lambert × seabed reflectivity with
    the per-sediment law of :mod:`sim.sonar.sediment` over a seeded patch field
    (sediment_seed; frac_mud/sand/gravel/rock: area fractions, renormalised;
    patch_scale_m: correlation length of the patches; texture_db / texture_scale_m: rms
    (dB) and correlation length of the within-sediment strength variation;
    ripple_wavelength_m / ripple_slope / ripple_direction_deg: sub-mesh sand ripples as a
    local slope (rms slope, 0 = off) tilting the normal of sandy hits; k_clutter: K-type
    clutter, a world-fixed unit-mean gamma texture per clutter_cell_m cell with the
    sediment's shape; sediment_gain_db: offset of every sediment law;
    low_grazing_knee_deg / low_grazing_exponent: below the knee grazing angle θk every
    sediment law falls faster than Lambert, × 1 / (1 + (sin θk / sin θg)^m), m the exponent
    (None = off: the laws as published, sin² at low grazing); see :mod:`sim.sonar.sediment`;
    micro_slope_deg / micro_slope_cell_m: world-fixed facets of micro_slope_cell_m m, each
    tilted by a Gaussian slope (rms micro_slope_deg per axis; None = off) — relief below
    the mesh, which modulates the return most where the law is steep (low grazing));
    grazing_clutter_deg / grazing_clutter_exponent: a K-type texture per clutter cell
    whose shape falls with the grazing angle, 1/ν = (sin θc / sin θg)^p (None = off; see
    :mod:`sim.sonar.sediment`).
    Speckle (item 2): speckle_correlated: complex Gaussian speckle on a sub-sample grid
    filtered by the range cell (range_cell_m, None = the sonar's range_resolution c/2B)
    and carried across pings by an AR(1) with the along-track beam overlap
    (along_track_overlap False: independent pings).
    Water column and receiver (item 3): volume_sv_db: volume backscattering strength
    (dB re 1/m, None = off); sea_state (Knudsen ambient noise, plus Mellen thermal noise;
    None = off) reduced by the receive directivity index; surface_wind_mps: Chapman–Harris
    sea-surface backscatter (None = off); surface_multipath_loss_db: loss of the first
    surface-bounce path of the seabed echo (None = off); upward_sidelobe_db: floor of the
    one-way vertical pattern above horizontal (side-scan staves are baffled on top),
    used by both surface terms; receiver_gain_db; tvg_exponent: the TVG's spreading law
    r^n (None = the acoustic config's tvg, r⁴; 3 = "30 log R"); tvg_reference:
    "transducer" (the TVG runs from the transmit) or "bottom" (the recorder's TVG referenced
    to the first bottom return: the water column gets the gain of the bottom return, flat
    in range; see :func:`sim.sonar.receiver.ping_tvg`); bit_depth
    (amplitude bits, 0 = no quantisation/clipping) with full_scale_db the intensity after
    TVG and gain (dB re 1 µPa²) at which the ADC saturates.
    Targets (item 4): object_mu_db: Lambert μ (dB) of a reflectivity-1 object, replacing
    lambert_mu_db on object hits (steel plating is far stronger than sand; None = keep);
    facet_specular_db / facet_width_deg: per-facet specular glint of
    objects (σ peak re 1 m²/m² and lobe width; None = off); corner_gain_db /
    corner_width_deg: double-bounce (dihedral: hull–seabed, deck–superstructure) returns
    traced with a second ray (None = off); fls_azimuth_sidelobe_db: first sidelobe of the
    FLS receive beams across beams (None = off).
    Receiver (item 3): the transmit pulse and its ring-down in the first samples of each
    ping, fields ``transmit_*`` from :class:`sim.sonar.transmit_pulse.TransmitPulseFields`
    (``transmit_level_db`` None = off).
    """

    seabed_model: SeabedModel = "sediment"
    sediment_seed: int = 0
    frac_mud: float = 0.25
    frac_sand: float = 0.6
    frac_gravel: float = 0.15
    frac_rock: float = 0.0
    patch_scale_m: float = 12.0
    texture_db: float = 1.0
    texture_scale_m: float = 0.8
    ripple_wavelength_m: float = 0.7
    ripple_slope: float = 0.06
    ripple_direction_deg: float = 30.0
    k_clutter: bool = True
    clutter_cell_m: float = 0.06
    sediment_gain_db: float = 0.0
    low_grazing_knee_deg: float | None = None
    low_grazing_exponent: float = 4.0
    micro_slope_deg: float | None = None
    micro_slope_cell_m: float = 0.2
    grazing_clutter_deg: float | None = None
    grazing_clutter_exponent: float = 5.0
    speckle_correlated: bool = True
    range_cell_m: float | None = None
    along_track_overlap: bool = True
    volume_sv_db: float | None = -80.0
    sea_state: float | None = 2.0
    surface_wind_mps: float | None = 5.0
    surface_multipath_loss_db: float | None = 8.0
    upward_sidelobe_db: float = -25.0
    receiver_gain_db: float = 0.0
    tvg_exponent: float | None = None
    tvg_reference: TvgReference = "transducer"
    bit_depth: int = 16
    full_scale_db: float = 150.0
    object_mu_db: float | None = -22.0
    facet_specular_db: float | None = 3.0
    facet_width_deg: float = 4.0
    corner_gain_db: float | None = -24.0
    corner_width_deg: float = 6.0
    fls_azimuth_sidelobe_db: float | None = -28.0

    @property
    def tvg_n(self) -> float:
        """The TVG's spreading exponent n of r^n: ``tvg_exponent``, or 4 (r⁴) when None."""
        return 4.0 if self.tvg_exponent is None else self.tvg_exponent

    def __post_init__(self) -> None:
        super().__post_init__()  # the transmit-pulse fields (sim.sonar.transmit_pulse)
        if self.seabed_model not in ("lambert", "sediment"):
            raise ValueError(
                f"seabed_model = {self.seabed_model!r}; allowed: 'lambert', 'sediment'"
            )
        if not isinstance(self.sediment_seed, int) or self.sediment_seed < 0:
            raise ValueError(f"sediment_seed = {self.sediment_seed!r}; allowed: integer >= 0")
        fr = [getattr(self, f"frac_{n}") for n in SEDIMENT_NAMES]
        for n, v in zip(SEDIMENT_NAMES, fr, strict=True):
            check_range(f"frac_{n}", v, 0.0, 1.0)
        if sum(fr) <= 0:
            raise ValueError(f"frac_mud/sand/gravel/rock = {fr}; allowed: at least one > 0")
        check_range("patch_scale_m", self.patch_scale_m, 1.0, 500.0)
        check_range("texture_db", self.texture_db, 0.0, 10.0)
        check_range("texture_scale_m", self.texture_scale_m, 0.2, 50.0)
        check_range("ripple_wavelength_m", self.ripple_wavelength_m, 0.05, 20.0)
        check_range("ripple_slope", self.ripple_slope, 0.0, 0.5)
        check_range("ripple_direction_deg", self.ripple_direction_deg, -360.0, 360.0)
        check_range("clutter_cell_m", self.clutter_cell_m, 0.005, 5.0)
        check_range("sediment_gain_db", self.sediment_gain_db, -40.0, 40.0)
        check_optional_range("low_grazing_knee_deg", self.low_grazing_knee_deg, 0.5, 60.0)
        check_range("low_grazing_exponent", self.low_grazing_exponent, 0.5, 12.0)
        check_optional_range("micro_slope_deg", self.micro_slope_deg, 0.0, 20.0)
        check_range("micro_slope_cell_m", self.micro_slope_cell_m, 0.01, 5.0)
        check_optional_range("grazing_clutter_deg", self.grazing_clutter_deg, 0.5, 45.0)
        check_range("grazing_clutter_exponent", self.grazing_clutter_exponent, 0.5, 12.0)
        check_optional_range("range_cell_m", self.range_cell_m, 1e-4, 5.0)
        check_optional_range("volume_sv_db", self.volume_sv_db, -150.0, -20.0)
        check_optional_range("sea_state", self.sea_state, 0.0, 6.0)
        check_optional_range("surface_wind_mps", self.surface_wind_mps, 0.5, 30.0)
        check_optional_range("surface_multipath_loss_db", self.surface_multipath_loss_db, 0.0, 60.0)
        check_range("upward_sidelobe_db", self.upward_sidelobe_db, -80.0, 0.0)
        check_range("receiver_gain_db", self.receiver_gain_db, -100.0, 100.0)
        check_optional_range("tvg_exponent", self.tvg_exponent, 1.0, 6.0)
        if self.tvg_reference not in ("transducer", "bottom"):
            raise ValueError(
                f"tvg_reference = {self.tvg_reference!r}; allowed: 'transducer', 'bottom'"
            )
        if not isinstance(self.bit_depth, int) or not 0 <= self.bit_depth <= 24:
            raise ValueError(f"bit_depth = {self.bit_depth!r}; allowed: integer 0 .. 24")
        check_range("full_scale_db", self.full_scale_db, 0.0, 300.0)
        check_optional_range("object_mu_db", self.object_mu_db, -60.0, 0.0)
        check_optional_range("facet_specular_db", self.facet_specular_db, -40.0, 30.0)
        check_range("facet_width_deg", self.facet_width_deg, 0.1, 45.0)
        check_optional_range("corner_gain_db", self.corner_gain_db, -40.0, 40.0)
        check_range("corner_width_deg", self.corner_width_deg, 0.1, 45.0)
        check_optional_range("fls_azimuth_sidelobe_db", self.fls_azimuth_sidelobe_db, -80.0, -3.0)

    @property
    def fractions(self) -> tuple[float, ...]:
        """Area fractions of mud, sand, gravel, rock, normalised to sum 1."""
        fr = [getattr(self, f"frac_{n}") for n in SEDIMENT_NAMES]
        s = sum(fr)
        return tuple(v / s for v in fr)


def all_off() -> RealismConfig:
    """A RealismConfig with every effect off (equivalent to ``realism = None`` except that
    the sediment model keeps Lambert: used by tests)."""
    return RealismConfig(
        seabed_model="lambert",
        k_clutter=False,
        speckle_correlated=False,
        volume_sv_db=None,
        sea_state=None,
        surface_wind_mps=None,
        surface_multipath_loss_db=None,
        bit_depth=0,
        object_mu_db=None,
        facet_specular_db=None,
        corner_gain_db=None,
        fls_azimuth_sidelobe_db=None,
    )
