"""The rooms of ARCHITECTURE.md, checked on the source: slam never imports sim or mujoco;
sim imports slam only from the runner, the envs, the CLI, sweeps, datasets and the
scenario schema (which validates against slam's registries) and the figures; the envs
use the runner only through its public names."""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
# scenario: the schema validates names and slam.params against slam's own registries;
# viz: figures draw slam's results (bottom track, mosaics of real recordings)
SIM_MAY_IMPORT_SLAM = ("runner", "envs", "cli", "sweep", "dataset", "scenario", "viz")


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


def test_slam_never_imports_sim_or_mujoco():
    files = sorted((REPO / "slam").rglob("*.py"))
    assert len(files) > 5
    bad = {str(p.relative_to(REPO)): sorted(_imports(p) & {"sim", "mujoco"}) for p in files}
    assert {k: v for k, v in bad.items() if v} == {}


def test_sim_imports_slam_only_where_allowed():
    bad = []
    for p in sorted((REPO / "sim").rglob("*.py")):
        rel = p.relative_to(REPO / "sim")
        if rel.parts[0].removesuffix(".py") in SIM_MAY_IMPORT_SLAM:
            continue
        if "slam" in _imports(p):
            bad.append(str(rel))
    assert bad == []


def _private_imports_from(path: Path, package: str) -> set[str]:
    """Names starting with "_" imported from ``package`` or its modules (``from package.x
    import _name``, ``import package._x``), and private modules of it."""
    tree = ast.parse(path.read_text(), filename=str(path))
    bad: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            mod = node.module
            if mod == package or mod.startswith(package + "."):
                parts = mod.split(".")
                bad.update(f"{mod}.{a.name}" for a in node.names if a.name.startswith("_"))
                if any(p.startswith("_") for p in parts):
                    bad.add(mod)
        elif isinstance(node, ast.Import):
            for a in node.names:
                parts = a.name.split(".")
                if a.name.startswith(package + ".") and any(p.startswith("_") for p in parts):
                    bad.add(a.name)
    return bad


def test_envs_use_no_private_runner_name():
    files = sorted((REPO / "sim" / "envs").rglob("*.py"))
    assert files
    bad = {str(p.relative_to(REPO)): sorted(_private_imports_from(p, "sim.runner")) for p in files}
    assert {k: v for k, v in bad.items() if v} == {}


def test_private_name_checker_sees_a_private_import(tmp_path):
    """The checker itself flags a private runner name and passes a public one."""
    f = tmp_path / "m.py"
    f.write_text("from sim.runner.core import _SonarWater, run_scenario\nimport sim.runner._x\n")
    assert _private_imports_from(f, "sim.runner") == {"sim.runner.core._SonarWater", "sim.runner._x"}


def test_checker_sees_imports():
    """The checker itself finds a plain and a from-import (it can fail)."""
    src = REPO / "tests" / "test_architecture.py"
    assert {"ast", "pathlib", "__future__"} <= _imports(src)
