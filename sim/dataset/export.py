"""Export a labelled sonar dataset: shards in parallel (local processes or Ray), merged
into one COCO file with a dataset card.

Output layout (``OUT``)::

    annotations.json      COCO: info, licenses, categories, images, annotations
    README.md             dataset card: counts per class, settings, seed, sonar presets, licence
    images/<frame>_<view>.png    8-bit log-compressed display image
    linear/<frame>_<view>.npy    float32 linear intensity (only with save_linear)
    meta/<frame>_<view>.json     sidecar: true pose (per ping for SSS), sonar geometry, config
    shards/shard_<k>.json        shard record (its images and annotations, without ids)

Every file is written atomically (temporary file + ``os.replace``) and a shard's record is
written last, after its images: a killed worker loses no finished shard, and running the
same command again resumes (shards with a record are skipped; their settings hash must
match). Ids are assigned at the merge, in (shard, frame, view) order, so the COCO file
does not depend on the number of workers. No wall-clock value enters any output file:
the same settings and seed give the same bytes.

Execution follows :mod:`sim.sweep.runner`: ``spawn`` worker processes (MuJoCo/OpenMP are
not fork-safe), a dead worker's shard is resubmitted on a fresh pool, or Ray tasks with
retries when ``use_ray``/``ray_address`` is given. Ray tasks return their shard's files to
the driver, which writes them (record last), so a multi-machine cluster needs no shared
file system; local workers write their own files.
"""

from __future__ import annotations

import json
import os
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from sim.atomic import atomic_write
from sim.dataset.config import DatasetConfig, ShardJob, plan_shards
from sim.parallel import ray_session, run_local_pool

# ----------------------------------------------------------------------- files ----------


def _json_bytes(obj, indent: int | None = None) -> bytes:
    return json.dumps(
        obj,
        sort_keys=True,
        indent=indent,
        separators=None if indent else (",", ":"),
        allow_nan=False,
    ).encode()


def shard_path(out: Path, k: int) -> Path:
    return out / "shards" / f"shard_{k:04d}.json"


# ----------------------------------------------------------------------- one shard ------


def _config_json(cfg) -> dict:
    d = asdict(cfg)
    return json.loads(json.dumps(d, default=float))


def run_shard(job: ShardJob, out_dir: str, in_memory: bool = False) -> dict:
    """Simulate one shard, write its images, sidecars and (last) its record.

    Returns ``{"shard", "frames", "images", "wall_s"}`` (wall time only in the return
    value). ``in_memory``: write nothing, return the files instead under ``"files"``
    (relative path -> bytes, the record last) for the caller to write -- how Ray workers
    on other machines hand their shard to the driver without a shared file system.
    An error is re-raised as RuntimeError naming the shard, its frames and seed."""
    try:
        return _run_shard(job, out_dir, in_memory)
    except Exception as exc:
        raise RuntimeError(
            f"shard {job.index} (frames {job.first_frame + 1}..{job.first_frame + job.n_frames}, "
            f"scenario seed {job.seed}, offset {job.offset_s:g} s): {type(exc).__name__}: {exc}"
        ) from exc


