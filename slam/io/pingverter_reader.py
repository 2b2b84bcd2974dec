"""Humminbird, Lowrance, Garmin and EdgeTech JSF recordings through ``pingverter`` (MIT).

``pingverter`` (PyPI, by C. Bodine, the PING-Mapper reader) decodes each format's ping
headers into one table per beam (``B002`` port side-scan, ``B003`` starboard) with the
byte offset of every ping's samples (``index + son_offset``), their count (``ping_cnt``),
the range (``max_range``, m), frequency (``f``, kHz), position (``lon``/``lat``, WGS84),
heading (``instr_heading``, deg), speed (``speed_ms``) and the unit's bottom depth
(``inst_dep_m``, m). It writes those tables as CSV into a scratch folder (here a
temporary directory, removed afterwards) and prints progress, which is silenced here.

The samples are then gathered from the file in one vectorized read per side. A ping whose
samples run past the end of the file (a truncated recording) is dropped with a
:class:`~slam.io.errors.TruncatedRecordingWarning`; the pings before it are kept.

Side orientation: the port beam is stored near range first by Humminbird, Garmin and
JSF and far range first by Lowrance (pingverter's own SonarDataPlayer export reverses the
Lowrance port beam for the same reason); the waterfall puts port far range at column 0.
"""

from __future__ import annotations

import contextlib
import io
import os
import tempfile
import warnings
from pathlib import Path

import joblib
import numpy as np
import pandas as pd
import pingverter

from slam.io.errors import RecordingError, TruncatedRecordingWarning
from slam.io.recording import PingNav, SidescanRecording, nav_dict_from_pingnav
from slam.io.waterfall import Waterfall

#: format -> does the port beam store far range first?
PORT_FAR_FIRST = {"humminbird": False, "lowrance": True, "garmin": False, "jsf": False}
_PORT, _STBD = "B002", "B003"


def humminbird_dat_path(path: Path) -> Path:
    """The recording's ``.DAT`` for a ``.DAT`` or one of its ``.SON`` files (a Humminbird
    unit writes ``NAME.DAT`` beside a folder ``NAME/`` holding ``B00k.SON``/``.IDX``)."""
    if path.suffix.lower() == ".dat":
        return path
    folder = path.parent
    for cand in folder.parent.glob(folder.name + ".*"):
        if cand.suffix.lower() == ".dat":
            return cand
    raise RecordingError(
        f"{path}: Humminbird .SON file without its recording header: expected "
        f"{folder.parent / (folder.name + '.DAT')} beside the folder {folder.name}/"
    )


#: Lowrance frame headers: byte offset of the u16 ``frame_size`` and the header size.
_LOWRANCE_FRAME = {".sl2": (28, 144), ".sl3": (8, 168)}
_LOWRANCE_FILE_HEADER = 8


def _lowrance_intact_prefix(path: Path, work: str) -> Path:
    """``path`` itself when its frame chain ends exactly at the end of the file; otherwise
    a copy (in ``work``) of the whole frames before the cut, with a warning. pingverter
    reads a cut Lowrance frame header as a numpy error and loses the whole file."""
    size_at, head = _LOWRANCE_FRAME.get(path.suffix.lower(), (28, 144))
    n_bytes = path.stat().st_size
    if n_bytes < _LOWRANCE_FILE_HEADER + head:
        raise RecordingError(
            f"{path}: not a Lowrance recording ({n_bytes} bytes: shorter than the file "
            f"header and one {head}-byte frame header)"
        )
    data = np.memmap(path, dtype=np.uint8, mode="r")
    version = int(data[0]) | int(data[1]) << 8
    if version not in (2, 3):
        raise RecordingError(
            f"{path}: not a Lowrance SL2/SL3 recording (file header format field {version}, "
            "expected 2 for SL2 or 3 for SL3)"
        )
    i, frames = _LOWRANCE_FILE_HEADER, 0
    while i + head <= n_bytes:
        frame = int(data[i + size_at]) | int(data[i + size_at + 1]) << 8
        if frame < head or i + frame > n_bytes:
            break
        i += frame
        frames += 1
    if i == n_bytes:
        return path
    if frames == 0:
        raise RecordingError(
            f"{path}: not a Lowrance recording or truncated before its first frame "
            f"(first frame header gives {frame} bytes)"
        )
    warnings.warn(
        f"{path}: truncated lowrance recording: kept {frames} whole frames "
        f"({i} of {n_bytes} bytes), dropped the cut frame after them",
        TruncatedRecordingWarning,
        stacklevel=3,
    )
    trimmed = Path(work) / ("intact" + path.suffix)
    trimmed.write_bytes(bytes(data[:i]))
    return trimmed


