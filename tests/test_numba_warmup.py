"""tests/helpers/numba_warmup.py: the kernels it finds and the cache state it reads are
numba's own (second implementation: the imported dispatchers and numba's index reader)."""

from __future__ import annotations

import importlib
from pathlib import Path

import numba
import numpy as np
from numba.core.registry import CPUDispatcher
from numba_warmup import cold_kernels, kernel_functions

from slam.frontend.segmentation.kernels import otsu_from_hist

REPO = Path(__file__).resolve().parents[1]


def _dispatchers():
    """(module file stem, function name) -> dispatcher, for every cached kernel the
    imported kernel modules define (``cache=True``, not inlined)."""
    out = {}
    for path in {p for p, _, _ in kernel_functions(REPO)}:
        name = ".".join(path.relative_to(REPO).with_suffix("").parts)
        for attr, obj in vars(importlib.import_module(name)).items():
            if (
                isinstance(obj, CPUDispatcher)
                and obj.__module__ == name
                and obj._cache.__class__.__name__ == "FunctionCache"
                and obj.targetoptions.get("inline") != "always"
            ):
                out[(path.stem, attr)] = obj
    return out


def test_kernel_functions_are_the_modules_cached_dispatchers():
    found = {(p.stem, name) for p, name, _ in kernel_functions(REPO)}
    assert found == set(_dispatchers())
    assert len(found) > 40  # sonar, segmentation, navigation, envs, physics, AEKF


def test_cold_kernels_agree_with_numbas_own_index_reader():
    """After one kernel is called (so at least one is cached), a kernel is cold exactly
    when numba's index reader finds no compilation for the current source."""
    assert otsu_from_hist(np.ones(256)) >= 0  # compiles or loads, and caches
    cold = set(cold_kernels(REPO))
    disp = _dispatchers()
    numba_cold = {
        f"{m}.{f}" for (m, f), d in disp.items() if not d._cache._cache_file._load_index()
    }
    assert "kernels.otsu_from_hist" not in cold
    assert cold == numba_cold
    assert numba.__version__  # the index is tied to this numba version
