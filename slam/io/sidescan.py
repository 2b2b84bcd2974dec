"""One entry point for side-scan recordings: :func:`read_sidescan`.

Formats (chosen by the file suffix):

========================  ===================  =====================================
suffix                    format               library
========================  ===================  =====================================
``.xtf``                  eXtended Triton      ``pyxtf`` (:mod:`slam.io.xtf`)
``.jsf``                  EdgeTech JSF         ``pingverter`` (MIT)
``.dat`` / ``.son``       Humminbird           ``pingverter`` — the ``.DAT`` beside
                                               the folder of ``.SON``/``.IDX`` files
``.sl2`` / ``.sl3``       Lowrance             ``pingverter``
``.rsd``                  Garmin               ``pingverter``
========================  ===================  =====================================

Every reader returns a :class:`SidescanRecording`: the waterfall (rows in time order,
port left / starboard right, :mod:`slam.io.waterfall`) and a :class:`PingNav` of per-ping
navigation arrays. Bad files raise :class:`~slam.io.errors.RecordingError` (a
``ValueError``); a file that ends inside a ping keeps its intact pings and warns with
:class:`~slam.io.errors.TruncatedRecordingWarning`.
"""

from __future__ import annotations

from pathlib import Path

from slam.io.errors import RecordingError
from slam.io.pingverter_reader import read_pingverter
from slam.io.recording import SidescanRecording, pingnav_from_xtf
from slam.io.xtf import read_xtf

#: suffix (lower case) -> format name
SUFFIX_FORMATS: dict[str, str] = {
    ".xtf": "xtf",
    ".jsf": "jsf",
    ".dat": "humminbird",
    ".son": "humminbird",
    ".sl2": "lowrance",
    ".sl3": "lowrance",
    ".rsd": "garmin",
}


def detect_format(path: str | Path) -> str:
    """The format name of ``path`` from its suffix; RecordingError for others."""
    suffix = Path(path).suffix.lower()
    if suffix not in SUFFIX_FORMATS:
        allowed = ", ".join(sorted(SUFFIX_FORMATS))
        raise RecordingError(
            f"{path}: unsupported side-scan recording suffix {suffix!r}; allowed: {allowed}"
        )
    return SUFFIX_FORMATS[suffix]


def read_sidescan(path: str | Path) -> SidescanRecording:
    """Read a side-scan recording (XTF, JSF, Humminbird, Lowrance SL2/SL3, Garmin RSD).

    Returns pings in time order with per-ping navigation and the sonar's range and
    frequency (see the module docstring). Raises :class:`RecordingError` for a missing,
    empty, wrong-format or unreadable file.
    """
    path = Path(path)
    fmt = detect_format(path)
    if not path.is_file():
        raise RecordingError(f"recording path {str(path)!r} is not a file")
    if path.stat().st_size == 0:
        raise RecordingError(f"{path}: empty file (0 bytes)")
    if fmt == "xtf":
        wf = read_xtf(path)
        return SidescanRecording(waterfall=wf, nav=pingnav_from_xtf(wf), format="xtf")
    return read_pingverter(path, fmt)