def _parse_headers(path: Path, fmt: str, work: str, source: Path):
    """Run pingverter's header decoder, silenced; any failure becomes RecordingError."""
    convert = {
        "humminbird": pingverter.hum2pingmapper,
        "lowrance": pingverter.low2pingmapper,
        "garmin": pingverter.gar2pingmapper,
        "jsf": pingverter.jsf2pingmapper,
    }[fmt]
    sink = io.StringIO()
    try:
        with (
            contextlib.redirect_stdout(sink),
            contextlib.redirect_stderr(sink),
            warnings.catch_warnings(),
            joblib.parallel_config(backend="threading"),
        ):
            warnings.simplefilter("ignore")
            return convert(str(path), work)
    except (Exception, SystemExit) as exc:  # pingverter signals bad input in many ways
        detail = str(exc).strip().splitlines()[-1:] or [type(exc).__name__]
        raise RecordingError(
            f"{source}: not a readable {fmt} side-scan recording (pingverter: "
            f"{type(exc).__name__}: {detail[0][:200]})"
        ) from None


def _beam_table(obj, work: str, beam: str, path: Path, fmt: str, source: Path):
    """pingverter's table of one beam, in time order, and the file holding its samples."""
    meta = os.path.join(work, "meta")
    csvs = sorted(Path(meta).glob(f"{beam}_*_meta.csv")) if os.path.isdir(meta) else []
    if not csvs:
        side = "port" if beam == _PORT else "starboard"
        raise RecordingError(
            f"{source}: the {fmt} recording has no {side} side-scan beam ({beam})"
        )
    df = pd.read_csv(csvs[0])
    for col in ("index", "son_offset", "ping_cnt"):
        if col not in df.columns:
            raise RecordingError(f"{source}: pingverter gave no {col!r} for beam {beam}")
    sort_cols = [c for c in ("time_s", "record_num") if c in df.columns]
    if sort_cols:
        df = df.sort_values(sort_cols, kind="mergesort").reset_index(drop=True)
    son = getattr(obj, "beamMeta", {}).get(beam, {}).get("sonFile", str(path))
    return df, Path(son)


def pair_sides(port_df, stbd_df):
    """The port and starboard rows of the same pings: matched on ``ping_number`` where the
    format stores one (JSF; a ping whose other side was unreadable is dropped), else row
    by row up to the shorter side. Returns both tables and the number of one-sided rows
    dropped."""
    if "ping_number" in port_df.columns and "ping_number" in stbd_df.columns:
        p = port_df.drop_duplicates("ping_number").set_index("ping_number", drop=False)
        s = stbd_df.drop_duplicates("ping_number").set_index("ping_number", drop=False)
        both = p.index.intersection(s.index, sort=False)
        port = p.loc[both].reset_index(drop=True)
        stbd = s.loc[both].reset_index(drop=True)
    else:
        n = min(len(port_df), len(stbd_df))
        port, stbd = port_df.iloc[:n], stbd_df.iloc[:n]
    return port, stbd, max(len(port_df), len(stbd_df)) - len(port)


def _sample_dtype(obj, df) -> np.dtype:
    """pingverter's own rule: a ``bytes_per_sample`` column, else ``sample_dtype``, else
    1 byte when ``son8bit``, else 2 (little-endian unsigned)."""
    if "bytes_per_sample" in df.columns and df["bytes_per_sample"].notna().any():
        bps = int(df["bytes_per_sample"].dropna().iloc[0])
    else:
        dt = str(getattr(obj, "sample_dtype", ""))
        if dt:
            return np.dtype(dt)
        bps = 1 if getattr(obj, "son8bit", False) else 2
    return np.dtype({1: "u1", 2: "<u2", 4: "<u4"}.get(bps, "u1"))


