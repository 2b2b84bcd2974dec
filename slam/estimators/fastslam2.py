"""FastSLAM 2.0 (Montemerlo, Thrun, Koller and Wegbreit, IJCAI 2003), particles as arrays.

The comparison filter of the reference thesis (chapter 6), which ran Tim Bailey's MATLAB
implementation. This version follows Bailey's structure and fixes its known failure:

* Each particle ``i`` holds a pose ``xv[i]`` (3,) = ``[x m, y m, phi rad]`` (2-D world
  frame) with a pose covariance ``Pv[i]`` (3, 3) that odometry grows between observation
  scans (Bailey: "no predict noise" — the mean is propagated deterministically and the
  uncertainty is carried as a covariance until the proposal samples it).
* ``update``: (1) data association per particle (known ``label`` or maximum likelihood with
  a reject gate and an augment gate on the normalized innovation squared); (2) importance
  weight ``w_i *= p(z | x_{k-1,i}, m_i)``, the predictive density with
  ``S = Hv Pv Hv^T + Hf Pf Hf^T + R``, accumulated in LOG form so that a huge innovation
  (loop closure) never underflows every weight to zero — Bailey's implementation
  multiplies linear weights and collapses there; (3) resampling (systematic by default,
  stratified as Bailey) when ``N_eff < resample_threshold * N``, *before* the proposal as
  Bailey does, for particle diversity — by default with Bailey's 75 % rule for
  maximum-likelihood association and never with known association (labels): the
  log-weighted particles then stay independent path hypotheses for the loop closure to
  choose among, see :attr:`FastSLAM2Config.resample_threshold`; (4) the
  FastSLAM 2.0 proposal: the pose mean and
  covariance are refined by a sequential EKF update with every associated observation,
  then a new pose is *sampled* from that Gaussian with the ``rng`` given; (5) per-particle
  landmark EKF updates (Joseph form) at the sampled pose and augmentation of new landmarks.
* Loop closure with maximum-likelihood association: a particle's own pose covariance only
  holds the few steps since its last sample, so after a loop its drift (metres) puts every
  old landmark far outside the gates and it duplicates them. A drift allowance that grows
  with the path length between a landmark's mapping and the landmarks the particle is
  anchored to widens the gate for old landmarks only; a particle that associates thanks
  to it (an observation plain gating would have made a new landmark) gets the drift as pose
  uncertainty in its weight and proposal, and an iterated (Gauss-Newton) proposal update
  puts it onto the old map (``loop_drift_100m``, ``loop_anchor_window_m``).
* Everything is vectorized across particles: poses ``(N, 3)``, landmark means
  ``(N, M, 2)``, covariances ``(N, M, 2, 2)``, existence mask ``(N, M)``. The only Python
  loop is over the observations of one scan in the sequential proposal (a handful).

Odometry model (the thesis's AEKF model, eq. 5.21): ``x' = x + dx cos(phi) - dy sin(phi)``,
``y' = y + dx sin(phi) + dy cos(phi)``, ``phi' = phi + dphi``, increments in the body frame.
Range-bearing model: ``r = |m - p|``, ``b = atan2(my - y, mx - x) - phi`` (radians,
counter-clockwise from body x, wrapped to (-pi, pi]).

Estimates: :meth:`FastSLAM2.pose` is the Rao-Blackwellized mixture: each particle
contributes the Gaussian its pose was last sampled from (the proposal), propagated since
(circular mean for the heading); it stays positive definite when one particle carries all
the weight. :meth:`FastSLAM2.landmarks` returns the map of
the highest-weight particle by default (``map_estimate="best"``, what Bailey plots and the
thesis's figure 6.1b shows); ``map_estimate="weighted"`` gives the weighted mixture per
landmark slot, meaningful with known association only (slots are then the same physical
landmark in every particle). Landmark indices in :class:`UpdateResult` and
:meth:`landmarks` refer to the same slots.

Two importance weights (``weighting``): ``"predictive"`` (default) is step (2) above, the
weight of Bailey's later fastslam2_sim, computed before resampling and the proposal;
``"proposal"`` is Bailey's 2004 fastslam2 (as the C++ ports by matzipan and bushuhui):
after the proposal and sampling ``xs``, ``w *= p(z | xs, m) N(xs; x_{k-1}, Pv_{k-1}) /
N(xs; mu, Sigma)`` with per-observation ``S = Hf Pf Hf^T + R`` (no pose term; a one-sample
estimate of the predictive density), and resampling *after* the landmark updates and
augmentation. Both keep log weights. Details that match Bailey in both: observations are
processed in scan order; new landmarks are initialised at the sampled pose with
``Pf = Gz R Gz^T``; the pose covariance after sampling is 0 (Bailey: ``eps I``, 2e-16,
immaterial); the odometry covariance between scans is the exact linearized composition of
the per-step increments (the runner's ``compose_increments``), i.e. Bailey's per-step
``Gv Pv Gv^T + Gu Q Gu^T`` to first order. One difference remains: the sequential proposal
relinearizes each observation at the mean refined by the previous ones (Bailey's 2004 code
linearizes all of a scan's observations at the predicted pose). Measured accuracy, consistency and run time on
the reference's maps, beside Bailey's Octave results: ``slam/experiments/README.md``.
The filter is inconsistent with 100 particles (Bailey, Nieto and Nebot, ICRA 2006).

The algorithm is hand-written (no library implements FastSLAM 2.0 on arrays);
resampling comes from :mod:`slam.estimators.resampling`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from slam.estimators.base import UpdateResult
from slam.estimators.rb_model import inv2 as _inv2
from slam.estimators.rb_model import symmetrize as _sym
from slam.estimators.rb_model import wrap as _wrap
from slam.estimators.resampling import (
    normalize_log_weights,
    stratified_resample,
    systematic_resample,
)
from slam.types import Odometry, RangeBearing

__all__ = ["FastSLAM2", "FastSLAM2Config", "observation_model", "validate_covariance"]

_LOG_2PI = float(np.log(2.0 * np.pi))
_NEW = -2  # association code inside the filter: observation creates a new landmark
_REJECT = -1


# ---------------------------------------------------------------------------- helpers
def validate_covariance(name: str, cov: np.ndarray, *, positive_definite: bool) -> None:
    """Raise ValueError unless ``cov`` is a finite, symmetric, PSD (or PD) matrix."""
    c = np.asarray(cov, dtype=float)
    if c.ndim != 2 or c.shape[0] != c.shape[1]:
        raise ValueError(f"{name} must be a square matrix, got shape {c.shape}")
    if not np.all(np.isfinite(c)):
        raise ValueError(f"{name} must be finite, got {c.tolist()}")
    diag = np.diag(c)
    if np.any(diag < 0.0):
        raise ValueError(f"{name} has negative variances {diag.tolist()}; variances must be >= 0")
    scale = max(float(np.max(np.abs(c))), 1e-300)
    if np.max(np.abs(c - c.T)) > 1e-9 * scale:
        raise ValueError(f"{name} must be symmetric, got {c.tolist()}")
    eig = np.linalg.eigvalsh(0.5 * (c + c.T))
    if positive_definite and not eig.min() > 1e-12 * scale:
        raise ValueError(f"{name} must be positive definite, got eigenvalues {eig.tolist()}")
    if eig.min() < -1e-9 * scale:
        raise ValueError(f"{name} must be positive semi-definite, got eigenvalues {eig.tolist()}")


def observation_model(xv: np.ndarray, m: np.ndarray):
    """Range-bearing prediction and Jacobians, vectorized over leading dimensions.

    Parameters
    ----------
    xv : (..., 3) vehicle poses ``[x, y, phi]`` (m, m, rad), world frame.
    m : (..., 2) landmark positions (m), world frame; broadcast against ``xv``.

    Returns
    -------
    zhat : (..., 2) predicted ``[range m, bearing rad]``.
    Hv : (..., 2, 3) Jacobian with respect to the pose.
    Hf : (..., 2, 2) Jacobian with respect to the landmark.
    """
    dx = m[..., 0] - xv[..., 0]
    dy = m[..., 1] - xv[..., 1]
    d2 = np.maximum(dx * dx + dy * dy, 1e-12)  # a landmark on the vehicle: keep finite
    d = np.sqrt(d2)
    zhat = np.stack([d, _wrap(np.arctan2(dy, dx) - xv[..., 2])], axis=-1)
    Hf = np.empty((*d.shape, 2, 2))
    Hf[..., 0, 0] = dx / d
    Hf[..., 0, 1] = dy / d
    Hf[..., 1, 0] = -dy / d2
    Hf[..., 1, 1] = dx / d2
    Hv = np.empty((*d.shape, 2, 3))
    Hv[..., :, :2] = -Hf
    Hv[..., 0, 2] = 0.0
    Hv[..., 1, 2] = -1.0
    return zhat, Hv, Hf


def _mm(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Batched product of small matrices as a sum of broadcast outer products (for inner
    dimension 2 or 3 this is 2-3x faster than ``np.matmul`` on large broadcast batches)."""
    out = A[..., :, 0, None] * B[..., None, 0, :]
    for k in range(1, A.shape[-1]):
        out = out + A[..., :, k, None] * B[..., None, k, :]
    return out


