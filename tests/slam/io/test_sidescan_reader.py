"""slam.io.read_sidescan: every format behind one call, on files written here (XTF with
pyxtf's ctypes structures, Lowrance SL2 from its published frame layout) and on the real
Humminbird recording; truncated, empty and wrong-format files."""

from __future__ import annotations

import shutil
import warnings

import numpy as np
import pytest

from slam.io.errors import RecordingError, TruncatedRecordingWarning
from slam.io.sidescan import read_sidescan

FT = 0.3048  # m per international foot
KNOT = 1852.0 / 3600.0  # m/s per knot


def _sl2_pings(rng, p=12, s=40):
    return rng.integers(1, 255, size=(p, 2 * s)).astype(np.uint8)


def test_sl2_samples_nav_range_and_frequency_as_written(tmp_path, write_sl2, rng):
    """Independent expectations: the bytes written, the foot/knot/radian conversions, the
    forward Mercator the writer used, and the 455 kHz code (3) of the frame header."""
    px = _sl2_pings(rng)
    lon = np.linspace(10.0, 10.002, len(px))
    lat = np.linspace(55.0, 55.001, len(px))
    rec = read_sidescan(write_sl2(tmp_path / "a.sl2", px, lon=lon, lat=lat, cog_rad=0.5))
    w = rec.waterfall
    assert rec.format == "lowrance"
    np.testing.assert_array_equal(w.intensity, px)  # port far range left: SL2's own order
    np.testing.assert_allclose(w.slant_range_m, 60.0 * FT, rtol=1e-6)
    np.testing.assert_allclose(w.frequency_hz, 455e3)
    np.testing.assert_allclose(w.time_s, 0.1 * np.arange(len(px)), atol=1e-9)
    # integer Mercator metres in the file: 1 m is ~1e-5 deg
    np.testing.assert_allclose(rec.nav.lon_deg, lon, atol=2e-5)
    np.testing.assert_allclose(rec.nav.lat_deg, lat, atol=2e-5)
    np.testing.assert_allclose(rec.nav.heading_deg, np.degrees(0.5), rtol=1e-6)
    np.testing.assert_allclose(rec.nav.speed_m_s, 4.0 * KNOT, rtol=1e-4)
    np.testing.assert_allclose(rec.nav.altitude_m, 10.0 * FT, rtol=1e-6)
    assert w.nav["xtf_nav_units"][0] == 3.0  # lon/lat flagged for the SLAM pipeline


def test_sl2_truncated_keeps_intact_pings(tmp_path, write_sl2, rng):
    px = _sl2_pings(rng)
    lon, lat = np.full(len(px), 10.0), np.full(len(px), 55.0)
    full = write_sl2(tmp_path / "a.sl2", px, lon=lon, lat=lat).read_bytes()
    cut = tmp_path / "cut.sl2"
    cut.write_bytes(full[: len(full) - 25])  # inside the last ping's samples
    with pytest.warns(TruncatedRecordingWarning, match="kept 11 whole frames"):
        rec = read_sidescan(cut)
    np.testing.assert_array_equal(rec.waterfall.intensity, px[:-1])
    head_only = tmp_path / "h.sl2"
    head_only.write_bytes(full[:8 + 100])
    with pytest.raises(RecordingError, match="not a Lowrance recording"):
        read_sidescan(head_only)


def test_xtf_through_read_sidescan_and_truncation(tmp_path, write_xtf, rng):
    """The XTF path: rows in time order, and a file cut inside its last ping keeps the
    others (equal to the first rows of the full read)."""
    p, s = 6, 32
    port = rng.integers(0, 4000, size=(p, s)).astype(np.uint16)
    stbd = rng.integers(0, 4000, size=(p, s)).astype(np.uint16)
    path = write_xtf(tmp_path / "a.xtf", port, stbd, np.arange(p, dtype=float))
    full = read_sidescan(path)
    assert full.format == "xtf" and full.n_pings == p
    np.testing.assert_allclose(full.range_m, 30.0)
    np.testing.assert_array_equal(full.waterfall.intensity[:, :s], port)
    cut = tmp_path / "cut.xtf"
    cut.write_bytes(path.read_bytes()[:-40])
    with pytest.warns(TruncatedRecordingWarning, match="kept 5 intact pings"):
        part = read_sidescan(cut)
    np.testing.assert_array_equal(part.waterfall.intensity, full.waterfall.intensity[:5])


@pytest.mark.parametrize("suffix", [".xtf", ".sl2", ".sl3", ".jsf", ".rsd", ".DAT"])
def test_empty_and_wrong_format_files_raise_recording_error(tmp_path, suffix):
    empty = tmp_path / f"e{suffix}"
    empty.write_bytes(b"")
    with pytest.raises(RecordingError, match="empty"):
        read_sidescan(empty)
    junk = tmp_path / f"j{suffix}"
    junk.write_bytes(b"PK\x03\x04" + bytes(range(256)) * 20)
    with pytest.raises(RecordingError, match=str(junk.name)):
        read_sidescan(junk)


def test_unknown_suffix_and_missing_file(tmp_path):
    with pytest.raises(RecordingError, match=r"unsupported side-scan recording suffix '\.txt'"):
        read_sidescan(tmp_path / "a.txt")
    with pytest.raises(RecordingError, match="not a file"):
        read_sidescan(tmp_path / "missing.sl2")
    assert issubclass(RecordingError, ValueError)


