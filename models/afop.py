"""AFOP-ML (paper Sec. IV): automatic feature optimisation + adapted cosine prototypes.

Offline (``fit``, source classes only): the 386-feature pool, z-scored with training
statistics; NCA feature-selection weights rank the features; the D-scan picks the top-D
size. Episode time (``predict_episodes``): the top-D z-scored features of the pool feed
the cosine-softmax prototypical head, adapted on each support set (all episodes batched).
"""

from __future__ import annotations

import numpy as np

from .base import FewShotMethod
from .dscan import DEFAULT_CANDIDATES, dscan
from .features import FEATURE_NAMES, pool_of
from .ncfs import NCFS
from .prototypes import adapt_cosine_head
from .scaling import FeatureScaler


class AFOPML(FewShotMethod):
    """AFOP-ML. Learned: ``scaler_``, ``ncfs_`` (weights, ranking), ``dscan_`` (curve),
    ``D_`` (chosen size), ``selected_`` (indices of the top-D features).

    ``ncfs_max_iter`` = 10 L-BFGS iterations of the NCA ranking: on the paper dataset's
    closed-set half (1,080 trials) pretrain takes 1.5 s instead of 3.2 s with 25, and
    5-way-5-shot / 36-way-1-shot accuracy moved from 96.5 / 64.4 % to 96.2 / 63.5 %
    (300 / 100 episodes; within about one CI).
    """

    name = "AFOP-ML"

    def __init__(
        self,
        *,
        seed: int = 0,
        steps: int = 250,
        lr: float = 1.5e-3,
        lam: float = 0.10,
        alpha: float = 10.0,
        candidates: tuple[int, ...] = DEFAULT_CANDIDATES,
        dscan_episodes: int = 200,
        ncfs_max_iter: int = 10,
    ) -> None:
        super().__init__(seed=seed)
        self.steps = steps
        self.lr = lr
        self.lam = lam
        self.alpha = alpha
        self.candidates = candidates
        self.dscan_episodes = dscan_episodes
        self.ncfs_max_iter = ncfs_max_iter

    def _fit(self, signals: np.ndarray, labels: np.ndarray, features: np.ndarray | None) -> None:
        raw = pool_of(signals, features)
        self.scaler_ = FeatureScaler().fit(raw)
        z = self.scaler_.transform(raw)
        self.ncfs_ = NCFS(max_iter=self.ncfs_max_iter).fit(z, labels)
        scan = dscan(
            z,
            labels,
            self.ncfs_.ranking_,
            candidates=self.candidates,
            episodes=self.dscan_episodes,
            seed=self.seed,
        )
        self.dscan_ = scan.as_dict()
        self.D_ = scan.best
        self.selected_ = self.ncfs_.ranking_[: self.D_].copy()

    @property
    def selected_names_(self) -> tuple[str, ...]:
        return tuple(FEATURE_NAMES[i] for i in self.selected_)

    def embed(self, signals: np.ndarray, features: np.ndarray | None = None) -> np.ndarray:
        """Top-D z-scored features ``(n, D)`` of trials (after ``fit``)."""
        raw = pool_of(signals, features)
        return self.scaler_.transform(raw)[:, self.selected_]

    def _predict(
        self,
        signals: np.ndarray,
        support: np.ndarray,
        query: np.ndarray,
        features: np.ndarray | None,
    ) -> np.ndarray:
        return adapt_cosine_head(
            self.embed(signals, features),
            support,
            query,
            steps=self.steps,
            lr=self.lr,
            lam=self.lam,
            alpha=self.alpha,
        )
