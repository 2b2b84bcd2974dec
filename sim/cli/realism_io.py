"""Loading the recordings ``undersea realism`` and ``undersea calibrate`` compare.

Everything :func:`slam.realism.recordings.load_recording` reads, plus the project's own
run output: a ``recording.rrd`` (or a run directory holding one). Its side-scan windows
are the front end's conditioned windows (normalized seabed = 0 dB, water column set to the
seabed level, 3 × 3 looks) shown by one fixed display mapping for the run
(``sim.viz.rerun_log.db_to_uint8`` over ``PREPARED_DB``), decoded back to intensity re
the normalized seabed level (8 bits over 30 dB: 0.12-dB steps). The looks lower the
speckle CV and raise the lag-1 correlations against the sonar's raw samples; the water
column and dynamic range are those of the conditioned image, not of the sonar.
"""

from __future__ import annotations

import contextlib
import io
import tempfile
from pathlib import Path

import numpy as np

from slam.frontend.sidescan_prepare import PREPARED_DB
from slam.realism.recordings import Recording, load_recording
from slam.realism.statistics import first_return_from_altitude


def _image_windows(path: Path) -> dict[str, list[np.ndarray]]:
    """Entity path -> its grey images in log order (only 8-bit single-channel images)."""
    from rerun.chunk import RrdReader

    out: dict[str, list[np.ndarray]] = {}
    store = RrdReader(str(path)).stream().collect()
    for ch in store.stream().to_chunks():
        rb = ch.to_record_batch()
        if "Image:buffer" not in rb.schema.names or not ch.entity_path.endswith("/image"):
            continue
        for buf, fmt in zip(
            rb.column("Image:buffer").to_pylist(),
            rb.column("Image:format").to_pylist(),
            strict=True,
        ):
            if not buf or not fmt:
                continue
            fmt = fmt[0] if isinstance(fmt, list) else fmt  # one-element list per row
            data = np.asarray(buf[0] if isinstance(buf[0], list) else buf, dtype=np.uint8)
            h, w = int(fmt["height"]), int(fmt["width"])
            if data.size == h * w:
                out.setdefault(ch.entity_path, []).append(data.reshape(h, w))
    return out


def load_rrd_waterfall(path: str | Path, entity: str | None = None) -> Recording:
    """The side-scan waterfall windows of a run's recording, stacked in time order and
    decoded from the fixed display mapping (intensity re the normalized seabed level)."""
    path = Path(path)
    if path.is_dir():
        path = path / "recording.rrd"
    if not path.is_file():
        raise ValueError(f"no recording.rrd at {str(path)!r}")
    windows = _image_windows(path)
    sss = {k: v for k, v in windows.items() if "/sonar/" in k and v[0].shape[1] % 2 == 0}
    if entity is not None:
        sss = {k: v for k, v in sss.items() if k.strip("/") == entity.strip("/")}
    if not sss:
        raise ValueError(f"{path}: no side-scan waterfall images (entity {entity or 'any'})")
    name = sorted(sss, key=lambda k: -sum(w.shape[0] for w in sss[k]))[0]
    width = sss[name][0].shape[1]
    stack = np.concatenate([w for w in sss[name] if w.shape[1] == width], axis=0)
    lo, hi = PREPARED_DB
    intensity = 10.0 ** ((lo + (hi - lo) * stack.astype(np.float64) / 255.0) / 10.0)
    return Recording(intensity, f"{path}:{name}", "rrd")


