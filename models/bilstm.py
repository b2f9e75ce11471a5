"""BiLSTM without meta-learning (paper Table I): a bidirectional LSTM trained from scratch
on each episode's support set only, then applied to its queries.

Input sequence: the 2 s window cut into 50 frames of 40 ms; each frame is described by
the mean and standard deviation of each z-scored channel (8 values per step). This keeps
the recurrence at 50 steps (the raw 2,000-sample sequence would make one network per
episode, 500 episodes per column, far beyond a 2-core budget); a 40 ms frame is shorter
than any edge transient at 10 mm/s.

The E networks of a chunk of episodes are trained together: their weights are stacked
``(E, ...)`` and every product is a batched matmul, so episodes never interact.
"""

from __future__ import annotations

import numpy as np
import torch

from .base import FewShotMethod
from .nets import ChannelScaler, train_per_episode

FRAMES = 50
HIDDEN = 16
CHUNK = 128


def frame_features(z: np.ndarray, frames: int = FRAMES) -> np.ndarray:
    """``(n, 4, T)`` z-scored signals -> ``(n, frames, 8)`` per-frame mean and std."""
    n, c, t = z.shape
    x = z[..., : t // frames * frames].reshape(n, c, frames, -1)
    return np.concatenate([x.mean(-1), x.std(-1)], axis=1).transpose(0, 2, 1).astype(np.float32)


def _init(e: int, d_in: int, n_out: int, gen: torch.Generator) -> list[torch.Tensor]:
    k = HIDDEN**-0.5
    params = []
    for _ in range(2):  # forward, backward direction
        params.append((torch.rand(e, d_in, 4 * HIDDEN, generator=gen) * 2 - 1) * k)
        params.append((torch.rand(e, HIDDEN, 4 * HIDDEN, generator=gen) * 2 - 1) * k)
        params.append(torch.zeros(e, 1, 4 * HIDDEN))
    params.append((torch.rand(e, 2 * HIDDEN, n_out, generator=gen) * 2 - 1) * (2 * HIDDEN) ** -0.5)
    params.append(torch.zeros(e, 1, n_out))
    return params


def _run(xw: torch.Tensor, w_hh: torch.Tensor, reverse: bool) -> torch.Tensor:
    """One LSTM direction over precomputed input projections ``(E, R, T, 4H)``; returns the
    final hidden state ``(E, R, H)``."""
    e, r = xw.shape[:2]
    h = xw.new_zeros(e, r, HIDDEN)
    c = xw.new_zeros(e, r, HIDDEN)
    # unbind once: indexing a time step per iteration would make autograd write a full
    # zero tensor of xw's size per step in the backward pass.
    inputs = xw.unbind(dim=2)
    for x_t in reversed(inputs) if reverse else inputs:
        g = x_t + torch.bmm(h, w_hh)
        ig, fg, gg, og = g.chunk(4, dim=-1)
        c = torch.sigmoid(fg) * c + torch.sigmoid(ig) * torch.tanh(gg)
        h = torch.sigmoid(og) * torch.tanh(c)
    return h


def bilstm_forward(x: torch.Tensor, params: list[torch.Tensor]) -> torch.Tensor:
    """x ``(E, R, T, 8)`` -> logits ``(E, R, N)``."""
    finals = []
    for d, reverse in enumerate((False, True)):
        w_ih, w_hh, b = params[3 * d : 3 * d + 3]
        xw = torch.einsum("ertd,edg->ertg", x, w_ih) + b[:, :, None, :]
        finals.append(_run(xw, w_hh, reverse))
    w_out, b_out = params[-2], params[-1]
    return torch.bmm(torch.cat(finals, dim=-1), w_out) + b_out


class BiLSTMBaseline(FewShotMethod):
    name = "BiLSTM"

    def __init__(self, *, seed: int = 0, steps: int = 30, lr: float = 2e-2) -> None:
        super().__init__(seed=seed)
        self.steps = steps
        self.lr = lr

    def _fit(self, signals: np.ndarray, labels: np.ndarray, features: np.ndarray | None) -> None:
        self.scaler_ = ChannelScaler().fit(signals)

    def _predict(
        self,
        signals: np.ndarray,
        support: np.ndarray,
        query: np.ndarray,
        features: np.ndarray | None,
    ) -> np.ndarray:
        x = torch.as_tensor(frame_features(self.scaler_.transform(signals)))
        return train_per_episode(
            x,
            support,
            query,
            init=lambda e, n, gen: _init(e, x.shape[-1], n, gen),
            gather=lambda xs, idx: xs[torch.as_tensor(idx)],
            forward=bilstm_forward,
            steps=self.steps,
            lr=self.lr,
            seed=self.seed,
            chunk=CHUNK,
        )
