"""Which landmarks of two maps are the same object: joint compatibility between maps.

Neira and Tardós, "Data association in stochastic mapping using the joint compatibility
test", IEEE T-RA 17(6), 2001, applied map to map: the "observations" are the landmarks of
the incoming map, expressed in the fused (world) frame through its frame estimate, and the
"predictions" the fused map's landmarks. A pairing hypothesis ``{(i_a, j_a)}`` (fused
landmark ``i_a``, incoming landmark ``j_a``) is jointly compatible when the stacked
differences ``d_a = G_{i_a} - g_{j_a}`` pass ``dᵀ S⁻¹ d < χ²(confidence, 2 p)`` with
``S_ab = Σ_G[i_a, i_b] + C_g[j_a, j_b]``: the two maps are independent (different
vehicles, sensors and start fixes), while all landmarks of one map share its frame and
navigation errors, which the full blocks carry. The branch and bound returns the
hypothesis with most pairings (ties: smallest joint NIS); with ``reject_ambiguous`` only
the pairings every best-size hypothesis shares are kept (the others are reported as
ambiguous), the rule of ``slam.estimators.jcbb`` for a scan.

The branch and bound is :func:`slam.estimators.jcbb.jcbb_search`, shared with the
range-bearing scan association; only the candidate pairs and their joint covariance
(two maps' differences instead of innovations that depend on the vehicle pose) are built
here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam.estimators.jcbb import chi2_limits, jcbb_search

__all__ = ["MapPairing", "pair_maps"]


@dataclass(frozen=True)
class MapPairing:
    """``pairs (m,)``: index of the fused landmark each incoming landmark is the same object
    as, or -1; ``ambiguous (m,)``: left unpaired because equally good hypotheses disagree;
    ``joint_nis`` of the chosen hypothesis; ``nodes`` searched; ``complete`` False when the
    node budget stopped the search (best found so far)."""

    pairs: np.ndarray
    ambiguous: np.ndarray
    joint_nis: float
    nodes: int
    complete: bool


def _individual(G, SG, g, Cg, gate):
    """Candidate pairs ``(i, j, d²)`` whose single difference passes ``gate`` (vectorized)."""
    n, m = len(G), len(g)
    ar_n, ar_m = np.arange(n), np.arange(m)
    Sg = SG.reshape(n, 2, n, 2)[ar_n, :, ar_n, :]  # (n, 2, 2)
    Cgg = Cg.reshape(m, 2, m, 2)[ar_m, :, ar_m, :]  # (m, 2, 2)
    C = Sg[:, None] + Cgg[None, :]  # (n, m, 2, 2)
    d = G[:, None, :] - g[None, :, :]  # (n, m, 2)
    det = C[..., 0, 0] * C[..., 1, 1] - C[..., 0, 1] * C[..., 1, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        d2 = (
            C[..., 1, 1] * d[..., 0] ** 2
            - (C[..., 0, 1] + C[..., 1, 0]) * d[..., 0] * d[..., 1]
            + C[..., 0, 0] * d[..., 1] ** 2
        ) / det
    i, j = np.nonzero((det > 0) & (d2 < gate))
    return i, j, d2[i, j]


def pair_maps(
    G: np.ndarray,
    SG: np.ndarray,
    g: np.ndarray,
    Cg: np.ndarray,
    *,
    confidence: float = 0.99,
    max_nodes: int = 20000,
    reject_ambiguous: bool = True,
) -> MapPairing:
    """Pair the incoming landmarks ``g (m, 2)`` (joint covariance ``Cg (2m, 2m)``, world
    frame, m) with the fused landmarks ``G (n, 2)`` (joint covariance ``SG (2n, 2n)``) by
    joint compatibility at ``confidence``; each fused landmark pairs with at most one.
    """
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    if not (isinstance(max_nodes, int) and max_nodes >= 1):
        raise ValueError(f"max_nodes must be an integer >= 1, got {max_nodes!r}")
    G = np.asarray(G, float).reshape(-1, 2)
    g = np.asarray(g, float).reshape(-1, 2)
    n, m = len(G), len(g)
    SG = np.asarray(SG, float).reshape(2 * n, 2 * n)
    Cg = np.asarray(Cg, float).reshape(2 * m, 2 * m)
    none = np.zeros(m, dtype=bool)
    pairs = np.full(m, -1, dtype=np.intp)
    if n == 0 or m == 0:
        return MapPairing(pairs, none, 0.0, 0, True)
    limits = chi2_limits(confidence, m)
    ci, cj, cd = _individual(G, SG, g, Cg, limits[0])
    if ci.size == 0:
        return MapPairing(pairs, none, 0.0, 0, True)
    # the joint covariance of every candidate pair with every other, built once
    ri = (2 * ci[:, None] + np.arange(2)).reshape(-1)
    rj = (2 * cj[:, None] + np.arange(2)).reshape(-1)
    S = SG[np.ix_(ri, ri)] + Cg[np.ix_(rj, rj)]
    S = 0.5 * (S + S.T)
    nu = (G[ci] - g[cj]).reshape(-1)
    pairs, ambiguous, d2, nodes, complete = jcbb_search(
        cj, ci, cd, nu, S, m, limits, max_nodes, reject_ambiguous
    )
    return MapPairing(pairs, ambiguous, d2, nodes, complete)
