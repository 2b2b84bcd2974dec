"""Writers of tiny synthetic recordings for reader and CLI tests: XTF with pyxtf's own
ctypes structures (pyxtf has no writer) and Lowrance SL2 from its published frame layout,
so the readers are tested without shipping a recording."""

from __future__ import annotations

import numpy as np


def write_xtf(path, port, stbd, times_s, slant=30.0, nav_x=None, lonlat=None, heading=None,
               altitude=None):
    """port / stbd: (P, S) uint16 as an XTF stores them (port far range first, starboard
    near range first); times_s: (P,) seconds after 2020-01-01T00:00 (hundredths kept).
    lonlat: optional ((P,), (P,)) degrees (NavUnits = 3); heading, altitude: optional (P,)."""
    from pyxtf import xtf_ctypes as x

    fh = x.XTFFileHeader()
    fh.FileFormat = 123
    fh.SystemType = 1
    fh.NumberOfSonarChannels = 2
    if lonlat is not None:
        fh.NavUnits = 3
    for k, (typ, name) in enumerate(((1, b"PORT"), (2, b"STARBOARD"))):
        fh.ChanInfo[k].TypeOfChannel = typ
        fh.ChanInfo[k].SubChannelNumber = k
        fh.ChanInfo[k].BytesPerSample = 2
        fh.ChanInfo[k].Frequency = 600.0
        fh.ChanInfo[k].ChannelName = name
    out = bytearray(bytes(fh))
    n, s = port.shape
    for i in range(n):
        ph = x.XTFPingHeader()
        ph.MagicNumber = 0xFACE
        ph.HeaderType = 0
        ph.NumChansToFollow = 2
        ph.NumBytesThisRecord = 256 + 2 * (64 + 2 * s)
        t = float(times_s[i])
        ph.Year, ph.Month, ph.Day = 2020, 1, 1
        ph.Hour, ph.Minute, ph.Second = int(t // 3600), int(t % 3600 // 60), int(t % 60)
        ph.HSeconds = round((t % 1) * 100)
        ph.PingNumber = i
        ph.SoundVelocity = 750.0
        if nav_x is not None:
            ph.SensorXcoordinate = float(nav_x[i])
        if lonlat is not None:
            ph.SensorXcoordinate, ph.SensorYcoordinate = float(lonlat[0][i]), float(lonlat[1][i])
        if heading is not None:
            ph.SensorHeading = float(heading[i])
        if altitude is not None:
            ph.SensorPrimaryAltitude = float(altitude[i])
        out += bytes(ph)
        for k, data in enumerate((port[i], stbd[i])):
            ch = x.XTFPingChanHeader()
            ch.ChannelNumber = k
            ch.SlantRange = slant
            ch.NumSamples = s
            ch.Frequency = 600
            out += bytes(ch)
            out += np.asarray(data, dtype="<u2").tobytes()
    path.write_bytes(bytes(out))
    return path




#: Lowrance's spherical-Mercator radius (sonarlight / pingverter), m.
LOWRANCE_R = 6356752.3142


def write_sl2(path, samples, *, lon, lat, max_range_ft=60.0, depth_ft=10.0, speed_kn=4.0,
               cog_rad=0.5, dt_ms=100, survey_type=5):
    """A Lowrance SL2 written from its published frame layout (pingverter's ``sl2Struct``,
    after sonarlight / SL3Reader): 8-byte file header, then per ping a 144-byte frame
    header and ``packet_size`` one-byte samples. ``samples``: (P, 2S) uint8 in the
    combined side-scan layout (port far range first, then starboard near range first).
    Positions are encoded with the forward spherical Mercator
    (``x = R·λ``, ``y = R·ln tan(π/4 + φ/2)``), the inverse of the reader's conversion."""
    from pingverter.lowrance_class import sl2Struct

    samples = np.asarray(samples, dtype=np.uint8)
    p, width = samples.shape
    out = bytearray(np.array([2, 0, 3200], dtype="<u2").tobytes() + bytes([0, 0]))
    for i in range(p):
        h = np.zeros(1, dtype=sl2Struct)
        h["frame_offset"] = len(out)
        h["frame_size"] = 144 + width
        h["survey_type"] = survey_type
        h["packet_size"] = width
        h["id"] = i
        h["max_range"] = max_range_ft
        h["frequency_type"] = 3
        h["hardware_time"] = 1_600_000_000
        h["depth_ft"] = depth_ft
        h["gps_speed"] = speed_kn
        h["utm_e"] = round(LOWRANCE_R * np.radians(lon[i]))
        h["utm_n"] = round(LOWRANCE_R * np.log(np.tan(np.pi / 4 + np.radians(lat[i]) / 2)))
        h["track_cog"] = cog_rad
        h["heading"] = cog_rad
        h["time_s"] = i * dt_ms
        out += h.tobytes() + samples[i].tobytes()
    path.write_bytes(bytes(out))
    return path
