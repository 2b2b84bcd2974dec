"""Realism statistics of side-scan waterfalls (real or simulated) and their comparison.

Pure numpy/scipy/scikit-image: runs on real recordings, imports no simulator.

* :mod:`slam.realism.statistics` — ``waterfall_statistics(intensity) -> WaterfallStatistics``
  (speckle CV, dB std, lag-1 correlations, water-column level, dynamic range, saturation).
* :mod:`slam.realism.textures` — intensity / LBP histograms and their distances.
* :mod:`slam.realism.bottom` — the small first-bottom-return detector the statistics use.
* :mod:`slam.realism.kdist` — K-distribution shape estimators.
* :mod:`slam.realism.compare` — the side-by-side table of two recordings.

Definitions: docs/realism.md.
"""
