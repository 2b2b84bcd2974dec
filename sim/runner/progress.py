"""Progress of a headless run: a tqdm bar on a terminal, a plain line every few seconds
otherwise (log files, CI, ``| tee``), nothing with ``progress=False``.

The plain line goes to stderr so ``--json`` on stdout stays one JSON object:
``shipwreck-survey: 42.0/120.0 sim s (35%), RTF 1.84, ETA 42 s``.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable
from typing import TextIO


def on_terminal(stream: TextIO | None = None) -> bool:
    """True when ``stream`` (default stderr) is a TTY and CI is not set."""
    stream = sys.stderr if stream is None else stream
    ci = os.environ.get("CI", "").lower() in ("1", "true", "yes")
    return bool(getattr(stream, "isatty", lambda: False)()) and not ci


class LineProgress:
    """Calls of ``update(t_sim)`` print one line at most every ``every_s`` wall seconds
    (and at the end). ``clock`` returns wall seconds (injected by tests)."""

    def __init__(
        self,
        name: str,
        duration_s: float,
        *,
        every_s: float = 5.0,
        stream: TextIO | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.name, self.duration_s, self.every_s = name, float(duration_s), float(every_s)
        self.stream = sys.stderr if stream is None else stream
        self.clock = clock
        self.t0 = clock()
        self.last = self.t0
        self.lines = 0

    def update(self, t_sim: float) -> None:
        now = self.clock()
        done = t_sim >= self.duration_s - 1e-6
        if now - self.last < self.every_s and not done:
            return
        self.last = now
        wall = max(now - self.t0, 1e-9)
        rtf = t_sim / wall
        eta = max(self.duration_s - t_sim, 0.0) / rtf if rtf > 0 else float("inf")
        eta_txt = f"{eta:.0f} s" if eta < 120 else f"{eta / 60:.1f} min"
        pct = 100.0 * t_sim / self.duration_s if self.duration_s > 0 else 100.0
        print(
            f"{self.name}: {t_sim:.1f}/{self.duration_s:.1f} sim s ({pct:.0f}%), "
            f"RTF {rtf:.2f}, ETA {eta_txt}",
            file=self.stream,
            flush=True,
        )
        self.lines += 1

    def close(self) -> None:
        pass


class BarProgress:
    """tqdm bar in sim seconds with the real-time factor as postfix."""

    def __init__(self, name: str, duration_s: float) -> None:
        from tqdm import tqdm

        self.duration_s = float(duration_s)
        self.t0 = time.perf_counter()
        self.last = 0.0
        self.bar = tqdm(
            total=round(duration_s, 1),
            unit="sim s",
            desc=name,
            dynamic_ncols=True,
            bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} sim s [{elapsed}<{remaining} ETA{postfix}]",
        )

    def update(self, t: float) -> None:
        if t - self.last >= 1.0 or t >= self.duration_s - 1e-6:
            self.bar.update(round(t - self.last, 1))
            self.last = round(t, 1)
            el = time.perf_counter() - self.t0
            self.bar.set_postfix_str(f"RTF {t / max(el, 1e-9):.2f}")

    def close(self) -> None:
        self.bar.close()


def make_progress(name: str, duration_s: float, enabled: bool | None):
    """The reporter for a run: None (``enabled=False``), a bar on a terminal, else lines.
    ``enabled=True`` forces the bar; ``None`` chooses by the terminal."""
    if enabled is False:
        return None
    if enabled or on_terminal():
        return BarProgress(name, duration_s)
    return LineProgress(name, duration_s)
