"""Calibration recovers the known parameters of the statistical model, and says when it
cannot."""

from __future__ import annotations

import numpy as np
import pytest

from slam.realism.calibration import CalibrationError, Parameter, calibrate
from slam.realism.statistics import RealismConfig, waterfall_statistics
from slam.realism.synthetic import FULL_SCALE, PARAMETERS, StatisticalSideScan

SIZE = dict(pings=96, samples_per_side=320)
MODEL_STATS = RealismConfig(full_scale=FULL_SCALE)


def test_fit_recovers_the_true_parameters_from_another_realization():
    """Target drawn with seed 1 at known values; the model (seed 0, other speckle and
    texture draws) starts elsewhere and must land near the truth. The bounds follow from
    the fit's own stopping rule (every statistic within its issue-11 tolerance): e.g.
    lag-1 ±0.1 is about ±0.1 on the AR(1) coefficient near 0.5 (amplitude correlation
    ≈ 0.92·phi²), plus the difference between the two realizations."""
    truth = dict(
        gain_db=-9.0,
        texture_db=2.5,
        corr_range=0.55,
        corr_ping=0.5,
        water_column_db=-40.0,
        looks=2.5,
    )
    target = waterfall_statistics(StatisticalSideScan(seed=1, **SIZE)(truth))
    r = calibrate(StatisticalSideScan(seed=0, **SIZE), target, PARAMETERS, model_config=MODEL_STATS)
    tol = dict(
        gain_db=1.0, texture_db=0.5, corr_range=0.12, corr_ping=0.12, water_column_db=2.0, looks=0.5
    )
    for k, t in tol.items():
        assert r.values[k] == pytest.approx(truth[k], abs=t), k
    assert r.loss < 0.1 * r.initial_loss
    assert all(abs(v) <= 1.0 for k, v in r.residuals.items() if not k.startswith("headroom"))


def test_unreachable_target_raises_did_not_converge():
    """Heavy K clutter (CV far above Rayleigh) while the model's texture is capped at
    0.5 dB: the CV cannot be met, the error names it."""
    rng = np.random.default_rng(3)
    model = StatisticalSideScan(seed=0, **SIZE)
    target_img = model({"texture_db": 0.0})
    seabed = target_img > 10 ** (-3.5)  # everything but the water column
    target_img[seabed] *= rng.gamma(0.5, 2.0, seabed.sum())
    target = waterfall_statistics(target_img)
    capped = [Parameter("texture_db", 0.0, 0.5, 0.2), Parameter("gain_db", -30.0, 0.0, -12.0)]
    with pytest.raises(CalibrationError, match=r"did not converge.*cv_amplitude"):
        calibrate(model, target, capped, max_evaluations=20, model_config=MODEL_STATS)


def test_model_without_image_at_the_start_raises():
    target = waterfall_statistics(StatisticalSideScan(seed=1, **SIZE)({}))

    def broken(values):
        return np.ones((8, 64))  # too short

    with pytest.raises(CalibrationError, match="no usable image"):
        calibrate(broken, target, PARAMETERS[:1])


def test_parameter_validation_and_unit_mapping():
    with pytest.raises(ValueError, match="lo < hi"):
        Parameter("x", 1.0, 0.0, 0.5)
    with pytest.raises(ValueError, match="log scale"):
        Parameter("x", 0.0, 1.0, 0.5, log=True)
    p = Parameter("cell", 0.01, 1.0, 0.1, log=True)
    assert p.to_unit(0.1) == pytest.approx(0.5)
    assert p.from_unit(p.to_unit(0.37)) == pytest.approx(0.37)
    with pytest.raises(ValueError, match="unique"):
        calibrate(StatisticalSideScan(**SIZE), None, [PARAMETERS[0], PARAMETERS[0]])


def test_model_runs_stay_within_the_budget_and_stop_when_good_enough():
    """The budget counts every model run (finite differences too); a start that already
    matches (the target is the model's own image there) ends the search after one run."""
    calls = []
    model = StatisticalSideScan(seed=0, **SIZE)

    def counted(values):
        calls.append(dict(values))
        return model(values)

    other = dict(gain_db=-9.0, texture_db=2.5, corr_range=0.55, corr_ping=0.5, looks=2.5)
    far = waterfall_statistics(StatisticalSideScan(seed=1, **SIZE)(other))
    with pytest.raises(CalibrationError):  # 7 runs cannot fit six parameters from afar
        calibrate(counted, far, PARAMETERS, max_evaluations=7, model_config=MODEL_STATS)
    assert len(calls) <= 7
    calls.clear()
    start = {p.name: p.initial for p in PARAMETERS}
    own = waterfall_statistics(model(start), MODEL_STATS)
    r = calibrate(counted, own, PARAMETERS, good_enough=0.8, model_config=MODEL_STATS)
    assert len(calls) == 1 and r.evaluations == 1 and r.values == pytest.approx(start)


