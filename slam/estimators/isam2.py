"""Graph-SLAM baseline: incremental smoothing and mapping (iSAM2, Kaess et al. 2012) via GTSAM.

The reference thesis names graph-based SLAM as future work; this is that comparison. It
needs the optional extra ``undersea[baselines]`` (``pip install 'undersea[baselines]'``,
which installs ``gtsam``).

Graph: pose nodes ``x0, x1, …`` (``gtsam.Pose2``, world frame ``[x m, y m, phi rad]``) and
landmark nodes ``l0, l1, …`` (``gtsam.Point2``, m). A prior factor fixes ``x0`` (``x0``,
``P0``). Odometry increments between two nodes are composed with the thesis's motion model
(eq. 5.21, which is exactly ``Pose2.compose``) and their covariance is propagated to first
order; a ``BetweenFactorPose2`` joins consecutive nodes. By default a pose node is created
at each ``update`` that carries observations (a key frame per observation scan, the usual
practice: the odometry between scans is a single composed factor). With
``node_every_predict=True`` every ``predict`` creates a node, as a per-odometry graph.
(GTSAM measures the odometry residual in the Pose2 tangent space; for the small increments
here it equals ``[dx, dy, dphi]`` to first order.)

Each observation becomes a ``BearingRangeFactor2D`` (GTSAM orders the measurement as
``[bearing, range]``, so ``R`` is permuted). Data association is the same gated scheme as
the filters: known ``label`` when given, otherwise maximum likelihood among landmarks
whose normalized innovation squared is below ``reject_gate``, a new landmark above
``augment_gate``, discarded between them. The NIS uses covariances from iSAM2: first
``S = Hv Pv Hv^T + Hf Pf Hf^T + R`` from cached marginals (cross-covariance neglected) for
every landmark, then, for the candidates that pass a loose ``candidate_gate`` on it, the
exact ``S`` from the joint marginal of the predicted pose and the landmark
(``ISAM2.jointMarginalCovariance``). Landmark marginals are cached, refreshed for the
landmarks just observed or tested after every update and for all of them every
``marginal_refresh_every`` updates and whenever :meth:`landmarks` is called.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from slam.estimators.base import UpdateResult
from slam.estimators.fastslam2 import observation_model, validate_covariance
from slam.estimators.rb_model import inv2, symmetrize, wrap
from slam.types import Odometry, RangeBearing

__all__ = ["ISAM2SLAM"]

_LOG_2PI = float(np.log(2.0 * np.pi))


def _import_gtsam():
    try:
        import gtsam
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError(
            "the 'isam2' estimator needs GTSAM, which is the optional extra "
            "undersea[baselines]: pip install 'undersea[baselines]' (or pip install gtsam)"
        ) from exc
    return gtsam


def _compose_jacobians(phi: float, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians of ``p ⊕ d`` (thesis eq. 5.21) with respect to ``p`` and ``d``."""
    c, s = np.cos(phi), np.sin(phi)
    Gv = np.array([[1.0, 0.0, -d[0] * s - d[1] * c], [0.0, 1.0, d[0] * c - d[1] * s], [0, 0, 1]])
    Gu = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return Gv, Gu


def _compose(p: np.ndarray, d: np.ndarray) -> np.ndarray:
    c, s = np.cos(p[2]), np.sin(p[2])
    return np.array(
        [p[0] + d[0] * c - d[1] * s, p[1] + d[0] * s + d[1] * c, float(wrap(p[2] + d[2]))]
    )


