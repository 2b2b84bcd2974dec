"""Invariants of FastSLAM 2.0 under arbitrary (valid) input sequences, checked with
hypothesis: the weights stay a probability distribution, every landmark covariance and the
mixture pose covariance stay symmetric positive semi-definite, poses and maps stay finite."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from slam.estimators.fastslam2 import FastSLAM2
from slam.types import Odometry, RangeBearing

step = st.tuples(
    st.floats(-2.0, 2.0),  # dx m
    st.floats(-0.5, 0.5),  # dy m
    st.floats(-0.5, 0.5),  # dphi rad
    st.floats(1e-6, 0.5),  # odometry std scale
    st.lists(
        st.tuples(
            st.floats(0.5, 40.0),  # range m
            st.floats(-3.1, 3.1),  # bearing rad
            st.floats(0.01, 1.0),  # sigma_r m
            st.floats(0.002, 0.2),  # sigma_b rad
            st.one_of(st.none(), st.integers(0, 5)),  # label
        ),
        max_size=4,
    ),
)


def _psd(P, tol=1e-9):
    P = np.asarray(P)
    sym = np.max(np.abs(P - np.swapaxes(P, -1, -2))) <= tol * max(1.0, np.max(np.abs(P)))
    eig = np.linalg.eigvalsh(0.5 * (P + np.swapaxes(P, -1, -2)))
    return sym and np.all(eig >= -tol * max(1.0, np.max(np.abs(P))))


@settings(max_examples=40, deadline=None)
@given(
    steps=st.lists(step, min_size=1, max_size=12),
    seed=st.integers(0, 1000),
    mode=st.sampled_from(["ml", "auto"]),
)
def test_weights_and_covariances_stay_valid(steps, seed, mode):
    f = FastSLAM2(n_particles=20, rng=np.random.default_rng(seed), association=mode)
    for dx, dy, dphi, sd, obs in steps:
        Q = np.diag([sd**2, (0.5 * sd) ** 2, (0.1 * sd) ** 2])
        f.predict(Odometry([dx, dy, dphi], Q))
        res = f.update(
            [RangeBearing([r, b], np.diag([sr**2, sb**2]), label=lab) for r, b, sr, sb, lab in obs]
        )
        assert res.associations.shape == (len(obs),)
        w = f.weights
        assert np.all(np.isfinite(w)) and np.all(w >= 0) and abs(w.sum() - 1.0) < 1e-12
        x, P = f.pose()
        assert np.all(np.isfinite(x)) and _psd(P)
        M, C = f.landmarks()
        assert np.all(np.isfinite(M)) and np.all(np.isfinite(C))
        if len(C):
            assert _psd(C)
        live = f._P[f._exists]
        if len(live):
            assert _psd(live)


@settings(max_examples=200, deadline=None)
@given(
    pose=st.tuples(st.floats(-50, 50), st.floats(-50, 50), st.floats(-3.1, 3.1)),
    lm=st.tuples(st.floats(-50, 50), st.floats(-50, 50)),
    z=st.tuples(st.floats(0.1, 60.0), st.floats(-3.1, 3.1)),
    seed=st.integers(0, 10_000),
)
def test_trace_bound_never_exceeds_the_exact_nis(pose, lm, z, seed):
    """The association prunes pairs with ``|v|² / tr_bound >= augment_gate``; that is only
    safe if ``|v|² / tr_bound <= vᵀ S⁻¹ v`` always (S <= tr(S) I <= tr_bound I)."""
    from slam.estimators.fastslam2 import _wrap, observation_model

    rng = np.random.default_rng(seed)
    A = rng.standard_normal((3, 3)) * rng.uniform(0, 2)
    B = rng.standard_normal((2, 2)) * rng.uniform(0, 2)
    Pv, Pf = A @ A.T, B @ B.T
    R = np.diag(rng.uniform(1e-4, 1.0, 2))
    x, m = np.array(pose), np.array(lm)
    zhat, Hv, Hf = observation_model(x, m)
    S = Hv @ Pv @ Hv.T + Hf @ Pf @ Hf.T + R
    v = np.array(z) - zhat
    v[1] = _wrap(v[1])
    exact = v @ np.linalg.solve(S, v)
    inv_d2 = 1.0 / max(zhat[0] ** 2, 1e-12)
    bound = np.trace(Pv) * (2 + inv_d2) + np.trace(Pf) * (1 + inv_d2) + np.trace(R)
    assert v @ v / bound <= exact * (1 + 1e-9) + 1e-12
