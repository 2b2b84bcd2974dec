"""Fuzzing the recording readers (issue 15, item 4): small valid recordings written by
the synthetic writers (XTF, EdgeTech JSF, Lowrance SL2), a small cut of the real
Humminbird recording (.DAT + .SON/.IDX) and garbage Garmin RSD files, damaged by
hypothesis — truncated at a random offset, random bytes flipped, emptied, or a declared
size (record, message, frame, sample count) set far beyond the file. Every case either
raises :class:`RecordingError` naming the file or returns a recording with whole, finite
pings; a truncated file, or one whose size field is broken, that loses pings says so with
a TruncatedRecordingWarning.

The number of cases run is printed at the end of the module (``pytest -s``)."""

from __future__ import annotations

import shutil
import struct
import tempfile
import warnings
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from recording_writers import write_jsf, write_sl2, write_xtf

from slam.io.errors import RecordingError, TruncatedRecordingWarning
from slam.io.sidescan import read_sidescan

CASES: Counter = Counter()
FUZZ = {
    "deadline": None,
    "suppress_health_check": [HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
    "derandomize": True,  # the same cases on every run
}
#: 0x7fffffff: a declared size no small file can hold
HUGE = 0x7FFFFFFF


def _xtf(path: Path) -> Path:
    rng = np.random.default_rng(1)
    port, stbd = rng.integers(0, 4000, (2, 4, 24), dtype=np.uint16)
    lon, lat = np.linspace(-70, -69.999, 4), np.full(4, 42.0)
    return write_xtf(path, port, stbd, np.arange(4.0), lonlat=(lon, lat))


def _jsf(path: Path) -> Path:
    rng = np.random.default_rng(2)
    port, stbd = rng.integers(0, 60000, (2, 4, 24))
    return write_jsf(path, port, stbd, lon=np.linspace(-70, -69.999, 4), lat=np.full(4, 42.0))


def _sl2(path: Path) -> Path:
    rng = np.random.default_rng(3)
    samples = rng.integers(0, 255, (4, 48), dtype=np.uint8)
    return write_sl2(path, samples, lon=np.linspace(10, 10.001, 4), lat=np.full(4, 59.0))


def _xtf_size_fields() -> list[tuple[int, str]]:
    """Byte offsets of the first ping's declared sizes: record bytes, samples per channel."""
    from pyxtf import xtf_ctypes as x

    ping = 1024  # after the file header
    chan = ping + 256  # after the ping header
    return [
        (ping + x.XTFPingHeader.NumBytesThisRecord.offset, "<I"),
        (chan + x.XTFPingChanHeader.NumSamples.offset, "<I"),
    ]


#: format -> (writer of a small valid file, [(byte offset, struct format) of declared sizes])
WRITERS = {
    "xtf": (_xtf, _xtf_size_fields),
    # JSF: message header payload size; message 80's samples count
    "jsf": (_jsf, lambda: [(12, "<i"), (16 + 114, "<H")]),
    # SL2: the first frame's frame size and packet size (pingverter's sl2Struct)
    "sl2": (_sl2, lambda: [(8 + 28, "<H"), (8 + 34, "<H")]),
}


@st.composite
def damage(draw, size: int, fields: list[tuple[int, str]]):
    """(operation, argument): how to damage a file of ``size`` bytes."""
    op = draw(st.sampled_from(["truncate", "flip", "empty", "huge"]))
    if op == "truncate":
        return op, draw(st.integers(0, size - 1))
    if op == "flip":
        k = draw(st.integers(1, 8))
        pos = draw(st.lists(st.integers(0, size - 1), min_size=k, max_size=k))
        masks = draw(st.lists(st.integers(1, 255), min_size=k, max_size=k))
        return op, list(zip(pos, masks, strict=True))
    if op == "huge":  # a declared size field, or 4 bytes anywhere in the headers
        if fields and draw(st.booleans()):
            return op, draw(st.sampled_from(fields))
        return "overwrite", (draw(st.integers(0, min(size, 512) - 4)), "<I")
    return op, None


def apply_damage(raw: bytes, op: str, arg) -> bytes:
    data = bytearray(raw)
    if op == "truncate":
        return bytes(data[:arg])
    if op == "empty":
        return b""
    if op == "flip":
        for pos, mask in arg:
            data[pos] ^= mask
        return bytes(data)
    offset, fmt = arg
    struct.pack_into(fmt, data, offset, min(HUGE, 2 ** (8 * struct.calcsize(fmt) - 1) - 1))
    return bytes(data)


def check_read(path: Path, n_valid: int, op: str) -> str:
    """Read a damaged file: a RecordingError naming it, or whole finite pings (a warning
    when a cut loses pings). Returns "error" or "salvaged"."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            rec = read_sidescan(path)
        except RecordingError as exc:
            assert path.name in str(exc) or path.parent.name in str(exc), str(exc)
            return "error"
    wf = rec.waterfall
    assert wf.intensity.ndim == 2 and wf.intensity.shape[0] == rec.n_pings >= 1
    assert wf.intensity.shape[1] == 2 * wf.samples_per_side > 0
    assert np.isfinite(wf.intensity).all()
    truncated = any(issubclass(c.category, TruncatedRecordingWarning) for c in caught)
    if op in ("truncate", "huge"):  # pings lost to a cut or a broken size field: say so
        # (a flip or an overwrite elsewhere may change any field: no count is promised)
        assert rec.n_pings <= n_valid
        if rec.n_pings < n_valid:
            assert truncated, [str(c.message) for c in caught]
    return "salvaged"


@pytest.fixture(scope="module", autouse=True)
def _report_cases():
    yield
    print(f"\nreader fuzzing: {sum(CASES.values())} cases: {dict(sorted(CASES.items()))}")


@pytest.mark.parametrize("fmt", sorted(WRITERS))
def test_damaged_synthetic_recordings(fmt):
    write, fields = WRITERS[fmt]
    with tempfile.TemporaryDirectory() as d:
        valid = write(Path(d) / f"valid.{fmt}")
        raw = valid.read_bytes()
        n_valid = read_sidescan(valid).n_pings

    @settings(max_examples=80, **FUZZ)
    @given(damage(len(raw), fields()))
    def run(case):
        op, arg = case
        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / f"damaged.{fmt}"
            path.write_bytes(apply_damage(raw, op, arg))
            CASES[f"{fmt} {op} {check_read(path, n_valid, op)}"] += 1

    run()


HUM_PINGS = 10


@pytest.fixture
def humminbird_cut(shared_data, tmp_path):
    """The first HUM_PINGS pings of the real Humminbird recording's side-scan channels
    (test.DAT, B002/B003 .SON cut at ping HUM_PINGS's byte offset, .IDX cut to match)."""
    src = shared_data / "humminbird"
    out = tmp_path / "hum"
    out.mkdir()
    (out / "test").mkdir()
    shutil.copy(src / "test.DAT", out / "test.DAT")
    (out / "test.DAT").chmod(0o644)
    for beam in ("B002", "B003"):
        idx = (src / "test" / f"{beam}.IDX").read_bytes()
        end = int(np.frombuffer(idx, ">u4").reshape(-1, 2)[HUM_PINGS, 1])
        (out / "test" / f"{beam}.IDX").write_bytes(idx[: 8 * HUM_PINGS])
        (out / "test" / f"{beam}.SON").write_bytes(
            (src / "test" / f"{beam}.SON").read_bytes()[:end]
        )
    assert read_sidescan(out / "test.DAT").n_pings == HUM_PINGS
    return out


@pytest.mark.shared_data
@settings(max_examples=25, **FUZZ)
@given(
    part=st.sampled_from(["test.DAT", "test/B002.SON", "test/B003.IDX"]),
    case=st.data(),
)
def test_damaged_humminbird(humminbird_cut, part, case):
    with tempfile.TemporaryDirectory() as d:
        root = Path(d)
        shutil.copytree(humminbird_cut, root, dirs_exist_ok=True)
        target = root / part
        raw = target.read_bytes()
        op, arg = case.draw(damage(len(raw), []))
        target.write_bytes(apply_damage(raw, op, arg))
        # a cut .IDX / .DAT loses no samples: only a cut .SON must warn
        result = check_read(root / "test.DAT", HUM_PINGS, op if part.endswith(".SON") else "")
        CASES[f"humminbird {part.split('/')[-1]} {op} {result}"] += 1


@settings(max_examples=15, **FUZZ)
@given(st.binary(min_size=0, max_size=600), st.sampled_from([".rsd", ".sl3", ".jsf", ".xtf"]))
def test_garbage_files_of_every_suffix(data, suffix):
    """No writer of Garmin RSD or Lowrance SL3 here: random bytes under those suffixes (and
    the others) are refused with a RecordingError."""
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / f"garbage{suffix}"
        path.write_bytes(data)
        CASES[f"garbage {suffix} {check_read(path, 0, '')}"] += 1


def _cli(args: list[str]) -> tuple[int, str]:
    import contextlib
    import io

    from sim.cli.main import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            rc = main(args)
        except SystemExit as exc:
            rc = exc.code if isinstance(exc.code, int) else 2
    return rc, err.getvalue()


#: command -> argv for input file F and output path O (a file for normalize, else a folder)
COMMANDS = {
    "normalize": lambda f, o: ["normalize", f, "--out", f"{o}.png"],
    "mosaic": lambda f, o: ["mosaic", f, "--out", o],
    "sss-slam": lambda f, o: ["sss-slam", f, "--out", o],
}


@settings(max_examples=30, **FUZZ)
@given(
    fmt=st.sampled_from(sorted(WRITERS)),
    command=st.sampled_from(sorted(COMMANDS)),
    case=st.data(),
)
def test_cli_on_damaged_recordings_exits_2_with_nothing_written(fmt, command, case):
    """`undersea normalize/mosaic/sss-slam` on a damaged recording: exit 0 (salvaged) or 2
    with a message on stderr, never a traceback; on 2 no output and no `.partial` left."""
    write, fields = WRITERS[fmt]
    with tempfile.TemporaryDirectory() as d:
        root = Path(d)
        raw = write(root / f"valid.{fmt}").read_bytes()
        (root / f"valid.{fmt}").unlink()
        op, arg = case.draw(damage(len(raw), fields()))
        path = root / f"damaged.{fmt}"
        path.write_bytes(apply_damage(raw, op, arg))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rc, err = _cli(COMMANDS[command](str(path), str(root / "out")))
        left = sorted(p.name for p in root.iterdir() if p.name != path.name)
    assert rc in (0, 2), (command, op, rc, err)
    assert "Traceback" not in err, err
    if rc == 2:
        assert err.strip()
        assert left == [], (command, op, left)
    CASES[f"cli {command} {fmt} {op} rc={rc}"] += 1
