"""Cross-shape generalisation (paper Section V-C, Fig. 5a).

3 fixed folds (:data:`benchmark.splits.CROSS_SHAPE_FOLDS`): fit on the 8 training shapes
(all materials), evaluate N-way-1-shot (N = 2..12) on the 4 unseen shapes' 12 classes.
Records per fold (``fold`` = 0, 1, 2) and across folds (``fold=None``: mean and 95 % CI
over all folds' episodes), plus AFOP-ML's selection record per fold.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from synth import Dataset

from ..splits import cross_shape_splits
from .generalisation import Task, reference_records, run_split_protocol

PROTOCOL = "cross-shape"


def tasks(data: Dataset) -> list[Task]:
    """One task per fold: train on the fold's 8 shapes, test on its 4 unseen shapes."""
    return [
        Task(
            fold=s.fold,
            condition=None,
            train_idx=np.flatnonzero(s.train),
            test_idx=np.flatnonzero(s.test),
        )
        for s in cross_shape_splits(data)
    ]


def run(
    data: Dataset,
    *,
    perturbed: Dataset | None = None,
    methods: Sequence[str] = ("AFOP-ML",),
    episodes: int = 500,
    seed: int = 0,
    progress: bool = False,
    features: np.ndarray | None = None,
    method_episodes: Mapping[str, int] | None = None,
    reference: bool = True,
) -> list[dict]:
    """Records of the cross-shape protocol (``perturbed`` is not used).

    features: optional precomputed ``(n, 386)`` pool of ``data``; reference: also add the
    closed-set AFOP-ML 1-shot 2..12-way reference curve (Fig. 5's dashed line).
    """
    del perturbed
    records = run_split_protocol(
        PROTOCOL,
        data,
        tasks(data),
        methods=methods,
        episodes=episodes,
        seed=seed,
        progress=progress,
        features=features,
        method_episodes=method_episodes,
    )
    if reference:
        records += reference_records(
            data, episodes=episodes, seed=seed, progress=progress, features=features
        )
    return records