def test_fit_with_tile_texture_meets_it_too():
    """With ``fit_tile_texture`` the seabed texture at the patch scale is a convergence
    feature: the converged fit has it within 1 dB of the target's as well."""
    truth = dict(
        gain_db=-9.0,
        texture_db=3.0,
        corr_range=0.5,
        corr_ping=0.4,
        water_column_db=-40.0,
        looks=2.0,
    )
    target = waterfall_statistics(StatisticalSideScan(seed=1, **SIZE)(truth))
    r = calibrate(
        StatisticalSideScan(seed=0, **SIZE),
        target,
        PARAMETERS,
        model_config=MODEL_STATS,
        fit_tile_texture=True,
    )
    for side in ("port", "starboard"):
        assert abs(r.residuals[f"texture_tile_db.{side}"]) <= 1.0
        sim, real = r.after.sides()[side], target.sides()[side]
        assert abs(sim.texture_tile_db - real.texture_tile_db) <= 1.0


def test_model_first_return_for_a_model_without_a_dark_water_column():
    """A display-like model whose water column is as bright as its seabed: the detector
    finds no bottom in its images (no usable image); given the first return it knows
    (its altitude), the fit runs and meets its own image."""
    from tests.slam.realism.conftest import WC_SAMPLES, make_waterfall

    def model(values):
        rng = np.random.default_rng(0)
        w = make_waterfall(
            rng.exponential(1.0, (96, 256)), rng.exponential(1.0, (96, 256)), rng
        ) * 10.0 ** (values["gain_db"] / 10.0)
        s = w.shape[1] // 2  # water column (WC_SAMPLES next to nadir) as bright as seabed
        w[:, s - WC_SAMPLES : s + WC_SAMPLES] = rng.exponential(1.0, (96, 2 * WC_SAMPLES))
        return w

    fr = np.full(96, float(WC_SAMPLES))
    target = waterfall_statistics(model({"gain_db": 0.0}), first_return=fr)
    p = [Parameter("gain_db", -3.0, 3.0, 0.0)]
    with pytest.raises(CalibrationError, match="no usable image"):
        calibrate(model, target, p, max_evaluations=3)
    r = calibrate(model, target, p, max_evaluations=3, model_first_return=WC_SAMPLES)
    assert r.values["gain_db"] == 0.0 and r.loss == pytest.approx(0.0, abs=1e-12)


def test_far_range_residual_is_in_2_db_units_and_joins_convergence_when_asked():
    """A model whose outer quarter is 10× (10 dB) darker than the target's: the far-range
    residual is the measured difference over 2 dB, and with ``fit_far_range`` a fit that
    cannot move it (its one parameter leaves the far range alone) does not converge."""
    from slam.realism.calibration import FAR_RANGE_TOLERANCE_DB, residual_keys, residuals
    from tests.slam.realism.conftest import WC_SAMPLES, make_waterfall

    rng = np.random.default_rng(4)
    s = WC_SAMPLES + 448
    cut = (3 * s) // 4 - WC_SAMPLES

    def image(far, gain=1.0):
        mean = np.ones(448)
        mean[cut:] = far
        sides = [rng.exponential(1.0, (256, 448)) * mean * gain for _ in range(2)]
        return make_waterfall(*sides, rng)

    real = waterfall_statistics(image(1.0))
    sim = waterfall_statistics(image(0.1))
    res = residuals(sim, real)
    for side in ("port", "starboard"):
        d = sim.sides()[side].far_range_db - real.sides()[side].far_range_db
        assert d == pytest.approx(-10.0, abs=0.5)
        assert res[f"far_range_db.{side}"] == pytest.approx(d / FAR_RANGE_TOLERANCE_DB)
    keys, n_conv = residual_keys(fit_far_range=True)
    assert "far_range_db.port" in keys[:n_conv]
    with pytest.raises(CalibrationError, match="far_range_db"):
        calibrate(
            lambda v: image(0.1, v["g"]),
            real,
            [Parameter("g", 0.5, 2.0, 1.0)],
            max_evaluations=6,
            fit_far_range=True,
        )
