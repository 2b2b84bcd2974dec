"""Joint compatibility branch and bound (JCBB) data association for landmark EKF-SLAM.

Neira and Tardós, "Data association in stochastic mapping using the joint compatibility
test", IEEE Trans. Robotics and Automation 17(6), 2001. Individual gating (the reference's
maximum-likelihood association with its reject gate) judges every observation alone; when
landmarks are clustered closer than the pose uncertainty projects (the segmentation-loop
map's five body centroids lie 1.7-11 m apart), several observations can each pass a gate
with the wrong landmark. All observations of a scan share the same vehicle-pose error, so
the innovations of a correct hypothesis are jointly Gaussian with covariance ``H P Hᵀ + R``
and a wrong pairing usually fails the joint test even when it passes its own. JCBB finds
the hypothesis with the most pairings whose joint NIS is below the χ² quantile for its
dimension (ties: smallest joint NIS).

Hand-written: the branch and bound is the paper's; no dependency of the project implements
it. The search recurses over the observations of one scan (a handful) and their
individually compatible landmarks; the joint covariance of all candidate pairs is built
once per scan, vectorized (O(c² ) for c candidate pairs), so every node costs one small
Cholesky factorization.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.stats import chi2

from slam.estimators.rb_kernels import jcbb_easy, joint_nis, pair_covariance

_PAIR = np.arange(2, dtype=np.intp)

__all__ = ["JCBBResult", "chi2_limits", "jcbb", "jcbb_search"]


class JCBBResult:
    """``pairs (k,)`` landmark index of each observation or -1, ``joint_nis`` of the
    hypothesis (0 when empty), ``nis (k, n)`` individual scores, ``nodes`` visited and
    ``complete`` (False when ``max_nodes`` stopped the search: best found so far),
    ``ambiguous (k,)`` observations left unpaired because hypotheses disagreed on them."""

    __slots__ = ("ambiguous", "complete", "joint_nis", "nis", "nodes", "pairs")

    def __init__(self, pairs, joint_nis, nis, nodes, complete, ambiguous=None):
        self.pairs = pairs
        self.joint_nis = joint_nis
        self.nis = nis
        self.nodes = nodes
        self.complete = complete
        self.ambiguous = np.zeros(pairs.size, dtype=bool) if ambiguous is None else ambiguous


@lru_cache(maxsize=64)
def chi2_limits(confidence: float, k: int) -> np.ndarray:
    """``chi2.ppf(confidence, 2 p)`` for p = 1..k (cached: scipy's ppf costs ~80 µs)."""
    out = chi2.ppf(confidence, 2 * np.arange(1, k + 1))
    out.setflags(write=False)
    return out


def _pair_covariance(x, P, z, R, obs, lms):
    """Innovations ``(2c,)`` and joint covariance ``(2c, 2c)`` of candidate pairs
    ``(obs[a], lms[a])``: ``S_ab = H_a P H_bᵀ + [obs_a = obs_b] R``, from the 5 × 5
    pose-and-landmark blocks of P (compiled: :func:`slam.estimators.rb_kernels.pair_covariance`)."""
    return pair_covariance(
        np.ascontiguousarray(x, dtype=float),
        np.ascontiguousarray(P, dtype=float),
        np.ascontiguousarray(z, dtype=float),
        np.ascontiguousarray(R, dtype=float),
        np.ascontiguousarray(obs, dtype=np.intp),
        np.ascontiguousarray(lms, dtype=np.intp),
    )


def _joint_nis(S, nu, rows) -> float:
    """``nuᵀ S⁻¹ nu`` over ``rows``; LinAlgError when that block of S is not positive
    definite (as a Cholesky factorization would raise)."""
    d2 = joint_nis(S, nu, rows)
    if d2 < 0.0:
        raise np.linalg.LinAlgError("joint covariance of the hypothesis is not positive definite")
    return d2


def jcbb(
    x,
    P,
    z,
    R,
    *,
    confidence: float = 0.99,
    individual_gate: float | None = None,
    max_nodes: int = 20000,
    reject_ambiguous: bool = True,
) -> JCBBResult:
    """Associate observations ``z (k, 2)`` (range m, bearing rad; covariance ``R`` (2, 2)
    or (k, 2, 2)) with the landmarks of state ``x``/``P`` by joint compatibility.

    confidence : χ² quantile of the joint test, ``chi2.ppf(confidence, 2 p)`` for p pairs.
    individual_gate : NIS gate of the candidate pairs (default ``chi2.ppf(confidence, 2)``).
    max_nodes : search budget; beyond it the best hypothesis found so far is returned
        (``complete=False``).
    reject_ambiguous : when several hypotheses with the most pairings all pass the joint
        test (a loop closure whose pose uncertainty spans two landmarks, seen once), keep
        only the pairings they share; the others are marked ``ambiguous`` (neither paired
        nor new) until more observations decide.

    Each landmark is paired with at most one observation of the scan.
    """
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    if not (isinstance(max_nodes, int) and max_nodes >= 1):
        raise ValueError(f"max_nodes must be an integer >= 1, got {max_nodes!r}")
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    z = np.asarray(z, dtype=float).reshape(-1, 2)
    k = z.shape[0]
    R = np.asarray(R, dtype=float)
    R = np.broadcast_to(R, (k, 2, 2)) if R.shape == (2, 2) else R
    limits = chi2_limits(confidence, max(k, 1))
    gate = limits[0] if individual_gate is None else float(individual_gate)
    # most scans (no candidate, one, or one each and jointly compatible) are decided by
    # one compiled call; the rest go to the branch and bound
    status, pairs, nis, d2, nodes = jcbb_easy(
        np.ascontiguousarray(x),
        np.ascontiguousarray(P),
        np.ascontiguousarray(z),
        np.ascontiguousarray(R),
        gate,
        limits,
    )
    if status == 1:
        return JCBBResult(pairs, d2, nis, nodes, True)
    if status == -1:
        raise np.linalg.LinAlgError("joint covariance of the hypothesis is not positive definite")
    obs, lms = np.nonzero(nis < gate)
    nu, S = _pair_covariance(x, P, z, R, obs, lms)
    pairs, ambiguous, d2, nodes, complete = jcbb_search(
        obs, lms, nis[obs, lms], nu, S, k, limits, max_nodes, reject_ambiguous
    )
    return JCBBResult(pairs, d2, nis, nodes, complete, ambiguous)


def jcbb_search(obs, lms, score, nu, S, k, limits, max_nodes, reject_ambiguous=True):
    """The branch and bound of Neira and Tardós over candidate pairs, shared by a scan's
    association (:func:`jcbb`) and the fleet's map-to-map association
    (:func:`slam.fleet.association.pair_maps`).

    obs, lms : (c,) int, candidate pair a pairs item ``obs[a]`` (an observation, or an
        incoming map's landmark; 0..k-1) with target ``lms[a]`` (a landmark of the map).
    score : (c,) individual score of each pair (NIS); better pairs are tried first.
    nu : (2c,) stacked differences of the pairs; S : (2c, 2c) their joint covariance.
    k : number of items; limits : (≥k,) χ² limit of a hypothesis of p pairs at ``limits[p-1]``.
    max_nodes : search budget (beyond it, the best hypothesis found so far).
    reject_ambiguous : keep only the pairings every hypothesis of the best size shares.

    Returns ``(pairs (k,) target or -1, ambiguous (k,) bool, joint NIS, nodes, complete)``:
    the hypothesis with the most pairs whose joint NIS is below its limit (ties: smallest
    joint NIS), each target used at most once.
    """
    # candidate pair ids of each item, best individual score first (finds good hypotheses
    # early, so the bound prunes more)
    order = np.lexsort((score, obs))
    cand = [order[obs[order] == i] for i in range(k)]
    remaining = np.cumsum([len(c) > 0 for c in cand][::-1])[::-1]  # items >= i with candidates

    best = {"n": 0, "d2": 0.0, "sel": []}
    ties: list[frozenset] = []  # every jointly compatible hypothesis of the best size
    nodes = 0

    S = np.ascontiguousarray(S, dtype=float)
    nu = np.ascontiguousarray(nu, dtype=float)

    def joint_nis(sel):
        return _joint_nis(S, nu, (2 * np.asarray(sel, dtype=np.intp)[:, None] + _PAIR).reshape(-1))

    def search(i, sel, used, d2):
        nonlocal nodes
        nodes += 1
        if nodes > max_nodes:
            return
        if i == k:
            n = len(sel)
            if n > best["n"]:
                ties.clear()
            if n >= best["n"] and n > 0:
                ties.append(frozenset(sel))
            if n > best["n"] or (n == best["n"] and n > 0 and d2 < best["d2"]):
                best.update(n=n, d2=d2, sel=list(sel))
            return
        for a in cand[i]:
            if lms[a] in used:
                continue
            d2a = joint_nis([*sel, a])
            if d2a < limits[len(sel)]:
                used.add(lms[a])
                sel.append(a)
                search(i + 1, sel, used, d2a)
                sel.pop()
                used.discard(lms[a])
        # leave item i unpaired if the rest could still beat the best
        if len(sel) + (remaining[i + 1] if i + 1 < k else 0) >= best["n"]:
            search(i + 1, sel, used, d2)

    search(0, [], set(), 0.0)
    chosen = best["sel"]
    pairs = np.full(k, -1, dtype=np.intp)
    ambiguous = np.zeros(k, dtype=bool)
    if reject_ambiguous and len(ties) > 1:
        # keep only the pairings every best-size hypothesis agrees on: another pairing
        # that the data support as well is not evidence for either
        common = frozenset.intersection(*ties)
        ambiguous[[obs[a] for a in chosen if a not in common]] = True
        chosen = [a for a in chosen if a in common]
    for a in chosen:
        pairs[obs[a]] = lms[a]
    return pairs, ambiguous, float(best["d2"]), nodes, nodes <= max_nodes
