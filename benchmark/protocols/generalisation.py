"""Shared engine of the 1-shot generalisation protocols (paper Section V-C, Fig. 5).

A protocol is a list of train/test *tasks* (a fold, a split or a force/speed condition).
For each method: fit once on a task's training trials, then evaluate N-way-1-shot episodes
(N = 2..12) drawn only from the task's test pool. The same episodes (same seed) are used
for every method, so methods are compared on identical tasks.

Episode seeds derive from ``SeedSequence([seed, protocol tag, task index, way])``; a fit's
seed from ``SeedSequence([seed, protocol tag, task index])``, so results do not depend on
the order or subset of methods requested.
"""

from __future__ import annotations

import time
import zlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from tqdm.auto import tqdm

from models import registry
from models.base import FewShotMethod
from models.registry import make_method
from models.stats import ci95
from shapes.validation import check_int
from synth import Dataset

from ..episodes import sample_episodes
from ..evaluate import evaluate
from ..results import accuracy_record, selection_record

#: The N of the paper's generalisation curves (Fig. 5): 2..12-way.
WAYS: tuple[int, ...] = tuple(range(2, 13))
#: Queries per class per episode (upper bound; lowered when a test pool is too small).
N_QUERY: int = 5
SHOT: int = 1


@dataclass(frozen=True)
class Task:
    """One train/test task of a protocol.

    train_idx / test_idx: int ``(n_train,)`` / ``(n_test,)`` indices into ``train_pool`` /
    ``test_pool`` datasets (the same dataset except for the perturbation protocol).
    """

    fold: int | str | None
    condition: str | None
    train_idx: np.ndarray
    test_idx: np.ndarray


def check_methods(methods: Sequence[str]) -> tuple[str, ...]:
    """Validate method names, plug-in names or ``module:Class`` specs (unknown names
    raise with the valid list, see :func:`models.registry.check_methods`); keep order."""
    return registry.check_methods(methods, arg="method")


def episodes_for(method: str, episodes: int, method_episodes: Mapping[str, int] | None) -> int:
    """Episode budget of ``method``: ``method_episodes[method]`` if given, else ``episodes``."""
    n = (
        episodes
        if not method_episodes or method not in method_episodes
        else method_episodes[method]
    )
    return check_int(f"episodes for {method}", n, minimum=1)


def child_seed(seed: int, *keys: int | str) -> int:
    """A 32-bit seed derived from ``seed`` and ``keys`` (strings hashed with CRC32)."""
    words = [seed] + [k if isinstance(k, int) else zlib.crc32(str(k).encode()) for k in keys]
    return int(np.random.SeedSequence(words).generate_state(1)[0])


def n_query_for(labels: np.ndarray, n_way: int, k_shot: int = SHOT) -> int:
    """Queries per class: :data:`N_QUERY`, fewer if the N-th most populous class of the
    pool has fewer than ``k_shot + N_QUERY`` trials. 0 means N-way is impossible."""
    counts = np.sort(np.unique(labels, return_counts=True)[1])[::-1]
    if counts.size < n_way:
        return 0
    return int(max(0, min(N_QUERY, counts[n_way - 1] - k_shot)))


def _condition_pool(labels: np.ndarray, n_way: int) -> np.ndarray:
    """Indices of the trials whose class has enough trials for ``n_way`` episodes."""
    q = n_query_for(labels, n_way)
    counts = dict(zip(*np.unique(labels, return_counts=True), strict=True))
    ok = [c for c, k in counts.items() if k >= SHOT + q]
    return np.flatnonzero(np.isin(labels, ok))