def _quad(H: np.ndarray, P: np.ndarray) -> np.ndarray:
    """``H P H^T`` batched."""
    return _mm(_mm(H, P), np.swapaxes(H, -1, -2))


def _propagate(xv, Pv, dx, dy, dphi, Q):
    """Odometry step (thesis eq. 5.21) of poses ``(n, 3)`` with covariances ``(n, 3, 3)``:
    the mean moves by the body-frame increment, ``Pv <- Gv Pv Gv^T + Gu Q Gu^T``."""
    phi = xv[:, 2]
    c, s = np.cos(phi), np.sin(phi)
    n = xv.shape[0]
    Gv = np.zeros((n, 3, 3))
    Gv[:, 0, 0] = Gv[:, 1, 1] = Gv[:, 2, 2] = 1.0
    Gv[:, 0, 2] = -dx * s - dy * c
    Gv[:, 1, 2] = dx * c - dy * s
    Gu = np.zeros((n, 3, 3))
    Gu[:, 0, 0], Gu[:, 0, 1] = c, -s
    Gu[:, 1, 0], Gu[:, 1, 1] = s, c
    Gu[:, 2, 2] = 1.0
    out = xv.copy()
    out[:, 0] += dx * c - dy * s
    out[:, 1] += dx * s + dy * c
    out[:, 2] = _wrap(phi + dphi)
    return out, _sym(_quad(Gv, Pv) + _quad(Gu, Q))


