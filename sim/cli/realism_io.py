"""Loading the recordings ``undersea realism`` and ``undersea calibrate`` compare.

Everything :func:`slam.realism.recordings.load_recording` reads, plus the project's own
run output: a ``recording.rrd`` (or a run directory holding one). Its side-scan windows
are display images (``sim.viz.rerun_log.to_display_uint8``: 8 bits over ``DISPLAY_DB``
below each window's 99.5th percentile), so they are decoded back to intensity relative to
that level, window by window (grey 0, at or below the floor, decodes to 0): the statistics inside seabed patches survive, the water
column and the dynamic range are limited by the 40-dB display floor.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from slam.realism.recordings import Recording, load_recording

#: dB span of the display mapping of sim.viz.rerun_log.to_display_uint8 (its default).
DISPLAY_DB = 40.0


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
    decoded from the display mapping (intensity re each window's display top)."""
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
    db = DISPLAY_DB * (stack.astype(np.float64) / 255.0 - 1.0)
    intensity = np.where(stack > 0, 10.0 ** (db / 10.0), 0.0)  # 0 = at or below the floor
    return Recording(intensity, f"{path}:{name}", "rrd")


def load_any(path: str | Path, scale: str | None = None) -> Recording:
    """A recording from any supported file, a ``.rrd`` or a run directory."""
    p = Path(path)
    if p.is_dir() or p.suffix.lower() == ".rrd":
        return load_rrd_waterfall(p)
    return load_recording(p, scale)


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
