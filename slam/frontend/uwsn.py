"""UWSN-DT: underwater wireless sensor network based Delaunay triangulation map fusion
(thesis Ch. 4.3).

Seabed sensor nodes with known positions serve as feature points where a sonar image
offers none. For each scan the AUV broadcasts HELLO (Algorithm 3): nodes within the AUV
communication range R = sqrt((L² + W²)/4 + H²) (eq. 4.19) wake up; those inside the
rectangular scan area x_A ± L/2, y_A ± W/2 (eqs. 4.20–4.21, strict inequalities as in
Algorithm 3 line 15) reply with their number and coordinates and are placed in that scan's
sonar map. Nodes seen in two scans are triangulated (``scipy.spatial.Delaunay``), and the
rigid transform between the two scan frames follows from the shared nodes by
Kabsch/Umeyama (``skimage.transform.EuclideanTransform``).

Frames: world x east, y north (m). A scan's map frame is the AUV pose at the scan
(x_A, y_A, heading ψ; x forward): p_scan = Rot(−ψ)·(p_world − [x_A, y_A]). Sonar-map
positions carry Gaussian noise (σ ``position_sigma`` m, from the rng passed in) standing in
for the error of placing a node in the sonar image.

Reproduced setup (thesis 4.3.2): area 3000 m × 3000 m, 1000 nodes, scans at (500, 500) and
(600, 600). The thesis gives R = 447 m and "400 m × 400 m in both left and right sonar
scans"; its Table 4.5 has nodes up to 390 m from the AUV in x but only 169 m in y, so the
scan rectangle is L = 800 m in x (two 400 m swaths) by W = 400 m in y, and
R = sqrt((800² + 400²)/4 + H²) = 447.2 m for H = 0 (any altitude below ~15 m rounds to
447 m). The default altitude is therefore 0 m.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class UWSNConfig:
    """area_m: (X, Y) extent of the node field from the origin, m; n_nodes: nodes placed
    uniformly at random; scan_length_m L (world x extent) and scan_width_m W (world y extent)
    of the scan rectangle; altitude_m H of the AUV; position_sigma_m: noise of a node's
    position in a sonar map."""

    area_m: tuple[float, float] = (3000.0, 3000.0)
    n_nodes: int = 1000
    scan_length_m: float = 800.0
    scan_width_m: float = 400.0
    altitude_m: float = 0.0
    position_sigma_m: float = 0.5

    def __post_init__(self) -> None:
        if not (self.area_m[0] > 0 and self.area_m[1] > 0):
            raise ValueError(f"area_m must be positive, got {self.area_m}")
        if self.n_nodes < 0:
            raise ValueError(f"n_nodes must be >= 0, got {self.n_nodes}")
        if self.scan_length_m <= 0 or self.scan_width_m <= 0 or self.altitude_m < 0:
            raise ValueError(
                f"scan_length_m={self.scan_length_m}, scan_width_m={self.scan_width_m} must be "
                f"> 0 and altitude_m={self.altitude_m} >= 0"
            )
        if self.position_sigma_m < 0:
            raise ValueError(f"position_sigma_m must be >= 0, got {self.position_sigma_m}")

    @property
    def comm_range_m(self) -> float:
        """R of eq. 4.19."""
        return communication_range(self.scan_length_m, self.scan_width_m, self.altitude_m)


def communication_range(length_m: float, width_m: float, altitude_m: float) -> float:
    """Minimum AUV communication range covering its scan rectangle, eq. 4.19:
    R = sqrt((L² + W²)/4 + H²)."""
    return float(np.sqrt((length_m**2 + width_m**2) / 4.0 + altitude_m**2))


def deploy_nodes(config: UWSNConfig, rng: np.random.Generator) -> np.ndarray:
    """(N, 2) node positions, uniform over the area, m. Node number = row index + 1."""
    return rng.uniform((0.0, 0.0), config.area_m, size=(config.n_nodes, 2))


@dataclass(frozen=True)
class Scan:
    """Nodes found by one scan.

    auv_xy, heading_rad : AUV pose of the scan (world).
    ids      : (K,) int node numbers (1-based) that replied (Algorithm 3).
    world_xy : (K, 2) their true positions, m.
    map_xy   : (K, 2) their positions in the scan's map frame, m (noisy).
    n_awake  : nodes that received HELLO (within R).
    """

    auv_xy: np.ndarray
    heading_rad: float
    ids: np.ndarray
    world_xy: np.ndarray
    map_xy: np.ndarray
    n_awake: int


def _rot(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s], [s, c]])


def discover_nodes(
    nodes: np.ndarray,
    auv_xy: tuple[float, float],
    config: UWSNConfig,
    rng: np.random.Generator,
    *,
    heading_rad: float = 0.0,
) -> Scan:
    """Algorithm 3 for one AUV position, vectorized over nodes.

    Awake = 3-D distance to the AUV (at altitude H) ≤ R (the node then answers with
    r_s ∈ [|As|, R], so the link is bi-directional). Reporting = awake and strictly inside
    x_A ± L/2, y_A ± W/2 (axis-aligned in world, as the thesis's eqs. 4.20–4.21).
    """
    nodes = np.asarray(nodes, dtype=np.float64).reshape(-1, 2)
    a = np.asarray(auv_xy, dtype=np.float64).reshape(2)
    d = nodes - a
    dist = np.sqrt(np.sum(d**2, axis=1) + config.altitude_m**2)
    awake = dist <= config.comm_range_m
    inside = (np.abs(d[:, 0]) < config.scan_length_m / 2.0) & (
        np.abs(d[:, 1]) < config.scan_width_m / 2.0
    )
    rep = np.flatnonzero(awake & inside)
    world = nodes[rep]
    local = (world - a) @ _rot(heading_rad)  # = Rot(-psi) (p - a), row form
    local = local + rng.normal(0.0, config.position_sigma_m, size=local.shape)
    return Scan(a, float(heading_rad), rep + 1, world, local, int(awake.sum()))


@dataclass(frozen=True)
class FusionResult:
    """Outcome of fusing two scans.

    common_ids  : (K,) node numbers seen in both scans.
    triangles   : (T, 3) indices into ``common_ids`` of the Delaunay triangulation in scan A's
                  map frame (empty when K < 3 or the nodes are collinear).
    shared_triangle_fraction : fraction of those triangles that scan B's own triangulation
                  also has (a rigid map leaves a Delaunay triangulation unchanged, so this is
                  1 up to noise-induced flips).
    transform   : (3, 3) homogeneous rigid transform taking scan-B map coordinates to scan-A
                  map coordinates (None when K < 2).
    rms_residual_m : RMS of the shared nodes after the transform.
    """

    common_ids: np.ndarray
    triangles: np.ndarray
    shared_triangle_fraction: float
    transform: np.ndarray | None
    rms_residual_m: float

    @property
    def matched(self) -> bool:
        """The thesis's criterion for two images: at least 3 shared feature points."""
        return self.common_ids.size >= 3


def rigid_transform(src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """Least-squares rigid transform (rotation + translation, no scale) dst ≈ T·src by
    Umeyama/Kabsch (``skimage.transform.EuclideanTransform.from_estimate``). (3, 3)."""
    from skimage.transform import EuclideanTransform

    src = np.asarray(src, dtype=np.float64)
    dst = np.asarray(dst, dtype=np.float64)
    if src.shape != dst.shape or src.ndim != 2 or src.shape[1] != 2 or src.shape[0] < 2:
        raise ValueError(f"need matching (K >= 2, 2) point sets, got {src.shape} and {dst.shape}")
    tf = EuclideanTransform.from_estimate(src, dst)
    if not tf:
        raise ValueError(f"rigid transform estimation failed: {tf}")
    return np.asarray(tf.params, dtype=np.float64)


def _triangles(points: np.ndarray) -> np.ndarray:
    from scipy.spatial import Delaunay, QhullError

    if points.shape[0] < 3:
        return np.zeros((0, 3), np.int64)
    try:
        return np.asarray(Delaunay(points).simplices, dtype=np.int64)
    except QhullError:  # collinear / coincident nodes
        return np.zeros((0, 3), np.int64)


def fuse_scans(scan_a: Scan, scan_b: Scan) -> FusionResult:
    """UWSN-DT fusion of two scans via their shared node numbers."""
    common, ia, ib = np.intersect1d(scan_a.ids, scan_b.ids, return_indices=True)
    pa, pb = scan_a.map_xy[ia], scan_b.map_xy[ib]
    tri_a = _triangles(pa)
    tri_b = _triangles(pb)
    if tri_a.shape[0]:
        key_a = {tuple(sorted(t)) for t in tri_a.tolist()}
        key_b = {tuple(sorted(t)) for t in tri_b.tolist()}
        shared = len(key_a & key_b) / len(key_a)
    else:
        shared = float("nan")
    if common.size >= 2:
        t = rigid_transform(pb, pa)
        res = pb @ t[:2, :2].T + t[:2, 2] - pa
        rms = float(np.sqrt(np.mean(np.sum(res**2, axis=1))))
    else:
        t, rms = None, float("nan")
    return FusionResult(common, tri_a, float(shared), t, rms)


def true_b_to_a(scan_a: Scan, scan_b: Scan) -> np.ndarray:
    """(3, 3) true transform from scan B's map frame to scan A's map frame."""

    def world_from(scan: Scan) -> np.ndarray:
        m = np.eye(3)
        m[:2, :2] = _rot(scan.heading_rad)
        m[:2, 2] = scan.auv_xy
        return m

    return np.linalg.inv(world_from(scan_a)) @ world_from(scan_b)


def transform_error(estimated: np.ndarray, truth: np.ndarray) -> tuple[float, float]:
    """(translation error m, rotation error deg) between two 3×3 rigid transforms."""
    dt = float(np.linalg.norm(estimated[:2, 2] - truth[:2, 2]))
    r = estimated[:2, :2] @ truth[:2, :2].T
    dr = float(np.degrees(abs(np.arctan2(r[1, 0], r[0, 0]))))
    return dt, dr


@dataclass(frozen=True)
class ThesisDemo:
    """Result of :func:`thesis_demo`."""

    config: UWSNConfig
    nodes: np.ndarray
    scan_a: Scan
    scan_b: Scan
    fusion: FusionResult
    truth: np.ndarray
    translation_error_m: float
    rotation_error_deg: float


def thesis_demo(
    rng: np.random.Generator,
    *,
    config: UWSNConfig | None = None,
    auv_a: tuple[float, float] = (500.0, 500.0),
    auv_b: tuple[float, float] = (600.0, 600.0),
    heading_a_rad: float = 0.0,
    heading_b_rad: float = 0.0,
) -> ThesisDemo:
    """The thesis's Table 4.5 experiment plus the transform recovery it implies."""
    cfg = config or UWSNConfig()
    nodes = deploy_nodes(cfg, rng)
    sa = discover_nodes(nodes, auv_a, cfg, rng, heading_rad=heading_a_rad)
    sb = discover_nodes(nodes, auv_b, cfg, rng, heading_rad=heading_b_rad)
    fus = fuse_scans(sa, sb)
    truth = true_b_to_a(sa, sb)
    if fus.transform is None:
        dt, dr = float("nan"), float("nan")
    else:
        dt, dr = transform_error(fus.transform, truth)
    return ThesisDemo(cfg, nodes, sa, sb, fus, truth, dt, dr)


def plot_demo(demo: ThesisDemo, path: str) -> None:
    """Save a figure like the thesis's Fig. 4.17/4.18: nodes, both scan rectangles, the
    nodes each scan found, and the Delaunay mesh over the shared nodes (world frame)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    cfg = demo.config
    fig, ax = plt.subplots(figsize=(7, 7))
    ax.plot(demo.nodes[:, 0], demo.nodes[:, 1], "+", color="0.7", ms=4, label="nodes")
    for scan, col in ((demo.scan_a, "tab:blue"), (demo.scan_b, "tab:orange")):
        x, y = scan.auv_xy
        ax.add_patch(
            Rectangle(
                (x - cfg.scan_length_m / 2, y - cfg.scan_width_m / 2),
                cfg.scan_length_m,
                cfg.scan_width_m,
                fill=False,
                ec=col,
            )
        )
        ax.add_patch(plt.Circle((x, y), cfg.comm_range_m, fill=False, ec=col, ls=":"))
        ax.plot(
            scan.world_xy[:, 0],
            scan.world_xy[:, 1],
            "o",
            mfc="none",
            color=col,
            ms=7,
            label=f"AUV ({x:.0f}, {y:.0f}): {scan.ids.size} nodes",
        )
        ax.plot([x], [y], "^", color=col, ms=10)
    fus = demo.fusion
    if fus.triangles.shape[0]:
        world = demo.nodes[fus.common_ids - 1]
        ax.triplot(world[:, 0], world[:, 1], fus.triangles, color="tab:red", lw=0.8)
    ax.set_title(
        f"UWSN-DT: {fus.common_ids.size} shared nodes, error "
        f"{demo.translation_error_m:.2f} m / {demo.rotation_error_deg:.3f}°"
    )
    ax.set_xlabel("x east [m]")
    ax.set_ylabel("y north [m]")
    pad = cfg.comm_range_m + 50
    xs = [demo.scan_a.auv_xy[0], demo.scan_b.auv_xy[0]]
    ys = [demo.scan_a.auv_xy[1], demo.scan_b.auv_xy[1]]
    ax.set_xlim(min(xs) - pad, max(xs) + pad)
    ax.set_ylim(min(ys) - pad, max(ys) + pad)
    ax.set_aspect("equal")
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