class ISAM2SLAM:
    """iSAM2 landmark SLAM with range-bearing factors; implements ``SlamEstimator``.

    Parameters
    ----------
    reject_gate, augment_gate : NIS gates of the data association (4.0, 25.0).
    x0 : (3,) start pose (default zeros); P0 : (3, 3) its covariance (default 0, floored
        at ``min_variance`` for the prior factor).
    association : "ml" (default: labels ignored, gated maximum likelihood), "known" (every
        observation's ``label`` is its landmark identity) or "auto" (label when present).
    node_every_predict : create a pose node per odometry increment instead of per scan.
    joint_marginals : compute the innovation covariance of candidate pairs (approximate
        NIS below ``candidate_gate``) from the joint marginal of pose and landmark, with
        their cross-covariance, instead of the independent-marginal approximation.
    relinearize_threshold, relinearize_skip : ``gtsam.ISAM2Params`` settings: relinearize
        variables whose delta exceeds 0.1 (GTSAM's default), checked at every update (GTSAM's
        default is every 10th). Marginals come from the linearization point, so a stale one
        at loop closure gave over-confident pose covariances and duplicated landmarks on the
        dense loop (seeds 1 and 8 of the runner); checking every update costs ~0-30 % more.
    factorization : "QR" (default) or "CHOLESKY" for iSAM2's elimination. Cholesky squares
        the condition number: on the line map (25 m lateral drift against a 0.1 mm anchor)
        it reported an indeterminate system; QR solves it at ~20 % more time.
    extra_iterations : additional ``ISAM2.update()`` calls after each update (more
        relinearization after loop closures; 0 is the standard one step per update).
    marginal_refresh_every : refresh all cached landmark marginals every this many updates.
    min_variance : absolute eigenvalue floor (m² / rad²) of the odometry and measurement
        covariances handed to GTSAM (a singular covariance has no square-root information).
    relative_floor : odometry covariances are also floored at this fraction of their
        largest eigenvalue (see ``_noise``).
    prior_min_variance : eigenvalue floor of the prior on ``x0`` (P0 = 0 by default:
        σ = 0.1 mm / 0.1 mrad instead of an exact anchor).
    rng, seed, **_ : accepted and ignored (the estimator is deterministic) so the factory
        can pass the same keywords to every estimator.
    """

    name = "isam2"

    def __init__(
        self,
        reject_gate: float = 4.0,
        augment_gate: float = 25.0,
        *,
        x0=None,
        P0=None,
        association: str = "ml",
        node_every_predict: bool = False,
        joint_marginals: bool = True,
        factorization: str = "QR",
        candidate_gate: float = 100.0,
        relinearize_threshold: float = 0.1,
        relinearize_skip: int = 1,
        extra_iterations: int = 0,
        marginal_refresh_every: int = 20,
        min_variance: float = 1e-9,
        relative_floor: float = 1e-3,
        prior_min_variance: float = 1e-8,
        rng: np.random.Generator | None = None,
        seed: int | None = None,
    ) -> None:
        gtsam = _import_gtsam()
        self._g = gtsam
        if not (np.isfinite(reject_gate) and reject_gate > 0):
            raise ValueError(f"reject_gate must be finite and > 0, got {reject_gate!r}")
        if not (np.isfinite(augment_gate) and augment_gate >= reject_gate):
            raise ValueError(
                f"augment_gate must be finite and >= reject_gate ({reject_gate}), got {augment_gate!r}"
            )
        if factorization not in ("QR", "CHOLESKY"):
            raise ValueError(f"factorization must be 'QR' or 'CHOLESKY', got {factorization!r}")
        if association not in ("ml", "known", "auto"):
            raise ValueError(f"association must be 'ml', 'known' or 'auto', got {association!r}")
        self.association = association
        if not (np.isfinite(relinearize_threshold) and relinearize_threshold > 0):
            raise ValueError(f"relinearize_threshold must be > 0, got {relinearize_threshold!r}")
        for nm, val, lo in (
            ("relinearize_skip", relinearize_skip, 1),
            ("extra_iterations", extra_iterations, 0),
            ("marginal_refresh_every", marginal_refresh_every, 1),
        ):
            if not (isinstance(val, int | np.integer) and val >= lo):
                raise ValueError(f"{nm} must be an integer >= {lo}, got {val!r}")
        if not (np.isfinite(min_variance) and min_variance > 0):
            raise ValueError(f"min_variance must be finite and > 0, got {min_variance!r}")
        self.reject_gate = float(reject_gate)
        self.augment_gate = float(augment_gate)
        self.node_every_predict = bool(node_every_predict)
        self.joint_marginals = bool(joint_marginals)
        if not (np.isfinite(candidate_gate) and candidate_gate >= augment_gate):
            raise ValueError(
                f"candidate_gate must be finite and >= augment_gate ({augment_gate}), got {candidate_gate!r}"
            )
        self.candidate_gate = float(candidate_gate)
        self.extra_iterations = int(extra_iterations)
        self.marginal_refresh_every = int(marginal_refresh_every)
        self.min_variance = float(min_variance)
        if not (np.isfinite(relative_floor) and 0 <= relative_floor < 1):
            raise ValueError(f"relative_floor must be in [0, 1), got {relative_floor!r}")
        if not (np.isfinite(prior_min_variance) and prior_min_variance > 0):
            raise ValueError(
                f"prior_min_variance must be finite and > 0, got {prior_min_variance!r}"
            )
        self.relative_floor = float(relative_floor)

        x0 = np.zeros(3) if x0 is None else np.asarray(x0, dtype=float).reshape(-1)
        if x0.shape != (3,) or not np.all(np.isfinite(x0)):
            raise ValueError(f"x0 must be a finite (3,) pose [x, y, phi], got {x0!r}")
        P0 = np.zeros((3, 3)) if P0 is None else np.asarray(P0, dtype=float)
        if P0.shape != (3, 3):
            raise ValueError(f"P0 must have shape (3, 3), got {P0.shape}")
        validate_covariance("P0", P0, positive_definite=False)

        params = gtsam.ISAM2Params()
        params.setRelinearizeThreshold(float(relinearize_threshold))
        params.relinearizeSkip = int(relinearize_skip)
        params.setFactorization(factorization)
        self._isam = gtsam.ISAM2(params)

        self._node = 0
        self._pose_est = x0.copy()
        self._pose_est[2] = wrap(x0[2])
        T = self._local_to_world(self._pose_est[2])
        P0_local = T.T @ symmetrize(P0) @ T
        graph = gtsam.NonlinearFactorGraph()
        graph.add(
            gtsam.PriorFactorPose2(
                self._xkey(0),
                gtsam.Pose2(*self._pose_est),
                self._noise(P0_local, floor=float(prior_min_variance)),
            )
        )
        values = gtsam.Values()
        values.insert(self._xkey(0), gtsam.Pose2(*self._pose_est))
        self._isam.update(graph, values)
        self._pose_cov_world = symmetrize(P0)

        self._pending = np.zeros(3)  # composed increment since the last node (its frame)
        self._pending_cov = np.zeros((3, 3))
        self._has_pending = False

        self._lm_mean = np.zeros((0, 2))
        self._lm_cov = np.zeros((0, 2, 2))
        self._lm_label: list[int] = []
        self._label_index: dict[int, int] = {}
        self._n_updates = 0
        self._cov_stale = False

    # ------------------------------------------------------------------ helpers
    def _xkey(self, i: int) -> int:
        return self._g.symbol("x", i)

    def _lkey(self, j: int) -> int:
        return self._g.symbol("l", j)

    @staticmethod
    def _local_to_world(phi: float) -> np.ndarray:
        c, s = np.cos(phi), np.sin(phi)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    def _noise(self, cov: np.ndarray, floor: float | None = None, relative: bool = False):
        """GTSAM Gaussian noise model with eigenvalues floored at ``min_variance`` (or
        ``floor``) and, for odometry (``relative=True``), at ``relative_floor`` times the
        largest one: a rank-deficient odometry covariance (two control noises driving three
        increments) otherwise gives information 1e8 times larger than elsewhere and iSAM2's
        Cholesky reports an indeterminate system. Measurement covariances are validated
        positive definite and only get the absolute floor."""
        lam, V = np.linalg.eigh(symmetrize(np.asarray(cov, dtype=float)))
        fl = self.min_variance if floor is None else floor
        if relative:
            fl = max(fl, self.relative_floor * lam.max())
        c = symmetrize((V * np.maximum(lam, fl)) @ V.T)
        return self._g.noiseModel.Gaussian.Covariance(c)

    @property
    def n_pose_nodes(self) -> int:
        return self._node + 1

    @property
    def n_landmarks(self) -> int:
        return self._lm_mean.shape[0]

    # ------------------------------------------------------------------ predict
    def predict(self, odometry: Odometry) -> None:
        """Compose one body-frame increment onto the pending odometry since the last node."""
        if not isinstance(odometry, Odometry):
            raise ValueError(
                f"odometry must be a slam.types.Odometry, got {type(odometry).__name__}"
            )
        validate_covariance("Odometry.cov", odometry.cov, positive_definite=False)
        Gv, Gu = _compose_jacobians(self._pending[2], odometry.delta)
        self._pending_cov = symmetrize(Gv @ self._pending_cov @ Gv.T + Gu @ symmetrize(odometry.cov) @ Gu.T)
        self._pending = _compose(self._pending, odometry.delta)
        self._has_pending = True
        if self.node_every_predict:
            g = self._g
            graph, values = g.NonlinearFactorGraph(), g.Values()
            self._add_node(graph, values)
            self._isam.update(graph, values)
            self._refresh(observed=())

    def _predicted_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World-frame pose and covariance of the last node composed with the pending odometry."""
        if not self._has_pending:
            return self._pose_est.copy(), self._pose_cov_world.copy()
        Gv, Gu = _compose_jacobians(self._pose_est[2], self._pending)
        x = _compose(self._pose_est, self._pending)
        P = Gv @ self._pose_cov_world @ Gv.T + Gu @ self._pending_cov @ Gu.T
        return x, symmetrize(P)

    def _add_node(self, graph, values) -> None:
        g = self._g
        if not self._has_pending:
            return
        x_new, _ = self._predicted_pose()
        i = self._node
        # GTSAM's residual is a right perturbation at the END of the increment
        # (actual = measured ∘ Exp(xi)): rotate the start-frame covariance into that frame.
        T = self._local_to_world(self._pending[2])
        cov_xi = T.T @ self._pending_cov @ T
        graph.add(
            g.BetweenFactorPose2(
                self._xkey(i),
                self._xkey(i + 1),
                g.Pose2(*self._pending),
                self._noise(cov_xi, relative=True),
            )
        )
        values.insert(self._xkey(i + 1), g.Pose2(*x_new))
        self._node = i + 1
        self._pose_est = x_new
        self._pending = np.zeros(3)
        self._pending_cov = np.zeros((3, 3))
        self._has_pending = False

    # ------------------------------------------------------------------ update
    def update(self, observations: Sequence[RangeBearing]) -> UpdateResult:
        """Associate, add a pose node with its factors, and run one iSAM2 step."""
        if isinstance(observations, RangeBearing):
            raise ValueError("observations must be a sequence of RangeBearing, got a single one")
        obs = list(observations)
        for i, o in enumerate(obs):
            if not isinstance(o, RangeBearing):
                raise ValueError(
                    f"observations[{i}] must be a slam.types.RangeBearing, got {type(o).__name__}"
                )
            validate_covariance(f"observations[{i}].R", o.R, positive_definite=True)
            if o.label is not None and not isinstance(o.label, int | np.integer):
                raise ValueError(f"observations[{i}].label must be an int or None, got {o.label!r}")
        k = len(obs)
        if k == 0:
            return UpdateResult(np.zeros(0, dtype=np.intp), np.zeros(0, dtype=bool), np.zeros(0))
        labels = [None if o.label is None else int(o.label) for o in obs]
        if self.association == "ml":
            labels = [None] * k
        elif self.association == "known" and None in labels:
            raise ValueError(
                "association='known' needs a label on every observation; "
                f"observations[{labels.index(None)}].label is None"
            )
        Z = np.array([o.z for o in obs])
        R = np.array([symmetrize(o.R) for o in obs])
        xp, Pv = self._predicted_pose()

        assoc, new, nis = self._associate(xp, Pv, Z, R, labels)

        g = self._g
        graph, values = g.NonlinearFactorGraph(), g.Values()
        self._add_node(graph, values)
        xkey = self._xkey(self._node)
        n_old = self.n_landmarks
        new_means, new_labels = [], []
        for j in range(k):
            if assoc[j] == -1:
                continue
            if new[j]:
                lm = assoc[j] = n_old + len(new_means)
                ang = xp[2] + Z[j, 1]
                pt = xp[:2] + Z[j, 0] * np.array([np.cos(ang), np.sin(ang)])
                new_means.append(pt)
                new_labels.append(-1 if labels[j] is None else labels[j])
                values.insert(self._lkey(lm), g.Point2(*pt))
            Rbr = R[j][::-1, ::-1]  # [range, bearing] -> GTSAM's [bearing, range]
            graph.add(
                g.BearingRangeFactor2D(
                    xkey,
                    self._lkey(int(assoc[j])),
                    g.Rot2.fromAngle(float(Z[j, 1])),
                    float(Z[j, 0]),
                    self._noise(Rbr),
                )
            )
        self._isam.update(graph, values)
        for _ in range(self.extra_iterations):
            self._isam.update()
        if new_means:
            self._lm_mean = np.vstack([self._lm_mean, np.array(new_means)])
            self._lm_cov = np.concatenate([self._lm_cov, np.zeros((len(new_means), 2, 2))])
            for lab in new_labels:
                if lab != -1:
                    self._label_index[lab] = len(self._lm_label)
                self._lm_label.append(lab)
        self._n_updates += 1
        observed = np.unique(assoc[assoc >= 0])
        self._refresh(observed=observed)
        return UpdateResult(associations=assoc, new=new, nis=nis)

    def _associate(self, xp, Pv, Z, R, labels):
        k = Z.shape[0]
        assoc = np.full(k, -1, dtype=np.intp)
        new = np.zeros(k, dtype=bool)
        nis = np.full(k, np.nan)
        n = self.n_landmarks
        if n:
            zhat, Hv, Hf = observation_model(xp[None], self._lm_mean)
            S0 = Hv @ Pv @ np.swapaxes(Hv, -1, -2) + Hf @ self._lm_cov @ np.swapaxes(Hf, -1, -2)
            S = S0[None] + R[:, None]  # (k, n, 2, 2)
            v = Z[:, None] - zhat[None]
            v[..., 1] = wrap(v[..., 1])
            Si, det = inv2(S)
            d2 = np.einsum("...i,...ij,...j->...", v, Si, v)
            # Candidates (loose gate on the approximate NIS): exact S from the joint marginal
            # of the pose and the landmark, cross-covariance included.
            if self.joint_marginals:
                cand = np.nonzero(np.any(d2 < self.candidate_gate, axis=0))[0]
                if cand.size:
                    S_c = self._joint_innovation_cov(cand, Hv[cand], Hf[cand], Pv)
                    S[:, cand] = S_c[None] + R[:, None]
                    Si, det = inv2(S)
                    d2 = np.einsum("...i,...ij,...j->...", v, Si, v)
            ll = -0.5 * d2 - 0.5 * np.log(det) - _LOG_2PI
        else:
            d2 = np.full((k, 0), np.inf)
            ll = d2
        taken: set[int] = set()
        seen_labels: set[int] = set()
        # known labels first, then unlabelled observations by increasing best NIS (greedy)
        order = sorted(
            range(k),
            key=lambda j: (labels[j] is None, float(d2[j].min()) if n else np.inf),
        )
        for j in order:
            lab = labels[j]
            if lab is not None:
                lab = int(lab)
                if lab in seen_labels:
                    continue  # the same label twice in one scan: keep the first
                seen_labels.add(lab)
                if lab in self._label_index:
                    assoc[j] = self._label_index[lab]
                    nis[j] = d2[j, assoc[j]]
                    taken.add(int(assoc[j]))
                else:
                    assoc[j], new[j] = -2, True
                continue
            if n:
                cand = (d2[j] < self.reject_gate) & ~np.isin(np.arange(n), list(taken))
                if cand.any():
                    best = int(np.argmax(np.where(cand, ll[j], -np.inf)))
                    assoc[j], nis[j] = best, d2[j, best]
                    taken.add(best)
                    continue
                if d2[j].min() <= self.augment_gate:
                    continue  # ambiguous: discarded
            assoc[j], new[j] = -2, True
        return assoc, new, nis

    def _joint_innovation_cov(self, cand, Hv, Hf, Pv) -> np.ndarray:
        """``[Hv Hf] Σ [Hv Hf]^T`` (c, 2, 2) for candidate landmarks ``cand`` with Σ the
        joint marginal of the predicted pose and each landmark (iSAM2 ``jointMarginalCovariance``
        of the last pose node and the landmarks, carried through the pending odometry)."""
        xk = self._xkey(self._node)
        lks = [self._lkey(int(j)) for j in cand]
        jm = self._isam.jointMarginalCovariance([xk, *lks])
        T = self._local_to_world(self._pose_est[2])
        G = T
        if self._has_pending:
            Gv, _ = _compose_jacobians(self._pose_est[2], self._pending)
            G = Gv @ T
        Pxl = np.array([G @ jm.at(xk, lk) for lk in lks])  # (c, 3, 2) world frame
        Pll = np.array([jm.at(lk, lk) for lk in lks])  # (c, 2, 2)
        self._lm_cov[cand] = symmetrize(Pll)  # fresh marginals for the cache as a side effect
        HvT, HfT = np.swapaxes(Hv, -1, -2), np.swapaxes(Hf, -1, -2)
        cross = Hv @ Pxl @ HfT
        return symmetrize(Hv @ Pv @ HvT + Hf @ Pll @ HfT + cross + np.swapaxes(cross, -1, -2))

    def _refresh(self, observed) -> None:
        """Pull the estimate and the marginals needed by the next association from iSAM2."""
        isam = self._isam
        p = isam.calculateEstimatePose2(self._xkey(self._node))
        self._pose_est = np.array([p.x(), p.y(), p.theta()])
        T = self._local_to_world(self._pose_est[2])
        self._pose_cov_world = symmetrize(T @ self._isam.marginalCovariance(self._xkey(self._node)) @ T.T)
        if self.n_landmarks:
            # per-key estimates: O(n landmarks), not O(n poses) like calculateEstimate()
            self._lm_mean = np.array(
                [isam.calculateEstimatePoint2(self._lkey(j)) for j in range(self.n_landmarks)],
                dtype=float,
            ).reshape(-1, 2)
            if self._n_updates % self.marginal_refresh_every == 0:
                observed = range(self.n_landmarks)
                self._cov_stale = False
            else:
                self._cov_stale = True
            for j in observed:
                self._lm_cov[j] = self._isam.marginalCovariance(self._lkey(int(j)))

    # ------------------------------------------------------------------ estimates
    def pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Latest pose node ⊕ pending odometry; covariance from the iSAM2 marginal (world frame)."""
        return self._predicted_pose()

    def landmarks(self) -> tuple[np.ndarray, np.ndarray]:
        """Landmark means (n, 2) m and marginal covariances (n, 2, 2) m², world frame."""
        if self._cov_stale:
            for j in range(self.n_landmarks):
                self._lm_cov[j] = self._isam.marginalCovariance(self._lkey(j))
            self._cov_stale = False
        return self._lm_mean.copy(), self._lm_cov.copy()

    def landmark_labels(self) -> np.ndarray:
        """(n,) labels of the landmarks (-1: created from an unlabelled observation)."""
        return np.array(self._lm_label, dtype=np.int64)

    @property
    def labels(self) -> np.ndarray:
        """Same as :meth:`landmark_labels` (the attribute name the AEKF uses)."""
        return self.landmark_labels()

    def trajectory(self) -> np.ndarray:
        """(n_nodes, 3) smoothed poses of all pose nodes (the whole path, re-estimated)."""
        est = self._isam.calculateEstimate()
        return np.asarray(self._g.utilities.extractPose2(est), dtype=float).reshape(-1, 3)
