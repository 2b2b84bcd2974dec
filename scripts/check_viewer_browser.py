"""Open ``undersea view RUN --web`` in a real headless Chromium and check what it shows.

Usage::

    python scripts/check_viewer_browser.py RUN_DIR [--screenshot viewer.png] [--timeout 240]

Starts ``undersea view RUN --web``, launches Debian's Chromium headless (a fresh profile,
no network services, software WebGL) with the Chrome DevTools Protocol (CDP) over
``websockets``, opens the URL the viewer printed and waits until rerun's web viewer has
drawn the recording. Checks, each reported by name:

* ``page``: the page loaded rerun's web viewer (a full-window ``<canvas>``);
* ``views``: the recording's blueprint (read from the .rrd) holds a 3-D world view, a
  sonar image view and a metrics time-series view;
* ``drawn``: in the screenshot, each pane of the default layout (3-D world left, sonar
  views and metric plots right, :func:`sim.viz.rerun_log.default_blueprint`) shows
  structure (not one flat colour) and the picture stopped changing (loaded);
* ``errors``: no console error, uncaught exception or failed request on the page, and no
  red error badge in the viewer's top bar.

Saves the screenshot (PNG) and exits 0 when every check passes, 1 when one fails (the
failures on stderr), 2 when the browser or the recording is missing.
"""

from __future__ import annotations

import argparse
import base64
import contextlib
import itertools
import json
import os
import re
import select
import signal
import subprocess
import sys
import tempfile
import time
import urllib.parse
import urllib.request
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
CHROMIUM = "/usr/bin/chromium"
CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--use-angle=swiftshader",  # WebGL in software: rerun's renderer needs WebGL2 or WebGPU
    "--enable-unsafe-swiftshader",
    "--window-size=1600,1000",
    "--disable-renderer-backgrounding",
    "--disable-background-timer-throttling",
    "--disable-backgrounding-occluded-windows",
    "--remote-debugging-port=0",
    "--remote-allow-origins=*",
]
LOCAL_HOSTS = {"127.0.0.1", "localhost", "::1", "[::1]"}
#: run in the page before its own scripts: collect console errors, uncaught exceptions and
#: rejected promises in ``window.__undersea_errors``; drop rerun's debug/info console
#: stream (thousands of shader-compiler lines that slow a software-rendered page)
COLLECT_ERRORS = """
window.__undersea_errors = [];
const __push = (kind, args) => window.__undersea_errors.push(
  kind + ": " + Array.from(args).map(a => (a && a.stack) || String(a)).join(" ").slice(0, 300));
const __error = console.error.bind(console);
console.error = function () { __push("console.error", arguments); __error(...arguments); };
console.debug = console.log = console.info = console.trace = function () {};
window.addEventListener("error", e => __push("exception", [e.message || e.error]));
window.addEventListener("unhandledrejection", e => __push("rejection", [e.reason]));
"""
#: a pane whose grey levels vary less than this (std, of 0..255) shows nothing
MIN_PANE_STD = 2.0
#: console messages of the browser itself, not of the page (headless software GL)
BENIGN = re.compile(r"GPU stall due to ReadPixels|Automatic fallback to software WebGL|favicon")


T0 = time.monotonic()


def log(msg: str) -> None:
    """Progress on stderr, with the seconds since start."""
    print(f"[{time.monotonic() - T0:6.1f} s] {msg}", file=sys.stderr, flush=True)


class CheckError(RuntimeError):
    """A check that cannot even start: no browser, no viewer URL, no page."""


