"""CNN without meta-learning (paper Table I, "DL without meta-learning"): a small 1-D CNN
trained from scratch on each episode's support set only, then applied to its queries.

One network per episode, trained for all episodes of a chunk at once: the E networks'
weights are stacked and applied with grouped convolutions (:mod:`models.nets`). Input:
per-channel z-scored signals (training-set statistics), block-averaged to 125 Hz.
``fit`` only learns that scaling (the paper lists no pretraining for this baseline).
"""

from __future__ import annotations

import numpy as np
import torch

from .base import FewShotMethod
from .nets import (
    ChannelScaler,
    cnn_forward,
    decimate,
    episode_inputs,
    init_cnn,
    train_per_episode,
)

CHUNK = 64
#: Support examples trained at once (cache-sized: see :func:`models.nets.episodes_per_chunk`).
ROWS = 3072


class CNNBaseline(FewShotMethod):
    name = "CNN"

    def __init__(self, *, seed: int = 0, steps: int = 30, lr: float = 2e-2) -> None:
        super().__init__(seed=seed)
        self.steps = steps
        self.lr = lr

    def _fit(self, signals: np.ndarray, labels: np.ndarray, features: np.ndarray | None) -> None:
        self.scaler_ = ChannelScaler().fit(decimate(signals))

    def _predict(
        self,
        signals: np.ndarray,
        support: np.ndarray,
        query: np.ndarray,
        features: np.ndarray | None,
    ) -> np.ndarray:
        return train_per_episode(
            torch.as_tensor(self.scaler_.transform(decimate(signals))),
            support,
            query,
            init=lambda e, n, gen: init_cnn(n, gen, copies=e),
            gather=episode_inputs,
            forward=lambda xs, params: cnn_forward(xs, params).transpose(0, 1),
            steps=self.steps,
            lr=self.lr,
            seed=self.seed,
            chunk=CHUNK,
            rows=ROWS,
        )
