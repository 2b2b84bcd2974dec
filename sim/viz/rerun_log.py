"""The one module of undersea that calls rerun: one ``log_*`` function per modality.

Algorithms return data and never log; the runner and the envs hand their data to these
functions. Every function takes the ``rerun.RecordingStream`` explicitly (no global
recording), so several recordings can be written side by side and tests stay isolated.

Entity tree (follows the frames; world frame x east, y north, z up, metres):

``world/seabed``                               static mesh
``world/objects/<class>_<id>``                 static boxes with class labels (ground truth)
``world/<vehicle>``                            Transform3D body->world, over ``sim_time``
``world/<vehicle>/mesh``                       static vehicle mesh (body frame)
``world/<vehicle>/sonar/<sonar>/image``        sonar waterfall / FLS image (uint8 for display)
``world/<vehicle>/sonar/<sonar>/segmentation`` segmentation overlay (class ids, annotated)
``world/trajectories/<vehicle>/true``          true path (line strip, world frame)
``world/trajectories/<vehicle>/estimated``     SLAM path
``world/slam/<vehicle>/landmarks``             estimated landmarks (points)
``world/slam/<vehicle>/landmark_cov``          their 2-sigma covariance ellipses (flat ellipsoids)
``world/slam/fleet/landmarks``, ``landmark_cov`` the fleet's fused map (end of a multi-vehicle run)
``world/detections/<vehicle>/<sonar>``         detections projected into the world
``metrics/<vehicle>/<name>``                   scalars over sim time (``metrics/fleet/...``: fused map)

Timeline: ``sim_time`` (a duration in seconds). rerun's wall-clock ``log_time`` is switched
off so a recording depends only on the scenario and seed.
"""

from __future__ import annotations

import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from sim.frames import xyzw_from_wxyz

TIMELINE = "sim_time"

#: Colours of object classes (RGB), shared by boxes, segmentation overlays and detections.
CLASS_COLORS: dict[str, tuple[int, int, int]] = {
    "background": (0, 0, 0),
    "seabed": (194, 178, 128),
    "shipwreck": (230, 60, 40),
    "rock": (140, 140, 150),
    "branch": (120, 80, 30),
    "mannequin": (250, 200, 60),
    "pipe": (60, 160, 220),
    "tyre": (40, 40, 40),
    "sensor_node": (60, 220, 120),
    "detection": (255, 0, 255),
}


def class_id(name: str) -> int:
    """Stable class id of an object class name for segmentation images (0 = background)."""
    names = list(CLASS_COLORS)
    return names.index(name) if name in names else len(names)


def open_recording(
    path: str | Path | None,
    *,
    application_id: str = "undersea",
    recording_id: str | None = None,
    blueprint: rrb.Blueprint | None = None,
) -> rr.RecordingStream:
    """A recording stream writing to ``path`` (an .rrd file), or kept in memory when None.

    recording_id defaults to a fixed id derived from the path name so reruns of one scenario
    and seed give comparable recordings."""
    rid = recording_id or f"undersea-{zlib.crc32(str(path).encode()):08x}"
    rec = rr.RecordingStream(application_id, recording_id=rid)
    rec.set_log_time_enabled(False)
    if path is None:
        rec.memory_recording()
    else:
        rec.save(str(path), default_blueprint=blueprint)
    return rec


def close_recording(rec: rr.RecordingStream) -> None:
    """Flush everything to the sink and close it (the file is complete and readable after)."""
    rec.flush()
    rec.disconnect()


def set_time(rec: rr.RecordingStream, t: float) -> None:
    """Set the ``sim_time`` cursor, s, for everything logged next."""
    rec.set_time(TIMELINE, duration=float(t))


def log_annotations(rec: rr.RecordingStream) -> None:
    """Class id -> name and colour, once, for every segmentation image (static)."""
    ctx = [(i, n, c) for i, (n, c) in enumerate(CLASS_COLORS.items())]
    rec.log("world", rr.AnnotationContext(ctx), static=True)
    rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)


