"""Bounding cones of a ray bundle and the compiled per-cast loops of the Embree backend.

:class:`RayCones` bounds consecutive chunks of a sonar's rays by cones (built once per
sonar in the sensor frame, rotated with it); :func:`near_moving` uses them to send to
MuJoCo only the rays that can pass within a moving geom's bounding sphere, and
:func:`gather_hits` turns Embree's float32 output into the float64 :class:`RayHits`
arrays in one pass. Loops compiled by numba on first use and cached on disk.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

#: a geom whose bounding-sphere centre is nearer than this many radii to the origin is
#: tested ray by ray (the cone bound assumes the sphere lies ahead of the origin)
_CONE_NEAR_RADII = 2.0
_CONE_MARGIN_RAD = 1e-6  # round-off allowance on every cone comparison


@dataclass(frozen=True)
class RayCones:
    """Bounding cones of consecutive chunks of a ray bundle: chunk k holds rays
    ``k·chunk … (k + 1)·chunk − 1``; every one lies within ``half_angle[k]`` (rad) of the
    unit ``axes[k]`` (same frame as the rays). ``n``: number of rays."""

    axes: np.ndarray
    half_angle: np.ndarray
    chunk: int
    n: int

    def rotated(self, R: np.ndarray) -> RayCones:
        """The cones of the rays ``d @ R.T`` (e.g. sensor frame → world frame)."""
        return RayCones(self.axes @ np.ascontiguousarray(R.T), self.half_angle, self.chunk, self.n)

    def candidates(self, centres: np.ndarray, radii: np.ndarray, cutoff: float):
        """Ray indices (sorted int64) that may pass within ``radii`` (G,) m of the sphere
        ``centres`` (G, 3) m (relative to the rays' origin) before ``cutoff`` m; None when
        a sphere is too near the origin for the cone bound (test every ray)."""
        c = np.ascontiguousarray(centres, np.float64)
        rb = np.ascontiguousarray(radii, np.float64)
        idx = _cone_candidates(self.axes, self.half_angle, self.chunk, self.n, c, rb, cutoff)
        return None if idx.size == 1 and idx[0] < 0 else idx

    def near(self, dirs: np.ndarray, centres: np.ndarray, radii: np.ndarray, cutoff: float):
        """Indices (sorted int64) of the rays ``dirs`` (N, 3) (the rays these cones bound)
        passing within ``radii`` (G,) m of the sphere ``centres`` (G, 3) m before
        ``cutoff``: :func:`near_rays` on the :meth:`candidates` only (one compiled call)."""
        return _near_in_cones(
            dirs, self.axes, self.half_angle, self.chunk, self.n, centres, radii, float(cutoff)
        )


def ray_cones(dirs: np.ndarray, chunk: int = 64) -> RayCones:
    """Bounding cones of consecutive chunks of ``chunk`` unit directions ``dirs`` (N, 3)
    (see :class:`RayCones`); the axis is each chunk's normalised mean direction."""
    d = np.asarray(dirs, float)
    n = d.shape[0]
    k = max(1, -(-n // chunk))
    pad = (
        np.concatenate([d, np.repeat(d[-1:], k * chunk - n, axis=0)])
        if n
        else np.zeros((k * chunk, 3))
    )
    blocks = pad.reshape(k, chunk, 3)
    s = blocks.sum(axis=1)
    ln = np.linalg.norm(s, axis=1)
    axes = np.where(ln[:, None] > 1e-9, s / np.maximum(ln, 1e-300)[:, None], np.array([1.0, 0, 0]))
    cosang = np.clip(np.einsum("kcj,kj->kc", blocks, axes), -1.0, 1.0)
    half = np.arccos(cosang.min(axis=1))
    half = np.where(ln > 1e-9, half, np.pi)
    return RayCones(axes, half + _CONE_MARGIN_RAD, int(chunk), int(n))


@numba.njit(cache=True)
def _cone_candidates(axes, half, chunk, n, c, rb, cutoff):
    """Indices of the rays of chunks whose cone meets a sphere (centre ``c`` (G, 3)
    relative to the origin, radius ``rb`` (G,)) reachable before ``cutoff``; ``[-1]``
    when a sphere is within ``_CONE_NEAR_RADII`` radii of the origin (test every ray)."""
    G = rb.size
    dist = np.empty(G)
    for g in range(G):
        dist[g] = np.sqrt(c[g, 0] * c[g, 0] + c[g, 1] * c[g, 1] + c[g, 2] * c[g, 2])
        if dist[g] <= _CONE_NEAR_RADII * rb[g]:
            return np.full(1, -1, np.int64)
    hit = np.zeros(axes.shape[0], np.bool_)
    for g in range(G):
        # a ray within distance rb of the centre has t ≥ sqrt(|c|² − rb²) along it
        if np.sqrt(dist[g] * dist[g] - rb[g] * rb[g]) - rb[g] > cutoff:
            continue
        alpha = np.arcsin(rb[g] / dist[g])  # angular radius of the sphere
        for k in range(axes.shape[0]):
            cosang = (axes[k, 0] * c[g, 0] + axes[k, 1] * c[g, 1] + axes[k, 2] * c[g, 2]) / dist[g]
            ang = np.arccos(min(max(cosang, -1.0), 1.0))
            if ang <= half[k] + alpha + _CONE_MARGIN_RAD:
                hit[k] = True
    m = 0
    for k in range(hit.size):
        if hit[k]:
            m += min(chunk, n - k * chunk)
    out = np.empty(m, np.int64)
    p = 0
    for k in range(hit.size):
        if hit[k]:
            for i in range(k * chunk, min((k + 1) * chunk, n)):
                out[p] = i
                p += 1
    return out


@numba.njit(cache=True)
def near_rays(dirs, idx, c, rb, cutoff):
    """Indices (among ``idx``, or all rays when ``idx`` is None) of the unit rays ``dirs``
    (N, 3) that pass within ``rb`` (G,) m of a sphere centre ``c`` (G, 3) m (relative to
    the origin) at a distance along the ray in [−rb, cutoff + rb]."""
    n = dirs.shape[0] if idx is None else idx.size
    out = np.empty(n, np.int64)
    m = 0
    for q in range(n):
        i = q if idx is None else idx[q]
        for g in range(rb.size):
            t = dirs[i, 0] * c[g, 0] + dirs[i, 1] * c[g, 1] + dirs[i, 2] * c[g, 2]
            d2 = (c[g, 0] * c[g, 0] + c[g, 1] * c[g, 1] + c[g, 2] * c[g, 2]) - t * t
            if d2 <= rb[g] * rb[g] and t >= -rb[g] and t - rb[g] <= cutoff:
                out[m] = i
                m += 1
                break
    return out[:m]


@numba.njit(cache=True)
def _near_in_cones(dirs, axes, half, chunk, n, c, rb, cutoff):
    idx = _cone_candidates(axes, half, chunk, n, c, rb, cutoff)
    if idx.size == 1 and idx[0] < 0:
        return near_rays(dirs, None, c, rb, cutoff)
    if idx.size == 0:
        return idx
    return near_rays(dirs, idx, c, rb, cutoff)


@numba.njit(cache=True)
def gather_hits(prim, tfar, face_geom, face_normal):
    """Embree's primitive ids (N,) int32 (−1 miss) and float32 distances (N,) → float64
    distances (inf for a miss), geom ids (−1) and float64 unit normals (zeros)."""
    n = prim.size
    dist = np.empty(n)
    geom = np.empty(n, np.int32)
    normal = np.empty((n, 3))
    for i in range(n):
        p = prim[i]
        if p < 0:
            dist[i] = np.inf
            geom[i] = -1
            normal[i, 0] = normal[i, 1] = normal[i, 2] = 0.0
        else:
            dist[i] = np.float64(tfar[i])
            geom[i] = face_geom[p]
            normal[i, 0] = face_normal[p, 0]
            normal[i, 1] = face_normal[p, 1]
            normal[i, 2] = face_normal[p, 2]
    return dist, geom, normal
