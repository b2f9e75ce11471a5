"""D-scan (paper Sec. IV-C, Fig. 4): choose the feature-space size D.

For each candidate D, the top-D prefix of the NCA ranking is scored by 5-way-5-shot
validation episodes drawn from the *training* classes, classified by a plain cosine
prototypical classifier (no adaptation). The D with the best mean accuracy wins (the
smallest on ties); the whole curve with 95% CIs is kept for the figure. Only training
data enter: nothing from the test classes or the queries of test episodes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .episodes import sample_episodes
from .prototypes import nearest_prototype
from .stats import ci95

#: Candidate D: every size up to 24, then coarser up to the whole pool.
DEFAULT_CANDIDATES: tuple[int, ...] = (
    *range(1, 25),
    28,
    32,
    40,
    48,
    64,
    80,
    96,
    128,
    160,
    192,
    256,
    320,
    386,
)


@dataclass(frozen=True)
class DScan:
    """The scan: candidate ``D`` with ``mean`` accuracy and ``ci95`` per candidate, and
    the chosen ``best`` D."""

    D: np.ndarray
    mean: np.ndarray
    ci95: np.ndarray
    best: int

    def as_dict(self) -> dict[str, np.ndarray]:
        return {"D": self.D, "mean": self.mean, "ci95": self.ci95}


def dscan(
    features: np.ndarray,
    labels: np.ndarray,
    ranking: np.ndarray,
    *,
    candidates: tuple[int, ...] = DEFAULT_CANDIDATES,
    n_way: int = 5,
    k_shot: int = 5,
    n_query: int = 5,
    episodes: int = 200,
    seed: int = 0,
) -> DScan:
    """Scan D over ``candidates`` (clipped to the pool size) on training features.

    ``features`` are the z-scored training features ``(n, d)``; the same validation
    episodes are used for every D, so the curve compares D values on identical tasks.
    """
    x = np.asarray(features, dtype=np.float32)
    d_max = x.shape[1]
    ds = np.array(sorted({min(int(c), d_max) for c in candidates if int(c) >= 1}))
    n_classes = np.unique(labels).size
    way = min(n_way, n_classes)
    counts = np.unique(labels, return_counts=True)[1]
    shots = max(1, min(k_shot, int(counts.min()) - 1))
    queries = max(1, min(n_query, int(counts.min()) - shots))
    batch = sample_episodes(
        labels, n_way=way, k_shot=shots, n_query=queries, episodes=episodes, seed=seed
    )
    truth = batch.query_labels
    means, cis = [], []
    for d in ds:
        cols = x[:, ranking[:d]]
        pred = nearest_prototype(cols, batch.support, batch.query)
        acc = (pred == truth).mean(axis=1)
        means.append(acc.mean())
        cis.append(ci95(acc))
    mean = np.asarray(means)
    best = int(ds[int(np.argmax(mean))])  # argmax: the first (smallest) D on ties
    return DScan(D=ds, mean=mean, ci95=np.asarray(cis), best=best)