def _run_shard(job: ShardJob, out_dir: str, in_memory: bool) -> dict:
    from sim.dataset.coco import fan_view, instance_annotations, npy_bytes, png_bytes, to_uint8
    from sim.dataset.simulate import ShardSimulation, frame_period, prepare_scenario

    t0 = time.perf_counter()
    out = Path(out_dir)
    files: dict[str, bytes] = {}

    def put(rel: str, data: bytes) -> None:
        if in_memory:
            files[rel] = data
        else:
            atomic_write(out / rel, data)

    cfg = job.config
    scn = prepare_scenario(job.scenario, job.seed)
    sim = ShardSimulation(scn, cfg.sonar_kinds, cfg.tile_pings, cfg.fls_interval_s)
    objects = [
        {
            "id": int(o.id),
            "class": o.class_name,
            "position": np.round(np.asarray(o.position, float), 4).tolist(),
            "size": np.round(np.asarray(o.size, float), 4).tolist(),
            "yaw_rad": round(float(o.yaw), 6),
        }
        for o in sim.objects
    ]
    class_of = {o["id"]: o["class"] for o in objects}
    period = frame_period(scn, cfg.sonar_kinds, cfg.tile_pings, cfg.fls_interval_s)
    images: list[dict] = []
    accept = None
    if cfg.min_objects > 0:

        def accept(fr) -> bool:
            return np.unique(fr.labels[fr.labels > 0]).size >= cfg.min_objects

    max_sim = max(600.0, 50.0 * job.n_frames * period, 2.0 * scn.duration_s)
    for fr in sim.frames(job.n_frames, job.offset_s, max_sim_s=max_sim, accept=accept):
        gidx = job.first_frame + fr.index
        views = []
        if fr.kind == "sss":
            views.append(("sss", fr.linear, fr.labels, {}))
        else:
            if "polar" in cfg.fls_views:
                views.append(("fls-polar", fr.linear, fr.labels, {}))
            if "fan" in cfg.fls_views:
                fan, fan_labels = fan_view(fr.fls, fr.linear, fr.labels)
                extra = {
                    "fan": {
                        "layout": "pixel (i, j) centre at forward x = x_max - (i + 0.5) res, "
                        "lateral y = y_max - (j + 0.5) res (y to port = image left), sensor frame",
                        "x_max_m": round(fan.x_max, 6),
                        "y_max_m": round(fan.y_max, 6),
                        "resolution_m": round(fan.resolution, 8),
                    }
                }
                views.append(("fls-fan", fan.image, fan_labels, extra))
        for view, linear, labels, extra in views:
            stem = f"{gidx + 1:06d}_{view}"
            acoustic = fr.config.acoustic
            put(f"images/{stem}.png", png_bytes(to_uint8(linear, acoustic)))
            rec = {
                "file_name": f"{stem}.png",
                "height": int(linear.shape[0]),
                "width": int(linear.shape[1]),
                "frame": gidx + 1,
                "shard": job.index,
                "kind": fr.kind,
                "view": view,
                "vehicle": fr.vehicle,
                "sonar": fr.sonar,
                "preset": fr.preset,
                "time_s": round(fr.time, 6),
                "meta_file": f"meta/{stem}.json",
            }
            if cfg.save_linear:
                put(f"linear/{stem}.npy", npy_bytes(np.asarray(linear, np.float32)))
                rec["linear_file"] = f"linear/{stem}.npy"
            anns = instance_annotations(labels, class_of, cfg.segmentation)
            ids = sorted({a["object_id"] for a in anns})
            meta = {
                **{
                    k: rec[k]
                    for k in (
                        "file_name",
                        "frame",
                        "kind",
                        "view",
                        "vehicle",
                        "sonar",
                        "preset",
                        "time_s",
                    )
                },
                "scenario": scn.name,
                "shard": job.index,
                "shard_seed": job.seed,
                "vehicle_kind": fr.vehicle_kind,
                "pose": fr.pose,
                "geometry": {**fr.geometry, **extra},
                "sonar_config": _config_json(fr.config),
                "display": {
                    "png": "round(255 * clip((10 log10(I) - floor_db) / dynamic_range_db, 0, 1))",
                    "floor_db": _display_floor(acoustic),
                    "dynamic_range_db": acoustic.dynamic_range_db,
                    "linear_unit": "uPa^2 after TVG",
                },
                "label_counts": _label_counts(labels),
                "instances": [o for o in objects if o["id"] in ids],
            }
            put(f"meta/{stem}.json", _json_bytes(meta))
            rec["annotations"] = anns
            images.append(rec)
    record = {
        "settings_hash": job.settings_hash,
        "shard": job.index,
        "first_frame": job.first_frame + 1,
        "n_frames": job.n_frames,
        "seed": job.seed,
        "offset_s": job.offset_s,
        "objects": objects,
        "images": images,
    }
    put(str(shard_path(Path(), job.index)), _json_bytes(record))  # last: the shard is done
    result = {
        "shard": job.index,
        "frames": job.n_frames,
        "images": len(images),
        "wall_s": time.perf_counter() - t0,
    }
    if in_memory:
        result["files"] = files
    return result


def _display_floor(acoustic) -> float:
    from sim.dataset.coco import display_floor_db

    return display_floor_db(acoustic)