# ---------------------------------------------------------------------------- config
@dataclass(frozen=True)
class FastSLAM2Config:
    """Parameters of :class:`FastSLAM2`.

    n_particles : number of particles (thesis: 100).
    resample_threshold : resample when ``N_eff < resample_threshold * n_particles``
        (thesis and Bailey: 75 of 100 → 0.75). None (default) → 0.0 with
        ``association="known"``, 0.75 otherwise. 0.0 never resamples: with
        ``association="known"`` and the predictive weight the log-weighted particles then stay
        independent path hypotheses (per-scan weight noise on a sparse map otherwise
        resamples away the low-drift paths long before the loop closes) and the closure's
        likelihood selects among them; after it one particle holds the weight. With
        maximum-likelihood association the particles must also agree on the associations,
        and the N_eff rule is better (measured, see slam/experiments/README.md).
    weighting : "predictive" (default; ``p(z | x_{k-1})`` before resampling, Bailey's later
        code) or "proposal" (Bailey's 2004 sample weight after the proposal, resampling
        after the updates); see the module docstring.
    reject_gate : an unlabelled observation is associated with the maximum-likelihood
        landmark among those whose normalized innovation squared (NIS, chi-square with 2
        dof) is below this gate (4.0 as the AEKF).
    augment_gate : if the smallest NIS exceeds this gate (25.0) the observation creates a
        new landmark in that particle; between the gates it is discarded as ambiguous.
    new_landmark_log_likelihood : log of the likelihood ``p0`` a particle gets for an
        observation it explains as a new landmark or discards (Montemerlo's new-feature
        likelihood). None → the Gaussian log density at ``NIS = augment_gate`` with the
        measurement covariance R of that observation, so a particle that cannot explain an
        observation scores like one that explains it at the augment gate.
    resampler : "systematic" (default) or "stratified" (Bailey's).
    map_estimate : "best" (highest-weight particle's map) or "weighted".
    association : "ml" (default, as the AEKF: labels are ignored and every particle
        associates by maximum likelihood), "known" (every observation must carry a
        ``label``, which is the landmark identity, as in Bailey's FastSLAM 2.0) or "auto"
        (the label when present, maximum likelihood otherwise).
    initial_capacity : landmark slots allocated at start (grown by doubling).
    loop_drift_100m : loop-closure allowance for maximum-likelihood association (m): the
        standard deviation of a particle's pose drift, relative to landmarks it has not been
        anchored to, after 100 m of path; it grows as ``(gap / 100 m) ** 1.5`` (a heading
        random walk integrated along the path). ``gap`` is the path length between the
        landmark's mapping and the landmarks the particle currently tracks (see
        ``_drift_gap``). The allowance widens the association gate (landmark covariance
        ``+ sigma^2 I``); a particle that associates an observation which plain gating would
        have made a new landmark (NIS without the allowance above ``augment_gate``) is
        closing a loop and gets the drift as pose uncertainty (position ``sigma^2``, heading
        ``3 sigma^2 / gap^2``) in its weight and proposal, so it jumps onto the old map
        instead of duplicating it. 0 disables it. Labels (``association="known"``) never
        use it. A heuristic: the exponent follows from the heading random walk, but 0.7 m
        was tuned on the dense loop (seeds 0-19, checked on 20-39), not derived from the
        odometry noise; other vehicles or maps may need another value.
    loop_augment_gate : augment gate on the NIS *with* the loop-closure allowance for an
        observation that plain gating would make a new landmark (its NIS without the
        allowance above ``augment_gate`` for every landmark): beyond it the observation is
        a new landmark, between ``reject_gate`` and it ambiguous (discarded). The allowance
        spreads an old landmark over metres (σ ≈ 11 m after a 650 m loop), so ``augment_gate``
        (25) on that NIS would hold back any new landmark within ~50 m of an old one for as
        long as the gate is wide — a landmark first seen at the loop's end was discarded for
        all its sightings that way. 9.21 is χ²₂'s 99 % point; tuned on the dense loop's seeds
        20-22 (closing observations had allowance-NIS ≤ 0.2, the held-back new landmark
        9.2-26, an old one just beyond plain gating 4.6), reported on seeds 0-19. Values
        above ``augment_gate`` act as ``augment_gate`` (the rule before this gate).
    loop_anchor_window_m : the landmarks a particle updated within this much path (m) before
        its last update are its anchors; after a closure the loop-end landmarks stay among
        them, so the gate stays wide until the particle has re-localized on the old map
        (dense loop ML, 20 runs, measured with an earlier closing test: runs with extra
        landmarks 10 with 30 m, 0 with 120 m, 2 with 200 m).
    """

    n_particles: int = 100
    resample_threshold: float | None = None
    reject_gate: float = 4.0
    augment_gate: float = 25.0
    new_landmark_log_likelihood: float | None = None
    resampler: str = "systematic"
    map_estimate: str = "best"
    association: str = "ml"
    initial_capacity: int = 32
    loop_drift_100m: float = 0.7
    loop_anchor_window_m: float = 120.0
    loop_augment_gate: float = 9.21
    weighting: str = "predictive"

    def __post_init__(self) -> None:
        if not (isinstance(self.n_particles, int | np.integer) and self.n_particles >= 1):
            raise ValueError(f"n_particles must be an integer >= 1, got {self.n_particles!r}")
        if self.resample_threshold is None:  # resolved here: config shows the value used
            default = 0.0 if self.association == "known" else 0.75
            object.__setattr__(self, "resample_threshold", default)
        if not 0.0 <= self.resample_threshold <= 1.0:
            raise ValueError(
                f"resample_threshold must be in [0, 1], got {self.resample_threshold!r}"
            )
        if not (np.isfinite(self.reject_gate) and self.reject_gate > 0.0):
            raise ValueError(f"reject_gate must be finite and > 0, got {self.reject_gate!r}")
        if not (np.isfinite(self.augment_gate) and self.augment_gate >= self.reject_gate):
            raise ValueError(
                f"augment_gate must be finite and >= reject_gate ({self.reject_gate}), "
                f"got {self.augment_gate!r}"
            )
        if self.new_landmark_log_likelihood is not None and not np.isfinite(
            self.new_landmark_log_likelihood
        ):
            raise ValueError(
                "new_landmark_log_likelihood must be finite or None, "
                f"got {self.new_landmark_log_likelihood!r}"
            )
        if self.resampler not in ("systematic", "stratified"):
            raise ValueError(
                f"resampler must be 'systematic' or 'stratified', got {self.resampler!r}"
            )
        if self.weighting not in ("predictive", "proposal"):
            raise ValueError(
                f"weighting must be 'predictive' or 'proposal', got {self.weighting!r}"
            )
        if self.map_estimate not in ("best", "weighted"):
            raise ValueError(
                f"map_estimate must be 'best' or 'weighted', got {self.map_estimate!r}"
            )
        if self.association not in ("ml", "known", "auto"):
            raise ValueError(
                f"association must be 'ml', 'known' or 'auto', got {self.association!r}"
            )
        if not (np.isfinite(self.loop_anchor_window_m) and self.loop_anchor_window_m > 0.0):
            raise ValueError(
                f"loop_anchor_window_m must be finite and > 0, got {self.loop_anchor_window_m!r}"
            )
        if not (np.isfinite(self.loop_augment_gate) and self.loop_augment_gate >= self.reject_gate):
            raise ValueError(
                f"loop_augment_gate must be finite and >= reject_gate ({self.reject_gate}), "
                f"got {self.loop_augment_gate!r}"
            )
        if not (np.isfinite(self.loop_drift_100m) and self.loop_drift_100m >= 0.0):
            raise ValueError(
                f"loop_drift_100m must be finite and >= 0, got {self.loop_drift_100m!r}"
            )
        if not (isinstance(self.initial_capacity, int | np.integer) and self.initial_capacity >= 1):
            raise ValueError(
                f"initial_capacity must be an integer >= 1, got {self.initial_capacity!r}"
            )


