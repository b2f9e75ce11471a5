"""Closed-set protocol (paper Section V-A/B, Table I).

The 36 classes are split 50:50 per class (seeded); each method is fitted once on the
training half; N-way K-shot episodes are drawn from the test half only, for the paper's
columns (1-shot 5/10/12/28/36-way, 3-shot 5/12/36, 5-shot 5/12/36), 500 episodes each by
default. The same episodes (same seeds) serve every method. Records: one accuracy record
per (method, way, shot) with ``fold=None, condition=None``, plus AFOP-ML's selection record.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np
from tqdm.auto import tqdm

from models.registry import make_method
from shapes.validation import check_int
from synth import Dataset

from ..episodes import sample_episodes
from ..evaluate import evaluate
from ..paper_reference import TABLE_ONE_COLUMNS
from ..results import accuracy_record
from .generalisation import check_methods, child_seed, dataset_features, feature_dim, selection_of

PROTOCOL = "closed-set"
#: Queries per class per episode (the paper does not state it; 5 keeps 36-way-5-shot
#: episodes inside the 30 test trials per class of the paper preset).
N_QUERY = 5
#: Episodes of the 5-way-5-shot column also adapted one at a time for the single-episode
#: latency (the paper's Table I "Adapt/episode" measure); the other columns record only
#: the batched throughput.
LATENCY_EPISODES = 10


def split_halves(labels: np.ndarray, *, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Seeded 50:50 split per class: ``(train_idx, test_idx)`` sorted index arrays.

    A class with an odd count gives its extra trial to the test half; a class with one
    trial goes entirely to the test half.
    """
    y = np.asarray(labels)
    if y.ndim != 1 or y.size == 0:
        raise ValueError(f"labels must be a non-empty 1-D array; got shape {y.shape}")
    check_int("seed", seed, minimum=0)
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0xC105ED]))
    train: list[np.ndarray] = []
    test: list[np.ndarray] = []
    for c in np.unique(y):
        idx = rng.permutation(np.flatnonzero(y == c))
        half = idx.size // 2
        train.append(idx[:half])
        test.append(idx[half:])
    return np.sort(np.concatenate(train)), np.sort(np.concatenate(test))


def columns_for(labels: np.ndarray) -> list[tuple[int, int, int]]:
    """The Table I columns ``(shot, way, query)`` this test pool can hold (query per class
    lowered when classes are small; columns needing more classes or trials are left out)."""
    counts = np.sort(np.unique(labels, return_counts=True)[1])[::-1]
    out = []
    for shot, way in TABLE_ONE_COLUMNS:
        if counts.size < way:
            continue
        q = min(N_QUERY, int(counts[way - 1]) - shot)
        if q >= 1:
            out.append((shot, way, q))
    return out


def run(
    data: Dataset,
    *,
    perturbed: Dataset | None = None,
    methods: Sequence[str] = ("AFOP-ML",),
    episodes: int = 500,
    seed: int = 0,
    progress: bool = False,
    features: np.ndarray | None = None,
) -> list[dict]:
    """Records of the closed-set protocol (``perturbed`` is not used)."""
    del perturbed
    methods = check_methods(methods)
    check_int("episodes", episodes, minimum=1)
    check_int("seed", seed, minimum=0)
    if features is None:
        features = dataset_features(data)
    train, test = split_halves(data.label, seed=seed)
    test_labels = data.label[test]
    cols = columns_for(test_labels)
    if not cols:
        raise ValueError(
            "the dataset's test half is too small for any Table I column (needs >= 5 "
            "classes with >= 2 test trials each)"
        )
    records: list[dict] = []
    bar = tqdm(total=len(methods) * len(cols), desc=PROTOCOL, disable=None if progress else True)
    try:
        for name in methods:
            method = make_method(name, seed=child_seed(seed, PROTOCOL, "fit"))
            t0 = time.perf_counter()
            method.fit(data.signals[train], data.label[train], features=features[train])
            pretrain_s = time.perf_counter() - t0
            if name == "AFOP-ML":
                records.append(selection_of(PROTOCOL, None, method))
            for shot, way, q in cols:
                bar.set_postfix_str(f"{name} {shot}-shot {way}-way")
                batch = sample_episodes(
                    test_labels,
                    n_way=way,
                    k_shot=shot,
                    n_query=q,
                    episodes=episodes,
                    seed=child_seed(seed, PROTOCOL, way, shot),
                )
                result = evaluate(
                    method,
                    data.signals[test],
                    batch,
                    features=features[test],
                    latency_episodes=LATENCY_EPISODES if (shot, way) == (5, 5) else 0,
                )
                records.append(
                    accuracy_record(
                        protocol=PROTOCOL,
                        fold=None,
                        condition=None,
                        method=name,
                        way=way,
                        shot=shot,
                        query=q,
                        result=result,
                        pretrain_s=pretrain_s,
                        feature_dim=feature_dim(method),
                    )
                )
                bar.update(1)
    finally:
        bar.close()
    return records