def run_tasks(
    *,
    protocol: str,
    tasks: Sequence[Task],
    train_signals: np.ndarray,
    train_labels: np.ndarray,
    train_features: np.ndarray | None,
    test_signals: np.ndarray,
    test_labels: np.ndarray,
    test_features: np.ndarray | None,
    methods: Sequence[str],
    episodes: int,
    seed: int,
    progress: bool,
    ways: Sequence[int] = WAYS,
    method_episodes: Mapping[str, int] | None = None,
    on_fit: Callable[[str, Task, FewShotMethod], None] | None = None,
    fit_groups: Sequence[Sequence[int]] | None = None,
    fit_seeds: Sequence[int] | None = None,
) -> list[tuple[dict, np.ndarray]]:
    """Fit every method per task and evaluate 1-shot ``ways`` episodes on its test trials.

    ``fit_groups`` lets several tasks share one fit (the perturbation protocol fits once
    and tests on every condition): a list of task-index groups with the same ``train_idx``.
    ``on_fit(method, task, fitted)`` is called after each fit (selection records).
    ``fit_seeds`` (one per fit group) replaces the derived fit seeds, so a protocol can
    reproduce another protocol's fit exactly (the perturbation protocol re-uses the
    closed-set fit).
    Returns ``(record, per-episode accuracies (E,))`` pairs, one per (task, method, way).
    """
    methods = check_methods(methods)
    groups = (
        [list(g) for g in fit_groups]
        if fit_groups is not None
        else [[i] for i in range(len(tasks))]
    )
    if fit_seeds is not None and len(fit_seeds) != len(groups):
        raise ValueError(f"fit_seeds must hold one seed per fit group ({len(groups)})")
    total = sum(len(g) for g in groups) * len(methods) * len(ways)
    # disable=None: quiet when stderr is not a TTY.
    bar = tqdm(total=total, desc=protocol, disable=None if progress else True, leave=False)
    records: list[tuple[dict, np.ndarray]] = []
    try:
        for g_i, group in enumerate(groups):
            first = tasks[group[0]]
            tr = first.train_idx
            for method_name in methods:
                fit_seed = (
                    child_seed(seed, protocol, g_i, "fit") if fit_seeds is None else fit_seeds[g_i]
                )
                method = make_method(method_name, seed=fit_seed)
                t0 = time.perf_counter()
                method.fit(
                    train_signals[tr],
                    train_labels[tr],
                    features=None if train_features is None else train_features[tr],
                )
                pretrain_s = time.perf_counter() - t0
                if on_fit is not None:
                    on_fit(method_name, first, method)
                n_ep = episodes_for(method_name, episodes, method_episodes)
                for t_i in group:
                    task = tasks[t_i]
                    te = task.test_idx
                    sig = test_signals[te]
                    lab = test_labels[te]
                    feats = None if test_features is None else test_features[te]
                    for way in ways:
                        bar.set_postfix_str(f"{method_name} {_task_name(task)} {way}-way")
                        pool = _condition_pool(lab, way)
                        q = n_query_for(lab, way)
                        if q < 1 or np.unique(lab[pool]).size < way:
                            bar.update(1)
                            continue
                        batch = sample_episodes(
                            lab[pool],
                            n_way=way,
                            k_shot=SHOT,
                            n_query=q,
                            episodes=n_ep,
                            seed=child_seed(seed, protocol, t_i, way),
                        )
                        result = evaluate(
                            method,
                            sig[pool],
                            batch,
                            features=None if feats is None else feats[pool],
                        )
                        rec = accuracy_record(
                            protocol=protocol,
                            fold=task.fold,
                            condition=task.condition,
                            method=method_name,
                            way=way,
                            shot=SHOT,
                            query=q,
                            result=result,
                            pretrain_s=pretrain_s,
                            feature_dim=feature_dim(method),
                        )
                        records.append((rec, np.asarray(result.accuracies)))
                        bar.update(1)
    finally:
        bar.close()
    return records


def _task_name(task: Task) -> str:
    return str(task.fold) if task.fold is not None else str(task.condition or "")


def feature_dim(method: FewShotMethod) -> int | None:
    """Width of the embedding the method's prototypes live in, if it exposes one:
    ``feature_dim_`` when set (AFO-MLP-ML: its 32-wide projection, Direct-Prot-ML: 386),
    else ``D_`` (AFOP-ML: the top-D features)."""
    for attr in ("feature_dim_", "D_"):
        value = getattr(method, attr, None)
        if value is not None:
            return int(value)
    return None


def pool_folds(pairs: Sequence[tuple[dict, np.ndarray]]) -> list[dict]:
    """Across-fold summary records (``fold=None``), one per (condition, method, way): mean
    and ``ci95 = 1.96 * std / sqrt(E)`` over the per-episode accuracies of all folds
    together (``pairs`` = per-fold record with its ``(E,)`` per-episode accuracies).
    Timing fields are the mean over folds (latencies over the folds that measured them),
    ``feature_dim`` the median.
    """
    groups: dict[tuple, list[tuple[dict, np.ndarray]]] = {}
    for r, acc in pairs:
        key = (r["protocol"], r["condition"], r["method"], r["way"], r["shot"])
        groups.setdefault(key, []).append((r, acc))
    out: list[dict] = []
    for rs in groups.values():
        acc = np.concatenate([a for _, a in rs]).astype(np.float64)
        pooled = dict(rs[0][0])
        pooled.update(
            fold=None,
            episodes=int(acc.size),
            accuracy=float(acc.mean()),
            ci95=ci95(acc),
            query=int(min(r["query"] for r, _ in rs)),
            pretrain_s=float(np.mean([r["pretrain_s"] for r, _ in rs])),
            adapt_ms_per_episode=float(np.mean([r["adapt_ms_per_episode"] for r, _ in rs])),
            latency_ms_per_episode=_mean_or_none([r["latency_ms_per_episode"] for r, _ in rs]),
            latency_with_features_ms_per_episode=_mean_or_none(
                [r["latency_with_features_ms_per_episode"] for r, _ in rs]
            ),
            latency_episodes=int(sum(r["latency_episodes"] for r, _ in rs)),
            feature_dim=_median_or_none([r["feature_dim"] for r, _ in rs]),
        )
        out.append(pooled)
    return out


