"""`undersea view --web` (issue 15): the printed URL opens the recording (rerun's web
viewer with ``?url=`` of the gRPC proxy serving the file), ports are free ones (two viewers
side by side), servers listen on 127.0.0.1 unless --bind, and SIGTERM / SIGINT leave no
server behind."""

from __future__ import annotations

import os
import re
import select
import signal
import subprocess
import sys
import time
import urllib.parse
import urllib.request
from pathlib import Path

import pytest

from sim.cli.view_cmd import viewer_url

psutil = pytest.importorskip("psutil")
REPO = Path(__file__).resolve().parents[2]


def test_url_names_the_proxy_that_serves_the_recording():
    """Format of rerun's own log line: http://HOST:WEB?url=rerun+http://HOST:GRPC/proxy."""
    url = viewer_url("127.0.0.1", 9090, 9876)
    parts = urllib.parse.urlsplit(url)
    assert (parts.scheme, parts.hostname, parts.port) == ("http", "127.0.0.1", 9090)
    assert urllib.parse.parse_qs(parts.query) == {"url": ["rerun+http://127.0.0.1:9876/proxy"]}
    assert "localhost" in viewer_url("0.0.0.0", 1, 2)  # a wildcard bind is opened locally


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    import rerun as rr

    path = tmp_path_factory.mktemp("rrd") / "recording.rrd"
    rec = rr.RecordingStream("undersea-test")
    rec.save(str(path))
    rec.log("world/points", rr.Points3D([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]]))
    rec.flush()
    del rec
    return path


def _start(path: Path) -> tuple[subprocess.Popen, str]:
    env = {**os.environ, "PYTHONPATH": str(REPO), "RERUN_LOG": "warn"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "sim.cli.main", "view", str(path), "--web"],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        env=env,
    )
    ready, _, _ = select.select([proc.stdout], [], [], 120)
    assert ready, "undersea view printed nothing"
    line = proc.stdout.readline()
    m = re.search(r"open (http://\S+)", line)
    assert m, line
    return proc, m.group(1)


def _listening(ports: set[int], deadline_s: float = 60.0) -> dict[int, str]:
    """port -> listening IP, once every port listens (polled until the deadline)."""
    end = time.monotonic() + deadline_s
    while time.monotonic() < end:
        found = {
            c.laddr.port: c.laddr.ip
            for c in psutil.net_connections(kind="tcp")
            if c.status == psutil.CONN_LISTEN and c.laddr.port in ports
        }
        if set(found) == ports:
            return found
        time.sleep(0.2)
    raise AssertionError(f"ports {ports} not listening")


def _ports(url: str) -> tuple[int, int]:
    parts = urllib.parse.urlsplit(url)
    proxy = urllib.parse.urlsplit(urllib.parse.parse_qs(parts.query)["url"][0])
    return parts.port, proxy.port


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_two_viewers_localhost_and_clean_stop(recording, sig):
    procs = [_start(recording), _start(recording)]
    try:
        ports = [_ports(url) for _, url in procs]
        assert len({p for pair in ports for p in pair}) == 4  # all four ports distinct
        for (_proc, url), pair in zip(procs, ports, strict=True):
            ips = _listening(set(pair))
            assert set(ips.values()) == {"127.0.0.1"}, ips
            with urllib.request.urlopen(url, timeout=30) as r:
                assert r.status == 200 and b"rerun" in r.read().lower()
        proc, _ = procs[0]
        family = psutil.Process(proc.pid).children(recursive=True)
        assert family
        proc.send_signal(sig)
        assert proc.wait(timeout=30) == 0
        _gone, alive = psutil.wait_procs(family, timeout=10)
        assert not alive, [p.cmdline() for p in alive]
        # the other viewer still serves
        with urllib.request.urlopen(procs[1][1], timeout=30) as r:
            assert r.status == 200
    finally:
        for proc, _ in procs:
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
                proc.wait(timeout=30)