# ---------------------------------------------------------------------------- filter
class FastSLAM2:
    """FastSLAM 2.0 with arrays of particles; implements ``SlamEstimator``.

    Parameters
    ----------
    n_particles, resample_threshold, reject_gate, augment_gate, new_landmark_log_likelihood,
    resampler, map_estimate, association, initial_capacity : see :class:`FastSLAM2Config`.
    rng : numpy Generator for proposal sampling and resampling; if None, one is made from
        ``seed`` (``np.random.default_rng(seed)``).
    seed : used only when ``rng`` is None.
    x0 : (3,) initial pose ``[x m, y m, phi rad]`` (default zeros, as Bailey's simulator).
    P0 : (3, 3) initial pose covariance (default zeros: the map frame is the start pose).
    config : a ready :class:`FastSLAM2Config` instead of the keywords above.
    """

    name = "fastslam2"

    def __init__(
        self,
        n_particles: int = 100,
        rng: np.random.Generator | None = None,
        resample_threshold: float | None = None,
        reject_gate: float = 4.0,
        augment_gate: float = 25.0,
        *,
        new_landmark_log_likelihood: float | None = None,
        resampler: str = "systematic",
        map_estimate: str = "best",
        association: str = "ml",
        initial_capacity: int = 32,
        loop_drift_100m: float = 0.7,
        loop_anchor_window_m: float = 120.0,
        loop_augment_gate: float = 9.21,
        weighting: str = "predictive",
        seed: int | None = None,
        x0=None,
        P0=None,
        config: FastSLAM2Config | None = None,
    ) -> None:
        if config is None:
            config = FastSLAM2Config(
                n_particles=n_particles,
                resample_threshold=resample_threshold,
                reject_gate=reject_gate,
                augment_gate=augment_gate,
                new_landmark_log_likelihood=new_landmark_log_likelihood,
                resampler=resampler,
                map_estimate=map_estimate,
                association=association,
                initial_capacity=initial_capacity,
                loop_drift_100m=loop_drift_100m,
                loop_anchor_window_m=loop_anchor_window_m,
                loop_augment_gate=loop_augment_gate,
                weighting=weighting,
            )
        self.config = config
        if rng is None:
            rng = np.random.default_rng(seed)
        if not isinstance(rng, np.random.Generator):
            raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        self.rng = rng
        x0 = np.zeros(3) if x0 is None else np.asarray(x0, dtype=float).reshape(-1)
        if x0.shape != (3,) or not np.all(np.isfinite(x0)):
            raise ValueError(f"x0 must be a finite (3,) pose [x, y, phi], got {x0!r}")
        P0 = np.zeros((3, 3)) if P0 is None else np.asarray(P0, dtype=float)
        validate_covariance("P0", P0, positive_definite=False)
        if P0.shape != (3, 3):
            raise ValueError(f"P0 must have shape (3, 3), got {P0.shape}")
        n, cap = int(config.n_particles), int(config.initial_capacity)
        self._xv = np.tile(x0, (n, 1))
        self._xv[:, 2] = _wrap(self._xv[:, 2])
        self._Pv = np.tile(_sym(P0), (n, 1, 1))
        self._logw = np.zeros(n)
        # Rao-Blackwellized pose estimate per particle: the proposal's Gaussian (mean and
        # covariance) before sampling, then propagated by odometry (what pose() reports).
        self._xv_rb, self._Pv_rb = self._xv.copy(), self._Pv.copy()
        self._m = np.zeros((n, cap, 2))
        self._P = np.zeros((n, cap, 2, 2))
        self._exists = np.zeros((n, cap), dtype=bool)
        self._count = np.zeros(n, dtype=np.intp)
        # path length travelled (m) when each landmark was mapped and last updated
        self._mapped = np.zeros((n, cap))
        self._updated = np.zeros((n, cap))
        self._path = 0.0  # path length travelled (m), from the odometry increments
        self._slot_label = np.full(cap, -1, dtype=np.int64)
        self._label_slot: dict[int, int] = {}
        self.n_resamples = 0
        self._valid_R: set[tuple] = set()
        self._threshold = float(config.resample_threshold)
        self._resample = (
            systematic_resample if config.resampler == "systematic" else stratified_resample
        )

    # ------------------------------------------------------------------ properties
    @property
    def n_particles(self) -> int:
        return self._xv.shape[0]

    @property
    def weights(self) -> np.ndarray:
        """(N,) normalized importance weights."""
        return normalize_log_weights(self._logw)[0]

    @property
    def log_weights(self) -> np.ndarray:
        """(N,) log importance weights (unnormalized; max shifted to 0 after each update)."""
        return self._logw.copy()

    @property
    def particle_poses(self) -> np.ndarray:
        """(N, 3) particle poses ``[x, y, phi]`` (copy)."""
        return self._xv.copy()

    def effective_sample_size(self) -> float:
        w = self.weights
        return float(1.0 / np.sum(w * w))

    # ------------------------------------------------------------------ predict
    def predict(self, odometry: Odometry) -> None:
        """Propagate every particle by one body-frame increment (thesis eq. 5.21).

        The mean moves deterministically; the pose covariance of each particle grows by
        ``Gv Pv Gv^T + Gu Q Gu^T`` (Q = ``odometry.cov``) and is sampled by the next
        proposal.
        """
        if not isinstance(odometry, Odometry):
            raise ValueError(
                f"odometry must be a slam.types.Odometry, got {type(odometry).__name__}"
            )
        validate_covariance("Odometry.cov", odometry.cov, positive_definite=False)
        dx, dy, dphi = odometry.delta
        Q = _sym(odometry.cov)
        n = self.n_particles
        x2, P2 = _propagate(
            np.concatenate([self._xv, self._xv_rb]),
            np.concatenate([self._Pv, self._Pv_rb]),
            dx,
            dy,
            dphi,
            Q,
        )
        self._xv, self._xv_rb, self._Pv, self._Pv_rb = x2[:n], x2[n:], P2[:n], P2[n:]
        self._path += float(np.hypot(dx, dy))

    # ------------------------------------------------------------------ update
    def _validate_observations(self, observations) -> tuple[np.ndarray, np.ndarray, list]:
        if isinstance(observations, RangeBearing):
            raise ValueError("observations must be a sequence of RangeBearing, got a single one")
        obs = list(observations)
        labels = []
        for i, o in enumerate(obs):
            if not isinstance(o, RangeBearing):
                raise ValueError(
                    f"observations[{i}] must be a slam.types.RangeBearing, got {type(o).__name__}"
                )
            Ra = np.asarray(o.R, dtype=float)
            key = (Ra.shape, Ra.tobytes())
            if key not in self._valid_R:  # scans share R: check each distinct one once
                validate_covariance(f"observations[{i}].R", o.R, positive_definite=True)
                if len(self._valid_R) < 64:
                    self._valid_R.add(key)
            if o.label is not None and not isinstance(o.label, int | np.integer):
                raise ValueError(f"observations[{i}].label must be an int or None, got {o.label!r}")
            labels.append(None if o.label is None else int(o.label))
        if self.config.association == "ml":
            labels = [None] * len(obs)
        elif self.config.association == "known" and any(lab is None for lab in labels):
            j = labels.index(None)
            raise ValueError(
                f"association='known' needs a label on every observation; observations[{j}].label is None"
            )
        if not obs:
            return np.zeros((0, 2)), np.zeros((0, 2, 2)), labels
        Z = np.array([o.z for o in obs], dtype=float)
        R = np.array([_sym(o.R) for o in obs], dtype=float)
        return Z, R, labels

    def _ensure_capacity(self, needed: int) -> None:
        cap = self._m.shape[1]
        if needed <= cap:
            return
        new_cap = max(needed, 2 * cap)
        n = self.n_particles
        m = np.zeros((n, new_cap, 2))
        P = np.zeros((n, new_cap, 2, 2))
        e = np.zeros((n, new_cap), dtype=bool)
        mapped, updated = np.zeros((n, new_cap)), np.zeros((n, new_cap))
        mapped[:, :cap], updated[:, :cap] = self._mapped, self._updated
        self._mapped, self._updated = mapped, updated
        lab = np.full(new_cap, -1, dtype=np.int64)
        m[:, :cap], P[:, :cap], e[:, :cap], lab[:cap] = (
            self._m,
            self._P,
            self._exists,
            self._slot_label,
        )
        self._m, self._P, self._exists, self._slot_label = m, P, e, lab

    def update(self, observations: Sequence[RangeBearing]) -> UpdateResult:
        """Associate, weight, resample, sample the proposal, update and augment.

        Returns the associations of the highest-weight particle after the update
        (landmark slot indices as in :meth:`landmarks`, -1 where it discarded the
        observation) and the NIS of its associated observations (predictive, with the
        particle's pose covariance included).
        """
        Z, R, labels = self._validate_observations(observations)
        k = Z.shape[0]
        if k == 0:
            return UpdateResult(np.zeros(0, dtype=np.intp), np.zeros(0, dtype=bool), np.zeros(0))
        cfg = self.config
        n = self.n_particles

        # New known labels get global slots (the same in every particle).
        new_labels = []
        for lab in labels:
            if lab is not None and lab not in self._label_slot and lab not in new_labels:
                new_labels.append(lab)
        base = int(self._count.max()) if n else 0
        label_slot = dict(self._label_slot)
        for q, lab in enumerate(new_labels):
            label_slot[lab] = base + q
        n_known_new = len(new_labels)

        # Working copies: the state is committed only at the end.
        xv, Pv, logw = self._xv.copy(), self._Pv.copy(), self._logw.copy()
        xv_rb, Pv_rb = self._xv_rb.copy(), self._Pv_rb.copy()
        self._ensure_capacity(base + n_known_new + k)  # capacity growth alone is harmless
        m, P, exists = self._m.copy(), self._P.copy(), self._exists.copy()
        mapped, updated = self._mapped.copy(), self._updated.copy()
        count = self._count.copy()

        # ---------------------------------------------------------- association
        assoc = np.full((n, k), _REJECT, dtype=np.intp)
        loop_gap = np.zeros(n)
        nis = np.full((n, k), np.nan)
        loglik = np.zeros((n, k))
        unknown = np.array([lab is None for lab in labels])
        j_unk = np.nonzero(unknown)[0]
        j_kn = np.nonzero(~unknown)[0]
        if j_kn.size:
            slots = np.array([label_slot[labels[j]] for j in j_kn])
            is_new = slots >= base  # labels first seen now
            seen: set[int] = set()
            keep = np.ones(j_kn.size, dtype=bool)
            for q, (jj, slot, new) in enumerate(zip(j_kn, slots, is_new)):
                if slot in seen:  # the same label twice in one scan: keep the first
                    keep[q] = False
                    continue
                seen.add(int(slot))
                assoc[:, jj] = _NEW if new else slot
            j_kn, slots, is_new = j_kn[keep], slots[keep], is_new[keep]
            old = j_kn[~is_new]
            if old.size:
                zhat, Hv, Hf = observation_model(xv[:, None, :], m[:, slots[~is_new]])
                S = _quad(Hv, Pv[:, None]) + _quad(Hf, P[:, slots[~is_new]]) + R[old][None]
                v = Z[old][None] - zhat
                v[..., 1] = _wrap(v[..., 1])
                Si, det = _inv2(S)
                d2 = np.einsum("...i,...ij,...j->...", v, Si, v)
                nis[:, old] = d2
                loglik[:, old] = -0.5 * d2 - 0.5 * np.log(det) - _LOG_2PI
        if j_unk.size:
            ku = j_unk.size
            p0 = self._p0(R[j_unk])  # (ku,)
            used = int(count.max())  # slots beyond every particle's count are empty
            if used and exists[:, :used].any():
                ex = exists[:, :used]
                zhat, Hv, Hf = observation_model(xv[:, None, :], m[:, :used])  # (n, used, ...)
                v = Z[j_unk][None, :, None] - zhat[:, None]  # (n, ku, used, 2)
                v[..., 1] = _wrap(v[..., 1])
                # Cheap lower bound on the NIS: S <= tr(S) I, and with ||Hv||_F^2 = 2 + 1/d^2,
                # ||Hf||_F^2 = 1 + 1/d^2: tr(S) <= tr(Pv)(2 + 1/d^2) + tr(Pf)(1 + 1/d^2) + tr(R).
                # Only pairs whose bound is below the augment gate need the exact S (most
                # landmarks of a map are far from a given observation).
                inv_d2 = 1.0 / np.maximum(zhat[..., 0] ** 2, 1e-12)  # (n, used)
                trPv = np.trace(Pv, axis1=1, axis2=2)[:, None]
                # Loop-closure allowance: a landmark last updated ``d`` metres of path ago
                # is, relative to the particle's drifted pose, uncertain by about
                # ``loop_drift_100m * d`` (the drift a finite particle set cannot hold).
                gap = self._drift_gap(mapped[:, :used], updated[:, :used], ex)
                dvar = cfg.loop_drift_100m**2 * (gap / 100.0) ** 3
                trPf = P[:, :used, 0, 0] + P[:, :used, 1, 1] + 2.0 * dvar
                tr_bound = trPv * (2.0 + inv_d2) + trPf * (1.0 + inv_d2)  # (n, used)
                tr_bound = tr_bound[:, None] + np.trace(R[j_unk], axis1=1, axis2=2)[None, :, None]
                lower = np.einsum("...i,...i->...", v, v) / tr_bound  # (n, ku, used)
                pi, pq, pl = np.nonzero((lower < cfg.augment_gate) & ex[:, None, :])
                d2 = np.full((n, ku, used), np.inf)
                ll = np.full((n, ku, used), -np.inf)
                cand = np.full((n, ku, used), -1, dtype=np.intp)
                cand[pi, pq, pl] = np.arange(pi.size)
                S = np.zeros((0, 2, 2))
                if pi.size:
                    Pf = P[pi, pl] + dvar[pi, pl][:, None, None] * np.eye(2)
                    S = _quad(Hv[pi, pl], Pv[pi]) + _quad(Hf[pi, pl], Pf) + R[j_unk][pq]
                    Si, det = _inv2(S)
                    vv = v[pi, pq, pl]
                    dd = np.einsum("...i,...ij,...j->...", vv, Si, vv)
                    d2[pi, pq, pl] = dd
                    ll[pi, pq, pl] = -0.5 * dd - 0.5 * np.log(det) - _LOG_2PI
                ll_gated = np.where(d2 < cfg.reject_gate, ll, -np.inf)
                best = np.argmax(ll_gated, axis=2)  # (n, ku)
                best_ll = np.take_along_axis(ll_gated, best[..., None], 2)[..., 0]
                best_d2 = np.take_along_axis(d2, best[..., None], 2)[..., 0]
                dmin = d2.min(axis=2)
                matched = np.isfinite(best_ll)
                new = (dmin > cfg.augment_gate) | (
                    (dmin > cfg.loop_augment_gate)
                    & (self._plain_nis_min(d2.shape, pi, pq, pl, S, dvar, Hf, v) > cfg.augment_gate)
                )
                a = np.where(matched, best, np.where(new, _NEW, _REJECT))
                # One landmark per particle per scan: among observations matched to the same
                # landmark in a particle, keep the smallest NIS (ties: first observation).
                same = (a[:, :, None] == a[:, None, :]) & matched[:, :, None] & matched[:, None, :]
                jidx = np.arange(ku)
                better = (best_d2[:, None, :] < best_d2[:, :, None]) | (
                    (best_d2[:, None, :] == best_d2[:, :, None])
                    & (jidx[None, None, :] < jidx[None, :, None])
                )
                loses = np.any(same & better, axis=2)
                a = np.where(loses, _REJECT, a)
                matched &= ~loses
                assoc[:, j_unk] = a
                # loop closures: pairs that plain gating would have made new landmarks
                mi, mq = np.nonzero(matched)
                bl = best[mi, mq]
                Hb = Hf[mi, bl]  # true S = inflated S - dvar Hf Hf^T
                HH = _mm(Hb, np.swapaxes(Hb, -1, -2))
                St = S[cand[mi, mq, bl]] - dvar[mi, bl][:, None, None] * HH
                Sti, _ = _inv2(St)
                vv = v[mi, mq, bl]
                closing = np.zeros((n, ku), dtype=bool)
                closing[mi, mq] = np.einsum("...i,...ij,...j->...", vv, Sti, vv) > cfg.augment_gate
                bgap = np.take_along_axis(gap, np.where(matched, best, 0), axis=1)
                loop_gap = np.where(closing, bgap, 0.0).max(axis=1)  # (n,)
                nis[:, j_unk] = np.where(matched, best_d2, np.nan)
                loglik[:, j_unk] = np.where(matched, best_ll, p0[None, :])
            else:
                assoc[:, j_unk] = _NEW
                loglik[:, j_unk] = p0[None, :]

        # ---------------------------------------------------------- weights, resampling
        # The observations of one scan share the particle's pose uncertainty Pv, so their
        # joint predictive density is one Gaussian with S = Hv Pv Hv^T + blockdiag(Hf Pf Hf^T + R)
        # (as in Bailey's later compute_weight), not the product of the per-observation ones.
        valid = assoc >= 0
        if np.any(loop_gap > 0.0):
            # A particle closing a loop is uncertain about its pose relative to the old map by
            # the drift allowance: position variance sigma^2 (gap), heading variance
            # 3 sigma^2 / gap^2 (a heading random walk integrated over the gap).
            pvar = cfg.loop_drift_100m**2 * (loop_gap / 100.0) ** 3
            hvar = 3.0 * pvar / np.maximum(loop_gap, 1.0) ** 2
            Pv = Pv.copy()
            Pv[:, 0, 0] += pvar
            Pv[:, 1, 1] += pvar
            Pv[:, 2, 2] += hvar
        logw = logw + np.where(valid, 0.0, loglik).sum(axis=1)
        resampled = False
        if cfg.weighting == "predictive":
            if valid.any():
                logw = logw + self._joint_log_likelihood(xv, Pv, m, P, Z, R, assoc, valid)
            logw -= logw.max()  # keep in range; the normalization is implicit
            idx = self._resample_index(logw)
            if idx is not None:
                xv, Pv, m, P, exists, count = (
                    xv[idx],
                    Pv[idx],
                    m[idx],
                    P[idx],
                    exists[idx],
                    count[idx],
                )
                assoc, nis, mapped, updated = assoc[idx], nis[idx], mapped[idx], updated[idx]
                xv_rb, Pv_rb = xv_rb[idx], Pv_rb[idx]
                logw = np.zeros(n)
                resampled = True
        xv_prior, Pv_prior = xv.copy(), Pv.copy()

        # ---------------------------------------------------------- proposal (sequential EKF)
        ar = np.arange(n)
        closers = np.nonzero((loop_gap > 0.0) & np.any(assoc >= 0, axis=1))[0]
        if closers.size:
            x0c, P0c = xv[closers].copy(), Pv[closers].copy()
        for j in range(k):
            sel = ar[assoc[:, j] >= 0]
            if sel.size == 0:
                continue
            sl = assoc[sel, j]
            zhat, Hv, Hf = observation_model(xv[sel], m[sel, sl])
            S = _quad(Hv, Pv[sel]) + _quad(Hf, P[sel, sl]) + R[j]
            Si, _ = _inv2(S)
            K = Pv[sel] @ np.swapaxes(Hv, -1, -2) @ Si  # (s, 3, 2)
            v = Z[j] - zhat
            v[:, 1] = _wrap(v[:, 1])
            xv[sel] = xv[sel] + np.einsum("sij,sj->si", K, v)
            xv[sel, 2] = _wrap(xv[sel, 2])
            Pv[sel] = _sym(Pv[sel] - K @ S @ np.swapaxes(K, -1, -2))
        if closers.size:
            # A loop closure moves the pose by metres: iterate the (joint) update, relinearizing
            # at the latest mean (Gauss-Newton / iterated EKF), for the closing particles only.
            xv[closers], Pv[closers] = self._iterated_pose_update(
                x0c, P0c, xv[closers], m[closers], P[closers], Z, R, assoc[closers]
            )

        # ---------------------------------------------------------- sample the pose
        draw = np.any(assoc != _REJECT, axis=1)
        if draw.any():
            xv_rb[draw], Pv_rb[draw] = xv[draw], Pv[draw]
            lam, V = np.linalg.eigh(Pv[draw])
            L = V * np.sqrt(np.maximum(lam, 0.0))[:, None, :]
            eps = self.rng.standard_normal((int(draw.sum()), 3))
            xv[draw] = xv[draw] + np.einsum("sij,sj->si", L, eps)
            xv[draw, 2] = _wrap(xv[draw, 2])
            if cfg.weighting == "proposal" and valid.any():
                # Bailey 2004: w *= p(z | xs, m) p(xs | x_{k-1}) / q(xs), one-sample estimate
                logw = logw + self._sample_log_weight(
                    xv, xv_rb, Pv_rb, xv_prior, Pv_prior, m, P, Z, R, assoc
                )
            Pv[draw] = 0.0

        # ---------------------------------------------------------- landmark EKF updates
        pi, pj = np.nonzero(assoc >= 0)
        if pi.size:
            sl = assoc[pi, pj]
            zhat, _, Hf = observation_model(xv[pi], m[pi, sl])
            Pf = P[pi, sl]
            S = _quad(Hf, Pf) + R[pj]
            Si, _ = _inv2(S)
            K = Pf @ np.swapaxes(Hf, -1, -2) @ Si
            v = Z[pj] - zhat
            v[:, 1] = _wrap(v[:, 1])
            m[pi, sl] = m[pi, sl] + np.einsum("sij,sj->si", K, v)
            IKH = np.eye(2) - K @ Hf  # Joseph form keeps the 2x2 covariances PSD
            P[pi, sl] = _sym(_quad(IKH, Pf) + _quad(K, R[pj]))
            updated[pi, sl] = self._path

        # ---------------------------------------------------------- augmentation
        newmask = assoc == _NEW
        pi, pj = np.nonzero(newmask)
        if pi.size:
            slots = np.empty(pi.size, dtype=np.intp)
            kn = ~unknown[pj]
            slots[kn] = [label_slot[labels[j]] for j in pj[kn]]
            # unknown: per particle, the next free slots after every known one
            first_free = np.maximum(count, base + n_known_new)
            unk_new = newmask & unknown[None, :]
            offs = np.cumsum(unk_new, axis=1) - 1
            slots[~kn] = (first_free[:, None] + offs)[pi[~kn], pj[~kn]]
            ang = xv[pi, 2] + Z[pj, 1]
            r = Z[pj, 0]
            c, s = np.cos(ang), np.sin(ang)
            m[pi, slots] = xv[pi, :2] + r[:, None] * np.stack([c, s], axis=1)
            Gz = np.empty((pi.size, 2, 2))
            Gz[:, 0, 0], Gz[:, 0, 1] = c, -r * s
            Gz[:, 1, 0], Gz[:, 1, 1] = s, r * c
            P[pi, slots] = _sym(_quad(Gz, R[pj]))
            exists[pi, slots] = True
            mapped[pi, slots] = updated[pi, slots] = self._path
            if n_known_new:
                count = np.maximum(count, base + n_known_new)
            count = np.maximum(count, first_free + unk_new.sum(axis=1))
            assoc[pi, pj] = slots

        if cfg.weighting == "proposal":
            logw -= logw.max()
            idx = self._resample_index(logw) if valid.any() else None
            if idx is not None:  # after the updates, as Bailey's 2004 fastslam2_sim
                xv, Pv, m, P, exists, count = (
                    xv[idx],
                    Pv[idx],
                    m[idx],
                    P[idx],
                    exists[idx],
                    count[idx],
                )
                assoc, nis, mapped, updated = assoc[idx], nis[idx], mapped[idx], updated[idx]
                xv_rb, Pv_rb, newmask = xv_rb[idx], Pv_rb[idx], newmask[idx]
                logw = np.zeros(n)
                resampled = True

        # ---------------------------------------------------------- commit
        self._xv, self._Pv, self._logw = xv, Pv, logw
        self._m, self._P, self._exists, self._count = m, P, exists, count
        self._mapped, self._updated = mapped, updated
        self._xv_rb, self._Pv_rb = xv_rb, Pv_rb
        for lab in new_labels:
            self._slot_label[label_slot[lab]] = lab
        self._label_slot = label_slot
        self.n_resamples += int(resampled)
        b = int(np.argmax(logw))
        return UpdateResult(associations=assoc[b].copy(), new=newmask[b].copy(), nis=nis[b].copy())

    def _resample_index(self, logw: np.ndarray) -> np.ndarray | None:
        """Resampling indexes when ``N_eff < resample_threshold * N``, else None."""
        w, _ = normalize_log_weights(logw)
        if 1.0 / np.sum(w * w) < self._threshold * w.size:
            return self._resample(w, self.rng)
        return None

    @staticmethod
    def _sample_log_weight(xs, xq, Pq, x0, P0, m, P, Z, R, assoc) -> np.ndarray:
        """(n,) ``log p(z | xs, m) + log N(xs; x0, P0) - log N(xs; xq, Pq)`` for the sampled
        poses ``xs`` (n, 3) drawn from the proposal ``N(xq, Pq)`` with the prior ``N(x0, P0)``
        (Bailey's 2004 ``sample_proposal``: per-observation ``S = Hf Pf Hf^T + R`` at ``xs``).
        Particles without an associated observation get 0 (``xq = x0``, ``Pq = P0``)."""
        valid = assoc >= 0
        n = assoc.shape[0]
        rows = np.arange(n)[:, None]
        sl = np.where(valid, assoc, 0)
        zhat, _, Hf = observation_model(xs[:, None, :], m[rows, sl])
        v = Z[None] - zhat
        v[..., 1] = _wrap(v[..., 1])
        Si, det = _inv2(_quad(Hf, P[rows, sl]) + R[None])
        ll = -0.5 * np.einsum("...i,...ij,...j->...", v, Si, v) - 0.5 * np.log(det) - _LOG_2PI
        like = np.where(valid, ll, 0.0).sum(axis=1)

        def log_gauss3(d, C):
            d = d.copy()
            d[:, 2] = _wrap(d[:, 2])
            C = _sym(C) + 1e-12 * np.eye(3)  # a pose covariance may be singular (P0 = 0)
            _, logdet = np.linalg.slogdet(C)
            q = np.einsum("ni,ni->n", d, np.linalg.solve(C, d[..., None])[..., 0])
            return -0.5 * q - 0.5 * logdet

        ratio = log_gauss3(xs - x0, P0) - log_gauss3(xs - xq, Pq)
        return np.where(valid.any(axis=1), like + ratio, 0.0)

    @staticmethod
    def _joint_log_likelihood(xv, Pv, m, P, Z, R, assoc, valid) -> np.ndarray:
        """(n,) log N(z_valid; zhat, S) per particle over its associated observations."""
        n, k = assoc.shape
        rows = np.arange(n)[:, None]
        sl = np.where(valid, assoc, 0)
        zhat, Hv, Hf = observation_model(xv[:, None, :], m[rows, sl])  # (n, k, ...)
        v = Z[None] - zhat
        v[..., 1] = _wrap(v[..., 1])
        v = np.where(valid[..., None], v, 0.0)
        Hv = np.where(valid[..., None, None], Hv, 0.0)
        Sf = np.where(valid[..., None, None], _quad(Hf, P[rows, sl]) + R[None], np.eye(2))
        Hvj = Hv.reshape(n, 2 * k, 3)
        S = Hvj @ Pv @ np.swapaxes(Hvj, 1, 2)
        S4 = S.reshape(n, k, 2, k, 2)
        idx = np.arange(k)
        S4[:, idx, :, idx, :] += np.moveaxis(Sf, 1, 0)  # advanced indices first: (k, n, 2, 2)
        S = _sym(S4.reshape(n, 2 * k, 2 * k))
        vj = v.reshape(n, 2 * k)
        _, logdet = np.linalg.slogdet(S)
        q = np.einsum("ni,ni->n", vj, np.linalg.solve(S, vj[..., None])[..., 0])
        return -0.5 * q - 0.5 * logdet - valid.sum(axis=1) * _LOG_2PI

    @staticmethod
    def _iterated_pose_update(x0, P0, x, m, P, Z, R, assoc, iterations: int = 5):
        """Iterated EKF of the pose prior ``N(x0, P0)`` (c, 3) with each particle's associated
        observations jointly (landmark uncertainty in the measurement noise, as the
        proposal), starting the linearization at ``x``; returns the mean and covariance."""
        c, k = assoc.shape
        valid = assoc >= 0
        rows = np.arange(c)[:, None]
        sl = np.where(valid, assoc, 0)
        mf, Pf = m[rows, sl], P[rows, sl]
        for _ in range(iterations):
            zhat, Hv, Hf = observation_model(x[:, None, :], mf)  # (c, k, ...)
            v = Z[None] - zhat
            v[..., 1] = _wrap(v[..., 1])
            dx = x - x0
            dx[:, 2] = _wrap(dx[:, 2])
            v = v + np.einsum("ckij,cj->cki", Hv, dx)  # z - h(x) - H (x0 - x)
            v = np.where(valid[..., None], v, 0.0)
            Hv = np.where(valid[..., None, None], Hv, 0.0)
            Sf = np.where(valid[..., None, None], _quad(Hf, Pf) + R[None], np.eye(2))
            Hj = Hv.reshape(c, 2 * k, 3)
            S = Hj @ P0 @ np.swapaxes(Hj, 1, 2)
            S4 = S.reshape(c, k, 2, k, 2)
            idx = np.arange(k)
            S4[:, idx, :, idx, :] += np.moveaxis(Sf, 1, 0)
            S = _sym(S4.reshape(c, 2 * k, 2 * k))
            PHt = P0 @ np.swapaxes(Hj, 1, 2)  # (c, 3, 2k)
            K = np.swapaxes(np.linalg.solve(S, np.swapaxes(PHt, 1, 2)), 1, 2)
            x_new = x0 + np.einsum("cij,cj->ci", K, v.reshape(c, 2 * k))
            x_new[:, 2] = _wrap(x_new[:, 2])
            step = np.abs(x_new - x).max()
            x = x_new
            if step < 1e-6:
                break
        Pn = _sym(P0 - K @ S @ np.swapaxes(K, 1, 2))
        return x, Pn

    @staticmethod
    def _plain_nis_min(shape, pi, pq, pl, S, dvar, Hf, v) -> np.ndarray:
        """(n, ku) smallest NIS of each observation over the candidate pairs ``(pi, pq, pl)``
        without the loop-closure allowance (``S`` of the pairs less ``dvar Hf Hf^T``); inf
        where no candidate (the allowance only lowers the NIS, so a pair that is not a
        candidate with it is beyond the augment gate without it)."""
        d2 = np.full(shape, np.inf)
        if pi.size:
            Hb = Hf[pi, pl]
            St = S - dvar[pi, pl][:, None, None] * _mm(Hb, np.swapaxes(Hb, -1, -2))
            Sti, _ = _inv2(St)
            vv = v[pi, pq, pl]
            d2[pi, pq, pl] = np.einsum("...i,...ij,...j->...", vv, Sti, vv)
        return d2.min(axis=2)

    def _drift_gap(self, mapped, updated, ex) -> np.ndarray:
        """(n, L) path length (m) over which each particle's pose may have drifted relative to
        each landmark: the particle is anchored to the landmarks it updated within
        ``loop_anchor_window_m`` of path before its last update (their mapping path lengths span ``[lo, hi]``); a
        landmark mapped at ``s`` is ``max(|s - lo|, |s - hi|)`` of path away from that anchor
        (the dead reckoning since the last update is already in the particle's ``Pv``). During a loop closure the anchors span
        both ends of the loop, so the gate stays wide until the particle has re-localized."""
        last = np.where(ex, updated, -np.inf).max(axis=1)  # (n,)
        last = np.where(np.isfinite(last), last, 0.0)
        recent = ex & (updated >= last[:, None] - self.config.loop_anchor_window_m)
        lo = np.where(recent, mapped, np.inf).min(axis=1)
        hi = np.where(recent, mapped, -np.inf).max(axis=1)
        lo = np.where(np.isfinite(lo), lo, 0.0)
        hi = np.where(np.isfinite(hi), hi, 0.0)
        span = np.maximum(np.abs(mapped - lo[:, None]), np.abs(mapped - hi[:, None]))
        return span

    def _p0(self, R: np.ndarray) -> np.ndarray:
        """Log-likelihood given to a new or discarded observation, (k,)."""
        if self.config.new_landmark_log_likelihood is not None:
            return np.full(R.shape[0], float(self.config.new_landmark_log_likelihood))
        _, det = _inv2(R)
        return -0.5 * self.config.augment_gate - 0.5 * np.log(det) - _LOG_2PI

    # ------------------------------------------------------------------ estimates
    def best_particle(self) -> int:
        """Index of the highest-weight particle."""
        return int(np.argmax(self._logw))

    def pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Rao-Blackwellized mixture mean and covariance of the current pose.

        Each particle contributes the Gaussian its pose was last sampled from (the
        FastSLAM 2.0 proposal ``N(mu_i, Pv_i)``, i.e. ``p(x_k | x_{0:k-1,i}, z_{1:k})``),
        propagated by the odometry since: ``x = sum w_i mu_i`` (circular mean for phi),
        ``P = sum w_i (Pv_i + d_i d_i^T)`` with ``d_i = mu_i - x`` (heading wrapped).
        Unlike the spread of the samples alone this stays positive definite when one
        particle carries all the weight.
        """
        w = self.weights
        mu, Pv = self._xv_rb, self._Pv_rb
        x = np.empty(3)
        x[:2] = w @ mu[:, :2]
        x[2] = np.arctan2(w @ np.sin(mu[:, 2]), w @ np.cos(mu[:, 2]))
        d = mu - x
        d[:, 2] = _wrap(d[:, 2])
        Pm = np.einsum("i,ij,ik->jk", w, d, d) + np.einsum("i,ijk->jk", w, Pv)
        return x, _sym(Pm)

    def _slots(self) -> np.ndarray:
        if self.config.map_estimate == "best":
            return np.nonzero(self._exists[self.best_particle()])[0]
        return np.nonzero(self._exists.any(axis=0))[0]

    def landmarks(self) -> tuple[np.ndarray, np.ndarray]:
        """Landmark means (n, 2) m and covariances (n, 2, 2) m², world frame.

        ``map_estimate="best"``: the highest-weight particle's landmarks, ordered by slot.
        ``"weighted"``: per slot, the weighted mixture over the particles holding it.
        """
        slots = self._slots()
        if self.config.map_estimate == "best":
            b = self.best_particle()
            return self._m[b, slots].copy(), self._P[b, slots].copy()
        w = self.weights
        ww = w[:, None] * self._exists[:, slots]  # (n, L)
        ww = ww / ww.sum(axis=0, keepdims=True)
        mu = np.einsum("il,ild->ld", ww, self._m[:, slots])
        d = self._m[:, slots] - mu[None]
        cov = np.einsum("il,ilj,ilk->ljk", ww, d, d) + np.einsum(
            "il,iljk->ljk", ww, self._P[:, slots]
        )
        return mu, _sym(cov)

    def landmark_labels(self) -> np.ndarray:
        """(n,) int labels of the landmarks returned by :meth:`landmarks` (-1: unlabelled)."""
        return self._slot_label[self._slots()].copy()

    @property
    def labels(self) -> np.ndarray:
        """Same as :meth:`landmark_labels` (the attribute name the AEKF uses)."""
        return self.landmark_labels()

    def landmark_slots(self) -> np.ndarray:
        """(n,) slot indices of the landmarks returned by :meth:`landmarks`."""
        return self._slots()
