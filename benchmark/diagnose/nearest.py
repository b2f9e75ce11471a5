"""Leave-one-out nearest neighbours: exact, deterministic, whatever the BLAS threads."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Channel groups: key, human-readable name, sensor kept (None: all features).


def loo_nearest(x: np.ndarray, *, block_rows: int = 256) -> np.ndarray:
    """Index of each row's nearest other row of ``x`` ``(n, d)`` (Euclidean), ``(n,)`` intp.

    Exact and deterministic: squared distances are first computed with the fast expansion
    ``|a|^2 + |b|^2 - 2 a.b`` (float64 matrix product), whose rounding error is bounded by
    ``(d + 3) * eps * (|a|^2 + |b|^2)``; every row whose candidates within twice that bound
    of its minimum are several is re-decided on directly summed squared differences, and
    equal distances go to the lowest index. The answer therefore does not depend on how
    the BLAS library blocks or threads the product. Rows are processed ``block_rows`` at a
    time (memory ``block_rows * n`` floats).
    """
    x = np.ascontiguousarray(x, dtype=np.float64)
    if x.ndim != 2 or x.shape[0] < 2:
        raise ValueError(f"x must be a 2-D array (n >= 2, d); got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("x contains NaN or inf")
    n, d = x.shape
    sq = np.einsum("ij,ij->i", x, x)
    margin = 8.0 * (d + 3) * np.finfo(np.float64).eps  # 2 x the bound, with room
    sq_max = float(sq.max())
    nearest = np.empty(n, dtype=np.intp)
    for start in range(0, n, block_rows):
        stop = min(start + block_rows, n)
        rows = np.arange(start, stop)
        approx = sq[start:stop, None] + sq[None, :] - 2.0 * (x[start:stop] @ x.T)
        approx[rows - start, rows] = np.inf
        best = approx.min(axis=1)
        tol = margin * (sq[start:stop] + sq_max)
        candidate = approx <= (best + tol)[:, None]
        nearest[start:stop] = np.argmax(candidate, axis=1)  # the first (only) candidate
        for r in np.flatnonzero(candidate.sum(axis=1) > 1):
            cols = np.flatnonzero(candidate[r])
            diff = x[cols] - x[start + r]
            exact = (diff * diff).sum(axis=1)
            nearest[start + r] = cols[int(np.argmin(exact))]  # argmin: first of equals
    return nearest


@dataclass(frozen=True)
class LooScore:
    """Leave-one-out 1-NN score of one label.

    accuracy: share of scored trials whose nearest neighbour has their label (``None``
    when no trial can be scored); chance: expected accuracy of a uniformly random other
    trial, ``mean((n_label - 1) / (n - 1))`` over the scored trials; scored: trials
    scored; left_out: trials left out because no other trial shares their label.
    """

    accuracy: float | None
    chance: float | None
    scored: int
    left_out: int


def loo_score(nearest: np.ndarray, labels: np.ndarray) -> LooScore:
    """Score ``labels`` ``(n,)`` given each trial's nearest neighbour ``nearest`` ``(n,)``."""
    labels = np.asarray(labels)
    _, inverse, counts = np.unique(labels, return_inverse=True, return_counts=True)
    per_trial = counts[inverse]
    scored = per_trial > 1
    k = int(scored.sum())
    if k == 0:
        return LooScore(None, None, 0, int(labels.size))
    hit = labels[nearest] == labels
    chance = float(np.mean((per_trial[scored] - 1) / (labels.size - 1)))
    return LooScore(float(np.mean(hit[scored])), chance, k, int(labels.size - k))
