"""`undersea calibrate --altitude-track legs`: each simulated leg flies the median altitude
of its share of the recording's pings; the model's first return follows each leg."""

from __future__ import annotations

import numpy as np
import pytest

from sim.cli.calibrate_cmd import leg_altitudes, model_first_return
from sim.realism.survey import SurveySpec
from slam.realism.recordings import Recording


def _rec(alt):
    return Recording(np.ones((alt.size, 64)), "x", "npy", altitude_m=alt, slant_range_m=30.0)


def test_leg_altitudes_are_chunk_medians_of_the_positive_altitudes():
    alt = np.concatenate([np.full(10, 9.0), np.full(10, 5.0), [0.0, 3.0, 3.0, 4.0]])
    # three consecutive chunks of 8 pings (numpy.array_split); zeros (no nav fix) left out
    legs = leg_altitudes(_rec(alt), 3, 30.0, "legs")
    expect = [np.median(c[c > 0]) for c in np.array_split(alt, 3)]
    assert legs == pytest.approx(expect)
    assert leg_altitudes(_rec(alt), 3, 30.0, "median") == ()
    assert leg_altitudes(Recording(np.ones((24, 64)), "x", "npy"), 3, 30.0, "legs") == ()


def test_model_first_return_follows_each_leg():
    spec = SurveySpec(6.0, 20.0, 200, pings=32, segments=2, leg_altitudes_m=(4.0, 8.0))
    fr = model_first_return(spec)
    assert fr.shape == (32,)
    assert np.allclose(fr[:16], 4.0 / 0.1) and np.allclose(fr[16:], 8.0 / 0.1)


def test_fit_tvg_adds_the_tvg_exponent_from_r4():
    import argparse

    from sim.cli.calibrate_cmd import _model, add_arguments

    parser = argparse.ArgumentParser()
    add_arguments(parser)
    names = {}
    for extra in ([], ["--fit-tvg"]):
        args = parser.parse_args(["r.xtf", "--out", "o.toml", "--gain", "fit", *extra])
        _, params, _ = _model(args, 5.0, 20.0, 128, None)
        names[bool(extra)] = {p.name: p for p in params}
    assert "tvg_exponent" not in names[False]
    p = names[True]["tvg_exponent"]
    assert (p.lo, p.hi, p.initial) == (2.0, 5.0, 4.0)  # the preset's None is the r⁴ law
