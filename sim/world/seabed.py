"""Seeded seabed generation: a regular height grid turned into a static triangle mesh.

Kinds: "flat" (sand with small-scale roughness), "ripples" (sand ripples: a dominant
wavelength with a sharpened, asymmetric crest profile and seeded phase/direction
wander), "slope" (a plane of given gradient), "rocks" (flat sand strewn with seeded
rock outcrops of ellipsoidal cap shape) and "grid" (a depth grid loaded from a .npy
file or passed in, depths positive down).

Why a mesh and not an hfield: MuJoCo's hfield ray casting marches the grid and is
orders of magnitude slower at the grazing angles side-scan sonar needs; a mesh gets a
BVH. The same grid also becomes a transparent, ray-invisible (alpha 0) hfield used only
for contacts, because MuJoCo collides mesh geoms through their convex hull, which would
be wrong for terrain.

Everything is a pure function of the spec (seeded ``numpy.random.Generator``): the
same spec gives the same bytes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.ndimage import gaussian_filter

SEABED_KINDS = ("flat", "ripples", "slope", "rocks", "grid")


def _positive(name: str, v: float, allow_zero: bool = False) -> float:
    v = float(v)
    if not np.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        raise ValueError(f"{name} must be {'>= 0' if allow_zero else '> 0'}, got {v!r}")
    return v


@dataclass(frozen=True)
class SeabedSpec:
    """Seabed description (world frame: x east, y north, z up; the grid is centred on
    ``center_xy``).

    kind            : one of SEABED_KINDS.
    size_xy         : (Lx, Ly) extent, m.  resolution : grid spacing, m.
    depth           : mean seabed depth below the surface datum, m (positive).
    seed            : seed of every random draw.
    roughness       : rms of small-scale (correlation ~1 m) height noise, m.
    ripple_wavelength, ripple_height, ripple_direction_deg : sand ripples (crest normal
                      direction, counter-clockwise from east).
    slope_deg, slope_direction_deg : downhill gradient and its direction.
    rock_density    : rocks per m²; rock_size : (min, max) rock diameter, m.
    relief, relief_scale : rms (m) and correlation length (m) of gentle large-scale
                      undulation added to any generated kind (0: none); the altitude
                      autopilot then rides it, so the side-scan nadir wanders.
    grid_path / grid: depth grid (ny, nx), metres positive down, for kind "grid";
                      ``resolution`` is its spacing.
    """

    kind: str = "flat"
    size_xy: tuple[float, float] = (100.0, 100.0)
    resolution: float = 0.25
    depth: float = 30.0
    seed: int = 0
    roughness: float = 0.02
    ripple_wavelength: float = 0.8
    ripple_height: float = 0.08
    ripple_direction_deg: float = 30.0
    slope_deg: float = 5.0
    slope_direction_deg: float = 0.0
    rock_density: float = 0.01
    rock_size: tuple[float, float] = (0.3, 1.5)
    center_xy: tuple[float, float] = (0.0, 0.0)
    relief: float = 0.0
    relief_scale: float = 25.0
    grid_path: str | None = None
    grid: np.ndarray | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        if self.kind not in SEABED_KINDS:
            raise ValueError(f"seabed.kind must be one of {SEABED_KINDS}, got {self.kind!r}")
        sx, sy = (float(v) for v in self.size_xy)
        _positive("seabed.size_xy[0]", sx)
        _positive("seabed.size_xy[1]", sy)
        _positive("seabed.resolution", self.resolution)
        if self.kind != "grid":
            n = (sx / self.resolution + 1) * (sy / self.resolution + 1)
            if n > 4_000_000 or sx / self.resolution < 2 or sy / self.resolution < 2:
                raise ValueError(
                    f"seabed.resolution {self.resolution!r} gives {n:.0f} grid points for "
                    f"size {self.size_xy!r}: allowed 3..4e6 per axis product"
                )
        _positive("seabed.depth", self.depth)
        _positive("seabed.roughness", self.roughness, allow_zero=True)
        _positive("seabed.ripple_wavelength", self.ripple_wavelength)
        _positive("seabed.ripple_height", self.ripple_height, allow_zero=True)
        if not 0.0 <= float(self.slope_deg) < 60.0:
            raise ValueError(f"seabed.slope_deg must be in [0, 60), got {self.slope_deg!r}")
        _positive("seabed.rock_density", self.rock_density, allow_zero=True)
        _positive("seabed.relief", self.relief, allow_zero=True)
        _positive("seabed.relief_scale", self.relief_scale)
        lo, hi = (float(v) for v in self.rock_size)
        if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo <= hi):
            raise ValueError(
                f"seabed.rock_size must be (min, max) with 0 < min <= max, got {self.rock_size!r}"
            )
        if self.kind == "grid" and self.grid is None and self.grid_path is None:
            raise ValueError(
                "seabed.kind 'grid' needs seabed.grid_path (a .npy file) or seabed.grid"
            )


@dataclass(frozen=True)
class Seabed:
    """A generated seabed: the grid, its axes and the triangle mesh built from it.

    x (nx,), y (ny,) grid axes, m; z (ny, nx) heights (world z, negative below datum);
    vertices (V, 3) float64 world m; faces (F, 3) int32 (counter-clockwise seen from
    above, normals up).
    """

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    vertices: np.ndarray
    faces: np.ndarray

    def to_trimesh(self):
        """The seabed as a ``trimesh.Trimesh`` (world frame; not processed, so vertex and
        face order match ``vertices``/``faces``)."""
        import trimesh

        return trimesh.Trimesh(self.vertices, self.faces, process=False)

    def height(self, xy: np.ndarray) -> np.ndarray:
        """Seabed z under points (N, 2), bilinear on the grid (= the mesh's triangles up to
        the diagonal split); points outside the grid take the nearest edge value."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        dx = self.x[1] - self.x[0]
        dy = self.y[1] - self.y[0]
        fx = np.clip((xy[:, 0] - self.x[0]) / dx, 0.0, len(self.x) - 1.000001)
        fy = np.clip((xy[:, 1] - self.y[0]) / dy, 0.0, len(self.y) - 1.000001)
        ix = fx.astype(np.intp)
        iy = fy.astype(np.intp)
        tx = fx - ix
        ty = fy - iy
        z = self.z
        # the mesh splits each cell along (i, j)-(i+1, j+1): interpolate on that triangle
        z00 = z[iy, ix]
        z11 = z[iy + 1, ix + 1]
        upper = ty > tx
        z_other = np.where(upper, z[iy + 1, ix], z[iy, ix + 1])
        a = np.where(upper, tx, ty)
        b = np.where(upper, ty, tx)
        # barycentric on triangle (00, other, 11): z = z00 + (b - a)(z_other - z00) + a (z11 - z00)
        return z00 + (b - a) * (z_other - z00) + a * (z11 - z00)


