"""Does training the second stage on the simulator's labelled side-scan tiles as well as
on the SDVD tune half help (issue 14 item 3)? Chosen and scored on the TUNE half only.

Simulator tiles: ``undersea dataset SCENARIO --kind sss --out DIR`` writes 8-bit display
images (rows = pings, columns = port far→near then starboard near→far) with COCO instance
masks (``annotations.json``, or per shard ``shards/shard_*.json`` while it is running).
Each image is resampled to square pixels (rows stretched by the along-track ping spacing
over the range resolution, from the frame's ``meta`` file) and cut into 256-column
windows; each window runs stages 1–4 of ``sdvd-trusted`` and its area filter; a region is
an object ("effigy") when its centroid lies in a ``mannequin`` mask (the simulator's
drowned-person stand-in), every other region (wreck, rock, branch, seabed) is not.

Variants, each through ``scripts/train_sdvd_stage2.py``'s grid and rule (highest tune hit
rate with PPV >= 0.5 and <= 0.7 false detections per negative tile) on the tune tiles:

* ``tune``: fitted on the tune regions (the reference: today's second stage);
* ``tune+sim``: fitted on the tune regions and the simulator's regions;
* ``sim``: fitted on the simulator's regions only (the domain gap), scored on tune.

    python scripts/sdvd_stage2_sim_study.py --sim DIR [--sim DIR ...] [--data DIR] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import cv2
import numpy as np

REPO = Path(__file__).resolve().parents[1]
for p in (REPO, REPO / "scripts"):
    if str(p) not in sys.path:
        sys.path.insert(0, str(p))

from train_sdvd_stage2 import (  # noqa: E402
    COUNTS,
    GAPS,
    THRESHOLDS,
    candidates_with_features,
    first_stage_ceiling,
    inside_flags,
    rule_key,
    score,
    tune_regions,
)

from slam.frontend.segmentation.detector import fit_region_classifier, get_detector  # noqa: E402
from slam.frontend.segmentation.evaluation import default_sdvd_dir, load_sdvd  # noqa: E402

WINDOW = 256
EFFIGY_CLASS = "mannequin"


def _records(root: Path) -> tuple[list[dict], dict[int, str]]:
    """COCO image records (with their annotations) of a dataset folder and the category
    names by id."""
    ann = root / "annotations.json"
    if ann.is_file():
        coco = json.loads(ann.read_text())
        by_img: dict[int, list] = {}
        for a in coco["annotations"]:
            by_img.setdefault(a["image_id"], []).append(a)
        recs = [{**im, "annotations": by_img.get(im["id"], [])} for im in coco["images"]]
        return recs, {c["id"]: c["name"] for c in coco["categories"]}
    recs = []
    for sh in sorted((root / "shards").glob("shard_*.json")):
        recs += json.loads(sh.read_text())["images"]
    if not recs:
        raise ValueError(f"--sim {str(root)!r}: no annotations.json and no finished shard")
    # the dataset's fixed category ids (sim.dataset.coco.CATEGORIES)
    names = ("shipwreck", "tree_branch", "mannequin", "rock", "pipe", "tyre", "sensor_node")
    return recs, {i + 1: n for i, n in enumerate(names)}


def _row_stretch(meta: dict) -> float:
    """Along-track ping spacing over the range resolution (both m): the factor that makes
    the image's pixels square."""
    g = meta["geometry"]
    pos = np.asarray(g["ping_pose"]["position"], dtype=np.float64)
    along = float(np.median(np.linalg.norm(np.diff(pos[:, :2], axis=0), axis=1)))
    rng = np.asarray(g["slant_range_m"], dtype=np.float64)
    across = float(np.median(np.abs(np.diff(rng[: g["samples_per_side"]]))))
    return along / across


def sim_windows(root: Path):
    """Yield ``(window image, effigy mask)`` pairs of a simulator dataset (module
    docstring)."""
    from pycocotools import mask as mask_utils

    recs, names = _records(root)
    for rec in recs:
        if rec.get("kind", "sss") != "sss":
            continue
        img = cv2.imread(str(root / "images" / rec["file_name"]), cv2.IMREAD_GRAYSCALE)
        meta = json.loads((root / rec["meta_file"]).read_text())
        eff = np.zeros(img.shape, np.uint8)
        for a in rec["annotations"]:
            if names.get(a["category_id"]) == EFFIGY_CLASS:
                eff |= mask_utils.decode(a["segmentation"]).astype(np.uint8)
        rows = max(1, round(img.shape[0] * _row_stretch(meta)))
        img = cv2.resize(img, (img.shape[1], rows), interpolation=cv2.INTER_LINEAR)
        eff = cv2.resize(eff, (eff.shape[1], rows), interpolation=cv2.INTER_NEAREST)
        for c0 in range(0, img.shape[1] - WINDOW + 1, WINDOW):
            yield img[:, c0 : c0 + WINDOW], eff[:, c0 : c0 + WINDOW].astype(bool)