def log_seabed(rec: rr.RecordingStream, vertices: np.ndarray, faces: np.ndarray) -> None:
    """Seabed triangle mesh, world frame (static). vertices (V, 3) m, faces (F, 3) int."""
    v = np.asarray(vertices, dtype=np.float32)
    z = v[:, 2]
    shade = ((z - z.min()) / max(float(np.ptp(z)), 1e-6))[:, None]
    base = np.array(CLASS_COLORS["seabed"], dtype=np.float32)
    colors = (base * (0.6 + 0.4 * shade)).astype(np.uint8)
    rec.log(
        "world/seabed",
        rr.Mesh3D(
            vertex_positions=v,
            triangle_indices=np.asarray(faces, dtype=np.uint32),
            vertex_colors=colors,
        ),
        static=True,
    )


def log_objects(
    rec: rr.RecordingStream,
    ids: Sequence[int],
    class_names: Sequence[str],
    positions: np.ndarray,
    sizes: np.ndarray,
) -> None:
    """Ground-truth objects as labelled boxes (static). positions, sizes (n, 3) m."""
    positions = np.asarray(positions, dtype=float).reshape(-1, 3)
    sizes = np.asarray(sizes, dtype=float).reshape(-1, 3)
    for oid, cls, p, s in zip(ids, class_names, positions, sizes):
        rec.log(
            f"world/objects/{cls}_{int(oid)}",
            rr.Boxes3D(
                centers=[p],
                half_sizes=[s / 2],
                labels=[f"{cls} #{int(oid)}"],
                colors=[CLASS_COLORS.get(cls, (200, 200, 200))],
            ),
            static=True,
        )


def log_vehicle_mesh(
    rec: rr.RecordingStream,
    vehicle: str,
    vertices: np.ndarray,
    faces: np.ndarray,
    color=(255, 200, 0),
    vertex_colors: np.ndarray | None = None,
) -> None:
    """Vehicle mesh in its body frame (static) under the vehicle's transform; one colour
    or per-vertex colours (V, 3) uint8."""
    kw = (
        {"vertex_colors": np.asarray(vertex_colors, np.uint8)}
        if vertex_colors is not None
        else {"albedo_factor": [*color, 255]}
    )
    rec.log(
        f"world/{vehicle}/mesh",
        rr.Mesh3D(
            vertex_positions=np.asarray(vertices, dtype=np.float32),
            triangle_indices=np.asarray(faces, dtype=np.uint32),
            **kw,
        ),
        static=True,
    )


def log_vehicle_pose(
    rec: rr.RecordingStream, vehicle: str, position: np.ndarray, quat_wxyz: np.ndarray
) -> None:
    """True body->world transform of a vehicle at the current sim time."""
    rec.log(
        f"world/{vehicle}",
        rr.Transform3D(
            translation=np.asarray(position, dtype=float),
            quaternion=rr.Quaternion(xyzw=xyzw_from_wxyz(quat_wxyz)),
        ),
    )


def log_trajectory(rec: rr.RecordingStream, vehicle: str, kind: str, xyz: np.ndarray) -> None:
    """Path so far as one line strip (kind 'true' or 'estimated'), world frame, m."""
    if kind not in ("true", "estimated"):
        raise ValueError(f"trajectory kind must be 'true' or 'estimated', got {kind!r}")
    xyz = np.asarray(xyz, dtype=np.float32).reshape(-1, 3)
    color = (40, 200, 255) if kind == "true" else (255, 120, 0)
    rec.log(
        f"world/trajectories/{vehicle}/{kind}", rr.LineStrips3D([xyz], colors=[color], radii=[0.15])
    )