def _smooth_noise(shape: tuple[int, int], sigma_px: float, rng: np.random.Generator) -> np.ndarray:
    n = gaussian_filter(rng.standard_normal(shape), sigma=max(sigma_px, 0.5), mode="wrap")
    n -= n.mean()
    s = n.std()
    return n / s if s > 0 else n


def load_depth_grid(path: str | Path) -> np.ndarray:
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"seabed.grid_path must be an existing .npy file, got {str(path)!r}")
    return np.load(p, allow_pickle=False)


def check_depth_grid(grid: np.ndarray) -> np.ndarray:
    """The grid as float (ny, nx) depths, m positive down; ValueError naming the problem
    (not 2-D, fewer than 2 rows or columns, non-finite or non-positive depths)."""
    g = np.asarray(grid, dtype=float)
    if g.ndim != 2 or min(g.shape) < 2:
        raise ValueError(
            f"seabed.grid must be a 2-D depth array with >= 2 rows and columns, got shape {g.shape}"
        )
    bad = ~np.isfinite(g)
    if bad.any():
        iy, ix = np.argwhere(bad)[0]
        raise ValueError(
            f"seabed.grid has {int(bad.sum())} non-finite depths (first at row {iy}, column {ix}: "
            f"{float(g[iy, ix])!r}); allowed: finite depths in metres, positive down"
        )
    if (g <= 0).any():
        raise ValueError(
            f"seabed.grid depths must be > 0 (metres below the surface, positive down), min is {g.min()!r}"
        )
    return g