def gather_samples(file: Path, offsets: np.ndarray, counts: np.ndarray, dtype: np.dtype):
    """(n, S) samples of each ping (zero-padded at far range) and the (n,) bool of pings
    whose bytes lie wholly inside the file."""
    if not file.is_file() or file.stat().st_size == 0:
        raise RecordingError(f"{file}: missing or empty sample file")
    data = np.memmap(file, dtype=np.uint8, mode="r")
    nbytes = counts.astype(np.int64) * dtype.itemsize
    complete = (offsets >= 0) & (offsets + nbytes <= data.size) & (counts > 0)
    s = int(counts[complete].max()) if complete.any() else 0
    width = s * dtype.itemsize
    j = np.arange(width, dtype=np.int64)[None, :]
    valid = complete[:, None] & (j < nbytes[:, None])
    idx = np.where(valid, offsets.astype(np.int64)[:, None] + j, 0)
    raw = np.where(valid, data[idx], 0).astype(np.uint8)
    samples = np.ascontiguousarray(raw).view(dtype).reshape(len(offsets), s)
    return samples.astype(np.float32), complete


def _ints_per_sample(df) -> np.ndarray:
    """(n,) 2 for JSF analytic (I, Q) data formats 1 and 9, else 1."""
    fmt = _col(df, "data_format")
    return np.where(np.isin(fmt, (1, 9)), 2.0, 1.0)


def jsf_amplitude(samples: np.ndarray, df) -> np.ndarray:
    """EdgeTech JSF samples as linear amplitude: analytic data (formats 1, 9: signed I, Q
    pairs) become √(I² + Q²); every ping is scaled by 2^−N, its weighting factor N (JSF
    spec, message 80), so pings recorded with different gains compare."""
    out = samples
    if np.any(_ints_per_sample(df) == 2):
        iq = samples.astype(np.uint16).view(np.int16).astype(np.float32)
        out = np.hypot(iq[:, 0::2], iq[:, 1::2])
    weight = np.nan_to_num(_col(df, "weighting_factor"), nan=0.0)
    return (out * np.exp2(-weight)[:, None]).astype(np.float32)


def _warn_jsf_tail(path: Path, *tables) -> None:
    """pingverter stops silently at a JSF message cut by the end of the file, keeping the
    whole messages before it; say so when bytes remain after the last whole message."""
    end = max(
        int(np.nanmax(_col(df, "index") + _col(df, "son_offset") + 2 * _col(df, "ping_cnt")))
        for df in tables
    )
    size = path.stat().st_size
    if size > end:
        warnings.warn(
            f"{path}: truncated jsf recording: kept the whole messages, dropped "
            f"{size - end} bytes of a cut message after byte {end}",
            TruncatedRecordingWarning,
            stacklevel=3,
        )


def _col(df, name: str, scale: float = 1.0) -> np.ndarray:
    if name not in df.columns:
        return np.full(len(df), np.nan)
    return pd.to_numeric(df[name], errors="coerce").to_numpy(dtype=np.float64) * scale


def _frequency_label_khz(obj, df) -> np.ndarray:
    """(n,) kHz from pingverter's Lowrance frequency labels (``"455kHz"``; a band
    ``"130kHz_210kHz"`` gives its centre), matched by ``record_num``; nan when absent.
    pingverter 2.1 leaves its numeric ``f`` at -1 for Lowrance (its lookup keys are the
    labels but it looks up the integer codes)."""
    hd = getattr(obj, "header_dat", None)
    if hd is None or "frequency" not in hd.columns or "record_num" not in df.columns:
        return np.full(len(df), np.nan)
    labels = hd.set_index("record_num")["frequency"].reindex(df["record_num"]).astype(str)
    parts = labels.str.findall(r"(\d+(?:\.\d+)?)kHz")
    return np.array([np.mean([float(v) for v in x]) if x else np.nan for x in parts])