def sim_regions(roots, gap: int):
    """Feature rows and labels of the simulator windows' candidate regions at ``gap``."""
    cfg = get_detector("sdvd-trusted").with_(merge_gap_px=gap, classifier=None, max_count=0)
    xs, ys, n_win, n_eff = [], [], 0, 0
    for root in roots:
        for img, eff in sim_windows(Path(root)):
            c, regs, f = candidates_with_features(img, cfg)
            n_win += 1
            n_eff += bool(eff.any())
            if len(regs):
                xs.append(f)
                ys.append(inside_flags(eff, regs, c.offset_rc))
    x = np.vstack(xs) if xs else np.zeros((0, 8))
    y = np.concatenate(ys) if ys else np.zeros(0, bool)
    return (
        x,
        y,
        {
            "windows": n_win,
            "windows_with_effigy": n_eff,
            "regions": len(y),
            "effigy_regions": int(y.sum()),
        },
    )


def choose_variant(rows, x_fit, y_fit, gap):
    """``train_sdvd_stage2``'s grid and rule on the tune ``rows`` for a model fitted on
    ``(x_fit, y_fit)``: ``(best entry or None, grid)``."""
    best, grid = None, []
    for tau in THRESHOLDS:
        clf = fit_region_classifier(x_fit, y_fit, threshold=tau)
        for k in COUNTS:
            s = score(rows, clf, k)
            entry = {"merge_gap_px": gap, "threshold": tau, "max_count": k, **s}
            grid.append(entry)
            key = rule_key(s)
            if key is not None and (best is None or key > best[0]):
                best = (key, entry)
    return (None if best is None else best[1]), grid


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=str(default_sdvd_dir()), help="SDVD folder")
    ap.add_argument("--sim", action="append", required=True, help="simulator dataset folder")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    data = Path(args.data)
    for d in [data, *map(Path, args.sim)]:
        if not d.is_dir():
            print(f"sdvd_stage2_sim_study: {str(d)!r} not found", file=sys.stderr)
            return 2
    tiles = [t for t in load_sdvd(data) if t.split == "tune"]
    out = {"variants": {}, "sim": {}}
    for gap in GAPS:
        rows = tune_regions(tiles, gap)
        xt = np.vstack([f for _, f, _ in rows if len(f)])
        yt = np.concatenate([i for _, f, i in rows if len(f)])
        xs, ys, info = sim_regions(args.sim, gap)
        out["sim"][gap] = info
        fits = {"tune": (xt, yt), "tune+sim": (np.vstack([xt, xs]), np.r_[yt, ys])}
        if 0 < ys.sum() < len(ys):
            fits["sim"] = (xs, ys)
        for name, (x, y) in fits.items():
            best, _grid = choose_variant(rows, x, y, gap)
            prev = out["variants"].get(name)
            if best is not None and (prev is None or rule_key(best) > rule_key(prev)):
                out["variants"][name] = {**best, "ceiling": first_stage_ceiling(rows)}
            out["variants"].setdefault(name, None)
    if args.json:
        print(json.dumps(out, indent=1))
        return 0
    for gap, info in out["sim"].items():
        print(f"simulator, gap {gap}: {info}")
    print(
        f"\n{'variant':10s} {'gap':>4s} {'tau':>5s} {'k':>2s} {'hit':>6s} {'PPV':>6s} {'det/neg':>8s}"
    )
    for name, e in out["variants"].items():
        if e is None:
            print(f"{name:10s} no setting meets the limits on the tune half")
            continue
        print(
            f"{name:10s} {e['merge_gap_px']:4d} {e['threshold']:5.2f} {e['max_count']:2d} "
            f"{e['hit_rate']:6.3f} {e['ppv']:6.3f} {e['detections_per_negative_tile']:8.2f}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
