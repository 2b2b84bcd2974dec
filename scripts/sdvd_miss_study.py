"""Where ``sdvd-trusted`` loses the SDVD effigies: per positive tile, the first stage of
the detection chain at which no region with its centroid inside the effigy mask is left.

Stages, in the chain's order (``slam.frontend.segmentation.detector``):

* ``threshold``: improved Otsu + Algorithm 2 (annotations masked) leaves no region whose
  centroid is in the mask, and neither does fragment merging;
* ``no-echo``: one did, but it was dropped as touching a no-echo area;
* ``merge``: after fragment merging (the chain's gap) no merged region's centroid is in
  the mask (the effigy's fragments were joined to others);
* ``area``: the merged region on the effigy is over ``max_area_px``;
* ``threshold p``: the second stage gives it p below the threshold;
* ``count``: p is high enough but other regions of the tile rank above it.

Prints one line per missed tile (frequency, seabed median grey level, whether the mask
touches the tile edge, the best in-mask p and its rank) and the counts per stage and
frequency, for the chosen split (``tune`` by default: read the misses there, choose fixes
there).

    python scripts/sdvd_miss_study.py [--data DIR] [--split tune|test|all] [--detector NAME]
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
for p in (REPO, REPO / "scripts"):
    if str(p) not in sys.path:
        sys.path.insert(0, str(p))

from train_sdvd_stage2 import inside_flags  # noqa: E402

from slam.frontend.segmentation.detector import (  # noqa: E402
    DETECTORS,
    candidate_regions,
    get_detector,
    region_features,
)
from slam.frontend.segmentation.evaluation import (  # noqa: E402
    default_sdvd_dir,
    load_sdvd,
    sdvd_frequency,
)

STAGES = ("threshold", "no-echo", "merge", "area", "threshold p", "count", "hit")


def _any_inside(cfg, tile) -> tuple[bool, object]:
    c = candidate_regions(tile.image, cfg)
    return bool(inside_flags(tile.mask, c.regions, c.offset_rc).any()), c


def lost_at(tile, cfg) -> dict:
    """The stage (:data:`STAGES`) at which ``cfg`` loses ``tile``'s effigy, with the
    in-mask region's probability and rank when it reached the second stage."""
    raw = cfg.with_(suppress_no_echo=False, merge_gap_px=0)
    info = {"p": None, "rank": None, "n_cand": None}
    ok, c = _any_inside(cfg, tile)
    if not ok:  # merging can also centre a group of fragments on the effigy
        if not _any_inside(raw, tile)[0]:
            return {"stage": "threshold", **info}
        if not _any_inside(cfg.with_(merge_gap_px=0), tile)[0]:
            return {"stage": "no-echo", **info}
        return {"stage": "merge", **info}
    regs = tuple(r for r in c.regions if r.area_px <= cfg.max_area_px)
    inside = inside_flags(tile.mask, regs, c.offset_rc)
    if not inside.any():
        return {"stage": "area", **info}
    if cfg.classifier is None:
        return {"stage": "hit", **info}
    p = cfg.classifier.probability(region_features(c.gray8, c.labels, regs))
    order = np.argsort(-p, kind="stable")
    rank = int(np.flatnonzero(inside[order])[0]) + 1
    best = float(p[inside].max())
    info = {"p": best, "rank": rank, "n_cand": len(regs)}
    if best < cfg.classifier.threshold:
        return {"stage": "threshold p", **info}
    kept = [i for i in order if p[i] >= cfg.classifier.threshold][: cfg.max_count or None]
    return {"stage": "hit" if inside[kept].any() else "count", **info}


def _edge(mask: np.ndarray) -> bool:
    return bool(mask[0].any() or mask[-1].any() or mask[:, 0].any() or mask[:, -1].any())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=str(default_sdvd_dir()), help="SDVD folder")
    ap.add_argument("--split", default="tune", choices=("tune", "test", "all"))
    ap.add_argument("--detector", default="sdvd-trusted", choices=tuple(DETECTORS))
    args = ap.parse_args(argv)
    data = Path(args.data)
    if not data.is_dir():
        print(f"sdvd_miss_study: {str(data)!r} not found", file=sys.stderr)
        return 2
    cfg = get_detector(args.detector)
    tiles = [t for t in load_sdvd(data) if t.positive and args.split in ("all", t.split)]
    counts: Counter = Counter()
    print(f"{'tile':48s} {'f':1s} {'seabed':>6s} {'edge':>4s} {'mask':>6s} stage        p     rank")
    for t in tiles:
        r = lost_at(t, cfg)
        f = sdvd_frequency(t.name) or "?"
        counts[(r["stage"], f)] += 1
        if r["stage"] == "hit":
            continue
        nz = t.image[t.image > 0]
        seabed = float(np.median(nz)) if nz.size else 0.0
        p = "" if r["p"] is None else f"{r['p']:.3f}"
        rank = "" if r["rank"] is None else f"{r['rank']}/{r['n_cand']}"
        print(
            f"{t.name[:48]:48s} {f} {seabed:6.0f} {str(_edge(t.mask))[0]:>4s} "
            f"{int(t.mask.sum()):6d} {r['stage']:12s} {p:6s} {rank}"
        )
    print(f"\n{args.split}: {len(tiles)} positive tiles; stage at which the effigy is lost")
    print(f"{'stage':12s} {'HF':>4s} {'LF':>4s}")
    for s in STAGES:
        print(f"{s:12s} {counts[(s, 'H')]:4d} {counts[(s, 'L')]:4d}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
