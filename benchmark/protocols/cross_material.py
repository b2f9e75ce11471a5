"""Cross-material generalisation (paper Section V-C, Fig. 5b), leave-one-material-in.

For each material: fit on its 12 classes (all shapes), evaluate N-way-1-shot (N = 2..12)
on the other two materials' 24 classes. Records per split (``fold`` = the training
material) and across splits (``fold=None``), plus AFOP-ML's selection record per split.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from synth import Dataset

from ..splits import cross_material_splits
from .generalisation import Task, reference_records, run_split_protocol

PROTOCOL = "cross-material"


def tasks(data: Dataset) -> list[Task]:
    """One task per training material: train on it, test on the other two."""
    return [
        Task(
            fold=s.fold,
            condition=None,
            train_idx=np.flatnonzero(s.train),
            test_idx=np.flatnonzero(s.test),
        )
        for s in cross_material_splits(data)
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
    """Records of the cross-material protocol (``perturbed`` is not used); arguments as
    :func:`benchmark.protocols.cross_shape.run`."""
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
