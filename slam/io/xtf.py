"""XTF side-scan reader (through ``pyxtf``) giving a :class:`~slam.io.waterfall.Waterfall`.

Two pyxtf conventions are handled here (checked on the real Scotsman recording in
``tests/slam/io/test_xtf_reader.py``):

* ``pyxtf.concatenate_channel`` returns pings newest-first (it sorts by time, then
  reverses). We do not use it: rows here are in acquisition-time order, row 0 earliest.
* The port channel is stored far range first (its last samples are the nadir water
  column), the starboard channel near range first. Placing the stored port samples left of
  the stored starboard samples therefore gives the field's display layout: port far range
  at column 0, nadir at the centre, starboard far range at the right edge.

Pings whose sample count differs from the longest are zero-padded at the far-range end
(documented, not NaN). Navigation fields are kept only when not all zero.

A truncated file: pyxtf reads the last, cut ping with fewer samples than its channel
header's ``NumSamples`` (or fails inside its header). The intact pings before it are kept
and a :class:`~slam.io.errors.TruncatedRecordingWarning` names both counts. A ping whose
declared record size exceeds the file (a damaged header: pyxtf then reads the rest of the
file as that one packet) counts as cut the same way.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from slam.io.errors import RecordingError, TruncatedRecordingWarning
from slam.io.waterfall import Waterfall

#: XTF file-header "FileFormat" byte value (always 0x7B).
XTF_FILE_FORMAT = 123
#: XTF packet magic number 0xFACE.
XTF_MAGIC = 0xFACE
_PORT, _STBD = 1, 2  # XTFChanInfo.TypeOfChannel

_NAV_FIELDS = {
    "x": "SensorXcoordinate",
    "y": "SensorYcoordinate",
    "ship_x": "ShipXcoordinate",
    "ship_y": "ShipYcoordinate",
    "heading_deg": "SensorHeading",
    "altitude_m": "SensorPrimaryAltitude",
    "depth_m": "SensorDepth",
    "speed_knots": "SensorSpeed",
    "pitch_deg": "SensorPitch",
    "roll_deg": "SensorRoll",
}


def _check_header_bytes(path: Path) -> None:
    size = path.stat().st_size
    if size < 1024:
        raise RecordingError(
            f"{path}: not an XTF file (size {size} bytes; an XTF file header alone is 1024 bytes)"
        )
    with path.open("rb") as fh:
        head = fh.read(1024 + 2)
    if head[0] != XTF_FILE_FORMAT:
        raise RecordingError(
            f"{path}: not an XTF file (first byte {head[0]}, XTF files start with {XTF_FILE_FORMAT})"
        )


def _read_sonar_packets(path: Path):
    """(file header, sonar ping packets in file order, error text or None): packets are
    read one by one so an error inside the last (cut) packet keeps the ones before it."""
    import pyxtf

    try:
        gen = pyxtf.xtf_read_gen(str(path), types=[pyxtf.XTFHeaderType.sonar])
        file_header = next(gen)
    except Exception as exc:  # ctypes/pyxtf raise many types on a bad header
        raise RecordingError(f"{path}: unreadable XTF file header ({exc})") from exc
    pings, broken = [], None
    while True:
        try:
            pings.append(next(gen))
        except StopIteration:
            break
        except Exception as exc:  # a cut packet: keep what was read before it
            broken = f"{type(exc).__name__}: {exc}"
            break
    return file_header, pings, broken


def _is_intact(ping, file_size: int) -> bool:
    """Every channel holds the samples its channel header announces, and the packet's
    declared size fits in the file (a larger one swallowed the packets after it)."""
    return (
        all(
            len(d) == int(h.NumSamples)
            for d, h in zip(ping.data, ping.ping_chan_headers, strict=False)
        )
        and len(ping.data) > 0
        and int(getattr(ping, "NumBytesThisRecord", 0)) <= file_size
    )


def read_xtf(path: str | Path, *, channels: tuple[int, int] | None = None) -> Waterfall:
    """Read the side-scan sonar channels of an XTF file.

    Parameters
    ----------
    path : XTF file.
    channels : optional (port_index, starboard_index) into each ping's data list; by default
        taken from the file header's channel types (port = 1, starboard = 2).

    Returns
    -------
    Waterfall with ``intensity`` (pings, 2·S) float32 raw sample values, rows in time order.

    Raises
    ------
    RecordingError (a ValueError) for missing, non-XTF files, files cut before their first
    intact ping, or files without a port/starboard pair. A file cut later keeps its intact
    pings with a TruncatedRecordingWarning.
    """
    path = Path(path)
    if not path.is_file():
        raise RecordingError(f"XTF path {str(path)!r} is not a file")
    _check_header_bytes(path)
    file_header, pings, broken = _read_sonar_packets(path)
    size = path.stat().st_size
    intact = [p for p in pings if _is_intact(p, size)]
    n_cut = len(pings) - len(intact) + int(broken is not None)
    if n_cut and not intact:
        raise RecordingError(
            f"{path}: truncated XTF file: no intact side-scan ping before the cut"
            + (f" ({broken})" if broken else "")
        )
    if not intact:
        raise RecordingError(f"{path}: XTF file holds no side-scan sonar pings")
    if n_cut:
        warnings.warn(
            f"{path}: truncated XTF file: kept {len(intact)} intact pings, dropped "
            f"{n_cut} cut ping(s)",
            TruncatedRecordingWarning,
            stacklevel=2,
        )
    pings = intact
    pings.sort(key=lambda p: p.get_time())  # stable: keeps file order for equal times

    if channels is None:
        types = [
            file_header.ChanInfo[ch.ChannelNumber].TypeOfChannel
            for ch in pings[0].ping_chan_headers
        ]
        if _PORT not in types or _STBD not in types:
            raise RecordingError(
                f"{path}: need one port (type 1) and one starboard (type 2) channel, "
                f"file has channel types {types}"
            )
        i_port, i_stbd = types.index(_PORT), types.index(_STBD)
    else:
        i_port, i_stbd = channels
    n_ch = len(pings[0].data)
    for name, i in (("port", i_port), ("starboard", i_stbd)):
        if not 0 <= i < n_ch:
            raise RecordingError(f"{name} channel index {i} out of range [0, {n_ch})")

    sizes = [max(len(p.data[i_port]), len(p.data[i_stbd])) for p in pings]
    s = max(sizes)
    if s == 0:
        raise RecordingError(f"{path}: pings hold no samples")
    n = len(pings)
    port = np.zeros((n, s), dtype=np.float32)
    stbd = np.zeros((n, s), dtype=np.float32)
    for k, p in enumerate(pings):
        dp = np.asarray(p.data[i_port], dtype=np.float32)
        ds = np.asarray(p.data[i_stbd], dtype=np.float32)
        port[k, s - dp.size :] = dp  # stored far-range first: pad at the far (left) end
        stbd[k, : ds.size] = ds

    t = np.array([p.get_time() for p in pings], dtype="datetime64[ns]")
    time_s = (t - t[0]).astype(np.float64) * 1e-9
    hdr = [p.ping_chan_headers[i_stbd] for p in pings]
    slant = np.array([h.SlantRange for h in hdr], dtype=np.float64)
    freq_khz = np.array(
        [file_header.ChanInfo[h.ChannelNumber].Frequency or h.Frequency for h in hdr],
        dtype=np.float64,
    )
    freq = np.where(freq_khz > 0, freq_khz * 1e3, np.nan)
    sv = np.array([p.SoundVelocity for p in pings], dtype=np.float64)
    sv = np.where(sv > 0, sv, np.nan)
    nav = {}
    for key, attr in _NAV_FIELDS.items():
        v = np.array([getattr(p, attr, 0.0) for p in pings], dtype=np.float64)
        if np.any(v != 0.0):
            nav[key] = v
    if "x" in nav or "y" in nav:
        # XTF file header NavUnits: 0 = metres (projected), 3 = degrees (lon, lat)
        nav["xtf_nav_units"] = np.full(len(pings), float(file_header.NavUnits))
    return Waterfall(
        intensity=np.concatenate([port, stbd], axis=1),
        samples_per_side=s,
        time_s=time_s,
        slant_range_m=slant,
        frequency_hz=freq,
        sound_velocity_m_s=sv,
        nav=nav,
        time_origin=str(t[0]),
        source=str(path),
    )
