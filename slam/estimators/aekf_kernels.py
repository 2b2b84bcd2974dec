"""Compiled per-scan bookkeeping of the AEKF (:mod:`slam.estimators.aekf`): the state
reduction's footprint test and miss counters in one pass over the landmarks instead of
some twenty NumPy calls on arrays of a few hundred elements. Compiled by numba on first
use and cached on disk (``cache=True``)."""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["count_misses"]

_TWO_PI = 2.0 * math.pi


@numba.njit(cache=True)
def count_misses(x, seen, compatible, hits, misses, r_max, b_max, max_misses, provisional_misses):
    """Update the miss counters of the landmarks of state ``x`` in place; returns the
    (n,) bool mask of landmarks to remove.

    A landmark ``seen`` (associated this scan) gets 0 misses; one inside the footprint
    (range ``< r_max`` m and ``|bearing| < b_max`` rad from the pose ``x[:3]``) that is not
    seen and not excused gets one more. ``compatible`` (m <= n,) excuses the first m
    landmarks (some observation was within the augment gate) unless, with
    ``provisional_misses >= 0``, the landmark is provisional (``hits < 2``). Removed:
    ``misses >= max_misses`` (when ``>= 0``) or provisional with ``misses >=
    provisional_misses`` (when ``>= 0``)."""
    n = misses.size
    drop = np.zeros(n, np.bool_)
    px, py, phi = x[0], x[1], x[2]
    for i in range(n):
        provisional = hits[i] < 2
        if seen[i]:
            misses[i] = 0
        else:
            dx = x[3 + 2 * i] - px
            dy = x[4 + 2 * i] - py
            if math.hypot(dx, dy) < r_max:
                b = abs((math.atan2(dy, dx) - phi + math.pi) % _TWO_PI - math.pi)
                excused = False
                if i < compatible.size:
                    excused = compatible[i] and not (provisional_misses >= 0 and provisional)
                if b < b_max and not excused:
                    misses[i] += 1
        if max_misses >= 0 and misses[i] >= max_misses:
            drop[i] = True
        if provisional_misses >= 0 and provisional and misses[i] >= provisional_misses:
            drop[i] = True
    return drop