def load_humminbird(path: str | Path, scale: str | None = None) -> Recording:
    """A Humminbird recording (``NAME.DAT`` beside ``NAME/B002.SON``, ``B003.SON``) through
    ``pingverter`` (MIT): its per-ping tables give each ping's byte offset
    (``index + son_offset``), sample count, sample size (``pixM``) and the unit's depth
    under the transducer (``inst_dep_m``, taken as altitude). Every ping is cut to the
    shortest ping's samples. Samples are uint8, near range first on
    both sides, taken as amplitude unless ``scale`` says otherwise. A small private
    reader for the realism tools; the project's reader of real recordings is in slam.io."""
    import pandas as pd
    import pingverter

    path = Path(path)
    son_dir = path.with_suffix("")
    if not (son_dir / "B002.SON").is_file() or not (son_dir / "B003.SON").is_file():
        raise ValueError(f"{path}: expected {son_dir}/B002.SON and B003.SON beside the .DAT")
    with tempfile.TemporaryDirectory() as work:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            pingverter.hum2pingmapper(str(path), work)
        tables = [
            pd.read_csv(next(Path(work, "meta").glob(f"{b}_*meta.csv"))) for b in ("B002", "B003")
        ]
    n = min(len(t) for t in tables)
    if n == 0:
        raise ValueError(f"{path}: no side-scan pings")
    # the range (and sample count) changes along the recording at a fixed sample size
    # (pixM): keep the samples every ping has, so no ping is padded
    width = int(min(t["ping_cnt"][:n].min() for t in tables))
    sides = []
    for beam, t in zip(("B002", "B003"), tables, strict=True):
        raw = np.fromfile(son_dir / f"{beam}.SON", dtype=np.uint8)
        start = (t["index"] + t["son_offset"]).to_numpy()[:n].astype(np.int64)
        count = t["ping_cnt"].to_numpy()[:n].astype(np.int64)
        k = np.arange(width)[None, :]
        idx = start[:, None] + k
        ok = (k < count[:, None]) & (idx < raw.size)
        sides.append(np.where(ok, raw[np.minimum(idx, raw.size - 1)], 0).astype(np.float64))
    values = np.concatenate([sides[0][:, ::-1], sides[1]], axis=1)
    use = scale or "amplitude"
    alt = tables[0]["inst_dep_m"].to_numpy()[:n].astype(np.float64)
    srange = width * float(np.median(tables[0]["pixM"].to_numpy()[:n]))
    intensity = values * values if use == "amplitude" else values
    return Recording(intensity, str(path), "humminbird", alt if np.any(alt > 0) else None, srange)


def load_any(path: str | Path, scale: str | None = None) -> Recording:
    """A recording from any supported file, a Humminbird ``.DAT``, a ``.rrd`` or a run
    directory."""
    p = Path(path)
    if p.is_dir() or p.suffix.lower() == ".rrd":
        return load_rrd_waterfall(p)
    if p.suffix.lower() == ".dat":
        return load_humminbird(p, scale)
    return load_recording(p, scale)


BOTTOM_MODES = ("detect", "altitude")


def first_return_for(rec: Recording, mode: str) -> np.ndarray | None:
    """The first bottom return to use for ``rec``: None = the detector; "altitude" = from
    the recording's altitude and slant range (error naming what is missing)."""
    if mode == "detect":
        return None
    if mode != "altitude":
        raise ValueError(f"bottom mode must be one of {BOTTOM_MODES}, got {mode!r}")
    if rec.altitude_m is None or not rec.slant_range_m:
        raise ValueError(
            f"{rec.source}: --bottom altitude needs the recording's altitude and range"
        )
    return first_return_from_altitude(
        rec.altitude_m, rec.slant_range_m, rec.intensity.shape[1] // 2
    )


def parse_pings(spec: str | None, n: int) -> slice:
    """'A:B' (either side may be empty; 'first'/'second' halves) → slice of pings."""
    if spec is None or spec == "all":
        return slice(0, n)
    if spec == "first":
        return slice(0, n // 2)
    if spec == "second":
        return slice(n // 2, n)
    try:
        a, b = spec.split(":")
        s = slice(int(a) if a else 0, int(b) if b else n)
    except ValueError as exc:
        raise ValueError(
            f"--pings must be 'A:B', 'first', 'second' or 'all', got {spec!r}"
        ) from exc
    if not 0 <= s.start < s.stop <= n:
        raise ValueError(f"--pings {spec!r} is outside the recording's 0:{n} pings")
    return s
