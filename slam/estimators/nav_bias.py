"""Navigation bias states beside a landmark EKF: the dead reckoner's systematic errors
estimated by SLAM, so a revisit corrects the drift along the whole trajectory.

A DVL + compass dead reckoner's error is dominated by a few constants of its sensors,
not by white noise (docs/navigation.md): the compass deviation
``e(psi) = k1 sin psi + k2 cos psi + k3 sin 2psi + k4 cos 2psi`` (hard- and soft-iron
residuals, rad), its slow Gauss–Markov drift ``g`` (rad, time constant ``tau``), and the
DVL's scale factor ``s``, yaw misalignment ``m`` (rad) and body-frame velocity offset
``b = (bx, by)`` (m/s). A filter that sees only the increments' own covariances treats
these as independent per increment and is over-confident; one that inflates Q to match
the composed covariance (``NavSuite``'s matched Q) is consistent but spreads a revisit's
correction over the trajectory as for a random walk, so a landmark mapped half a loop
back keeps most of its drift. Carried as states ``beta = [k1, k2, k3, k4, g, s, m, bx,
by]`` they are corrected by every observation through their correlation with the pose,
and each later prediction applies the corrected values.

Model of one body-frame increment ``u = [dx, dy, dphi]`` (dead-reckoned frame at the
start of the interval, duration ``dt``): the dead reckoner's heading is the compass's
(aided gyro), so its heading error is ``eps(t) = e(psi) + g`` and the increment carries
``eps(t1) - eps(t0)``; its velocity is the DVL's. The true increment is, to first order,

    dphi_true = dphi - (basis(psi1) - basis(psi0)) . k - (g1 - g0)
    d_true    = (1 - s) Rz(-m) [dx, dy] - Rz(dphi / 2) b dt

with ``psi0, psi1`` the dead-reckoned headings at the ends of the interval (known to
the filter: the sum of the increments), so the model is linear in ``beta`` with
Jacobians that do not depend on the estimate (no linearization inconsistency).
``g1 = a g0 + w``, ``a = exp(-dt / tau)``, ``Var w = sigma_g² (1 - a²)``; the other
states are constant. The run's start pose is known (SLAM starts where the dead reckoner
does), so the compass error at the start cancels in every heading difference.

Implementation: the landmark filter (``AEKFSlam``, unchanged, with its association,
augmentation and iterated updates) keeps ``m = [pose, landmarks]``; this wrapper keeps
``beta``, ``C = Cov(beta, m)`` and ``P_bb``. Prediction applies the linear model above
to the joint covariance. An update observes ``m`` only, so ``beta`` is conditionally
independent of the observations given ``m``: with the regression ``B = C P_mm^-1``
taken before the update, ``beta += B (m' - m)``, ``C' = B P'_mm`` and
``P_bb' = P_bb - B C^T + B P'_mm B^T`` are the exact joint update for any linear
(ized) update of ``m``, including new landmarks (``B`` is zero for them) and iterated
updates.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
from scipy.linalg import lapack as _lapack

from slam.types import Odometry, wrap_angle

__all__ = ["BIAS_STATES", "NavBiasModel", "NavBiasSlam"]

#: names of the bias states, in state order
BIAS_STATES = ("k1", "k2", "k3", "k4", "g", "s", "m", "bx", "by")
_K = slice(0, 4)
_G, _S, _M = 4, 5, 6
_BV = slice(7, 9)
_NB = len(BIAS_STATES)


@dataclass(frozen=True)
class NavBiasModel:
    """Prior standard deviations of the navigation bias states (the sensors' datasheet
    errors, ``sim.navigation.sensor_config``).

    hard_iron_std, soft_iron_std : compass deviation, first / second harmonic, rad.
    drift_std, drift_tau_s : compass Gauss–Markov drift, rad and s.
    scale_factor_std : DVL scale-factor error (fraction). misalignment_std : DVL yaw
    misalignment, rad. velocity_bias_std : DVL velocity offset per body axis, m/s.
    """

    hard_iron_std: float = 0.0
    soft_iron_std: float = 0.0
    drift_std: float = 0.0
    drift_tau_s: float = 600.0
    scale_factor_std: float = 0.0
    misalignment_std: float = 0.0
    velocity_bias_std: float = 0.0

    def __post_init__(self) -> None:
        for name in (
            "hard_iron_std",
            "soft_iron_std",
            "drift_std",
            "scale_factor_std",
            "misalignment_std",
            "velocity_bias_std",
        ):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise ValueError(f"NavBiasModel.{name} must be a finite number >= 0, got {v!r}")
        if not (math.isfinite(self.drift_tau_s) and self.drift_tau_s > 0):
            raise ValueError(f"NavBiasModel.drift_tau_s must be > 0, got {self.drift_tau_s!r}")

    def prior_covariance(self) -> np.ndarray:
        """(9, 9) diagonal prior covariance of ``beta`` (state order :data:`BIAS_STATES`)."""
        sd = [self.hard_iron_std] * 2 + [self.soft_iron_std] * 2
        sd += [self.drift_std, self.scale_factor_std, self.misalignment_std]
        sd += [self.velocity_bias_std] * 2
        return np.diag(np.square(sd))


def _basis(psi: float) -> np.ndarray:
    return np.array([math.sin(psi), math.cos(psi), math.sin(2 * psi), math.cos(2 * psi)])


#: LAPACK dpocon's estimate of the reciprocal 1-norm condition number of the correlation
#: matrix above which :func:`_regression` solves with its Cholesky factor: then its
#: 2-norm condition number (<= the 1-norm one for a symmetric matrix; the estimate is
#: within a small factor of it) is far below the 1e10 at which the pseudo-inverse
#: (:func:`_regression_pinv`, rcond 1e-10) would drop an eigenvalue, so both compute
#: ``C P⁻¹``. Below it (never seen in the runs) the pseudo-inverse is used as before.
_RCOND_SOLVE = 1e-8


def _regression(C: np.ndarray, P: np.ndarray) -> np.ndarray:
    """``C P⁻¹`` over the components of ``P`` with a variance > 0 (exactly known ones,
    e.g. the start pose, have zero rows in a PSD ``P`` and get zero weight, as in the
    pseudo-inverse): a Cholesky solve with the correlation form of ``P`` (variances of
    metres and radians differ by orders of magnitude), O(N³/3) against the pseudo-inverse's
    eigendecomposition; :func:`_regression_pinv` when ``P`` is ill-conditioned
    (:data:`_RCOND_SOLVE`) or not positive definite on those components."""
    d = np.sqrt(np.clip(np.diagonal(P), 0.0, None))
    live = np.flatnonzero(d > 0)
    B = np.zeros_like(C)
    if live.size == 0:
        return B
    dl = d[live]
    Pl = P if live.size == d.size else P[np.ix_(live, live)]
    Pn = Pl / dl / dl[:, None]
    Pn = np.asfortranarray(0.5 * (Pn + Pn.T))  # LAPACK's order: no copies in the calls
    anorm = float(np.abs(Pn).sum(axis=0).max())
    L, info = _lapack.dpotrf(Pn, lower=1, clean=0, overwrite_a=1)
    if info == 0:
        rcond, info = _lapack.dpocon(L, anorm, uplo="L")
        if info == 0 and rcond >= _RCOND_SOLVE:
            X, info = _lapack.dpotrs(L, np.asfortranarray((C[:, live] / dl).T), lower=1)
            if info == 0:
                B[:, live] = X.T / dl
                return B
    return _regression_pinv(C, P)


def _regression_pinv(C: np.ndarray, P: np.ndarray) -> np.ndarray:
    """``C P^+`` with the pseudo-inverse of the correlation form of ``P`` (exactly known
    components get zero weight; eigenvalues below 1e-10 of the largest are dropped)."""
    d = np.sqrt(np.clip(np.diagonal(P), 0.0, None))
    d = np.where(d > 0, d, 1.0)
    Pn = P / np.outer(d, d)
    return (C / d) @ np.linalg.pinv(0.5 * (Pn + Pn.T), rcond=1e-10, hermitian=True) / d


class NavBiasSlam:
    """A landmark EKF (``AEKFSlam``-like: ``x``, ``P``, ``predict``, ``update``, ``ids``)
    with the navigation bias states of the module docstring.

    inner : the landmark filter at the run's start pose. model : prior of the states.
    t0 : time of the start pose, s. Everything else (``pose``, ``landmarks``, ...) is
    the inner filter's; ``bias()`` gives the states' estimate and covariance.
    """

    def __init__(self, inner, model: NavBiasModel, *, t0: float = 0.0) -> None:
        self.inner = inner
        self.model = model
        self.beta = np.zeros(_NB)
        self.P_bb = model.prior_covariance()
        self.C = np.zeros((_NB, inner.x.size))
        self._psi = float(inner.x[2])  # dead-reckoned heading (sum of increments)
        self._t = float(t0)
        self._pose_prior = inner.x[:3].copy()  # the inner filter's FEJ linearization pose

    @property
    def name(self) -> str:
        return self.inner.name

    def __getattr__(self, key):  # pose(), landmarks(), ids, n_landmarks, ... of the filter
        if key == "inner":
            raise AttributeError(key)
        return getattr(self.inner, key)

    def join(self) -> SimpleNamespace:
        """The joint map ``x, P`` over [pose, landmarks] (the inner filter's full state, the
        exact marginal of the joint one): what slam.fleet merges."""
        x, P = self.inner.state()
        return SimpleNamespace(x=x, P=P)

    def bias(self) -> tuple[np.ndarray, np.ndarray]:
        """Copies of the bias estimate (9,) and its covariance (9, 9)."""
        return self.beta.copy(), self.P_bb.copy()

    # ---- prediction
    def predict(self, odometry: Odometry) -> None:
        u = np.asarray(odometry.delta, float)
        dt = float(odometry.t) - self._t
        if not dt >= 0:
            raise ValueError(f"odometry.t = {odometry.t}: before the previous one ({self._t})")
        mdl = self.model
        a = math.exp(-dt / mdl.drift_tau_s)
        q_g = mdl.drift_std**2 * (1.0 - a * a)
        dx, dy, dphi = float(u[0]), float(u[1]), float(u[2])
        psi0, psi1 = self._psi, self._psi + dphi
        ch, sh = math.cos(0.5 * dphi) * dt, math.sin(0.5 * dphi) * dt
        # U = d u_true / d beta (3, 9)
        U = np.zeros((3, _NB))
        U[0, _S], U[1, _S] = -dx, -dy
        U[0, _M], U[1, _M] = dy, -dx
        U[0, 7], U[0, 8], U[1, 7], U[1, 8] = -ch, sh, -sh, -ch
        U[2, _K] = _basis(psi0) - _basis(psi1)
        U[2, _G] = 1.0 - a
        u_true = u + U @ self.beta
        x = self.inner.x
        phi = float(x[2])
        c, s = math.cos(phi), math.sin(phi)
        xn = x[0] + c * u_true[0] - s * u_true[1]
        yn = x[1] + s * u_true[0] + c * u_true[1]
        ref = self._pose_prior if self.inner.config.jacobians == "fej" else x[:3]
        F = np.array([[1.0, 0.0, -(yn - ref[1])], [0.0, 1.0, xn - ref[0]], [0.0, 0.0, 1.0]])
        A = U.copy()  # G U, G the rotation by phi (pose rows)
        A[0], A[1] = c * U[0] - s * U[1], s * U[0] + c * U[1]
        Cv, Cm = self.C[:, :3].copy(), self.C[:, 3:]
        if hasattr(self.inner, "predict_arrays"):  # validates u_true and Q itself
            self.inner.predict_arrays(u_true, odometry.cov)
        else:
            self.inner.predict(Odometry(u_true, odometry.cov, odometry.t))
        P = self.inner.P
        # joint terms the inner predict does not know: pose' = F pose + A beta - e_phi w
        AP = A @ self.P_bb
        dPvv = A @ Cv @ F.T
        P[:3, :3] += dPvv + dPvv.T + AP @ A.T
        P[2, 2] += q_g
        if P.shape[0] > 3:
            dPvm = A @ Cm
            P[:3, 3:] += dPvm
            P[3:, :3] += dPvm.T
        # beta' = D beta (+ w in g): D = 1 except a for the drift g
        self.C[:, :3] = Cv @ F.T + AP.T
        self.C[_G] *= a
        self.C[_G, 2] -= q_g
        self.P_bb[_G] *= a
        self.P_bb[:, _G] *= a
        self.P_bb[_G, _G] += q_g
        self.beta[_G] *= a
        self._psi = psi1
        self._t = float(odometry.t)
        self._pose_prior = self.inner.x[:3].copy()

    def predict_arrays(self, u, Q) -> None:
        self.predict(Odometry(np.asarray(u, float), np.asarray(Q, float), self._t))

    # ---- update
    def update(self, observations):
        inner = self.inner
        x0, P0, ids0 = inner.x.copy(), inner.P.copy(), np.asarray(inner.ids).copy()
        res = inner.update(observations)
        self._condition(x0, P0, ids0)
        return res

    def _condition(self, x0: np.ndarray, P0: np.ndarray, ids0: np.ndarray) -> None:
        """Carry ``beta`` through whatever the inner filter did to ``m`` (module docstring):
        landmarks matched by their persistent ids; removed ones are marginalized with the
        covariance before the update."""
        inner = self.inner
        ids1 = np.asarray(inner.ids)
        n0 = ids0.size
        if ids1.size >= n0 and np.array_equal(ids1[:n0], ids0):
            # no landmark removed (most scans; new ones come last): the old state is the
            # leading block of the new one
            B = _regression(self.C, P0)
            dm = inner.x[: x0.size] - x0
            dm[2] = wrap_angle(dm[2])
            P_r = self.P_bb - B @ self.C.T
            self.beta = self.beta + B @ dm
            self.C = B @ inner.P[: x0.size]
            P_bb = P_r + self.C[:, : x0.size] @ B.T
            self.P_bb = 0.5 * (P_bb + P_bb.T)
            return
        pos1 = {int(i): j for j, i in enumerate(ids1)}
        kept_old = [j for j, i in enumerate(ids0) if int(i) in pos1]
        old_cols = np.r_[0:3, [3 + 2 * j + o for j in kept_old for o in (0, 1)]].astype(int)
        new_cols = np.r_[0:3, [3 + 2 * pos1[int(ids0[j])] + o for j in kept_old for o in (0, 1)]]
        new_cols = new_cols.astype(int)
        Ck = self.C[:, old_cols]
        B = _regression(Ck, P0[np.ix_(old_cols, old_cols)])
        dm = inner.x[new_cols] - x0[old_cols]
        dm[2] = wrap_angle(dm[2])
        P_r = self.P_bb - B @ Ck.T
        Bn = np.zeros((_NB, inner.x.size))
        Bn[:, new_cols] = B
        self.beta = self.beta + B @ dm
        self.C = Bn @ inner.P
        P_bb = P_r + self.C @ Bn.T
        self.P_bb = 0.5 * (P_bb + P_bb.T)
