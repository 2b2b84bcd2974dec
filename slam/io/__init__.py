"""Readers for real sonar data: image files and side-scan recordings.

Submodules are imported lazily so ``slam.io.images`` never pays for ``pyxtf``,
``pingverter`` or ``rasterio``; ``slam.io.read_sidescan`` is resolved on first use.

* :mod:`slam.io.sidescan` — ``read_sidescan(path) -> SidescanRecording``: XTF, EdgeTech
  JSF, Humminbird, Lowrance SL2/SL3, Garmin RSD (pings in time order, per-ping navigation,
  range, frequency).
* :mod:`slam.io.images` — ``read_image(path) -> SonarImage`` (PNG/JPG/TIFF, 8/16-bit,
  refused above a stated pixel bound).
* :mod:`slam.io.xtf` — ``read_xtf(path) -> Waterfall`` (side-scan, via pyxtf).
* :mod:`slam.io.pingverter_reader` — the formats read through ``pingverter``.
* :mod:`slam.io.recording` — ``SidescanRecording`` and ``PingNav``.
* :mod:`slam.io.waterfall` — the ``Waterfall`` dataclass every reader produces.
* :mod:`slam.io.geo` — mosaic GeoTIFF and GeoJSON (WGS84) outputs.
* :mod:`slam.io.errors` — ``RecordingError`` (a ValueError), ``TruncatedRecordingWarning``.
"""

from __future__ import annotations

import importlib


def __getattr__(name: str):
    if name == "read_sidescan":
        return importlib.import_module("slam.io.sidescan").read_sidescan
    raise AttributeError(f"module 'slam.io' has no attribute {name!r}")
