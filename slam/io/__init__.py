"""Readers for real sonar data: image files and XTF side-scan recordings.

Submodules are imported lazily so ``slam.io.images`` never pays for ``pyxtf``.

* :mod:`slam.io.images` — ``read_image(path) -> SonarImage`` (PNG/JPG/TIFF, 8/16-bit).
* :mod:`slam.io.xtf` — ``read_xtf(path) -> Waterfall`` (side-scan, via pyxtf).
* :mod:`slam.io.waterfall` — the ``Waterfall`` dataclass both produce.
"""
