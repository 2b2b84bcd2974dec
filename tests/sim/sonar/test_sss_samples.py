"""The compiled side-scan receive steps (sim/sonar/sss_samples.py) against the numpy
chain they replace in the ping (acoustics.finish_samples, then the port reversal)."""

from __future__ import annotations

import numpy as np
import pytest

from sim.sonar.acoustics import finish_samples, tvg_gain
from sim.sonar.config import AcousticConfig
from sim.sonar.sss_samples import ping_samples


@pytest.mark.parametrize("speckle", ["none", "rayleigh", "k"])
@pytest.mark.parametrize("tvg", ["none", "spreading", "spreading_absorption"])
@pytest.mark.parametrize("log", [True, False])
@pytest.mark.parametrize("floor", [None, 95.0])
def test_ping_samples_same_bytes_as_finish_samples(speckle, tvg, log, floor):
    """Second implementation: finish_samples with the same Generator state, rows joined
    port-reversed, gives the same float32 bytes (mean echoes over 25 decades, zeros
    and sub-floor values included, so both clips are exercised)."""
    rng = np.random.default_rng(7)
    S = 1000
    mean = 10.0 ** rng.uniform(-5.0, 20.0, (2, S))
    mean[:, ::17] = 0.0
    r = 0.5 + 0.05 * np.arange(S)
    cfg = AcousticConfig(
        speckle=speckle, tvg=tvg, log_compression=log, display_floor_db=floor, k_shape=2.5
    )
    alpha = 0.2
    g = tvg_gain(r, alpha, tvg)
    noise = 10.0 ** (cfg.noise_level_db / 10.0)
    a = ping_samples(mean, cfg, np.random.default_rng(3), g, noise)
    ref = finish_samples(mean, r, alpha, cfg, np.random.default_rng(3), g)
    ref = np.concatenate([ref[0, ::-1], ref[1]])
    assert a.dtype == np.float32 and a.shape == (2 * S,)
    assert a.tobytes() == ref.tobytes()
    if log:
        assert (a == 0.0).any() and (a == 1.0).any() and ((a > 0.0) & (a < 1.0)).any()
