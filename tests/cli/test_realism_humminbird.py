"""The private Humminbird loader on the real recording, against the independent numbers
of ../shared/data/README.md (speckle CV of amplitude 0.12 / 0.16, 16-px patches;
seabed dynamic range 10 / 19 dB, a different definition, so only the order is checked)."""

from __future__ import annotations

import numpy as np
import pytest

from sim.cli.realism_io import first_return_for, load_humminbird
from slam.realism.statistics import waterfall_statistics


def test_humminbird_speckle_cv_matches_the_independent_measurement(shared_data):
    rec = load_humminbird(shared_data / "humminbird" / "test.DAT")
    assert rec.intensity.shape[1] % 2 == 0 and rec.altitude_m is not None
    assert not (rec.intensity == 0).all(axis=1).any()  # no padded pings
    half = rec.pings(0, rec.n_pings // 2)
    st = waterfall_statistics(half.intensity, first_return=first_return_for(half, "altitude"))
    assert st.port.cv_amplitude == pytest.approx(0.12, rel=0.1)
    assert st.starboard.cv_amplitude == pytest.approx(0.16, rel=0.1)
    assert st.port.dynamic_range_db < st.starboard.dynamic_range_db
    assert np.isfinite(st.port.water_column_db)