def _label_counts(labels: np.ndarray) -> dict:
    return {
        "object": int(np.count_nonzero(labels > 0)),
        "seabed": int(np.count_nonzero(labels == 0)),
        "no_return": int(np.count_nonzero(labels == -1)),
        "other_geom": int(np.count_nonzero(labels == -2)),
    }


# ----------------------------------------------------------------------- the dataset ----


@dataclass
class DatasetResult:
    """What happened: where the dataset is, shards simulated now / resumed, COCO counts."""

    out_dir: Path
    n_frames: int
    n_images: int
    n_annotations: int
    shards_done: list[int] = field(default_factory=list)
    shards_resumed: list[int] = field(default_factory=list)
    wall_s: float = 0.0
    frames_now: int = 0  # frames simulated this invocation (not resumed)
    retried: list[int] = field(default_factory=list)  # shards re-run after a worker died

    @property
    def frames_per_s(self) -> float | None:
        """Frames simulated and written per wall-clock second this invocation."""
        return None if self.wall_s <= 0 or not self.frames_now else self.frames_now / self.wall_s


def resolve_scenario(cfg: DatasetConfig):
    """(decoded scenario table with the overrides applied, validated Scenario).

    Raises ValueError (ScenarioError) for an unknown scenario or a bad override."""
    from sim.scenario import load_scenario_dict, parse_scenario, set_dotted

    data = load_scenario_dict(cfg.scenario)
    for k, v in cfg.overrides:
        data = set_dotted(data, k, v)
    return data, parse_scenario(data)


#: what build_dataset writes into its output directory (and force=True deletes)
DATASET_ENTRIES = ("shards", "images", "linear", "meta", "annotations.json", "README.md")


def clear_dataset(out: Path) -> None:
    """Delete a dataset's own files and folders in ``out`` (nothing else)."""
    import shutil

    for name in DATASET_ENTRIES:
        p = out / name
        if p.is_dir():
            shutil.rmtree(p)
        elif p.exists():
            p.unlink()


def plan_dataset(cfg: DatasetConfig) -> list[ShardJob]:
    """Validate everything that can be checked before simulating and split into shards."""
    from sim.dataset.simulate import frame_period

    data, scn = resolve_scenario(cfg)
    period = frame_period(scn, cfg.sonar_kinds, cfg.tile_pings, cfg.fls_interval_s)
    return plan_shards(cfg, data, scn.duration_s, period)


def _progress(total: int, enabled: bool):
    from tqdm import tqdm

    quiet = not enabled or os.environ.get("CI") or not sys.stderr.isatty()
    return tqdm(total=total, unit="frame", disable=bool(quiet), desc="dataset")


