"""The statistics on the real Scotsman XTF against the issue's independent measurement
(issue 11 table: CV 0.38/0.36, dB std 3.3/3.1, water column −41/−38 dB, dynamic range
58/55 dB, saturation 1.4 %/2.4 %), within the issue's own tolerances."""

from __future__ import annotations

import numpy as np
import pytest

from slam.io.xtf import read_xtf
from slam.realism.statistics import waterfall_statistics

ISSUE = {  # port, starboard
    "cv_amplitude": ((0.38, 0.36), "rel", 0.10),
    "db_std": ((3.3, 3.1), "abs", 0.5),
    "water_column_db": ((-41.0, -38.0), "abs", 6.0),
    "dynamic_range_db": ((58.0, 55.0), "abs", 8.0),
}


def test_scotsman_statistics_match_the_issue_measurement(shared_data):
    w = read_xtf(shared_data / "xtf" / "scotsman-iver2.xtf")
    stats = waterfall_statistics(w.intensity.astype(np.float64) ** 2)  # samples are amplitude
    for i, side in enumerate((stats.port, stats.starboard)):
        assert side.bottom_fraction > 0.95
        for key, (values, kind, tol) in ISSUE.items():
            got, want = getattr(side, key), values[i]
            if kind == "rel":
                assert got == pytest.approx(want, rel=tol), key
            else:
                assert got == pytest.approx(want, abs=tol), key
        want_sat = (0.014, 0.024)[i]
        assert want_sat / 2 <= side.saturation <= want_sat * 2