def ellipse_axes(covs: np.ndarray, n_sigma: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    """(half_axes (n, 2), angle (n,)) of the n-sigma ellipses of 2x2 covariances (vectorized)."""
    covs = np.asarray(covs, dtype=float).reshape(-1, 2, 2)
    w, v = np.linalg.eigh(0.5 * (covs + np.swapaxes(covs, 1, 2)))
    half = n_sigma * np.sqrt(np.clip(w, 0.0, None))
    angle = np.arctan2(v[:, 1, 1], v[:, 0, 1])  # direction of the major axis (largest eigenvalue)
    return half[:, ::-1], angle


def log_landmarks(
    rec: rr.RecordingStream,
    vehicle: str,
    means: np.ndarray,
    covs: np.ndarray,
    z: float | np.ndarray = 0.0,
) -> None:
    """Estimated 2-D landmarks (n, 2) m with covariances (n, 2, 2) m², drawn at height z."""
    means = np.asarray(means, dtype=float).reshape(-1, 2)
    n = len(means)
    zz = np.broadcast_to(np.asarray(z, dtype=float), (n,))
    centers = np.column_stack([means, zz])
    half, angle = ellipse_axes(covs)
    quats = np.column_stack([np.zeros((n, 2)), np.sin(angle / 2), np.cos(angle / 2)])
    rec.log(
        f"world/slam/{vehicle}/landmarks",
        rr.Points3D(centers, radii=0.3, colors=[(255, 120, 0)], labels=[f"L{i}" for i in range(n)]),
    )
    rec.log(
        f"world/slam/{vehicle}/landmark_cov",
        rr.Ellipsoids3D(
            centers=centers,
            half_sizes=np.column_stack([half, np.full(n, 0.05)]),
            quaternions=[rr.Quaternion(xyzw=q) for q in quats],
            colors=[(255, 120, 0)],
            fill_mode=rr.components.FillMode.MajorWireframe,
        ),
    )


def log_estimated_pose(rec: rr.RecordingStream, vehicle: str, pose: np.ndarray, z: float) -> None:
    """SLAM pose estimate [x, y, phi] as an arrow in the world frame."""
    x, y, phi = (float(a) for a in np.asarray(pose, dtype=float)[:3])
    rec.log(
        f"world/slam/{vehicle}/pose",
        rr.Arrows3D(
            origins=[[x, y, z]],
            vectors=[[2.0 * np.cos(phi), 2.0 * np.sin(phi), 0.0]],
            colors=[(255, 120, 0)],
        ),
    )


def log_detections(
    rec: rr.RecordingStream,
    vehicle: str,
    sonar: str,
    positions: np.ndarray,
    labels: Sequence[str] | None = None,
) -> None:
    """Detections projected into the world frame, (k, 3) m."""
    positions = np.asarray(positions, dtype=float).reshape(-1, 3)
    rec.log(
        f"world/detections/{vehicle}/{sonar}",
        rr.Points3D(
            positions,
            radii=0.4,
            colors=[CLASS_COLORS["detection"]],
            labels=list(labels) if labels else None,
        ),
    )


def to_display_uint8(image: np.ndarray, db_range: float = 40.0) -> np.ndarray:
    """Linear float intensity -> uint8 for display: log compression to ``db_range`` dB
    below the 99.5th percentile (as real sonars compress for display)."""
    a = np.asarray(image, dtype=np.float32)
    if a.dtype == np.uint8:
        return a
    a = np.where(np.isfinite(a), a, 0.0)
    pos = a[a > 0]
    if pos.size == 0:
        return np.zeros(a.shape, np.uint8)
    top = float(np.percentile(pos, 99.5))
    db = 10.0 * np.log10(np.maximum(a, top * 10 ** (-db_range / 10)) / top)
    return np.clip(255.0 * (1.0 + db / db_range), 0, 255).astype(np.uint8)


def db_to_uint8(image_db: np.ndarray, db_span: tuple[float, float]) -> np.ndarray:
    """dB image -> uint8 by one fixed linear mapping of ``db_span`` = (lo, hi) dB onto
    0..255 (clipped): the same grey means the same level in every window of a run."""
    lo, hi = db_span
    a = np.where(np.isfinite(image_db), np.asarray(image_db, np.float64), lo)
    return np.clip(np.round(255.0 * (a - lo) / (hi - lo)), 0, 255).astype(np.uint8)


def log_sonar_image(
    rec: rr.RecordingStream,
    vehicle: str,
    sonar: str,
    image: np.ndarray,
    segmentation: np.ndarray | None = None,
    *,
    already_display: bool = False,
    db_span: tuple[float, float] | None = None,
) -> None:
    """A sonar image (waterfall (pings, 2 x samples) or FLS (bins, beams)) with an optional
    segmentation overlay of class ids (same shape; 0 = background). ``db_span``: the
    image is in dB and is displayed by that fixed mapping (:func:`db_to_uint8`) instead of
    the per-image one of :func:`to_display_uint8`."""
    img = np.asarray(image)
    if already_display:
        disp = img.astype(np.uint8)
    elif db_span is not None:
        disp = db_to_uint8(img, db_span)
    else:
        disp = to_display_uint8(img)
    base = f"world/{vehicle}/sonar/{sonar}"
    rec.log(f"{base}/image", rr.Image(disp))
    if segmentation is not None:
        seg = np.asarray(segmentation)
        if seg.shape != img.shape[:2]:
            raise ValueError(
                f"segmentation shape {seg.shape} must equal image shape {img.shape[:2]}"
            )
        rec.log(f"{base}/segmentation", rr.SegmentationImage(seg.astype(np.uint16), opacity=0.5))


def log_scalars(rec: rr.RecordingStream, vehicle: str, values: Mapping[str, float]) -> None:
    """Metrics at the current sim time, one entity per name (non-finite values skipped)."""
    for k, v in values.items():
        if v is not None and np.isfinite(v):
            rec.log(f"metrics/{vehicle}/{k}", rr.Scalars(float(v)))


def default_blueprint(vehicles: Mapping[str, Sequence[str]]) -> rrb.Blueprint:
    """3-D world on the left, one 2-D view per sonar and metric plots on the right.

    vehicles: vehicle name -> its sonar names."""
    sonar_views = [
        rrb.Spatial2DView(origin=f"world/{v}/sonar/{s}", name=f"{v} {s}")
        for v, sonars in vehicles.items()
        for s in sonars
    ]
    plots = [rrb.TimeSeriesView(origin=f"metrics/{v}", name=f"{v} metrics") for v in vehicles]
    right = rrb.Vertical(*(sonar_views or [rrb.TextDocumentView(origin="notes")]), *plots)
    # the sonar images live under their vehicle but are 2-D pixels with no camera model:
    # a 3-D view cannot place them (the web viewer shows an error badge), so the world
    # view leaves them to their own 2-D views
    world = rrb.Spatial3DView(
        origin="world",
        name="world",
        contents=["+ $origin/**", *(f"- /world/{v}/sonar/**" for v in vehicles)],
    )
    return rrb.Blueprint(
        rrb.Horizontal(world, right, column_shares=[3, 2]),
        collapse_panels=True,
    )


# ----------------------------------------------------------------- reading back ----------
@dataclass(frozen=True)
class EntitySummary:
    """What a recording holds for one entity: rows logged, static or not, component columns."""

    path: str
    rows: int
    static: bool
    components: tuple[str, ...]


def read_recording(path: str | Path) -> dict[str, EntitySummary]:
    """Entity path -> summary, read with rerun's own reader (``rerun.chunk.RrdReader``)."""
    from rerun.chunk import RrdReader

    store = RrdReader(str(path)).stream().collect()
    acc: dict[str, list] = {}
    for ch in store.stream().to_chunks():
        ep = ch.entity_path
        names = tuple(n for n in ch.to_record_batch().schema.names if ":" in n)
        rows, static, comps = acc.get(ep, [0, True, set()])
        acc[ep] = [rows + ch.num_rows, static and ch.is_static, comps | set(names)]
    return {ep: EntitySummary(ep, r, s, tuple(sorted(c))) for ep, (r, s, c) in acc.items()}


def read_component(path: str | Path, entity: str, component: str) -> list:
    """All values of one component column of one entity (e.g. 'Scalars:scalars'), in log order."""
    from rerun.chunk import RrdReader

    entity = entity if entity.startswith("/") else "/" + entity
    out: list = []
    store = RrdReader(str(path)).stream().collect()
    for ch in store.stream().to_chunks():
        if ch.entity_path != entity:
            continue
        rb = ch.to_record_batch()
        if component in rb.schema.names:
            out.extend(rb.column(component).to_pylist())
    return out
