"""CNN without meta-learning (paper Table I, "DL without meta-learning"): a small 1-D CNN
trained from scratch on each episode's support set only, then applied to its queries.

- Input: per-channel z-scored signals (training-set statistics), resampled without
  aliasing to 500 Hz (:func:`models.nets.resample`: the band up to 250 Hz is kept).
- Network (:data:`LAYERS`, ReLU after each convolution): a strided filter bank (8 filters
  of 32 ms, stride 16 ms), then two convolutions of 16 channels (5 taps; the first with
  stride 2), global average pooling and a linear head: receptive field about 220 ms,
  16-d embedding. Strided convolutions take the place of max-pooling (as in the
  all-convolutional net of Springenberg et al. 2015): the same down-sampling at half the
  convolution cost.
- Training: Adam on the support cross-entropy, from a fresh He initialisation per
  episode. The paper gives no training settings for this baseline, so ``fit`` chooses
  the learning rate (from :data:`LRS`) and the number of steps (from :data:`STEPS`) on
  5-way 1- and 5-shot validation episodes drawn from the training split
  (:func:`models.nets.select_steps_lr`); ``selection_`` records the grid and accuracies.
  Passing ``lr`` and ``steps`` skips the selection. :data:`STEPS` stops at 20 to keep the
  500-episode closed-set table within the run's time budget (the larger rates of
  :data:`LRS` make up for fewer steps where the validation episodes say so).

One network per episode, trained for all episodes of a chunk at once: the E networks'
weights are stacked and applied with grouped convolutions (:mod:`models.nets`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch

from .base import FewShotMethod
from .nets import (
    ChannelScaler,
    ConvLayer,
    PoolCache,
    cnn_forward,
    episode_inputs,
    init_cnn,
    resample,
    steps_and_lr,
    train_per_episode,
)

LAYERS = (
    ConvLayer(4, 8, 16, stride=8),
    ConvLayer(8, 16, 5, stride=2),
    ConvLayer(16, 16, 5),
)
#: Candidate Adam learning rates and step counts for the validation selection.
LRS = (3e-3, 1e-2, 3e-2)
STEPS = (10, 20)
#: Validation episodes per shot (1 and 5) in ``fit``.
VAL_EPISODES = 40
CHUNK = 64
#: Support examples trained at once (cache-sized: see :func:`models.nets.episodes_per_chunk`).
ROWS = 3072


def _train(
    x: torch.Tensor,
    support: np.ndarray,
    query: np.ndarray,
    *,
    steps: int | Sequence[int],
    lr: float,
    seed: int,
) -> np.ndarray:
    return train_per_episode(
        x,
        support,
        query,
        init=lambda e, n, gen: init_cnn(LAYERS, n, gen, copies=e),
        gather=episode_inputs,
        forward=lambda xs, params: cnn_forward(xs, params, LAYERS).transpose(0, 1),
        steps=steps,
        lr=lr,
        seed=seed,
        chunk=CHUNK,
        rows=ROWS,
    )


class CNNBaseline(FewShotMethod):
    """Learned: ``scaler_``, ``lr_`` and ``steps_`` (chosen on validation episodes of the
    training split unless given), ``selection_`` (the grid); ``feature_dim_`` = 16."""

    name = "CNN"

    def __init__(self, *, seed: int = 0, steps: int | None = None, lr: float | None = None):
        super().__init__(seed=seed)
        self.steps = steps
        self.lr = lr
        self._check_settings(steps="count", lr="rate")

    def _fit(self, signals: np.ndarray, labels: np.ndarray, features: np.ndarray | None) -> None:
        self._cache = PoolCache()
        small = resample(signals)
        self.scaler_ = ChannelScaler().fit(small)
        self.feature_dim_ = LAYERS[-1].c_out
        self.lr_, self.steps_, self.selection_ = steps_and_lr(
            steps=self.steps,
            lr=self.lr,
            inputs=lambda: torch.as_tensor(self.scaler_.transform(small)),
            labels=labels,
            train=_train,
            seed=self.seed,
            lrs=LRS,
            grid_steps=STEPS,
            episodes=VAL_EPISODES,
        )

    def _predict(
        self,
        signals: np.ndarray,
        support: np.ndarray,
        query: np.ndarray,
        features: np.ndarray | None,
    ) -> np.ndarray:
        x = self._cache.get(signals, lambda s: torch.as_tensor(self.scaler_.transform(resample(s))))
        return _train(x, support, query, steps=self.steps_, lr=self.lr_, seed=self.seed)
