"""The rooms of ARCHITECTURE.md, checked on the source: slam never imports sim or mujoco;
sim imports slam only from the runner, the envs, the CLI, sweeps and datasets."""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SIM_MAY_IMPORT_SLAM = ("runner", "envs", "cli", "sweep", "dataset")


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


def test_checker_sees_imports():
    """The checker itself finds a plain and a from-import (it can fail)."""
    src = REPO / "tests" / "test_architecture.py"
    assert {"ast", "pathlib", "__future__"} <= _imports(src)