def build_dataset(
    cfg: DatasetConfig,
    out_dir: str | Path,
    workers: int = 1,
    use_ray: bool = False,
    ray_address: str | None = None,
    max_retries: int = 1,
    progress: bool = True,
    force: bool = False,
) -> DatasetResult:
    """Export the dataset ``cfg`` into ``out_dir`` (resuming finished shards).

    A resume needs the same plan (settings, scenario and code version: the shards'
    ``settings_hash``); otherwise ValueError, and ``force=True`` deletes the old dataset's
    files in ``out_dir`` and starts over.

    workers     : 1 runs the shards in this process; K > 1 on K local processes
                  (spawn), or K Ray workers with ``use_ray`` / ``ray_address``.
    ray_address : a running Ray cluster ("auto", "ray://host:10001"); implies Ray.
    Raises ValueError for bad settings, RuntimeError when a shard fails (after retries).
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers = {workers!r} is not allowed; allowed: an integer >= 1")
    jobs = plan_dataset(cfg)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if force:
        clear_dataset(out)
    result = DatasetResult(out, cfg.frames, 0, 0)
    todo = []
    for job in jobs:
        p = shard_path(out, job.index)
        if p.exists():
            rec = json.loads(p.read_text())
            if rec.get("settings_hash") != job.settings_hash:
                raise ValueError(
                    f"out = {str(out)!r} holds a dataset of another plan ({p.name}: other "
                    "settings, scenario or code version); allowed: the same plan to resume, "
                    "a new directory, or --force to delete it and start over"
                )
            result.shards_resumed.append(job.index)
        else:
            todo.append(job)
    t0 = time.perf_counter()
    bar = _progress(sum(j.n_frames for j in todo), progress)

    def collect(r: dict) -> None:
        bar.update(r["frames"])
        result.shards_done.append(r["shard"])
        result.frames_now += r["frames"]

    try:
        if use_ray or ray_address:
            _run_ray(todo, out, workers, ray_address, collect)
        elif workers == 1:
            for job in todo:
                collect(run_shard(job, str(out)))
        else:
            _run_local(todo, out, workers, max_retries, collect, result.retried.append)
    finally:
        bar.close()
    result.wall_s = time.perf_counter() - t0
    coco = merge_shards(cfg, jobs, out)
    result.n_images = len(coco["images"])
    result.n_annotations = len(coco["annotations"])
    return result


def _run_local(todo, out: Path, workers: int, max_retries: int, collect, on_retry) -> None:
    def finished(job) -> dict | None:
        # a worker died (killed, OOM): its finished shards are on disk
        return {"shard": job.index, "frames": job.n_frames} if shard_path(out, job.index).exists() else None

    def give_up(job, attempts: int) -> None:
        raise RuntimeError(
            f"shard {job.index} (frames {job.first_frame + 1}..{job.first_frame + job.n_frames}, "
            f"seed {job.seed}): worker process died {attempts} times"
        )

    run_local_pool(
        run_shard, todo, lambda job: (job, str(out)), workers, max_retries,
        key=lambda job: job.index, collect=collect, finished=finished, give_up=give_up,
        on_retry=lambda job: on_retry(job.index),
    )


def _run_ray(todo, out: Path, workers: int, address: str | None, collect) -> None:
    with ray_session(workers, address, "export") as ray:
        # workers hand back their files (no shared file system needed); the driver writes
        # them, the shard record last, as each shard arrives
        remote = ray.remote(max_retries=2, num_cpus=1)(run_shard)
        refs = [remote.remote(job, str(out), True) for job in todo]
        while refs:
            done, refs = ray.wait(refs, num_returns=1)
            for ref in done:
                r = ray.get(ref)
                for rel, data in r.pop("files").items():  # insertion order: record last
                    atomic_write(out / rel, data)
                collect(r)


# ----------------------------------------------------------------------- merge ----------


def merge_shards(cfg: DatasetConfig, jobs: list[ShardJob], out: Path) -> dict:
    """Merge the shard records into ``annotations.json`` (COCO) and write ``README.md``.

    Image ids 1.. in (shard, frame, view) order; annotation ids 1.. in image order."""
    from sim.dataset.card import dataset_card, preview_image
    from sim.dataset.coco import coco_categories, png_bytes

    images, annotations, shards = [], [], []
    for job in jobs:
        rec = json.loads(shard_path(out, job.index).read_text())
        shards.append(rec)
        for im in rec["images"]:
            im = dict(im)
            anns = im.pop("annotations")
            image_id = len(images) + 1
            images.append({"id": image_id, **im})
            for a in anns:
                annotations.append({"id": len(annotations) + 1, "image_id": image_id, **a})
    _, scn = resolve_scenario(cfg)
    coco = {
        "info": {
            "description": f"undersea synthetic sonar dataset: scenario {scn.name!r}, seed {cfg.seed}",
            "contributor": "generated by undersea (simulated, not real sonar data)",
            "version": _undersea_version(),
            "settings": cfg.settings(),
            "settings_hash": jobs[0].settings_hash,
            "shards": [
                {k: r[k] for k in ("shard", "first_frame", "n_frames", "seed", "offset_s")}
                for r in shards
            ],
        },
        "licenses": [{"id": 1, "name": cfg.licence, "url": _licence_url(cfg.licence)}],
        "categories": coco_categories(),
        "images": images,
        "annotations": annotations,
    }
    atomic_write(out / "annotations.json", _json_bytes(coco))
    atomic_write(out / "README.md", dataset_card(cfg, scn, coco, shards).encode())
    atomic_write(out / "preview.png", png_bytes(preview_image(out, coco)))
    return coco


def _undersea_version() -> str:
    try:
        from importlib.metadata import version

        return version("undersea")
    except Exception:  # not installed as a package
        return "unknown"


def _licence_url(name: str) -> str:
    return {
        "CC-BY-4.0": "https://creativecommons.org/licenses/by/4.0/",
        "CC0-1.0": "https://creativecommons.org/publicdomain/zero/1.0/",
    }.get(name, "")
