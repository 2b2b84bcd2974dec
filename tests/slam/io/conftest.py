"""Fixture writing tiny synthetic XTF files with pyxtf's own ctypes structures (pyxtf has
no writer), so the reader is tested without shipping a recording."""

from __future__ import annotations

import numpy as np
import pytest


def _write_xtf(path, port, stbd, times_s, slant=30.0, nav_x=None):
    """port / stbd: (P, S) uint16 as an XTF stores them (port far range first, starboard
    near range first); times_s: (P,) seconds after 2020-01-01T00:00 (hundredths kept)."""
    from pyxtf import xtf_ctypes as x

    fh = x.XTFFileHeader()
    fh.FileFormat = 123
    fh.SystemType = 1
    fh.NumberOfSonarChannels = 2
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


@pytest.fixture
def write_xtf():
    return _write_xtf
