"""Non-dominated sorting: the Pareto rank of each point of a set of goals (all minimised)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v

F64 = NDArray[np.float64]


def pareto_ranks(objectives: Any, limit: int | None = None) -> NDArray[np.int64]:
    """Non-dominated sorting: the Pareto rank of each point (0: the first front), all goals
    minimised.

    Point i dominates j when it is no worse in every goal and better in one. Rank 0 holds the
    points no other dominates; rank r those dominated only by ranks below r.

    Parameters
    ----------
    objectives : array-like, shape (N, m)
        Goal values (minimised; negate a goal to maximise it). Rows with a NaN are never ranked.
    limit : int, optional
        Stop after the fronts that hold at least ``limit`` points (the rest get rank -1).

    Returns
    -------
    ndarray of int, shape (N,)
        Ranks, -1 for rows not ranked.

    Examples
    --------
    >>> pareto_ranks([[1.0, 4.0], [2.0, 2.0], [3.0, 3.0], [4.0, 1.0]]).tolist()
    [0, 0, 1, 0]
    """
    f = np.asarray(objectives, dtype=np.float64)
    if f.ndim != 2:
        raise v.fail("objectives", f"an array of shape {f.shape}", "shape (N, m)")
    ranks = np.full(f.shape[0], -1, dtype=np.int64)
    left = np.nonzero(~np.isnan(f).any(axis=1))[0]
    if f.shape[1] == 2:
        return _ranks_2d(f, left, ranks, limit)
    rank, ranked = 0, 0
    while left.size and (limit is None or ranked < limit):
        g = f[left]
        dominated = np.zeros(left.size, dtype=bool)
        for start in range(0, left.size, 512):  # blocks: 512 × N comparisons at a time
            block = g[start:start + 512]
            le = np.all(g[None, :, :] <= block[:, None, :], axis=2)
            lt = np.any(g[None, :, :] < block[:, None, :], axis=2)
            dominated[start:start + 512] = np.any(le & lt, axis=1)
        front = left[~dominated]
        ranks[front] = rank
        ranked += front.size
        left = left[dominated]
        rank += 1
    return ranks


def _ranks_2d(f: F64, left: NDArray[np.int64], ranks: NDArray[np.int64], limit: int | None
              ) -> NDArray[np.int64]:
    """:func:`pareto_ranks` of two goals in O(N log N) per front: the distinct points sorted by
    the first goal, then the second; a point is dominated exactly when an earlier one is no worse
    in the second goal (equal points share their rank)."""
    points, inverse = np.unique(f[left], axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    counts = np.bincount(inverse, minlength=points.shape[0])
    point_rank = np.full(points.shape[0], -1, dtype=np.int64)
    rest = np.arange(points.shape[0])  # lexicographic order, kept by every selection
    rank, ranked = 0, 0
    while rest.size and (limit is None or ranked < limit):
        second = points[rest, 1]
        before = np.concatenate([[np.inf], np.minimum.accumulate(second)[:-1]])
        front = second < before
        point_rank[rest[front]] = rank
        ranked += int(counts[rest[front]].sum())
        rest = rest[~front]
        rank += 1
    ranks[left] = point_rank[inverse]
    return ranks
