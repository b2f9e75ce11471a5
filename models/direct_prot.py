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
    """Direct-Prot-ML: all 386 z-scored features into the adapted cosine prototypical head.

    Parameters
    ----------
    seed : int, default 0
        Seeds the head's adaptation.
    steps : int, default 250
        Adam steps of the head's adaptation per episode (paper).
    lr : float, default 1.5e-3
        The head's Adam learning rate (paper).
    lam : float, default 0.10
        Weight of the posteriors' entropy in the head's loss (paper).
    alpha : float or None
        The head's temperature (None: the tuned value, :mod:`models.tuned`).

    Attributes
    ----------
    scaler_ : models.scaling.FeatureScaler
        z-scoring of the 386 features with training statistics.
    feature_dim_ : int
        386: the head works in the whole feature pool.

    Examples
    --------
    >>> from tests.synthetic_data import make_dataset
    >>> data = make_dataset(trials_per_class=3, shapes=("circle", "square", "moon"),
    ...                     n_samples=1000, noise=0.1)
    >>> from models.episodes import sample_episodes
    >>> batch = sample_episodes(data.label, n_way=3, k_shot=1, n_query=2, episodes=4, seed=0)
    >>> model = DirectProtML(steps=20).fit(data.signals, data.label)
    >>> model.predict_episodes(data.signals, batch.support, batch.query).shape
    (4, 6)
    """

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
