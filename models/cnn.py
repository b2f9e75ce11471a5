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
- Training: Adam on the support cross-entropy (full batch), from a fresh He
  initialisation per episode. The paper gives no training settings for this baseline, so
  ``fit`` chooses them on validation episodes drawn from the training split
  (:func:`models.nets.select_schedule`): for each of Table I's shots (1, 3, 5) and the
  ways 5, 12 and 36 (lowered to the training classes), every rate of :data:`LRS` is
  trained on the same episodes and read at 5, 10, 20, ... steps until a doubling brings no
  gain beyond the best point's 95 % CI; the setting is the fewest steps within the 95 % CI
  of the best accuracy. A test episode takes the setting of the validated cell nearest in
  shot, then in way (log scale). The way matters as much as the shot: on the paper
  preset's training half the 5-way 1-shot curves level off after 20-40 steps and the
  36-way ones after 40-160 (a 36-way 1-shot network reads 14 % after 20 steps at the
  middle rate and 25 % after 40), so one setting chosen at 5 ways could leave the large
  episodes unfitted.
  ``schedule_`` holds the settings and the curves. Passing ``lr`` and ``steps`` skips the
  selection; passing one fixes its axis.

One network per episode, trained for all episodes of a chunk at once: the E networks'
weights are stacked and applied with grouped convolutions (:mod:`models.nets`).
"""

from __future__ import annotations

import numpy as np
import torch

from .base import FewShotMethod
from .nets import (
    ChannelScaler,
    ConvLayer,
    EpisodeNet,
    PoolCache,
    Schedule,
    cnn_forward,
    episode_inputs,
    init_cnn,
    resample,
    schedule,
    train_per_episode,
)

LAYERS = (
    ConvLayer(4, 8, 16, stride=8),
    ConvLayer(8, 16, 5, stride=2),
    ConvLayer(16, 16, 5),
)
#: Candidate Adam learning rates of the validation.
LRS = (3e-3, 1e-2, 3e-2)
#: Episodes trained together, and support examples in all (cache-sized: see
#: :func:`models.nets.episodes_per_chunk`).
CHUNK = 64
ROWS = 3072

NET = EpisodeNet(
    init=lambda e, n, gen: init_cnn(LAYERS, n, gen, copies=e),
    gather=episode_inputs,
    forward=lambda xs, params: cnn_forward(xs, params, LAYERS).transpose(0, 1),
    chunk=CHUNK,
    rows=ROWS,
)


def predict_scheduled(
    net: EpisodeNet,
    x: torch.Tensor,
    support: np.ndarray,
    query: np.ndarray,
    plan: Schedule,
    seed: int,
) -> np.ndarray:
    """Predictions ``(E, M)`` of per-episode networks trained with the setting ``plan``
    gives these episodes' shot and way."""
    _, n_way, k_shot = support.shape
    setting = plan.of(k_shot, n_way)
    return train_per_episode(net, x, support, query, steps=setting.steps, lr=setting.lr, seed=seed)


class CNNBaseline(FewShotMethod):
    """CNN: a small 1-D CNN trained from scratch on each episode's support set.

    Parameters
    ----------
    seed : int, default 0
        Seeds the networks' initialisation and the validation episodes.
    steps : int or None
        Adam steps per episode (None: chosen on validation episodes of the training
        split, per shot and way).
    lr : float or None
        Adam learning rate (None: chosen likewise, from :data:`LRS`).

    Attributes
    ----------
    scaler_ : models.nets.ChannelScaler
        Per-channel z-scoring with training statistics.
    schedule_ : models.nets.Schedule
        Rate and steps per validated shot and way, with the validation curves.
    feature_dim_ : int
        16: the width of the embedding before the linear head.

    Examples
    --------
    >>> from tests.synthetic_data import make_dataset
    >>> data = make_dataset(trials_per_class=3, shapes=("circle", "square", "moon"),
    ...                     n_samples=1000, noise=0.1)
    >>> from models.episodes import sample_episodes
    >>> batch = sample_episodes(data.label, n_way=3, k_shot=1, n_query=2, episodes=4, seed=0)
    >>> model = CNNBaseline(steps=10, lr=1e-2).fit(data.signals, data.label)
    >>> model.predict_episodes(data.signals, batch.support, batch.query).shape
    (4, 6)
    """

    name = "CNN"
    cost_hint = (60.0, 60.0)

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
        self.schedule_ = schedule(
            NET,
            steps=self.steps,
            lr=self.lr,
            inputs=lambda: torch.as_tensor(self.scaler_.transform(small)),
            labels=labels,
            seed=self.seed,
            lrs=LRS,
            needed=self.test_cells_,
        )

    def _predict(
        self,
        signals: np.ndarray,
        support: np.ndarray,
        query: np.ndarray,
        features: np.ndarray | None,
    ) -> np.ndarray:
        x = self._cache.get(signals, lambda s: torch.as_tensor(self.scaler_.transform(resample(s))))
        return predict_scheduled(NET, x, support, query, self.schedule_, self.seed)
