"""Keypoint matching between overlapping sonar images (thesis Ch. 4.2).

Detectors (OpenCV), the thesis's five (Ch. 4.2.1) less SURF, plus ORB:

- ``"harris"``: Harris & Stephens corners (``cv2.goodFeaturesToTrack`` with the Harris
  measure, k = 0.04) at one scale, each described by a SIFT descriptor over a fixed
  :data:`HARRIS_SUPPORT_PX` support, oriented by the intensity centroid of a disc around
  the corner (Rosin 1999, the orientation ORB uses). Rotation-invariant, not
  scale-invariant — the weakness the thesis names.
- ``"brisk"``: BRISK (Leutenegger et al. 2011; binary, Hamming distance), from
  opencv-contrib's ``xfeatures2d`` in OpenCV 5 (``cv2.BRISK`` in 4.x).
- ``"sift"`` (cv2.SIFT); ``"orb"`` (cv2.ORB, binary, Hamming distance); ``"asift"``
  (cv2.AffineFeature wrapping SIFT: SIFT over simulated affine tilts and rotations,
  Morel & Yu).

SURF, the thesis's main detector, is patented code in opencv-contrib's ``xfeatures2d``
"nonfree" part, which pip's OpenCV wheels do not build (``SURF_create`` raises "This
algorithm is patented and is excluded"); it is therefore not offered (SIFT is its closest
free substitute).

Candidate pairs follow the thesis's bidirectional nearest-neighbour criterion with ratio
α ≤ 1 (eqs. 4.16–4.18): (p_i, q_j) is kept when q_j is p_i's nearest neighbour and p_i
is q_j's (A), and d(p_i, q_j) ≤ α × the second-nearest distance on both sides (B, C).
RANSAC then fits a similarity (``cv2.estimateAffinePartial2D``, default) or a homography
(``cv2.findHomography``); two images are "matched" when at least 3 inlier pairs remain.

Transforms map pixel coordinates (x = column, y = row) of image A to image B.
``rotation_deg`` is counter-clockwise as displayed (the sign ``cv2.getRotationMatrix2D``
uses), ``scale`` is B/A size.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from slam.io.images import as_grey_float

DETECTORS = ("harris", "brisk", "sift", "orb", "asift")
BINARY_DETECTORS = ("orb", "brisk")  # Hamming-distance descriptors
UNAVAILABLE_DETECTORS = {"surf": "patented; not built into pip's OpenCV (nonfree contrib)"}
HARRIS_SUPPORT_PX = 24.0  # diameter of the SIFT descriptor's support around a Harris corner


@dataclass(frozen=True)
class Keypoints:
    """points : (N, 2) float32 pixel (x, y); descriptors : (N, D) (float32 or uint8)."""

    points: np.ndarray
    descriptors: np.ndarray
    detector: str

    def __len__(self) -> int:
        return int(self.points.shape[0])


@dataclass(frozen=True)
class MatchResult:
    """Outcome of :func:`match_images`.

    n_keypoints_a, n_keypoints_b : detected keypoints.
    pairs       : (K, 2) int, candidate pairs (index in A, index in B) after eqs. 4.16–4.18.
    inliers     : (K,) bool, RANSAC inliers among ``pairs``.
    n_inliers   : inliers.sum().
    matched     : n_inliers >= min_inliers (3 in the thesis).
    transform   : (2, 3) similarity or (3, 3) homography A → B, or None.
    rotation_deg, scale : from the similarity (nan for none / homography's linear part).
    time_s      : wall time of detection + matching + RANSAC.
    """

    detector: str
    n_keypoints_a: int
    n_keypoints_b: int
    pairs: np.ndarray
    inliers: np.ndarray
    n_inliers: int
    matched: bool
    transform: np.ndarray | None
    rotation_deg: float
    scale: float
    time_s: float

    @property
    def n_candidates(self) -> int:
        return int(self.pairs.shape[0])

    def summary(self) -> dict:
        return {
            "detector": self.detector,
            "keypoints_a": self.n_keypoints_a,
            "keypoints_b": self.n_keypoints_b,
            "candidates": self.n_candidates,
            "inliers": self.n_inliers,
            "matched": self.matched,
            "rotation_deg": self.rotation_deg,
            "scale": self.scale,
            "transform": None if self.transform is None else self.transform.tolist(),
            "time_s": self.time_s,
        }


def to_uint8(image: np.ndarray, *, low: float = 0.5, high: float = 99.5) -> np.ndarray:
    """Percentile-stretch a grey image to uint8 (detectors need 8-bit input).

    uint8 input is returned unchanged. A constant image maps to zeros.
    """
    a = np.asarray(image)
    if a.dtype == np.uint8 and a.ndim == 2 and a.size:
        return a
    f = as_grey_float(a, name="image").astype(np.float64)
    lo, hi = np.percentile(f, [low, high])
    if hi <= lo:
        return np.zeros(f.shape, np.uint8)
    return np.clip(np.rint(255.0 * (f - lo) / (hi - lo)), 0, 255).astype(np.uint8)


def _brisk():
    import cv2

    if hasattr(cv2, "BRISK_create"):  # OpenCV 4.x main module
        return cv2.BRISK_create()
    return cv2.xfeatures2d.BRISK_create()  # OpenCV 5: opencv-contrib's xfeatures2d


def _make_detector(detector: str, max_features: int):
    import cv2

    if detector == "brisk":
        return _brisk()
    if detector == "sift":
        return cv2.SIFT_create(nfeatures=max_features)
    if detector == "orb":
        return cv2.ORB_create(nfeatures=max_features or 5000)
    if detector == "asift":
        return cv2.AffineFeature_create(cv2.SIFT_create(nfeatures=max_features))
    raise ValueError(_unknown_detector(detector))


def _unknown_detector(detector: str) -> str:
    why = UNAVAILABLE_DETECTORS.get(str(detector).lower())
    if why:
        return f"detector {detector!r} is not available: {why}; allowed {DETECTORS}"
    return f"detector {detector!r} not available; allowed {DETECTORS}"


def intensity_centroid_angles(
    img: np.ndarray, points: np.ndarray, *, radius: int = 12
) -> np.ndarray:
    """Orientation in degrees (OpenCV keypoint convention, [0, 360)) of each point from the
    intensity centroid of a disc of ``radius`` px around it (Rosin 1999; ORB's rule):
    θ = atan2(m01, m10), m_pq = Σ x^p y^q I(x, y) over the disc, x right and y down.

    Written here because OpenCV computes it only inside ORB's own detector. Two
    whole-image ``filter2D`` passes give m10 and m01 everywhere; the points sample them.
    """
    import cv2

    r = int(radius)
    yy, xx = np.mgrid[-r : r + 1, -r : r + 1].astype(np.float32)
    disc = (xx**2 + yy**2 <= r * r).astype(np.float32)
    f = img.astype(np.float32)
    m10 = cv2.filter2D(f, cv2.CV_32F, xx * disc, borderType=cv2.BORDER_REFLECT)
    m01 = cv2.filter2D(f, cv2.CV_32F, yy * disc, borderType=cv2.BORDER_REFLECT)
    if points.shape[0] == 0:
        return np.zeros(0, np.float64)
    c = np.clip(np.rint(points[:, 0]).astype(int), 0, f.shape[1] - 1)
    rr = np.clip(np.rint(points[:, 1]).astype(int), 0, f.shape[0] - 1)
    return np.degrees(np.arctan2(m01[rr, c], m10[rr, c])) % 360.0


def _harris_keypoints(img: np.ndarray, max_features: int):
    """Harris corners (k = 0.04, quality 1 % of the best, 5 px apart) with SIFT descriptors
    over a fixed support, oriented by :func:`intensity_centroid_angles`."""
    import cv2

    corners = cv2.goodFeaturesToTrack(
        img,
        maxCorners=max_features or 5000,
        qualityLevel=0.01,
        minDistance=5,
        blockSize=5,
        useHarrisDetector=True,
        k=0.04,
    )
    pts = np.zeros((0, 2), np.float32) if corners is None else corners.reshape(-1, 2)
    angles = intensity_centroid_angles(img, pts)
    kps = [
        cv2.KeyPoint(float(x), float(y), HARRIS_SUPPORT_PX, float(a))
        for (x, y), a in zip(pts, angles, strict=True)
    ]
    if not kps:
        return [], None
    return cv2.SIFT_create().compute(img, kps)


def detect(image: np.ndarray, detector: str = "sift", *, max_features: int = 0) -> Keypoints:
    """Detect keypoints and compute descriptors on a grey image (any dtype; stretched to
    uint8 by :func:`to_uint8`). ``max_features`` 0 = detector default (ORB: 5000)."""
    if detector not in DETECTORS:
        raise ValueError(_unknown_detector(detector))
    img = to_uint8(image)
    if detector == "harris":
        kps, desc = _harris_keypoints(img, max_features)
    else:
        kps, desc = _make_detector(detector, max_features).detectAndCompute(img, None)
    if desc is None or len(kps) == 0:
        width = {"orb": 32, "brisk": 64}.get(detector, 128)
        dtype = np.uint8 if detector in BINARY_DETECTORS else np.float32
        return Keypoints(np.zeros((0, 2), np.float32), np.zeros((0, width), dtype), detector)
    pts = np.array([k.pt for k in kps], dtype=np.float32).reshape(-1, 2)
    return Keypoints(pts, desc, detector)


def _nn2(
    query: np.ndarray, train: np.ndarray, norm: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each query row: index of nearest train row, its distance, second distance
    (inf when train has one row)."""
    import cv2

    bf = cv2.BFMatcher(norm, crossCheck=False)
    k = min(2, train.shape[0])
    knn = bf.knnMatch(query, train, k=k)
    idx = np.array([m[0].trainIdx for m in knn], dtype=np.int64)
    d1 = np.array([m[0].distance for m in knn], dtype=np.float64)
    d2 = np.array([m[1].distance if len(m) > 1 else np.inf for m in knn], dtype=np.float64)
    return idx, d1, d2


def bidirectional_matches(
    desc_a: np.ndarray, desc_b: np.ndarray, *, ratio: float = 0.8, binary: bool = False
) -> np.ndarray:
    """Candidate pairs by the thesis's bidirectional nearest-neighbour rule (eqs. 4.16–4.18).

    A: mutual nearest neighbours; B: d(p_i, q_j) ≤ α·(second-nearest distance from p_i in
    Q); C: d(p_i, q_j) ≤ α·(second-nearest distance from q_j in P). ``binary`` selects
    Hamming distance (ORB), else L2. Returns (K, 2) int pairs (i in A, j in B).
    """
    import cv2

    if not 0.0 < ratio <= 1.0:
        raise ValueError(f"ratio alpha must be in (0, 1], got {ratio}")
    if desc_a is None or desc_b is None or len(desc_a) == 0 or len(desc_b) == 0:
        return np.zeros((0, 2), np.int64)
    norm = cv2.NORM_HAMMING if binary else cv2.NORM_L2
    da = np.ascontiguousarray(desc_a)
    db = np.ascontiguousarray(desc_b)
    j_of_i, d_ab, d2_a = _nn2(da, db, norm)
    i_of_j, _, d2_b = _nn2(db, da, norm)
    i = np.arange(da.shape[0])
    mutual = i_of_j[j_of_i] == i  # (4.16)
    cond_b = d_ab <= ratio * d2_a  # (4.17)
    cond_c = d_ab <= ratio * d2_b[j_of_i]  # (4.18)
    keep = mutual & cond_b & cond_c
    return np.stack([i[keep], j_of_i[keep]], axis=1).astype(np.int64)


def similarity_params(m: np.ndarray) -> tuple[float, float]:
    """(rotation_deg counter-clockwise as displayed, scale) of a 2×3 similarity."""
    m = np.asarray(m, dtype=np.float64)
    scale = float(np.hypot(m[0, 0], m[1, 0]))
    rot = float(np.degrees(np.arctan2(-m[1, 0], m[0, 0])))
    return rot, scale


def match_images(
    a: np.ndarray,
    b: np.ndarray,
    *,
    detector: str = "sift",
    ratio: float = 0.8,
    model: str = "similarity",
    ransac_threshold: float = 3.0,
    min_inliers: int = 3,
    max_features: int = 0,
) -> MatchResult:
    """Detect, match (eqs. 4.16–4.18) and verify with RANSAC; see the module docstring.

    Raises ValueError for bad images, an unknown detector or model, ratio outside (0, 1].
    """
    _check_match_args(model, ratio)
    t0 = time.perf_counter()
    ka = detect(a, detector, max_features=max_features)
    kb = detect(b, detector, max_features=max_features)
    return match_keypoints(
        ka,
        kb,
        ratio=ratio,
        model=model,
        ransac_threshold=ransac_threshold,
        min_inliers=min_inliers,
        elapsed_s=time.perf_counter() - t0,
    )


def _check_match_args(model: str, ratio: float) -> None:
    if model not in ("similarity", "homography"):
        raise ValueError(f"model must be 'similarity' or 'homography', got {model!r}")
    if not 0.0 < ratio <= 1.0:
        raise ValueError(f"ratio alpha must be in (0, 1], got {ratio}")


def match_keypoints(
    ka: Keypoints,
    kb: Keypoints,
    *,
    ratio: float = 0.8,
    model: str = "similarity",
    ransac_threshold: float = 3.0,
    min_inliers: int = 3,
    elapsed_s: float = 0.0,
) -> MatchResult:
    """The matching half of :func:`match_images` on keypoints already detected (so a
    sweep detects its fixed image once). ``elapsed_s`` (s) is added to the reported
    ``time_s`` (the detection time spent before the call)."""
    import cv2

    _check_match_args(model, ratio)
    if ka.detector != kb.detector:
        raise ValueError(f"keypoints from two detectors: {ka.detector!r} and {kb.detector!r}")
    t0 = time.perf_counter()
    pairs = bidirectional_matches(
        ka.descriptors, kb.descriptors, ratio=ratio, binary=ka.detector in BINARY_DETECTORS
    )
    transform = None
    inliers = np.zeros(pairs.shape[0], bool)
    need = 2 if model == "similarity" else 4
    if pairs.shape[0] >= need:
        src = ka.points[pairs[:, 0]].reshape(-1, 1, 2)
        dst = kb.points[pairs[:, 1]].reshape(-1, 1, 2)
        if model == "similarity":
            m, mask = cv2.estimateAffinePartial2D(
                src,
                dst,
                method=cv2.RANSAC,
                ransacReprojThreshold=ransac_threshold,
                maxIters=5000,
                confidence=0.999,
            )
        else:
            m, mask = cv2.findHomography(src, dst, cv2.RANSAC, ransac_threshold)
        if m is not None and mask is not None:
            transform = np.asarray(m, dtype=np.float64)
            inliers = mask.reshape(-1).astype(bool)
    n_in = int(inliers.sum())
    rot, scale = (np.nan, np.nan)
    if transform is not None:
        lin = transform[:2, :3] if model == "similarity" else transform[:2, :3] / transform[2, 2]
        rot, scale = similarity_params(lin)
    return MatchResult(
        detector=ka.detector,
        n_keypoints_a=len(ka),
        n_keypoints_b=len(kb),
        pairs=pairs,
        inliers=inliers,
        n_inliers=n_in,
        matched=n_in >= min_inliers,
        transform=transform,
        rotation_deg=rot,
        scale=scale,
        time_s=elapsed_s + time.perf_counter() - t0,
    )


def rotate_scale(
    image: np.ndarray, angle_deg: float, scale: float
) -> tuple[np.ndarray, np.ndarray]:
    """Rotate (counter-clockwise as displayed) and scale an image about its centre into a
    canvas big enough to hold all of it. Returns (warped uint8 image, 2×3 transform A→B)."""
    import cv2

    img = to_uint8(image)
    if scale <= 0:
        raise ValueError(f"scale must be > 0, got {scale}")
    h, w = img.shape
    m = cv2.getRotationMatrix2D((w / 2.0, h / 2.0), float(angle_deg), float(scale))
    corners = np.array([[0, 0, 1], [w, 0, 1], [0, h, 1], [w, h, 1]], dtype=np.float64)
    xy = corners @ m.T
    lo = xy.min(axis=0)
    size = np.ceil(xy.max(axis=0) - lo).astype(int)
    m[:, 2] -= lo
    out = cv2.warpAffine(img, m, (int(size[0]), int(size[1])), flags=cv2.INTER_LINEAR)
    return out, m


@dataclass(frozen=True)
class SweepRow:
    """One cell of a Table-4.3-style sweep."""

    angle_deg: float
    scale: float
    n_inliers: int
    matched: bool
    rotation_error_deg: float
    scale_error: float
    corner_error_px: float
    time_s: float


def rotation_scale_sweep(
    image: np.ndarray,
    *,
    angles_deg: tuple[float, ...] = (20, 45, 90, 135, 180),
    scales: tuple[float, ...] = (0.6, 0.8, 0.9, 1.0, 1.1, 1.2, 1.4),
    detector: str = "sift",
    ratio: float = 0.8,
    blur: tuple[int, float] | None = (11, 1.5),
    speckle: float = 0.0,
    rng: np.random.Generator | None = None,
    second: np.ndarray | None = None,
    max_features: int = 0,
) -> list[SweepRow]:
    """Thesis Table 4.3 protocol: image A = ``image`` blurred with a Gaussian (11×11,
    σ 1.5; the "large-space low-resolution" image), image B = ``image`` rotated and scaled.
    Each cell reports inliers, whether matched, and the recovered transform's errors
    against the known one (rotation, relative scale, mean error at A's corners, px in B).

    ``speckle`` > 0 multiplies B by independent unit-mean Gamma speckle of that standard
    deviation (from ``rng``), a crude stand-in for a second pass seeing new speckle;
    without it, A and B share their noise and matching is easier than between real passes.

    ``second`` (optional): a second image of the same place on the same pixel grid (e.g. a
    second pass mosaicked with the true poses); B is then made from it instead of from
    ``image``, so the pair differs as two real passes do and the true transform is still
    the applied rotation and scale.
    """
    import cv2

    base = to_uint8(image)
    a = cv2.GaussianBlur(base, (blur[0], blur[0]), blur[1]) if blur else base
    other = base if second is None else to_uint8(second)
    if other.shape != base.shape:
        raise ValueError(f"second has shape {other.shape}; allowed: image's {base.shape}")
    h, w = base.shape
    corners = np.array([[0, 0, 1], [w, 0, 1], [0, h, 1], [w, h, 1]], dtype=np.float64)
    t0 = time.perf_counter()
    ka = detect(a, detector, max_features=max_features)  # A is the same in every cell
    t_a = time.perf_counter() - t0
    rows = []
    for s in scales:
        for ang in angles_deg:
            b, m_true = rotate_scale(other, ang, s)
            if speckle > 0:
                if rng is None:
                    raise ValueError("speckle > 0 needs an rng (numpy.random.Generator)")
                k = 1.0 / speckle**2
                noise = rng.gamma(k, 1.0 / k, size=b.shape)
                b = np.clip(b * noise, 0, 255).astype(np.uint8)
            t0 = time.perf_counter()
            kb = detect(b, detector, max_features=max_features)
            # time per cell as the thesis counts it: both images' detection and the matching
            res = match_keypoints(ka, kb, ratio=ratio, elapsed_s=t_a + time.perf_counter() - t0)
            if res.transform is None:
                rot_err = scale_err = corner_err = np.nan
            else:
                rot_err = float(abs((res.rotation_deg - ang + 180.0) % 360.0 - 180.0))
                scale_err = float(abs(res.scale / s - 1.0))
                corner_err = float(
                    np.mean(np.linalg.norm(corners @ res.transform.T - corners @ m_true.T, axis=1))
                )
            rows.append(
                SweepRow(
                    float(ang),
                    float(s),
                    res.n_inliers,
                    res.matched,
                    rot_err,
                    scale_err,
                    corner_err,
                    res.time_s,
                )
            )
    return rows