def read_pingverter(path: str | Path, fmt: str) -> SidescanRecording:
    """Read a Humminbird (``.DAT``/``.SON``), Lowrance (``.sl2``/``.sl3``), Garmin
    (``.rsd``) or EdgeTech (``.jsf``) recording; see the module docstring."""
    path = Path(path)
    if fmt not in PORT_FAR_FIRST:
        raise RecordingError(f"{path}: format {fmt!r} is not read through pingverter")
    if fmt == "humminbird":
        path = humminbird_dat_path(path)
    with tempfile.TemporaryDirectory(prefix="undersea-pingverter-") as work:
        parse = _lowrance_intact_prefix(path, work) if fmt == "lowrance" else path
        obj = _parse_headers(parse, fmt, work, path)
        port_df, port_file = _beam_table(obj, work, _PORT, parse, fmt, path)
        stbd_df, stbd_file = _beam_table(obj, work, _STBD, parse, fmt, path)
        if fmt == "jsf":
            _warn_jsf_tail(path, port_df, stbd_df)
        port_df, stbd_df, one_sided = pair_sides(port_df, stbd_df)
        n = len(port_df)
        if n == 0:
            raise RecordingError(f"{path}: the {fmt} recording holds no side-scan pings")
        if one_sided:
            warnings.warn(
                f"{path}: damaged {fmt} recording: kept {n} pings with both sides, dropped "
                f"{one_sided} whose other side was unreadable",
                TruncatedRecordingWarning,
                stacklevel=2,
            )
        dtype = _sample_dtype(obj, port_df)
        sides, complete = [], np.ones(n, dtype=bool)
        for df, file in ((port_df, port_file), (stbd_df, stbd_file)):
            off = (_col(df, "index") + _col(df, "son_offset")).astype(np.int64)
            cnt = _col(df, "ping_cnt").astype(np.int64)
            samples, ok = gather_samples(file, off, cnt, dtype)
            sides.append(jsf_amplitude(samples, df) if fmt == "jsf" else samples)
            complete &= ok
    keep = np.flatnonzero(complete)
    if keep.size == 0:
        raise RecordingError(
            f"{path}: truncated or corrupt {fmt} recording: none of its {n} side-scan pings "
            "lies wholly inside the file"
        )
    if keep.size < n:
        warnings.warn(
            f"{path}: truncated {fmt} recording: kept {keep.size} intact pings, dropped "
            f"{n - keep.size} that run past the end of the file",
            TruncatedRecordingWarning,
            stacklevel=2,
        )
    port, stbd = sides[0][keep], sides[1][keep]
    s = max(port.shape[1], stbd.shape[1])
    port = np.pad(port, ((0, 0), (0, s - port.shape[1])))
    stbd = np.pad(stbd, ((0, 0), (0, s - stbd.shape[1])))
    if not PORT_FAR_FIRST[fmt]:
        port = port[:, ::-1]
    sdf = stbd_df.iloc[keep]
    cnt = _col(sdf, "ping_cnt") / _ints_per_sample(sdf)
    slant = _col(sdf, "max_range") * s / cnt  # range of S samples at this ping's spacing
    no_range = ~np.isfinite(slant)
    slant[no_range] = (_col(sdf, "pixM") * s)[no_range]  # JSF: c · sample interval / 2
    freq_khz = _col(sdf, "f")
    if not np.any(freq_khz > 0):
        freq_khz = _frequency_label_khz(obj, sdf)
    t = _col(sdf, "time_s")
    nav = PingNav(
        lon_deg=_col(sdf, "lon"),
        lat_deg=_col(sdf, "lat"),
        easting_m=np.full(keep.size, np.nan),
        northing_m=np.full(keep.size, np.nan),
        heading_deg=_col(sdf, "instr_heading"),
        altitude_m=_col(sdf, "inst_dep_m"),
        depth_m=np.full(keep.size, np.nan),
        speed_m_s=_col(sdf, "speed_ms"),
    )
    origin = ""
    if {"date", "time"} <= set(sdf.columns):
        origin = f"{sdf['date'].iloc[0]}T{sdf['time'].iloc[0]}"
    elif t[0] > 1e8:  # JSF: seconds since 1970
        origin = str(np.datetime64(round(float(t[0]) * 1e3), "ms"))
    wf = Waterfall(
        intensity=np.concatenate([port, stbd], axis=1),
        samples_per_side=s,
        time_s=t - t[0],
        slant_range_m=slant,
        frequency_hz=np.where(freq_khz > 0, freq_khz * 1e3, np.nan),
        sound_velocity_m_s=np.full(keep.size, np.nan),
        nav=nav_dict_from_pingnav(nav),
        time_origin=origin,
        source=str(path),
    )
    return SidescanRecording(waterfall=wf, nav=nav, format=fmt)
