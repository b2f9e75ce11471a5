"""Direct-Prot-ML (paper Sec. V): all 386 z-scored features straight into the
prototypical head (no NCA ranking, no D-scan), adapted per episode like AFOP-ML's head.

The head's 250 steps, lr 1.5e-3 and entropy weight 0.10 are the paper's; ``alpha`` (its
temperature, not given in the paper) defaults to the value ``scripts/tune.py`` chose for
this method on validation data of the closed-set training half (:mod:`models.tuned`)."""

from __future__ import annotations

import numpy as np

from .base import FewShotMethod
from .features import N_FEATURES, pool_of
from .prototypes import adapt_cosine_head
from .scaling import FeatureScaler
from .tuned import tuned


class DirectProtML(FewShotMethod):
    """Learned: ``scaler_`` (training-set z-scoring); ``feature_dim_`` = 386."""

    name = "Direct-Prot-ML"
    cost_hint = (0.5, 3.0)

    def __init__(
        self,
        *,
        seed: int = 0,
        steps: int = 250,
        lr: float = 1.5e-3,
        lam: float = 0.10,
        alpha: float | None = None,
    ) -> None:
        super().__init__(seed=seed)
        self.steps = steps
        self.lr = lr
        self.lam = lam
        self.alpha = tuned(self.name, "alpha") if alpha is None else alpha
        self._check_settings(steps="steps", lr="rate", lam="weight", alpha="rate")

    def _fit(self, signals: np.ndarray, labels: np.ndarray, features: np.ndarray | None) -> None:
        raw = pool_of(signals, features)
        self.scaler_ = FeatureScaler().fit(raw)
        self.feature_dim_ = N_FEATURES

    def _predict(
        self,
        signals: np.ndarray,
        support: np.ndarray,
        query: np.ndarray,
        features: np.ndarray | None,
    ) -> np.ndarray:
        raw = pool_of(signals, features)
        return adapt_cosine_head(
            self.scaler_.transform(raw),
            support,
            query,
            steps=self.steps,
            lr=self.lr,
            lam=self.lam,
            alpha=self.alpha,
        )
