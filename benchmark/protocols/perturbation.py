"""Force/speed perturbation (paper Section V-C, Fig. 5c) and the robustness heat map.

Every method is fitted once on the nominal dataset's closed-set training half (the
closed-set protocol's seeded 50:50 per-class split and fit seed, reused: the paper trains
"at nominal force and speed on the original training set"), then evaluated N-way-1-shot
(N = 2..12) on the perturbation dataset: per force/speed combination
(``condition="force=1.4N,speed=6mm/s"``) and on all its trials together
(``condition="pooled"``). The 5-way-1-shot per-condition records form the force x speed
heat map. ``fold`` is null. One AFOP-ML selection record (the nominal fit).

The "Force&Speed" D of this protocol (paper Fig. 6) is therefore the closed-set D: the fit
is the closed-set fit, and its D-scan sees only nominal training trials (drawing
validation episodes from the perturbed conditions would train on the test conditions).
The report says so next to the value.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from models.base import FewShotMethod
from synth import Dataset

from ..guards import check_perturbation_pair
from ..splits import condition_name
from .generalisation import (
    Task,
    child_seed,
    closed_set_halves,
    dataset_features,
    reference_records,
    run_tasks,
    selection_of,
)

PROTOCOL = "perturbation"
POOLED = "pooled"


def closed_set_fit_seed(seed: int) -> int:
    """The closed-set protocol's fit seed (so this protocol's fit is the closed-set fit)."""
    from .closed_set import PROTOCOL as CLOSED_SET

    return child_seed(seed, CLOSED_SET, "fit")


def conditions(perturbed: Dataset) -> list[tuple[float, float]]:
    """The (force_n, speed_mm_s) combinations present, sorted by force then speed."""
    pairs = {
        (float(f), float(s)) for f, s in zip(perturbed.force_n, perturbed.speed_mm_s, strict=True)
    }
    return sorted(pairs)


def tasks(data: Dataset, perturbed: Dataset, seed: int) -> list[Task]:
    """One task per force/speed condition, then the pooled task; all share one fit."""
    train_idx, _ = closed_set_halves(data, seed)
    out = []
    for f, s in conditions(perturbed):
        idx = np.flatnonzero((perturbed.force_n == f) & (perturbed.speed_mm_s == s))
        out.append(
            Task(fold=None, condition=condition_name(f, s), train_idx=train_idx, test_idx=idx)
        )
    out.append(
        Task(fold=None, condition=POOLED, train_idx=train_idx, test_idx=np.arange(len(perturbed)))
    )
    return out


def run(
    data: Dataset,
    *,
    perturbed: Dataset | None,
    methods: Sequence[str] = ("AFOP-ML",),
    episodes: int = 500,
    seed: int = 0,
    progress: bool = False,
    features: np.ndarray | None = None,
    perturbed_features: np.ndarray | None = None,
    method_episodes: Mapping[str, int] | None = None,
    reference: bool = True,
) -> list[dict]:
    """Records of the perturbation protocol. ``data`` is the nominal dataset,
    ``perturbed`` the perturbation dataset (required); ``features`` /
    ``perturbed_features`` optional precomputed 386-feature pools of each."""
    if perturbed is None:
        raise ValueError("the perturbation protocol needs perturbed= (the perturbation dataset)")
    if len(perturbed) == 0:
        raise ValueError("perturbed dataset is empty")
    check_perturbation_pair(data, perturbed, seeds=False)
    if features is None:
        features = dataset_features(data)
    if perturbed_features is None:
        perturbed_features = dataset_features(perturbed)
    task_list = tasks(data, perturbed, seed)
    selections: list[dict] = []

    def on_fit(name: str, _task: Task, fitted: FewShotMethod) -> None:
        if name == "AFOP-ML":
            selections.append(selection_of(PROTOCOL, None, fitted))

    pairs = run_tasks(
        protocol=PROTOCOL,
        tasks=task_list,
        train_signals=data.signals,
        train_labels=data.label,
        train_features=features,
        test_signals=perturbed.signals,
        test_labels=perturbed.label,
        test_features=perturbed_features,
        methods=methods,
        episodes=episodes,
        seed=seed,
        progress=progress,
        method_episodes=method_episodes,
        on_fit=on_fit,
        fit_groups=[list(range(len(task_list)))],
        fit_seeds=[closed_set_fit_seed(seed)],
    )
    records = [r for r, _ in pairs] + selections
    if reference:
        records += reference_records(
            data, episodes=episodes, seed=seed, progress=progress, features=features
        )
    return records
