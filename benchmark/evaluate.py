"""Run a fitted method on a batch of episodes and score it.

Returns a result object (never a bare float): per-episode accuracies, their mean, the
95% CI half-width ``1.96 * std / sqrt(E)``, the episode seed, and two kinds of timing,
each named for what it measures:

- ``batch_ms_per_episode`` (batched throughput): wall time of ONE ``predict_episodes``
  call that adapts all E episodes of the batch together (methods stack episodes into
  tensor problems), with the 386-feature pool precomputed, divided by E. This is an
  amortised cost, not the time a user waits for one episode.
- ``latency_ms_per_episode`` (single-episode latency, the paper's Table I "Adapt/episode"
  measure): mean wall time of adapting ONE episode at a time (a ``predict_episodes``
  call on a pool holding only that episode's support and query trials), features
  precomputed; ``latency_with_features_ms_per_episode``: the same call starting from
  raw signals, so it includes extracting the 386-feature pool of the episode's trials
  (methods that read raw signals do their own preprocessing in both). Measured on the
  first ``latency_episodes`` episodes of the batch after one untimed warm-up call; None
  when not measured.

Query labels stay here: the method sees only trial indices.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from models.base import FewShotMethod
from models.stats import ci95
from tactile_synth.validation import check_int

from .episodes import EpisodeBatch


@dataclass(frozen=True)
class EvalResult:
    """accuracies: ``(E,)`` fraction of each episode's queries labelled right; timing
    fields as in the module docstring (``latency_*`` are None when not measured)."""

    accuracies: np.ndarray
    accuracy: float
    ci95: float
    episodes: int
    seed: int
    batch_ms_per_episode: float
    predictions: np.ndarray
    latency_ms_per_episode: float | None = None
    latency_with_features_ms_per_episode: float | None = None
    latency_episodes: int = 0

    @property
    def adapt_ms_per_episode(self) -> float:
        """Batched throughput (``batch_ms_per_episode``), under the results.json name."""
        return self.batch_ms_per_episode


def evaluate(
    method: FewShotMethod,
    signals: np.ndarray,
    batch: EpisodeBatch,
    *,
    features: np.ndarray | None = None,
    latency_episodes: int = 0,
) -> EvalResult:
    """Adapt ``method`` to every episode of ``batch`` (indices into ``signals``) and score.

    ``latency_episodes`` > 0 also times that many episodes one at a time (see the module
    docstring); it does not change the scores, which come from the batched call.
    """
    if not isinstance(batch, EpisodeBatch):
        raise ValueError(f"batch must be an EpisodeBatch; got {type(batch).__name__}")
    check_int("latency_episodes", latency_episodes, minimum=0)
    t0 = time.perf_counter()
    pred = method.predict_episodes(signals, batch.support, batch.query, features=features)
    elapsed = time.perf_counter() - t0
    acc = (np.asarray(pred) == batch.query_labels).mean(axis=1)
    n_lat = min(latency_episodes, acc.size)
    lat = lat_f = None
    if n_lat:
        lat, lat_f = single_episode_latency(method, signals, batch, features, n_lat)
    return EvalResult(
        accuracies=acc,
        accuracy=float(acc.mean()),
        ci95=ci95(acc),
        episodes=int(acc.size),
        seed=batch.seed,
        batch_ms_per_episode=elapsed / acc.size * 1e3,
        predictions=np.asarray(pred),
        latency_ms_per_episode=lat,
        latency_with_features_ms_per_episode=lat_f,
        latency_episodes=n_lat,
    )


def _episode_pool(batch: EpisodeBatch, e: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Trials of episode ``e`` and its support/query re-indexed into them."""
    trials, inverse = np.unique(
        np.concatenate([batch.support[e].ravel(), batch.query[e]]), return_inverse=True
    )
    n_support = batch.support[e].size
    support = inverse[:n_support].reshape(1, *batch.support.shape[1:])
    query = inverse[n_support:].reshape(1, -1)
    return trials, support, query


def single_episode_latency(
    method: FewShotMethod,
    signals: np.ndarray,
    batch: EpisodeBatch,
    features: np.ndarray | None,
    n: int,
) -> tuple[float, float]:
    """(ms without, ms with feature extraction): mean wall time of adapting episodes
    ``0..n-1`` of ``batch`` one at a time, each on a pool of only its own trials."""
    from models.features import extract

    check_int("n", n, minimum=1)
    pools = [_episode_pool(batch, e) for e in range(n)]
    pool_features = [
        extract(signals[t]) if features is None else np.asarray(features)[t] for t, _, _ in pools
    ]
    # One untimed call first: lazy imports and first-touch allocations are not per-episode.
    # It is made on the last episode's pool and each timed loop runs through all pools, so
    # with two or more episodes no timed call meets the pool of the call before it: a
    # method that keeps the prepared input of the last pool (scalograms, resampled
    # signals) prepares every timed episode's own, as a new episode of new trials needs.
    t, s, q = pools[-1]
    method.predict_episodes(signals[t], s, q, features=pool_features[-1])
    sigs = [np.ascontiguousarray(signals[t]) for t, _, _ in pools]
    without, with_features = [], []
    for sig, (_, s, q), f in zip(sigs, pools, pool_features, strict=True):
        t0 = time.perf_counter()
        method.predict_episodes(sig, s, q, features=f)
        without.append(time.perf_counter() - t0)
    for sig, (_, s, q) in zip(sigs, pools, strict=True):
        t0 = time.perf_counter()
        method.predict_episodes(sig, s, q, features=None)
        with_features.append(time.perf_counter() - t0)
    return float(np.mean(without) * 1e3), float(np.mean(with_features) * 1e3)
