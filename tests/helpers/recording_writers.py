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


def write_jsf(path, port, stbd, *, lon, lat, t0=1_600_000_000, dt_s=1, heading_deg=45.0,
              speed_kn=3.0, altitude_m=6.0, interval_ns=20_000, sound_speed=1500.0,
              freq_dahz=(39000, 41000), weight=0):
    """An EdgeTech JSF written from the published layout (JSF spec rev. 1.20, message 80;
    the offsets pingverter's ``jsf._decode_msg80`` reads): per ping and side a 16-byte
    message header (marker 0x1601, type 80, channel 0 port / 1 starboard, payload size)
    then the 240-byte sonar-data header and u16 envelope samples (format 0), near range
    first on both sides. Positions in minutes × 10000 (coordinate units 2); ``dt_s`` whole
    seconds between pings (the format's time field is in whole seconds plus ms of day)."""
    import struct

    port, stbd = np.asarray(port, dtype="<u2"), np.asarray(stbd, dtype="<u2")
    p, s = port.shape
    out = bytearray()
    for i in range(p):
        for channel, data in ((0, port[i]), (1, stbd[i])):
            h80 = bytearray(240)
            struct.pack_into("<i", h80, 0, t0 + i * dt_s)
            struct.pack_into("<I", h80, 8, i)
            struct.pack_into("<H", h80, 30, (1 << 6) | (1 << 9))  # altitude, depth valid
            struct.pack_into("<h", h80, 34, 0)  # envelope data
            struct.pack_into("<i", h80, 80, round(lon[i] * 600000))
            struct.pack_into("<i", h80, 84, round(lat[i] * 600000))
            struct.pack_into("<h", h80, 88, 2)  # minutes of arc × 10000
            struct.pack_into("<H", h80, 114, s)
            struct.pack_into("<I", h80, 116, interval_ns)
            struct.pack_into("<HH", h80, 126, *freq_dahz)
            struct.pack_into("<i", h80, 136, round(altitude_m * 1000))
            struct.pack_into("<i", h80, 144, round(altitude_m * 1000))
            struct.pack_into("<f", h80, 148, sound_speed)
            struct.pack_into("<h", h80, 168, weight)
            struct.pack_into("<H", h80, 172, round(heading_deg * 100))
            struct.pack_into("<h", h80, 194, round(speed_kn * 10))
            head = struct.pack("<HBBHBBBBHi", 0x1601, 16, 0, 80, 0, 20, channel, 0, 0, 240 + 2 * s)
            out += head + bytes(h80) + data.tobytes()
    path.write_bytes(bytes(out))
    return path
