"""Fuzzing the scenario schema (issue 15): random mutations of the built-in files — a
value replaced by one of another type or an extreme one, a key deleted, an unknown key
added, a table emptied — either parse or raise ScenarioError naming a field; never
another exception (which the CLI would show as a traceback)."""

from __future__ import annotations

import copy
import math

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sim.scenario import ScenarioError, builtin_scenarios, load_scenario_dict, parse_scenario

BUILTINS = {name: load_scenario_dict(name) for name in builtin_scenarios()}


def _paths(node, prefix=()) -> list[tuple]:
    """Every key path (tuple of keys / list indices) of a decoded TOML tree."""
    out = []
    items = (
        node.items()
        if isinstance(node, dict)
        else enumerate(node)
        if isinstance(node, list)
        else ()
    )
    for k, v in items:
        out.append((*prefix, k))
        out.extend(_paths(v, (*prefix, k)))
    return out


VALUES = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, -1, 1e308, -1e-308, math.nan, math.inf, "", "lava", "x" * 300]),
    st.text(max_size=20),
    st.lists(st.floats(min_value=-1e6, max_value=1e6), max_size=4),
    st.lists(st.text(max_size=3), max_size=3),
    st.dictionaries(st.text(max_size=5), st.integers(), max_size=2),
)


@st.composite
def mutated(draw):
    name = draw(st.sampled_from(sorted(BUILTINS)))
    data = copy.deepcopy(BUILTINS[name])
    for _ in range(draw(st.integers(1, 3))):
        paths = _paths(data)
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent = data
        for k in path[:-1]:
            parent = parent[k]
        op = draw(st.sampled_from(["replace", "delete", "unknown", "empty"]))
        key = path[-1]
        if op == "replace" or (op == "delete" and isinstance(parent, list)):
            parent[key] = draw(VALUES)
        elif op == "delete":
            del parent[key]
        elif op == "unknown" and isinstance(parent, dict):
            parent[draw(st.text(min_size=1, max_size=8))] = draw(VALUES)
        elif isinstance(parent[key], dict | list):
            parent[key] = type(parent[key])()
    return data


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated())
def test_mutated_builtins_parse_or_name_a_field(data):
    try:
        parse_scenario(data)
    except ScenarioError as exc:
        msg = str(exc)
        assert msg.startswith(("scenario field '", "override key")), msg


FILES = {name: path.read_bytes() for name, path in builtin_scenarios().items()}


@st.composite
def damaged_file(draw) -> bytes:
    raw = bytearray(FILES[draw(st.sampled_from(sorted(FILES)))])
    op = draw(st.sampled_from(["truncate", "flip", "insert", "empty"]))
    if op == "empty":
        return b""
    i = draw(st.integers(0, len(raw) - 1))
    if op == "truncate":
        return bytes(raw[:i])
    if op == "flip":
        raw[i] ^= 1 << draw(st.integers(0, 7))
        return bytes(raw)
    return bytes(raw[:i]) + draw(st.binary(min_size=1, max_size=8)) + bytes(raw[i:])


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(damaged_file())
def test_damaged_files_load_or_raise_scenario_error(content):
    import tempfile
    from pathlib import Path

    from sim.scenario import load_scenario

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "s.toml"
        p.write_bytes(content)
        try:
            load_scenario(p)
        except ScenarioError as exc:
            assert str(exc).startswith(("scenario field '", f"scenario file {str(p)!r}")), exc