def height_grid(spec: SeabedSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x (nx,), y (ny,), z (ny, nx)) heights, world z."""
    rng = np.random.default_rng(spec.seed)
    cx, cy = (float(v) for v in spec.center_xy)
    r = float(spec.resolution)
    if spec.kind == "grid":
        g = check_depth_grid(spec.grid if spec.grid is not None else load_depth_grid(spec.grid_path))
        ny, nx = g.shape
        x = cx + (np.arange(nx) - (nx - 1) / 2) * r
        y = cy + (np.arange(ny) - (ny - 1) / 2) * r
        return x, y, -g
    sx, sy = (float(v) for v in spec.size_xy)
    nx = round(sx / r) + 1
    ny = round(sy / r) + 1
    x = cx + (np.arange(nx) - (nx - 1) / 2) * r
    y = cy + (np.arange(ny) - (ny - 1) / 2) * r
    X, Y = np.meshgrid(x - cx, y - cy, indexing="xy")
    z = np.full((ny, nx), -float(spec.depth))
    if spec.roughness > 0:
        z += spec.roughness * _smooth_noise((ny, nx), 1.0 / r, rng)
    if spec.kind == "ripples":
        th = np.deg2rad(spec.ripple_direction_deg)
        # slow seeded wander of phase (crest sinuosity) over ~10 wavelengths
        wander = _smooth_noise((ny, nx), 10 * spec.ripple_wavelength / r, rng)
        phase = 2 * np.pi * (X * np.cos(th) + Y * np.sin(th)) / spec.ripple_wavelength
        phase = phase + 1.5 * wander
        # asymmetric ripple profile (steeper lee side): sin + 0.25 sin(2·)
        prof = np.sin(phase) + 0.25 * np.sin(2 * phase)
        prof /= np.abs(prof).max()
        amp = (
            0.5 * spec.ripple_height * (1.0 + 0.3 * np.tanh(_smooth_noise((ny, nx), 20.0 / r, rng)))
        )
        z += amp * prof
    elif spec.kind == "slope":
        th = np.deg2rad(spec.slope_direction_deg)
        z -= np.tan(np.deg2rad(spec.slope_deg)) * (X * np.cos(th) + Y * np.sin(th))
    elif spec.kind == "rocks":
        area = sx * sy
        n = rng.poisson(spec.rock_density * area)
        lo, hi = spec.rock_size
        centres = rng.uniform([-sx / 2, -sy / 2], [sx / 2, sy / 2], size=(n, 2))
        diam = rng.uniform(lo, hi, size=n)
        elong = rng.uniform(0.6, 1.0, size=n)
        yaw = rng.uniform(0, np.pi, size=n)
        heights = diam * rng.uniform(0.25, 0.6, size=n)
        bump = np.zeros_like(z)
        for c, d, e, w, h in zip(centres, diam, elong, yaw, heights):  # build time only
            a, b = d / 2, d * e / 2
            i0 = max(int((c[0] - a + sx / 2) / r), 0)
            i1 = min(int((c[0] + a + sx / 2) / r) + 2, nx)
            j0 = max(int((c[1] - a + sy / 2) / r), 0)
            j1 = min(int((c[1] + a + sy / 2) / r) + 2, ny)
            px = X[j0:j1, i0:i1] - c[0]
            py = Y[j0:j1, i0:i1] - c[1]
            u = (px * np.cos(w) + py * np.sin(w)) / a
            v = (-px * np.sin(w) + py * np.cos(w)) / b
            cap = h * np.sqrt(np.clip(1.0 - u * u - v * v, 0.0, None))
            np.maximum(bump[j0:j1, i0:i1], cap, out=bump[j0:j1, i0:i1])
        z += bump
    if spec.relief > 0:  # own stream: the other draws stay as without relief
        relief_rng = np.random.default_rng([spec.seed, 101])
        z += spec.relief * _smooth_noise((ny, nx), spec.relief_scale / r, relief_rng)
    return x, y, z


def grid_mesh(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (ny*nx, 3) and faces (2 (ny-1)(nx-1), 3) int32 of the height grid, two
    triangles per cell split along the (i, j)-(i+1, j+1) diagonal, normals up."""
    ny, nx = z.shape
    X, Y = np.meshgrid(x, y, indexing="xy")
    verts = np.column_stack([X.ravel(), Y.ravel(), z.ravel()])
    i = (np.arange(ny - 1)[:, None] * nx + np.arange(nx - 1)[None, :]).ravel()
    faces = np.concatenate(
        [np.column_stack([i, i + 1, i + nx + 1]), np.column_stack([i, i + nx + 1, i + nx])]
    ).astype(np.int32)
    return verts, faces


def generate_seabed(spec: SeabedSpec) -> Seabed:
    x, y, z = height_grid(spec)
    v, f = grid_mesh(x, y, z)
    for a in (x, y, z, v, f):
        a.setflags(write=False)
    return Seabed(x=x, y=y, z=z, vertices=v, faces=f)
