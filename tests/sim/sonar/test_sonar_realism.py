"""Image-realism effects: sediment field, correlated speckle, water column and receiver,
glints, FLS sidelobes; each against an independent expectation (analytic law, published
number, numerical integral)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from scipy import special, stats

from sim.sonar import ForwardLookingSonar, preset
from sim.sonar.effects import RealismConfig, all_off
from sim.sonar.glint import add_azimuth_sidelobes, azimuth_sidelobe_kernel
from sim.sonar.receiver import ambient_noise_db, digitise, volume_reverberation
from sim.sonar.scenes import SceneObject, build_scene
from sim.sonar.sediment import SEDIMENTS, SedimentField
from sim.sonar.speckle import CorrelatedSpeckle

MU = 10 ** (-27 / 10)


def _sss(scene, name="deepeye680d_realistic", **over):
    return scene.sidescan(preset(name, max_range=40.0, **over))


def _survey(scene, son, n, step=0.107, seed=1):
    """n pings while the vehicle advances ``step`` m along x per ping."""
    rng = np.random.default_rng(seed)
    q = scene.model.jnt_qposadr[0]
    x0 = float(scene.data.qpos[q])
    out = []
    for k in range(n):
        scene.data.qpos[q] = x0 + k * step
        mujoco.mj_forward(scene.model, scene.data)
        out.append(son.ping(scene.data, rng))
    scene.data.qpos[q] = x0
    mujoco.mj_forward(scene.model, scene.data)
    return out


# ---------------------------------------------------------------- sediment ----------
def test_sediment_law_reduces_to_lambert_far_from_the_specular_lobe():
    """Lurton's generic law A·exp(−θ²/2w²) + B·cos^β θ with β = 2 is Lambert's μ cos²θ
    (μ = B) once θ is many lobe widths from normal."""
    sand = SEDIMENTS["sand"]
    th = np.deg2rad(np.array([50.0, 60.0, 70.0, 80.0]))
    lam = 10 ** (sand.b_db / 10) * np.cos(th) ** 2
    assert np.allclose(sand.sigma(th), lam, rtol=1e-6)
    # and the ranking of the published curves: rock > gravel > sand > mud at 60° incidence
    s = [SEDIMENTS[n].sigma(np.deg2rad(60.0)) for n in ("rock", "gravel", "sand", "mud")]
    assert s == sorted(s, reverse=True)


@pytest.mark.parametrize(
    "fractions", [(0.25, 0.25, 0.25, 0.25), (0.1, 0.6, 0.2, 0.1), (0.0, 0.0, 0.0, 1.0)]
)
def test_sediment_patches_cover_the_requested_area_fractions(fractions):
    """The dominant sediment of a place covers the configured area fractions (± 0.03 over
    a 400 m square, one period of the field)."""
    cfg = RealismConfig(
        **dict(zip(("frac_mud", "frac_sand", "frac_gravel", "frac_rock"), fractions))
    )
    f = SedimentField(cfg, MU)
    g = np.stack(np.meshgrid(np.arange(0, 409.6, 0.8), np.arange(0, 409.6, 0.8)), -1)
    w, _ = f.lookup(g.reshape(-1, 2))
    share = np.bincount(np.argmax(w, axis=1), minlength=4) / w.shape[0]
    assert np.allclose(share, cfg.fractions, atol=0.03), share


def test_texture_rms_is_texture_db_without_rebuilding_the_fields():
    """The within-sediment texture has rms ``texture_db`` over one field period (the field
    nodes: the construction's own definition), and another ``texture_db`` reuses the
    cached fields (no 1024² rebuild per calibration step)."""
    from sim.sonar.sediment import FIELD_CELL_M, FIELD_SIZE, _fields

    g = np.stack(np.meshgrid(*(2 * [np.arange(FIELD_SIZE) * FIELD_CELL_M])), -1).reshape(-1, 2)
    f1 = SedimentField(RealismConfig(texture_db=1.0), MU)
    misses = _fields.cache_info().misses
    f3 = SedimentField(RealismConfig(texture_db=3.0), MU)
    assert _fields.cache_info().misses == misses
    for f, rms in ((f1, 1.0), (f3, 3.0)):
        _, tex = f.lookup(g)
        assert np.sqrt(np.mean(tex**2)) == pytest.approx(rms, rel=1e-3)


def test_k_clutter_texture_recovers_the_sediment_gamma_shape():
    """The world-fixed clutter texture is Γ(ν, 1/ν): mean 1, variance 1/ν (method-of-moments
    K shape recovery) and a KS fit to the gamma law, for gravel (ν = 5)."""
    f = SedimentField(RealismConfig(), MU)
    xy = np.random.default_rng(0).uniform(-200, 200, size=(40000, 2))
    nu = SEDIMENTS["gravel"].k_shape
    t = f.clutter(xy, np.full(xy.shape[0], nu))
    assert abs(t.mean() - 1) < 0.02
    assert abs(1 / t.var() - nu) / nu < 0.1
    assert stats.kstest(t, stats.gamma(nu, scale=1 / nu).cdf).pvalue > 0.001
    # fixed in the world: the same place gives the same value
    assert np.array_equal(t[:100], f.clutter(xy[:100], np.full(100, nu)))


def test_sand_ripples_imprint_their_wavelength_on_the_backscatter():
    """Sub-mesh ripples of wavelength λ tilt the normal periodically: σ along the ripple
    direction has its spectral peak at 1/λ (flat normal, 70° incidence, sand only)."""
    lam = 0.7
    cfg = RealismConfig(
        frac_mud=0,
        frac_sand=1,
        frac_gravel=0,
        frac_rock=0,
        ripple_direction_deg=0,
        ripple_wavelength_m=lam,
        texture_db=0.0,
        k_clutter=False,
    )
    f = SedimentField(cfg, MU)
    x = np.arange(0, 51.2, 0.05)
    pts = np.stack([x, np.zeros_like(x), np.zeros_like(x)], 1)
    n = np.tile([0.0, 0.0, 1.0], (x.size, 1))
    d = np.tile([np.sin(np.deg2rad(70)), 0.0, -np.cos(np.deg2rad(70))], (x.size, 1))
    s = f.sigma_over_mu(pts, n, d)
    spec = np.abs(np.fft.rfft(s - s.mean()))
    freq = np.fft.rfftfreq(x.size, 0.05)
    assert abs(freq[np.argmax(spec)] - 1 / lam) < 0.05


# ---------------------------------------------------------------- speckle -----------
def test_fully_developed_looks_give_the_gamma_intensity_law():
    """Range cell ≪ sample: M independent sub-samples per bin, intensity Γ(M, 1/M): mean 1
    and the amplitude CV of an M-look intensity, √(M Γ(M)²/Γ(M+½)² − 1)."""
    sp = CorrelatedSpeckle(0.04, 1e-4, np.linspace(1, 40, 1000), 0.0035, overlap=False)
    rng = np.random.default_rng(2)
    i = np.concatenate([sp.factors(2, np.zeros(3), rng).ravel() for _ in range(20)])
    m = sp.m
    assert abs(i.mean() - 1) < 0.02
    cv = np.sqrt(m * special.gamma(m) ** 2 / special.gamma(m + 0.5) ** 2 - 1)
    a = np.sqrt(i)
    assert abs(a.std() / a.mean() - cv) / cv < 0.05
    assert stats.kstest(i, stats.gamma(m, scale=1 / m).cdf).pvalue > 0.001


def test_range_correlation_grows_with_the_range_cell():
    """Samples closer than the resolution cell share scatterers: lag-1 correlation of the
    intensity is ≈ 0 for δr ≪ Δr and rises with δr/Δr."""
    rng = np.random.default_rng(3)

    def lag1(cell):
        sp = CorrelatedSpeckle(0.04, cell, np.linspace(1, 40, 1000), 0.0035, overlap=False)
        x = np.stack([sp.factors(1, np.zeros(3), rng)[0] for _ in range(20)])
        x = x - x.mean()
        return float((x[:, 1:] * x[:, :-1]).sum() / (x * x).sum())

    c = [lag1(v) for v in (0.005, 0.04, 0.08)]
    assert abs(c[0]) < 0.05 and c[0] < c[1] < c[2]


def test_ping_to_ping_correlation_is_the_beam_overlap_integral():
    """Intensity correlation of consecutive pings = |ρ|², ρ the normalised overlap integral
    ∫w(x)w(x−d)dx / ∫w² of the Gaussian along-track illumination (numerical quadrature)."""
    bw, d, r = np.deg2rad(0.5), 0.1, 20.0
    sp = CorrelatedSpeckle(0.04, 0.04, np.full(2000, r), bw)
    rng = np.random.default_rng(4)
    f = [sp.factors(1, np.array([k * d, 0, 0]), rng)[0] for k in range(40)]
    a, b = np.stack(f[:-1]).ravel(), np.stack(f[1:]).ravel()
    sx = r * bw / (2 * np.sqrt(2 * np.log(2)))
    x = np.linspace(-10 * sx, 10 * sx, 20001)
    w = np.exp(-0.5 * (x / sx) ** 2)
    rho = np.trapezoid(w * np.exp(-0.5 * ((x - d) / sx) ** 2), x) / np.trapezoid(w * w, x)
    assert abs(np.corrcoef(a, b)[0, 1] - rho**2) < 0.05


# ---------------------------------------------------------------- receiver ----------
def test_adc_saturation_of_exponential_intensity_is_exp_minus_fs_over_mean():
    """Clipping at full scale I_fs: for exponential intensity of mean m the saturated share
    is P(I ≥ I_fs) = exp(−I_fs/m); quantisation error below one count."""
    i = np.random.default_rng(5).standard_exponential(200000) * 10.0**12
    out = digitise(i, 0.0, 12, 130.0)
    fs = 10.0**13
    assert abs((out >= fs * (1 - 1e-12)).mean() - np.exp(-fs / 1e12)) < 0.002
    ok = i < fs
    assert np.all(np.abs(np.sqrt(out[ok]) - np.sqrt(i[ok])) <= np.sqrt(fs) / 4095 + 1e-6)


def test_volume_reverberation_falls_as_r_squared_with_absorption():
    """Urick: I_v ∝ Ψ Δr r⁻² 10^(−2αr/10): 20·log10 between 10 and 20 m plus 2α·10 m."""
    r = np.array([10.0, 20.0])
    v = volume_reverberation(r, 210.0, -80.0, 0.003, 0.04, 0.2)
    assert abs(10 * np.log10(v[0] / v[1]) - (20 * np.log10(2) + 2 * 0.2 * 10)) < 1e-9


def test_thermal_noise_dominates_at_high_frequency():
    """Mellen (1952): thermal noise −15 + 20 log10 f_kHz dB/Hz; at 680 kHz and sea state 0 it
    is > 30 dB above Knudsen's wind noise, so the band level is the thermal one."""
    f, b, psi = 680e3, 1.0, 4 * np.pi  # 1 Hz band, omnidirectional
    assert abs(ambient_noise_db(f, 0.0, b, psi) - (-15 + 20 * np.log10(680))) < 0.01


# ---------------------------------------------------------------- images ------------
@pytest.fixture(scope="module")
def box_on_sand():
    return build_scene(
        altitude=8.0,
        objects=[SceneObject("box", (0.0, 14.0, 1.0), (2.0, 1.0, 1.0), reflectivity=1.0)],
        seabed_cells=20,
        seabed_reflectivity=0.3,
    )


def test_realistic_pings_are_seeded_bit_identical(box_on_sand):
    """Same seed, same bytes (speckle state, fields, clutter); another seed differs."""
    a = _survey(box_on_sand, _sss(box_on_sand), 3, seed=5)
    b = _survey(box_on_sand, _sss(box_on_sand), 3, seed=5)
    c = _survey(box_on_sand, _sss(box_on_sand), 3, seed=6)
    assert all(x.intensity.tobytes() == y.intensity.tobytes() for x, y in zip(a, b))
    assert a[-1].intensity.tobytes() != c[-1].intensity.tobytes()


def test_all_off_realism_reproduces_the_plain_mean_echo(box_on_sand):
    """With every effect off and speckle/noise/TVG off, the realism path gives the plain
    path's image exactly (same mean echo, same labels)."""
    q = dict(speckle="none", noise_level_db=-100.0, tvg="none", log_compression=False)
    a = _sss(box_on_sand, "deepeye680d", acoustic=q).ping(
        box_on_sand.data, np.random.default_rng(0)
    )
    b = _sss(box_on_sand, "deepeye680d", acoustic=dict(q, realism=all_off())).ping(
        box_on_sand.data, np.random.default_rng(0)
    )
    assert np.allclose(a.intensity, b.intensity, rtol=1e-6)
    assert np.array_equal(a.labels, b.labels)


def test_corner_return_lands_at_the_box_base_edge(box_on_sand):
    """The wall–seabed dihedral returns along the incoming ray: the double-bounce path
    equals twice the slant range to the base edge, so the added energy peaks there."""
    q = dict(speckle="none", noise_level_db=-100.0, tvg="none", log_compression=False)
    base = dict(
        q,
        realism=RealismConfig(
            seabed_model="lambert",
            k_clutter=False,
            speckle_correlated=False,
            volume_sv_db=None,
            sea_state=None,
            surface_wind_mps=None,
            surface_multipath_loss_db=None,
            bit_depth=0,
            facet_specular_db=None,
        ),
    )
    on = _sss(box_on_sand, "deepeye680d", acoustic=base).ping(
        box_on_sand.data, np.random.default_rng(0)
    )
    off_rz = base["realism"].__class__(**{**base["realism"].__dict__, "corner_gain_db": None})
    off = _sss(box_on_sand, "deepeye680d", acoustic=dict(q, realism=off_rz)).ping(
        box_on_sand.data, np.random.default_rng(0)
    )
    gain = on.side("port") - off.side("port")
    r = on.slant_range[on.samples_per_side :]
    h = float(box_on_sand.data.site_xpos[box_on_sand.sites["sss"], 2])
    r_edge = np.hypot(13.0, h)  # near face at y = 14 − 1 m (MJCF half sizes), base z = 0
    assert gain.max() > 0
    assert abs(r[np.argmax(gain)] - r_edge) < 0.3


def test_wreck_like_target_stands_10_to_25_db_over_the_seabed(box_on_sand):
    """Item 4's target: the object's brightest samples (95th percentile) stand 10–25 dB over
    the median seabed just before it with the realistic preset (steel box on the sediment
    field), measured before the ADC (which clips glints, as real recorders do)."""
    p = _survey(box_on_sand, _sss(box_on_sand, log_compression=False, bit_depth=0), 12)
    i = np.stack([x.side("port") for x in p]).astype(float)
    lab = np.stack([x.labels[: x.samples_per_side][::-1] for x in p])
    cols = np.flatnonzero((lab == 1).any(axis=0))
    sea = i[:, cols.min() - 60 : cols.min() - 10][lab[:, cols.min() - 60 : cols.min() - 10] == 0]
    over = 10 * np.log10(np.percentile(i[lab == 1], 95) / np.median(sea))
    assert 10.0 <= over <= 25.0, over


def test_fls_sidelobe_kernel_first_sidelobe_level():
    """Line-array sinc²: the first sidelobe peak (x ≈ 1.43) of the kernel sits at the
    configured level, the main lobe is excluded, and a single bright beam leaks exactly the
    kernel into the others."""
    k = azimuth_sidelobe_kernel(512, np.deg2rad(90 / 512), np.deg2rad(1.0), -28.0)
    assert abs(10 * np.log10(k.max()) + 28.0) < 0.3
    assert k[k.size // 2] == 0
    img = np.zeros((512, 4))
    img[256, 1] = 1.0
    out = add_azimuth_sidelobes(img, k)
    assert np.allclose(out[:, 1] - img[:, 1], k[511 - 256 : 511 - 256 + 512], atol=1e-12)


def test_fls_frame_with_realism_runs_and_differs_only_by_sidelobes(box_on_sand):
    """FLS with only the sidelobes on: the frame is the plain one plus non-negative leak."""
    q = dict(speckle="none", noise_level_db=-100.0, tvg="none", log_compression=False)
    rz = RealismConfig(**{**all_off().__dict__, "fls_azimuth_sidelobe_db": -20.0})

    def frame(realism):
        cfg = preset(
            "blueview_p900_90", max_range=30.0, n_beams=64, acoustic=dict(q, realism=realism)
        )
        s = box_on_sand
        son = ForwardLookingSonar(
            cfg, s.model, s.data, s.sites["fls"], s.geom_object_id, s.geom_reflectivity, s.water
        )
        return son.frame(s.data, np.random.default_rng(0)).image

    a, b = frame(None), frame(rz)
    assert np.all(b >= a * (1 - 1e-6)) and b.sum() > a.sum()


def test_realism_fields_are_validated_and_switchable_from_scenario_values():
    """Bad values name the field; "off" (TOML has no null) switches an optional level off;
    a scenario using the realistic preset with overrides parses."""
    with pytest.raises(ValueError, match="texture_db"):
        preset("deepeye680d_realistic", texture_db=99.0)
    with pytest.raises(ValueError, match="frac_mud"):
        preset("deepeye680d_realistic", frac_mud=0.0, frac_sand=0.0, frac_gravel=0.0)
    assert preset("deepeye680d_realistic", volume_sv_db="off").acoustic.realism.volume_sv_db is None
    assert preset("deepeye680d").acoustic.realism is None
    from sim.scenario.schema import ScenarioError, _parse_sonar, load_scenario

    sp = _parse_sonar({"preset": "deepeye680d_realistic", "overrides": {"texture_db": 2.0}}, "s")
    assert sp.is_sidescan
    with pytest.raises(ScenarioError, match="texture_db"):
        _parse_sonar({"preset": "deepeye680d_realistic", "overrides": {"texture_db": 99.0}}, "s")
    assert load_scenario("shipwreck-survey", {"world.relief_m": 0.3}).world.relief_m == 0.3
    with pytest.raises(ScenarioError, match="relief_m"):
        load_scenario("shipwreck-survey", {"world.relief_m": -1.0})
