"""NavBiasSlam: landmark EKF + navigation bias states (slam/estimators/nav_bias.py).

Expectations: a second implementation (one dense EKF over the joint state [pose,
landmarks, biases], written here from the model in the module docstring) for the
wrapper's regression-based joint update; and a simulated loop with a known compass
deviation, where the bias states recover the deviation and the track error falls below
the random-walk filter's.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam.estimators.aekf import AEKFSlam
from slam.estimators.nav_bias import BIAS_STATES, NavBiasModel, NavBiasSlam
from slam.types import Odometry, RangeBearing

MODEL = NavBiasModel(
    hard_iron_std=math.radians(0.7),
    soft_iron_std=math.radians(0.3),
    drift_std=math.radians(0.5),
    drift_tau_s=600.0,
    scale_factor_std=0.002,
    misalignment_std=math.radians(0.1),
    velocity_bias_std=0.001,
)
NB = len(BIAS_STATES)


def _basis(p):
    return np.array([math.sin(p), math.cos(p), math.sin(2 * p), math.cos(2 * p)])


class DenseJointEKF:
    """The reference: one EKF over x = [x, y, phi, l1, ..., ln, beta] (standard Jacobians,
    known association), predict and update written out in full."""

    def __init__(self, x0, P0, model):
        self.x = np.concatenate([x0, np.zeros(NB)])
        self.P = np.zeros((3 + NB, 3 + NB))
        self.P[:3, :3] = P0
        self.P[3:, 3:] = model.prior_covariance()
        self.model = model
        self.n = 0
        self.psi = float(x0[2])
        self.t = 0.0
        self.labels: list[int] = []

    def _b(self):
        return slice(3 + 2 * self.n, 3 + 2 * self.n + NB)

    def predict(self, u, Q, t):
        m, b = self.model, self._b()
        dt = t - self.t
        a = math.exp(-dt / m.drift_tau_s)
        qg = m.drift_std**2 * (1 - a * a)
        U = np.zeros((3, NB))
        U[:2, 5] = -u[:2]
        U[:2, 6] = [u[1], -u[0]]
        c2, s2 = math.cos(u[2] / 2), math.sin(u[2] / 2)
        U[:2, 7:9] = -np.array([[c2, -s2], [s2, c2]]) * dt
        U[2, 0:4] = -(_basis(self.psi + u[2]) - _basis(self.psi))
        U[2, 4] = 1 - a
        ut = u + U @ self.x[b]
        phi = self.x[2]
        c, s = math.cos(phi), math.sin(phi)
        G = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
        N = self.x.size
        J = np.eye(N)
        J[0, 2] = -(s * ut[0] + c * ut[1])
        J[1, 2] = c * ut[0] - s * ut[1]
        J[:3, b] = G @ U
        J[b.start + 4, b.start + 4] = a
        W = np.zeros((N, 4))  # noise: u (3) and the drift's w (1)
        W[:3, :3] = G
        W[2, 3] = -1.0
        W[b.start + 4, 3] = 1.0
        Qw = np.zeros((4, 4))
        Qw[:3, :3] = Q
        Qw[3, 3] = qg
        self.x[:3] = self.x[:3] + G @ ut
        self.x[2] = (self.x[2] + math.pi) % (2 * math.pi) - math.pi
        self.x[b.start + 4] *= a
        self.P = J @ self.P @ J.T + W @ Qw @ W.T
        self.psi += u[2]
        self.t = t

    def update(self, obs):
        """Known association by label; new labels augment (after the update of known ones)."""
        known = [o for o in obs if o.label in self.labels]
        new = [o for o in obs if o.label not in self.labels]
        if known:
            H = np.zeros((2 * len(known), self.x.size))
            y = np.zeros(2 * len(known))
            R = np.zeros((2 * len(known), 2 * len(known)))
            for k, o in enumerate(known):
                i = self.labels.index(o.label)
                li = slice(3 + 2 * i, 5 + 2 * i)
                d = self.x[li] - self.x[:2]
                q = d @ d
                r = math.sqrt(q)
                Hm = np.array([[d[0] / r, d[1] / r], [-d[1] / q, d[0] / q]])
                H[2 * k : 2 * k + 2, :2] = -Hm
                H[2 * k + 1, 2] = -1.0
                H[2 * k : 2 * k + 2, li] = Hm
                zh = np.array([r, math.atan2(d[1], d[0]) - self.x[2]])
                e = o.z - zh
                e[1] = (e[1] + math.pi) % (2 * math.pi) - math.pi
                y[2 * k : 2 * k + 2] = e
                R[2 * k : 2 * k + 2, 2 * k : 2 * k + 2] = o.R
            S = H @ self.P @ H.T + R
            K = self.P @ H.T @ np.linalg.inv(S)
            self.x = self.x + K @ y
            self.P = self.P - K @ S @ K.T
        for o in new:
            r, br = o.z
            phi = self.x[2]
            lm = self.x[:2] + r * np.array([math.cos(phi + br), math.sin(phi + br)])
            Gv = np.array([[1, 0, -r * math.sin(phi + br)], [0, 1, r * math.cos(phi + br)]])
            Gz = np.array(
                [
                    [math.cos(phi + br), -r * math.sin(phi + br)],
                    [math.sin(phi + br), r * math.cos(phi + br)],
                ]
            )
            pos = 3 + 2 * self.n  # insert before the bias block
            N = self.x.size
            T = np.zeros((N + 2, N))  # new state = T x_old (+ Gz noise) about the mean
            T[:pos, :pos] = np.eye(pos)
            T[pos : pos + 2, :3] = Gv
            T[pos + 2 :, pos:] = np.eye(N - pos)
            Pn = T @ self.P @ T.T
            Pn[pos : pos + 2, pos : pos + 2] += Gz @ o.R @ Gz.T
            self.x = np.concatenate([self.x[:pos], lm, self.x[pos:]])
            self.P = Pn
            self.n += 1
            self.labels.append(o.label)


def _loop_stream(seed: int, deviation, n_loops: int = 2):
    """A vehicle on a circle of radius 40 m at 1.5 m/s with a compass-deviated heading
    increment (deviation (4,) rad) and white odometry noise; 8 landmarks 12 m outside the
    circle, observed when within 25 m. Returns (events, true poses at the events, true
    landmarks)."""
    rng = np.random.default_rng(seed)
    R0, v, dt = 40.0, 1.5, 1.0
    w = v / R0
    lms = np.array(
        [
            [(R0 + 12) * math.cos(a), (R0 + 12) * math.sin(a)]
            for a in np.linspace(0, 2 * np.pi, 8, endpoint=False)
        ]
    )
    Rz = np.diag([0.3**2, math.radians(1.0) ** 2])
    Q = np.diag([0.02**2, 0.02**2, math.radians(0.05) ** 2])
    pose = np.array([R0, 0.0, math.pi / 2])
    events, truth = [], []
    n = int(n_loops * 2 * math.pi / w / dt)
    eps0 = _basis(pose[2]) @ deviation
    for k in range(1, n + 1):
        u_true = np.array(
            [
                v * dt * math.sin(w * dt) / (w * dt),
                v * dt * (1 - math.cos(w * dt)) / (w * dt),
                w * dt,
            ]
        )
        new = pose.copy()
        c, s = math.cos(pose[2]), math.sin(pose[2])
        new[:2] += [c * u_true[0] - s * u_true[1], s * u_true[0] + c * u_true[1]]
        new[2] += u_true[2]
        eps1 = _basis(new[2]) @ deviation
        u = u_true + rng.multivariate_normal(np.zeros(3), Q)
        u[2] += eps1 - eps0
        eps0 = eps1
        pose = new
        events.append(("p", Odometry(u, Q, k * dt)))
        truth.append(pose.copy())
        d = lms - pose[:2]
        rng_ = np.hypot(d[:, 0], d[:, 1])
        obs = []
        for i in np.flatnonzero(rng_ < 25.0):
            z = np.array([rng_[i], math.atan2(d[i, 1], d[i, 0]) - pose[2]])
            z = z + rng.multivariate_normal(np.zeros(2), Rz)
            obs.append(RangeBearing(z, Rz, k * dt, label=int(i)))
        if obs and k % 3 == 0:
            events.append(("u", obs))
            truth.append(pose.copy())
    return events, np.array(truth), lms


def _run(est, events):
    poses = []
    for kind, e in events:
        if kind == "p":
            est.predict(e)
        else:
            est.update(e)
        poses.append(est.pose()[0].copy())
    return np.array(poses)


def test_regression_update_equals_the_dense_joint_ekf():
    """The wrapper's joint bookkeeping (prediction terms, regression update, landmarks
    added later) against one dense EKF over all states, on a stream with new landmarks
    and revisits."""
    deviation = np.radians([0.7, -0.5, 0.2, 0.1])
    events, _, _ = _loop_stream(3, deviation, n_loops=1)
    events = events[:400]
    x0 = np.array([40.0, 0.0, math.pi / 2])
    P0 = np.diag([0.01, 0.01, 1e-6])
    inner = AEKFSlam(preset="reference", association="known", x0=x0, P0=P0)
    est = NavBiasSlam(inner, MODEL)
    ref = DenseJointEKF(x0, P0, MODEL)
    for kind, e in events:
        if kind == "p":
            est.predict(e)
            ref.predict(e.delta, e.cov, e.t)
        else:
            est.update(e)
            ref.update(e)
    assert inner.n_landmarks == ref.n > 3
    b, Pb = est.bias()
    nb = slice(3 + 2 * ref.n, None)
    np.testing.assert_allclose(inner.x, ref.x[: 3 + 2 * ref.n], atol=1e-7)
    np.testing.assert_allclose(b, ref.x[nb], atol=1e-9)
    np.testing.assert_allclose(Pb, ref.P[nb, nb], atol=1e-12, rtol=1e-6)
    np.testing.assert_allclose(
        inner.P, ref.P[: 3 + 2 * ref.n, : 3 + 2 * ref.n], atol=1e-9, rtol=1e-6
    )
    np.testing.assert_allclose(est.C, ref.P[nb, : 3 + 2 * ref.n], atol=1e-10, rtol=1e-6)


def test_loop_recovers_the_compass_deviation_and_beats_the_plain_filter():
    """Three loops with a 1.4° hard-iron deviation: the first-harmonic states end within
    3σ of the truth, and after the first loop closure the track error is well below that
    of the same filter without bias states (whose landmarks keep the first loop's drift)."""
    deviation = np.radians([1.2, -0.8, 0.0, 0.0])
    events, truth, _ = _loop_stream(5, deviation, n_loops=3)
    x0 = np.array([40.0, 0.0, math.pi / 2])
    P0 = np.zeros((3, 3))
    plain = _run(AEKFSlam(preset="reference", association="known", x0=x0, P0=P0), events)
    est = NavBiasSlam(AEKFSlam(preset="reference", association="known", x0=x0, P0=P0), MODEL)
    biased = _run(est, events)
    b, Pb = est.bias()
    sd = np.sqrt(np.diag(Pb))
    assert np.all(np.abs(b[:2] - deviation[:2]) < 3 * sd[:2]), (b[:2], deviation[:2], sd[:2])
    assert sd[0] < 0.5 * MODEL.hard_iron_std  # it learnt something
    later = slice(len(truth) // 3, None)  # loops 2 and 3

    def ate(p):
        return float(np.sqrt(np.mean(np.sum((p[later, :2] - truth[later, :2]) ** 2, axis=1))))

    assert ate(biased) < 0.6 * ate(plain), (ate(biased), ate(plain))


@pytest.mark.parametrize("field", ["hard_iron_std", "drift_std", "velocity_bias_std"])
def test_bad_model_field_is_named(field):
    with pytest.raises(ValueError, match=rf"NavBiasModel\.{field}"):
        NavBiasModel(**{field: -1.0})


def test_odometry_back_in_time_is_refused():
    est = NavBiasSlam(AEKFSlam(x0=np.zeros(3)), MODEL, t0=5.0)
    with pytest.raises(ValueError, match=r"odometry\.t"):
        est.predict(Odometry(np.zeros(3), np.eye(3) * 1e-4, 4.0))


def _spd(rng, n, zero=0, cond=None):
    """A random SPD matrix with ``zero`` exactly known leading components (zero rows)."""
    A = rng.standard_normal((n, n + 3))
    P = A @ A.T
    if cond is not None:  # eigenvalues spread over ``cond``
        _, V = np.linalg.eigh(P)
        P = (V * np.geomspace(1.0, 1.0 / cond, n)) @ V.T
        P = 0.5 * (P + P.T)
    scale = np.geomspace(1e-4, 1e2, n)  # rad² next to m²
    P = P * np.sqrt(np.outer(scale, scale))
    P[:zero, :] = 0.0
    P[:, :zero] = 0.0
    return P


def test_regression_solve_equals_the_pseudo_inverse(rng):
    """The Cholesky regression against the pseudo-inverse path it replaced (1e-9 of the
    result's magnitude), with exactly known components (zero weight in both) and without;
    an ill-conditioned correlation matrix (where the pseudo-inverse drops eigenvalues)
    takes the pseudo-inverse path itself."""
    from slam.estimators.nav_bias import _regression, _regression_pinv

    for _ in range(50):
        n = int(rng.integers(3, 80))
        zero = int(rng.integers(0, 4)) if rng.random() < 0.5 else 0
        P = _spd(rng, n, min(zero, n - 1))
        C = rng.standard_normal((NB, n)) * 1e-3
        C[:, :zero] = 0.0
        got, want = _regression(C, P), _regression_pinv(C, P)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9 * np.abs(want).max())
        assert np.all(got[:, :zero] == 0.0)
    P = _spd(rng, 20, cond=1e13)
    C = rng.standard_normal((NB, 20))
    assert np.array_equal(_regression(C, P), _regression_pinv(C, P))


def test_run_with_the_solve_equals_the_run_with_the_pseudo_inverse(monkeypatch):
    """A whole loop stream (consistent inner filter, its own association) through the
    wrapper with the Cholesky regression and with the pseudo-inverse one: the same bias
    estimate, covariance and landmark map to 1e-9."""
    import slam.estimators.nav_bias as nb

    events, _, _ = _loop_stream(5, np.radians([1.2, -0.8, 0.3, 0.0]), n_loops=2)
    x0 = np.array([40.0, 0.0, math.pi / 2])

    def drive():
        est = NavBiasSlam(AEKFSlam(preset="consistent", x0=x0), MODEL)
        _run(est, events)
        return est.beta, est.P_bb, est.C, est.inner.x, est.inner.P

    a = drive()
    monkeypatch.setattr(nb, "_regression", nb._regression_pinv)
    b = drive()
    for u, v in zip(a, b, strict=True):
        assert u.shape == v.shape
        np.testing.assert_allclose(u, v, rtol=0, atol=1e-9 * max(1.0, np.abs(v).max()))