def _mean_or_none(values: Sequence[float | None]) -> float | None:
    v = [x for x in values if x is not None]
    return float(np.mean(v)) if v else None


def _median_or_none(values: Sequence[int | None]) -> int | None:
    v = [x for x in values if x is not None]
    return int(np.median(v)) if v else None


def dataset_features(data: Dataset) -> np.ndarray:
    """The raw 386-feature pool ``(n, 386)`` of every trial of ``data``."""
    from models.features import extract

    return extract(data.signals)


def selection_of(protocol: str, fold: int | str | None, method: FewShotMethod) -> dict:
    """Selection record of a fitted AFOP-ML: chosen D and PVDF/SG shares of its top-D."""
    from models.features import FEATURE_NAMES

    from ..interpret import sensor_shares

    pvdf, sg = sensor_shares(method.selected_, FEATURE_NAMES)
    return selection_record(
        protocol=protocol, fold=fold, D=int(method.D_), pvdf_share=pvdf, sg_share=sg
    )


def run_split_protocol(
    protocol: str,
    data: Dataset,
    tasks: Sequence[Task],
    *,
    methods: Sequence[str],
    episodes: int,
    seed: int,
    progress: bool,
    features: np.ndarray | None,
    method_episodes: Mapping[str, int] | None,
) -> list[dict]:
    """Per-fold and across-fold accuracy records and AFOP-ML selection records of a
    protocol whose tasks all index ``data`` (cross-shape, cross-material)."""
    check_int("seed", seed, minimum=0)
    check_int("episodes", episodes, minimum=1)
    if features is None:
        features = dataset_features(data)
    selections: list[dict] = []

    def on_fit(name: str, task: Task, fitted: FewShotMethod) -> None:
        if name == "AFOP-ML":
            selections.append(selection_of(protocol, task.fold, fitted))

    pairs = run_tasks(
        protocol=protocol,
        tasks=tasks,
        train_signals=data.signals,
        train_labels=data.label,
        train_features=features,
        test_signals=data.signals,
        test_labels=data.label,
        test_features=features,
        methods=methods,
        episodes=episodes,
        seed=seed,
        progress=progress,
        method_episodes=method_episodes,
        on_fit=on_fit,
    )
    return [r for r, _ in pairs] + pool_folds(pairs) + selections


def closed_set_halves(data: Dataset, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(train, test) index arrays of the closed-set protocol's seeded 50:50 per-class split
    (the closed-set protocol's own function, reused so both see the same halves)."""
    from .closed_set import split_halves

    return split_halves(data.label, seed=seed)


@dataclass(frozen=True)
class Reference:
    """The closed-set AFOP-ML fit behind Fig. 5's dashed curve, Fig. 6 and Fig. 7.

    records: accuracy records (``protocol="closed-set", condition="reference"``);
    model: the fitted AFOP-ML; train_idx / test_idx: the closed-set halves of ``data``.
    """

    records: list[dict]
    model: FewShotMethod
    train_idx: np.ndarray
    test_idx: np.ndarray


def closed_set_reference(
    data: Dataset,
    *,
    episodes: int,
    seed: int,
    progress: bool,
    features: np.ndarray | None = None,
) -> Reference:
    """Fit AFOP-ML on the closed-set training half; 1-shot 2..12-way on the test half."""
    if features is None:
        features = dataset_features(data)
    train_idx, test_idx = closed_set_halves(data, seed)
    fitted: list[FewShotMethod] = []
    task = Task(fold=None, condition="reference", train_idx=train_idx, test_idx=test_idx)
    pairs = run_tasks(
        protocol="closed-set",
        tasks=[task],
        train_signals=data.signals,
        train_labels=data.label,
        train_features=features,
        test_signals=data.signals,
        test_labels=data.label,
        test_features=features,
        methods=["AFOP-ML"],
        episodes=episodes,
        seed=seed,
        progress=progress,
        on_fit=lambda _n, _t, m: fitted.append(m),
    )
    return Reference([r for r, _ in pairs], fitted[0], train_idx, test_idx)


def reference_records(
    data: Dataset, *, episodes: int, seed: int, progress: bool, features: np.ndarray | None
) -> list[dict]:
    """Just the records of :func:`closed_set_reference`."""
    return closed_set_reference(
        data, episodes=episodes, seed=seed, progress=progress, features=features
    ).records
