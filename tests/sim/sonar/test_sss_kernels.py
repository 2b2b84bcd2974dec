"""The compiled side-scan receive steps (sim.sonar.sss_kernels.py) against the numpy
chain they replace in the ping (acoustics.finish_samples, then the port reversal)."""

from __future__ import annotations

import numpy as np
import pytest

from sim.sonar.acoustics import finish_samples, tvg_gain
from sim.sonar.config import AcousticConfig
from sim.sonar.sss_kernels import ping_samples


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


@pytest.mark.parametrize("seed", range(6))
def test_probe_altitude_is_numpy_median_of_the_hits_in_range(seed):
    """Second implementation: np.median of −d_z·dist over the rays with dist ≤ max_range
    (odd and even counts, misses at inf, hits beyond range); NaN when none is in range."""
    from sim.sonar.sss_kernels import probe_altitude

    rng = np.random.default_rng(seed)
    n = 14
    dirs = rng.normal(size=(n, 3))
    dirs[:, 2] = -np.abs(dirs[:, 2])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    dist = rng.uniform(1.0, 80.0, n)
    dist[rng.uniform(size=n) < 0.3] = np.inf
    ok = dist <= 50.0
    got = probe_altitude(dirs, dist, 50.0)
    if ok.any():
        assert got == np.median(-dirs[ok, 2] * dist[ok])
    else:
        assert np.isnan(got)
    assert np.isnan(probe_altitude(dirs, np.full(n, np.inf), 50.0))
