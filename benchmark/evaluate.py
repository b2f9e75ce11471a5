"""Run a fitted method on a batch of episodes and score it.

Returns a result object (never a bare float): per-episode accuracies, their mean, the
95% CI half-width ``1.96 * std / sqrt(E)``, the episode seed, and the adaptation time.
Query labels stay here: the method sees only trial indices.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from models.base import FewShotMethod

from .episodes import EpisodeBatch


@dataclass(frozen=True)
class EvalResult:
    """accuracies: ``(E,)`` fraction of each episode's queries labelled right.
    adapt_ms_per_episode: wall time of ``predict_episodes`` over the batch / E (the
    batch is adapted as one tensor problem, so this is the amortised cost)."""

    accuracies: np.ndarray
    accuracy: float
    ci95: float
    episodes: int
    seed: int
    adapt_ms_per_episode: float
    predictions: np.ndarray


def ci95(accuracies: np.ndarray) -> float:
    """Half-width of the 95% normal CI of the mean over episodes."""
    a = np.asarray(accuracies, dtype=np.float64)
    return float(1.96 * a.std() / np.sqrt(a.size)) if a.size else float("nan")


def evaluate(
    method: FewShotMethod,
    signals: np.ndarray,
    batch: EpisodeBatch,
    *,
    features: np.ndarray | None = None,
) -> EvalResult:
    """Adapt ``method`` to every episode of ``batch`` (indices into ``signals``) and score."""
    if not isinstance(batch, EpisodeBatch):
        raise ValueError(f"batch must be an EpisodeBatch; got {type(batch).__name__}")
    t0 = time.perf_counter()
    pred = method.predict_episodes(signals, batch.support, batch.query, features=features)
    elapsed = time.perf_counter() - t0
    acc = (np.asarray(pred) == batch.query_labels).mean(axis=1)
    return EvalResult(
        accuracies=acc,
        accuracy=float(acc.mean()),
        ci95=ci95(acc),
        episodes=int(acc.size),
        seed=batch.seed,
        adapt_ms_per_episode=elapsed / acc.size * 1e3,
        predictions=np.asarray(pred),
    )
