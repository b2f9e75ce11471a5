"""A complete user method: nearest class mean on the z-scored 386-feature pool.

Benchmark it without editing tactile-synth (run from the repository root)::

    tactile-synth benchmark closed-set --data data/quick --out out/mine \
        --methods AFOP-ML examples/nearest_mean.py:NearestClassMean

or install it as a plug-in (see docs/methods.md) under a name of your choice.

``fit`` learns only the z-scoring statistics of the training trials' features; for each
episode, ``predict_episodes`` averages the K support trials of every episode class into a
class mean and gives each query the class of the nearest mean (Euclidean distance).
"""

from __future__ import annotations

import numpy as np

from models.base import FewShotMethod
from models.features import N_FEATURES, pool_of
from models.scaling import FeatureScaler


class NearestClassMean(FewShotMethod):
    """Learned: ``scaler_`` (z-scoring of the training features); ``feature_dim_`` = 386."""

    name = "nearest-class-mean"

    def _fit(self, signals: np.ndarray, labels: np.ndarray, features: np.ndarray | None) -> None:
        # pool_of: the given (n, 386) features, or extracted from the signals when None.
        self.scaler_ = FeatureScaler().fit(pool_of(signals, features))
        self.feature_dim_ = N_FEATURES

    def _predict(
        self,
        signals: np.ndarray,
        support: np.ndarray,
        query: np.ndarray,
        features: np.ndarray | None,
    ) -> np.ndarray:
        x = self.scaler_.transform(pool_of(signals, features))  # (P, 386)
        means = x[support].mean(axis=2)  # (E, N, 386): one mean per episode class
        q = x[query]  # (E, M, 386)
        # Squared distance to each mean, less the |q|^2 every mean shares: (E, M, N).
        dist = (means**2).sum(axis=-1)[:, None, :] - 2 * np.einsum("emd,end->emn", q, means)
        return dist.argmin(axis=-1)  # (E, M) episode-class positions 0..N-1
