"""XTF reader: ping order, port orientation, metadata, bad files."""

from __future__ import annotations

import numpy as np
import pytest

from slam.io.xtf import read_xtf


def _ramps(p=6, s=32):
    # near-range value k*10 at sample k from nadir on both sides (port stored far first)
    near_first = np.arange(1, s + 1, dtype=np.uint16) * 10
    port = np.tile(near_first[::-1], (p, 1))
    stbd = np.tile(near_first, (p, 1))
    return port, stbd


def test_rows_in_time_order_even_when_file_order_is_reversed(tmp_path, write_xtf):
    """Pings written newest-first come back oldest-first: row k carries the marker written
    for time k (independent expectation: the marker value we wrote)."""
    port, stbd = _ramps()
    times = np.array([5.0, 4.0, 3.0, 2.0, 1.0, 0.5])
    port[:, 0] = np.arange(6)[::-1] * 100  # marker = rank of its time
    f = write_xtf(tmp_path / "rev.xtf", port, stbd, times, nav_x=np.arange(6.0) + 1)
    w = read_xtf(f)
    assert w.intensity.shape == (6, 64)
    np.testing.assert_array_equal(w.intensity[:, 0], np.arange(6) * 100)
    np.testing.assert_allclose(w.time_s, np.sort(times) - 0.5)
    assert np.all(np.diff(w.time_s) > 0)
    np.testing.assert_allclose(w.nav["x"], (np.arange(6.0) + 1)[::-1])
    assert "heading_deg" not in w.nav  # all-zero fields are dropped


def test_port_far_range_left_nadir_centre(tmp_path, write_xtf):
    """Both sides rise with range in the file, so the display row must be symmetric about
    the centre with its minimum at the nadir columns S-1 and S."""
    port, stbd = _ramps(s=32)
    w = read_xtf(write_xtf(tmp_path / "o.xtf", port, stbd, np.arange(6.0)))
    row = w.intensity[0]
    np.testing.assert_array_equal(row, row[::-1])
    assert row[31] == row[32] == 10 and row[0] == row[-1] == 320
    np.testing.assert_array_equal(w.port[0], w.starboard[0])  # near-range-first views agree
    assert w.samples_per_side == 32
    np.testing.assert_allclose(w.slant_range_m, 30.0)
    np.testing.assert_allclose(w.frequency_hz, 600e3)


def test_truncated_and_non_xtf_files_raise_value_error(tmp_path, write_xtf):
    port, stbd = _ramps()
    good = write_xtf(tmp_path / "g.xtf", port, stbd, np.arange(6.0)).read_bytes()
    trunc = tmp_path / "t.xtf"
    trunc.write_bytes(good[: 1024 + 300])
    with pytest.raises(ValueError, match="truncated"):
        read_xtf(trunc)
    junk = tmp_path / "j.xtf"
    junk.write_bytes(b"PK\x03\x04" + bytes(4000))
    with pytest.raises(ValueError, match="not an XTF"):
        read_xtf(junk)
    tiny = tmp_path / "e.xtf"
    tiny.write_bytes(b"")
    with pytest.raises(ValueError, match="not an XTF"):
        read_xtf(tiny)
    with pytest.raises(ValueError, match="not a file"):
        read_xtf(tmp_path / "missing.xtf")
    header_only = tmp_path / "h.xtf"
    header_only.write_bytes(good[:1024])
    with pytest.raises(ValueError, match="no side-scan"):
        read_xtf(header_only)


@pytest.mark.shared_data
def test_real_scotsman_orientation(shared_data):
    """Real recording (README facts): 461 pings, 2x1024 samples, 29.98 m, 600 kHz; the dark
    water column sits at the centre of the waterfall; the wreck (bright returns) is on
    starboard around the labelled ping 281, sample 138 (.hits file, time order)."""
    w = read_xtf(shared_data / "xtf" / "scotsman-iver2.xtf")
    assert w.intensity.shape == (461, 2048)
    assert np.all(np.diff(w.time_s) > 0)
    np.testing.assert_allclose(w.slant_range_m, 29.98, atol=0.01)
    np.testing.assert_allclose(w.frequency_hz, 600e3)
    med = np.median(w.intensity, axis=0)
    s = 1024
    # water column: samples 20..120 from nadir on both sides are dark vs the outer half
    for side in (med[:s][::-1], med[s:]):
        assert np.median(side[20:120]) < 0.1 * np.median(side[300:700])
    # the hit (.hits, "channel sample ping"): starboard, near edge of the wreck. The wreck's
    # highlights saturate (32767): in the 80 pings up to the hit, starboard has > 2x the
    # saturated fraction of port, and > 1.5x that of the same rows counted in reversed order.
    ch, sample, ping = map(
        int, (shared_data / "xtf" / "scotsman-iver2.xtf.hits").read_text().split()
    )
    assert ch == 1 and 0 < sample < s

    def saturated(side, r0, r1):
        return float((side[r0:r1, 20:600] >= 32767).mean())

    stbd_hit = saturated(w.starboard, ping - 60, ping + 20)
    assert stbd_hit > 2.0 * saturated(w.port, ping - 60, ping + 20)
    rev = w.n_pings - 1 - ping
    assert stbd_hit > 1.5 * saturated(w.starboard, rev - 20, rev + 60)