@pytest.mark.shared_data
def test_real_humminbird(shared_data):
    """Independent facts of the recording: each side-scan channel's .IDX index holds one
    8-byte entry per ping; 455 kHz side-scan (data README); the DAT header's water type
    and the unit's depth field between 1 and 7 m; the two sides' water columns mirror."""
    dat = shared_data / "humminbird" / "test.DAT"
    rec = read_sidescan(dat)
    n_idx = (shared_data / "humminbird" / "test" / "B003.IDX").stat().st_size // 8
    assert rec.format == "humminbird"
    assert rec.n_pings == n_idx
    np.testing.assert_allclose(rec.frequency_hz, 455e3)
    assert np.all(np.diff(rec.time_s) >= 0)
    assert np.all(rec.nav.has_position)
    assert 1.0 <= np.nanmin(rec.nav.altitude_m) and np.nanmax(rec.nav.altitude_m) <= 7.0
    assert np.all((rec.nav.heading_deg >= 0) & (rec.nav.heading_deg < 360))
    # near range of both sides (water column, then seabed) mirrors about the centre
    w = rec.waterfall
    near_port = w.port[:, :300].mean(axis=0)
    near_stbd = w.starboard[:, :300].mean(axis=0)
    assert np.corrcoef(near_port, near_stbd)[0, 1] > 0.9
    # a .SON path finds the same recording through its .DAT
    son = read_sidescan(shared_data / "humminbird" / "test" / "B002.SON")
    assert son.n_pings == rec.n_pings


@pytest.mark.shared_data
def test_real_humminbird_truncated_copy_keeps_intact_pings(shared_data, tmp_path):
    src = shared_data / "humminbird"
    shutil.copy(src / "test.DAT", tmp_path / "test.DAT")
    shutil.copytree(src / "test", tmp_path / "test")
    full = read_sidescan(src / "test.DAT")
    son = tmp_path / "test" / "B003.SON"
    son.chmod(0o644)
    data = son.read_bytes()
    son.write_bytes(data[: len(data) // 2 + 100])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        part = read_sidescan(tmp_path / "test.DAT")
    assert any(issubclass(c.category, TruncatedRecordingWarning) for c in caught)
    assert 0.4 * full.n_pings < part.n_pings < 0.6 * full.n_pings
    k, m = part.n_pings, part.waterfall.samples_per_side  # the first half's longest ping
    for side in ("port", "starboard"):  # near range first on both
        np.testing.assert_array_equal(
            getattr(part.waterfall, side), getattr(full.waterfall, side)[:k, :m]
        )


def test_package_level_entry_point():
    import slam.io
    import slam.io.sidescan

    assert slam.io.read_sidescan is slam.io.sidescan.read_sidescan
    with pytest.raises(AttributeError, match="no attribute 'read_nothing'"):
        slam.io.read_nothing  # noqa: B018


def test_jsf_samples_range_and_nav_as_written(tmp_path, rng):
    """EdgeTech JSF message 80 written from the spec: samples unchanged (near range first
    on both sides), range = samples · c · Δt / 2, frequency the band centre, positions in
    minutes × 10000 back to degrees; a cut last message keeps the whole pings before it."""
    from recording_writers import write_jsf

    p, s = 8, 50
    port = rng.integers(0, 60000, size=(p, s))
    stbd = rng.integers(0, 60000, size=(p, s))
    lon, lat = np.linspace(-70.0, -69.999, p), np.full(p, 42.0)
    path = write_jsf(tmp_path / "a.jsf", port, stbd, lon=lon, lat=lat, heading_deg=45.0,
                     speed_kn=3.0, altitude_m=6.0, interval_ns=20_000, sound_speed=1500.0)
    rec = read_sidescan(path)
    assert rec.format == "jsf"
    np.testing.assert_array_equal(rec.waterfall.port, port)
    np.testing.assert_array_equal(rec.waterfall.starboard, stbd)
    np.testing.assert_allclose(rec.range_m, s * 1500.0 * 20e-6 / 2)
    np.testing.assert_allclose(rec.frequency_hz, 400e3)  # (390 + 410) / 2 kHz
    np.testing.assert_allclose(rec.time_s, np.arange(p, dtype=float))
    np.testing.assert_allclose(rec.nav.lon_deg, lon, atol=1e-6)
    np.testing.assert_allclose(rec.nav.lat_deg, lat, atol=1e-6)
    np.testing.assert_allclose(rec.nav.heading_deg, 45.0)
    np.testing.assert_allclose(rec.nav.speed_m_s, 3.0 * KNOT, rtol=1e-4)
    np.testing.assert_allclose(rec.nav.altitude_m, 6.0)
    cut = tmp_path / "cut.jsf"
    cut.write_bytes(path.read_bytes()[:-30])
    with pytest.warns(TruncatedRecordingWarning, match="truncated jsf"):
        part = read_sidescan(cut)
    np.testing.assert_array_equal(part.waterfall.starboard, stbd[:-1])


def test_lone_humminbird_son_names_the_missing_dat(tmp_path):
    folder = tmp_path / "R00001"
    folder.mkdir()
    son = folder / "B002.SON"
    son.write_bytes(bytes(500))
    with pytest.raises(RecordingError, match=r"without its recording header: expected .*R00001\.DAT"):
        read_sidescan(son)