def start_viewer(run: Path, timeout_s: float) -> tuple[subprocess.Popen, str]:
    """``undersea view RUN --web`` as a child process and the URL it printed."""
    env = {**os.environ, "PYTHONPATH": str(REPO), "RERUN_LOG": "warn"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "sim.cli.main", "view", str(run), "--web"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    ready, _, _ = select.select([proc.stdout], [], [], timeout_s)
    line = proc.stdout.readline() if ready else ""
    m = re.search(r"open (http://\S+)", line)
    if not m:
        stop(proc)
        raise CheckError(f"undersea view printed no URL: {line!r} {proc.stderr.read()[-500:]!r}")
    return proc, m.group(1)


def start_chromium(exe: str, profile: str, timeout_s: float) -> tuple[subprocess.Popen, int]:
    """Headless Chromium with a fresh profile and the DevTools port it picked."""
    proc = subprocess.Popen(
        [exe, *CHROMIUM_FLAGS, f"--user-data-dir={profile}", "about:blank"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    port_file = Path(profile) / "DevToolsActivePort"
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if port_file.is_file() and port_file.read_text().strip():
            return proc, int(port_file.read_text().split()[0])
        if proc.poll() is not None:
            raise CheckError(f"{exe} exited with code {proc.returncode} at start")
        time.sleep(0.2)
    stop(proc)
    raise CheckError(f"{exe} wrote no DevToolsActivePort within {timeout_s:.0f} s")


def stop(proc: subprocess.Popen) -> None:
    """SIGTERM (the viewer cleans up its servers), SIGKILL after 10 s."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


class Cdp:
    """A minimal Chrome DevTools Protocol client over one page's websocket."""

    def __init__(self, ws_url: str):
        from websockets.sync.client import connect

        self.ws = connect(ws_url, max_size=2**28, open_timeout=30, ping_interval=None)
        self.ids = itertools.count(1)
        self.events: list[dict] = []
        self.offline: list[str] = []
        self.notes: list[str] = []

    def call(self, method: str, timeout_s: float = 600.0, **params) -> dict:
        """Send one command and wait for its answer (handling events meanwhile)."""
        i = next(self.ids)
        self.ws.send(json.dumps({"id": i, "method": method, "params": params}))
        end = time.monotonic() + timeout_s
        while True:
            left = end - time.monotonic()
            if left <= 0:
                raise CheckError(f"CDP {method}: no answer within {timeout_s:.0f} s")
            msg = self._recv(left)
            if msg is not None and msg.get("id") == i:
                if "error" in msg:
                    raise CheckError(f"CDP {method}: {msg['error']}")
                return msg.get("result", {})

    def pump(self, seconds: float) -> None:
        """Handle events for ``seconds`` (the page keeps running meanwhile)."""
        end = time.monotonic() + seconds
        while (left := end - time.monotonic()) > 0:
            self._recv(left)

    def _recv(self, timeout_s: float) -> dict | None:
        try:
            msg = json.loads(self.ws.recv(timeout=timeout_s))
        except TimeoutError:
            return None
        if msg.get("method") == "Fetch.requestPaused":
            self._offline(msg["params"])
        elif "method" in msg:
            self.events.append(msg)
        return msg

    def _offline(self, p: dict) -> None:
        """Let requests to this machine through; answer those to other hosts (fonts, the
        update check, telemetry) with 404 (their CORS preflights with 204), as a server
        that has nothing would, instead of a network error in the page's console."""
        url = p["request"]["url"]
        host = urllib.parse.urlsplit(url).hostname or ""
        params: dict = {"requestId": p["requestId"]}
        if host in LOCAL_HOSTS or not url.startswith("http"):
            method = "Fetch.continueRequest"
        else:
            self.offline.append(url)
            method = "Fetch.fulfillRequest"
            preflight = p["request"].get("method") == "OPTIONS"
            cors = [
                {"name": f"Access-Control-Allow-{k}", "value": "*"}
                for k in ("Origin", "Methods", "Headers")
            ]
            params |= {"responseCode": 204 if preflight else 404, "responseHeaders": cors}
        self.ws.send(json.dumps({"id": next(self.ids), "method": method, "params": params}))

    def evaluate(self, expr: str):
        res = self.call("Runtime.evaluate", expression=expr, returnByValue=True)
        return res.get("result", {}).get("value")

    def screenshot(self) -> np.ndarray:
        import cv2

        data = base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"])
        return cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self.ws.close()


def page_problems(cdp: Cdp) -> list[str]:
    """Errors on the page: console errors and uncaught exceptions collected in the page, a
    rerun panic, failed requests to the viewer's own servers. Requests to other hosts are
    answered 404 by :meth:`Cdp._offline` (an offline machine); their console lines name
    those hosts and are not counted."""
    offline_hosts = {urllib.parse.urlsplit(u).hostname for u in cdp.offline}
    found = list(cdp.evaluate("window.__undersea_errors || []") or [])
    if cdp.evaluate("window._handle ? window._handle.has_panicked() : false"):
        found.append("rerun panicked: " + str(cdp.evaluate("window._handle.panic_message()")))
    urls = {
        e["params"]["requestId"]: e["params"]["request"]["url"]
        for e in cdp.events
        if e["method"] == "Network.requestWillBeSent"
    }
    for e in cdp.events:
        m, p = e["method"], e.get("params", {})
        if m == "Log.entryAdded" and p["entry"]["level"] == "error":
            found.append("log: " + p["entry"].get("text", "") + " " + p["entry"].get("url", ""))
        elif m == "Network.loadingFailed" and not p.get("canceled"):
            url = urls.get(p.get("requestId"), "?")
            found.append(f"request failed: {p.get('errorText', '')} {p.get('type', '')} {url}")
    return [
        t[:300]
        for t in found
        if not any(h and h in t for h in offline_hosts) and not BENIGN.search(t)
    ]


def rrd_views(path: Path) -> list[tuple[str, str, str]]:
    """(view class, name, origin) of every view in the blueprint stored in an .rrd."""
    from rerun.chunk import RrdReader

    reader = RrdReader(str(path))
    out = []
    for store in reader.blueprints():
        for ch in reader.stream(store=store).collect().stream().to_chunks():
            rb = ch.to_record_batch()
            cols = {n.split(":")[-1]: n for n in rb.schema.names if n.startswith("ViewBlueprint:")}
            if "class_identifier" not in cols:
                continue
            get = {k: rb.column(v).to_pylist() for k, v in cols.items()}
            for i, cls in enumerate(get["class_identifier"]):
                name = (get.get("display_name") or [[""]] * (i + 1))[i] or [""]
                origin = (get.get("space_origin") or [[""]] * (i + 1))[i] or [""]
                out.append((cls[0], name[0], origin[0]))
    return out


def views_missing(views: list[tuple[str, str, str]]) -> list[str]:
    """The kinds of view among {3-D world, sonar image, metrics plot} that ``views`` lacks."""
    want = {
        "3-D world view": lambda c, o: c == "3D" and o.strip("/") == "world",
        "sonar image view": lambda c, o: c == "2D" and "/sonar/" in o,
        "metrics plot": lambda c, o: c == "TimeSeries" and o.strip("/").startswith("metrics"),
    }
    return [k for k, ok in want.items() if not any(ok(c, o) for c, _n, o in views)]


def browser_rrd(cdp: Cdp, what: str, out: Path) -> int:
    """Write the viewer's active recording or blueprint (``what``: "recording" or
    "blueprint", rerun's ``WebHandle.save_*``) to ``out``; its size in bytes (0 when the
    viewer has none; the reason in ``cdp.notes``)."""
    res = cdp.evaluate(
        f"(() => {{ try {{ const b = window._handle.save_{what}(); let s = '';"
        " for (let i = 0; i < b.length; i += 32768)"
        " s += String.fromCharCode.apply(null, b.subarray(i, i + 32768));"
        " return 'ok:' + btoa(s); } catch (e) { return 'error:' + e; } })()",
    )
    kind, _, text = str(res).partition(":")
    data = base64.b64decode(text) if kind == "ok" else b""
    if kind != "ok":
        cdp.notes.append(f"save_{what}: {text or res}"[:300])
    out.write_bytes(data)
    return len(data)


def pane_structure(img: np.ndarray, n_right: int) -> dict[str, float]:
    """Grey-level standard deviation inside each pane of the default layout."""
    grey = img.mean(axis=2)
    h, w = grey.shape
    return {k: float(grey[b].std()) for k, b in pane_boxes(h, w, n_right).items()}


def pane_boxes(h: int, w: int, n_right: int) -> dict[str, tuple[slice, slice]]:
    """Pixel boxes (inner halves, away from borders and titles) of the default layout's
    panes, rerun's side panels collapsed as the recording's blueprint asks: the 3-D world
    on the left 3/5, ``n_right`` stacked views (sonar images, then metric plots) on the
    right, between the top bar and the time bar."""
    top, bottom = int(0.04 * h), int(0.96 * h)
    split = w * 3 // 5
    boxes = {"world 3-D view": _inner(top, bottom, 0, split)}
    step = (bottom - top) / max(n_right, 1)
    for k in range(n_right):
        name = "metrics plot" if k == n_right - 1 else f"sonar view {k + 1}"
        boxes[name] = _inner(int(top + k * step), int(top + (k + 1) * step), split, w)
    return boxes


def _inner(y0: int, y1: int, x0: int, x1: int) -> tuple[slice, slice]:
    dy, dx = (y1 - y0) // 4, (x1 - x0) // 4
    return slice(y0 + dy, y1 - dy), slice(x0 + dx, x1 - dx)


def error_badges(img: np.ndarray) -> list[tuple[int, int]]:
    """(x, y) centres of rerun's red error badges (the filled red circle a view shows in
    its title bar when one of its visualizers failed) in a BGR screenshot: blobs of
    saturated red of badge size. The orange "Software rasterizer" note is not red."""
    import cv2

    b, g, r = (img[..., i].astype(int) for i in range(3))
    red = ((r > 170) & (g < 80) & (b < 130) & (r - b > 80)).astype(np.uint8)
    n, _lab, stats, cent = cv2.connectedComponentsWithStats(red)
    return [
        (int(cent[i][0]), int(cent[i][1]))
        for i in range(1, n)
        if 40 <= stats[i, cv2.CC_STAT_AREA] <= 600
        and 0.6 <= stats[i, cv2.CC_STAT_WIDTH] / max(stats[i, cv2.CC_STAT_HEIGHT], 1) <= 1.6
    ]


def hover_screenshot(cdp: Cdp, x: int, y: int, out: Path) -> None:
    """Move the mouse over (x, y) and click (rerun then lists the view's reports), save a
    screenshot to ``out``."""
    import cv2

    cdp.call("Input.dispatchMouseEvent", type="mouseMoved", x=x, y=y)
    cdp.pump(4.0)
    cdp.call("Input.dispatchMouseEvent", type="mouseMoved", x=x + 1, y=y)
    cdp.pump(4.0)
    for kind in ("mousePressed", "mouseReleased"):  # opens the view's list of reports
        cdp.call("Input.dispatchMouseEvent", type=kind, x=x, y=y, button="left", clickCount=1)
    cdp.pump(4.0)
    cv2.imwrite(str(out), cdp.screenshot())


def open_page(port: int) -> Cdp:
    """CDP on Chromium's first tab, with other hosts answered offline and page errors
    collected from the first script on."""
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=60) as r:
        pages = [t for t in json.load(r) if t["type"] == "page"]
    cdp = Cdp(pages[0]["webSocketDebuggerUrl"])
    cdp.call("Fetch.enable", patterns=[{"urlPattern": "*"}])
    for domain in ("Log", "Page", "Network"):
        cdp.call(f"{domain}.enable")
    cdp.call(
        "Emulation.setDeviceMetricsOverride",
        width=1600,
        height=1000,
        deviceScaleFactor=1,
        mobile=False,
    )
    cdp.call("Page.addScriptToEvaluateOnNewDocument", source=COLLECT_ERRORS)
    return cdp


def wait_until(cdp: Cdp, expr: str, deadline: float, what: str) -> None:
    while not cdp.evaluate(expr):
        if time.monotonic() > deadline:
            raise CheckError(f"{what} (waited for {expr!r})")
        cdp.pump(2.0)


def loaded_recording(cdp: Cdp, rrd: Path, work: Path, deadline: float):
    """Wait until the viewer's active recording stops growing; the failures of comparing
    its entities with the file's (every entity of the file is in the browser, with all its
    rows) and the viewer's entity paths."""
    from sim.viz.rerun_log import read_recording

    got, size, same = work / "browser.rrd", -1, 0
    while same < 2 and time.monotonic() < deadline:
        cdp.pump(3.0)
        n = browser_rrd(cdp, "recording", got)
        same = same + 1 if n == size and n > 0 else 0
        size = n
    if size <= 0:
        return ["recording: the viewer holds no recording (it shows the welcome screen)"], {}
    want, have = read_recording(rrd), read_recording(got)
    missing = sorted(set(want) - set(have))
    short = sorted(e for e in want if e in have and have[e].rows < want[e].rows)
    out = []
    if missing:
        out.append(
            f"recording: {len(missing)} entities of the file not in the viewer: "
            + ", ".join(missing[:5])
        )
    if short:
        out.append(
            "recording: fewer rows in the viewer than in the file for " + ", ".join(short[:5])
        )
    return out, have


def settled_screenshot(cdp: Cdp, deadline: float) -> tuple[np.ndarray, bool]:
    """Screenshots every 3 s until three in a row show the same picture (or the deadline)."""
    import cv2

    prev, img, same = None, None, 0
    while same < 3:
        cdp.pump(3.0)
        img = cdp.screenshot()
        small = cv2.resize(img, (320, 200), interpolation=cv2.INTER_AREA).astype(np.int16)
        same = same + 1 if prev is not None and np.abs(small - prev).mean() < 0.5 else 0
        prev = small
        if time.monotonic() > deadline:
            return img, False
    return img, True


def inspect_page(cdp: Cdp, rrd: Path, shot: Path, work: Path, timeout_s: float) -> list[str]:
    """Every check of the module docstring; the failures."""
    import cv2

    deadline = time.monotonic() + timeout_s
    wait_until(cdp, "!!window._handle", deadline, "the rerun web viewer did not start")
    log("rerun web viewer started")
    failures, entities = loaded_recording(cdp, rrd, work, deadline)
    log("recording loaded")
    views = []
    if browser_rrd(cdp, "blueprint", work / "blueprint.rrd"):
        views = rrd_views(work / "blueprint.rrd")
    log(f"blueprint views: {views} {cdp.notes}")
    failures += [
        f"views: the viewer's blueprint has no {k} (views: {views})" for k in views_missing(views)
    ]
    for cls, name, origin in views:
        if not any(e.startswith("/" + origin.strip("/")) for e in entities):
            failures.append(f"views: the {cls} view {name!r} has no data under /{origin}")
    img, settled = settled_screenshot(cdp, deadline)
    cv2.imwrite(str(shot), img)
    log(f"screenshot {shot}")
    if not settled:
        failures.append(f"drawn: the picture still changed after {timeout_s:.0f} s")
    n_right = sum(c in ("2D", "TimeSeries") for c, _n, _o in views)
    for pane, std in pane_structure(img, n_right).items():
        if std < MIN_PANE_STD:
            failures.append(f"drawn: the {pane} is one flat colour (grey std {std:.1f})")
    for k, (x, y) in enumerate(error_badges(img)):
        tip = shot.with_name(f"{shot.stem}-badge{k + 1}.png")
        hover_screenshot(cdp, x, y, tip)
        failures.append(f"errors: red error badge at ({x}, {y}); its tooltip: {tip}")
    failures += [f"errors: {t}" for t in page_problems(cdp)]
    return failures


def run_checks(run: Path, shot: Path, exe: str, timeout_s: float) -> list[str]:
    """Start the viewer and the browser, check the page, stop both; the failures."""
    rrd = run / "recording.rrd" if run.is_dir() else run
    viewer, url = start_viewer(run, timeout_s)
    browser = cdp = None
    with tempfile.TemporaryDirectory(prefix="undersea-viewer-check-") as work:
        try:
            browser, port = start_chromium(exe, str(Path(work) / "profile"), timeout_s)
            cdp = open_page(port)
            cdp.call("Page.navigate", url=url)
            return inspect_page(cdp, rrd, shot, Path(work), timeout_s)
        finally:
            if cdp is not None:
                cdp.close()
            if browser is not None:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(browser.pid, signal.SIGTERM)  # its own session: every helper
                stop(browser)
            stop(viewer)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", type=Path, help="run directory (with recording.rrd) or .rrd file")
    ap.add_argument("--screenshot", type=Path, default=Path("viewer_screenshot.png"))
    ap.add_argument("--timeout", type=float, default=240.0, help="seconds to wait, per stage")
    ap.add_argument("--chromium", default=CHROMIUM, help=f"browser executable (default {CHROMIUM})")
    args = ap.parse_args(argv)
    if not Path(args.chromium).is_file():
        print(
            f"check_viewer_browser: no browser at {args.chromium} (apt-get install chromium)",
            file=sys.stderr,
        )
        return 2
    rrd = args.run / "recording.rrd" if args.run.is_dir() else args.run
    if not rrd.is_file():
        print(f"check_viewer_browser: no recording at {args.run}", file=sys.stderr)
        return 2
    try:
        failures = run_checks(args.run, args.screenshot, args.chromium, args.timeout)
    except CheckError as exc:
        failures = [str(exc)]
    for f in failures:
        print(f"FAIL {f}", file=sys.stderr)
    print(f"screenshot: {args.screenshot}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
