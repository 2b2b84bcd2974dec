"""Checks of a scenario against its seabed, at load time (not at world build).

Everything the file decides is checked when the scenario is read, with the usual
:class:`ScenarioError` naming the field: a grid seabed's ``.npy`` file (missing,
unreadable, not 2-D, smaller than 2 x 2, non-finite or non-positive depths), the seabed
grid size, vehicle starts above the seabed (a sloped or grid seabed is higher than
``world.depth_m`` in places) and objects on the seabed grid.

The seabed is generated exactly as the world builder will (``sim.world.seabed``) from
:func:`seabed_spec`, the one place that maps the scenario's world to a ``SeabedSpec``.
"""

from __future__ import annotations

import functools
import zipfile
from pathlib import Path

import numpy as np

from sim.world.seabed import Seabed, SeabedSpec, check_depth_grid, height_grid

#: a start must be at least this far above the seabed, m (the largest hull half-height)
START_CLEARANCE_M = 0.5


def _error(path: str, value, allowed: str):
    from sim.scenario.schema import ScenarioError  # here: schema imports this module

    return ScenarioError(f"scenario field '{path}': got {value!r}; allowed: {allowed}")


def seabed_resolution(size_m: tuple[float, float]) -> float:
    """Grid spacing of the seabed of a world of this size, m (0.25 .. 2 m, ~400 cells)."""
    return float(np.clip(max(size_m) / 400.0, 0.25, 2.0))


def load_grid(grid_path: str, field: str = "world.grid_path") -> np.ndarray:
    """The depth grid (ny, nx) of a grid seabed, m positive down; ScenarioError otherwise."""
    p = Path(grid_path)
    if not p.is_file():
        raise _error(field, grid_path, "an existing .npy file of depths (m, positive down)")
    try:
        g = np.load(p, allow_pickle=False)
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise _error(
            field, grid_path, f"a readable .npy file of depths ({type(exc).__name__}: {exc})"
        ) from exc
    if not isinstance(g, np.ndarray) or not np.issubdtype(g.dtype, np.number):
        raise _error(field, grid_path, "one numeric 2-D array saved with numpy.save")
    try:
        return check_depth_grid(g)
    except ValueError as exc:
        raise _error(field, grid_path, str(exc)) from exc


def seabed_spec(world, seed: int, grid: np.ndarray | None = None) -> SeabedSpec:
    """The sim.world SeabedSpec of a scenario's world (``WorldSpecConfig``)."""
    return SeabedSpec(
        kind=world.seabed,
        size_xy=world.size_m,
        resolution=seabed_resolution(world.size_m),
        depth=world.depth_m,
        seed=seed,
        grid_path=world.grid_path or None,
        grid=grid,
        relief=world.relief_m,
    )


def build_seabed(world, seed: int) -> Seabed:
    """The seabed heights the world builder will make (no mesh), or ScenarioError naming
    the field. Generated seabeds are cached per spec (fuzzing and sweeps load one world
    many times)."""
    grid = load_grid(world.grid_path) if world.seabed == "grid" else None
    try:
        spec = seabed_spec(world, seed, grid)
    except ValueError as exc:
        raise _error("world.size_m", list(world.size_m), str(exc)) from exc
    return _heights(spec) if grid is None else _heights.__wrapped__(spec)


@functools.lru_cache(maxsize=16)
def _heights(spec: SeabedSpec) -> Seabed:
    x, y, z = height_grid(spec)
    return Seabed(x=x, y=y, z=z, vertices=np.empty((0, 3)), faces=np.empty((0, 3), np.int32))


def check_scenario_seabed(world, vehicles, seed: int) -> None:
    """Vehicle starts above the seabed and objects on the seabed grid (ScenarioError)."""
    seabed = build_seabed(world, seed)
    lo = np.array([seabed.x[0], seabed.y[0]])
    hi = np.array([seabed.x[-1], seabed.y[-1]])
    for i, o in enumerate(world.objects):
        xy = np.asarray(o.position, float)
        for ax in range(2):
            if not lo[ax] <= xy[ax] <= hi[ax]:
                raise _error(
                    f"world.objects[{i}].position[{ax}]",
                    float(xy[ax]),
                    f"a position on the seabed grid, {lo[ax]:g} .. {hi[ax]:g} m",
                )
    for i, v in enumerate(vehicles):
        x, y, z = v.start_position
        for ax, c in enumerate((x, y)):
            if not lo[ax] <= c <= hi[ax]:
                raise _error(
                    f"vehicles[{i}].start.position[{ax}]",
                    c,
                    f"a position over the seabed grid, {lo[ax]:g} .. {hi[ax]:g} m",
                )
        floor = float(seabed.height(np.array([[x, y]]))[0])
        if z < floor + START_CLEARANCE_M:
            raise _error(
                f"vehicles[{i}].start.position[2]",
                z,
                f"a z above the seabed there: >= {floor + START_CLEARANCE_M:.2f} m "
                f"(seabed at z = {floor:.2f} m under ({x:g}, {y:g}), plus "
                f"{START_CLEARANCE_M:g} m clearance)",
            )
