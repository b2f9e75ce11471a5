"""MAML (paper Table I): a 1-D CNN on the raw 4-channel signals (125 Hz, z-scored),
meta-trained with first-order MAML on episodes of the training classes, then adapted to
each test episode with a few gradient steps on its support set.

- Inner loop: ``inner_steps`` (5) plain SGD steps at ``inner_lr`` (0.1) on the support
  cross-entropy during meta-training, ``test_steps`` (30) at test time; all weights
  (conv body and head) are adapted. (Measured on a 36-class synthetic set: 10 test steps
  gave 65 % at 5-way-1-shot, 30 gave 74 %; inner rates 0.4 and 1.0 diverged.)
- Outer loop: first-order MAML (the query-loss gradient at the adapted weights is the
  meta-gradient), Adam at ``outer_lr`` (1e-3), ``meta_batch`` (8) tasks per step,
  ``meta_iterations`` (200) steps of 5-way episodes.
- The classifier head starts at zero for every task (as in "unicorn-MAML", Ye & Chao
  2022): the output layer is then the same for all N and label orders, so one
  meta-learned body serves 5-way meta-training and N-way tests alike.

Written with plain tensors and ``torch.autograd.grad`` (no meta-learning library): the
tasks of a meta-batch, and the test episodes of a chunk, are separate networks stacked
along a leading axis (grouped convolutions, :mod:`models.nets`).
"""

from __future__ import annotations

import numpy as np
import torch

from .base import FewShotMethod
from .episodes import meta_training_episodes
from .nets import (
    ChannelScaler,
    cnn_forward,
    decimate,
    episode_inputs,
    episodes_per_chunk,
    init_cnn,
)

CHUNK = 64
#: Support examples adapted at once (cache-sized: see :func:`models.nets.episodes_per_chunk`).
ROWS = 3072


def _zero_head(params: list[torch.Tensor], copies: int, n_way: int) -> list[torch.Tensor]:
    body = [p.expand(copies, *p.shape[1:]).clone() for p in params[:-2]]
    c_last = params[-3].shape[1]
    return [*body, torch.zeros(copies, c_last, n_way), torch.zeros(copies, n_way)]


def _adapt(
    x: torch.Tensor,
    support: np.ndarray,
    body: list[torch.Tensor],
    n_way: int,
    k_shot: int,
    steps: int,
    lr: float,
) -> list[torch.Tensor]:
    """Inner loop for E tasks at once; returns the adapted (detached) weights."""
    e = support.shape[0]
    fast = [p.detach().requires_grad_(True) for p in _zero_head(body, e, n_way)]
    xs = episode_inputs(x, support.reshape(e, -1))
    tgt = torch.arange(n_way).repeat_interleave(k_shot)[:, None].expand(-1, e).reshape(-1)
    for _ in range(steps):
        logits = cnn_forward(xs, fast)
        loss = torch.nn.functional.cross_entropy(logits.reshape(-1, n_way), tgt) * e
        grads = torch.autograd.grad(loss, fast)
        fast = [(p - lr * g).detach().requires_grad_(True) for p, g in zip(fast, grads)]  # noqa: B905
    return fast


class MAML(FewShotMethod):
    """Learned: ``scaler_`` (per-channel z-scoring), ``body_`` (meta-learned weights)."""

    name = "MAML"

    def __init__(
        self,
        *,
        seed: int = 0,
        meta_iterations: int = 200,
        meta_batch: int = 8,
        inner_steps: int = 5,
        inner_lr: float = 0.1,
        outer_lr: float = 1e-3,
        test_steps: int = 30,
    ) -> None:
        super().__init__(seed=seed)
        self.meta_iterations = meta_iterations
        self.meta_batch = meta_batch
        self.inner_steps = inner_steps
        self.inner_lr = inner_lr
        self.outer_lr = outer_lr
        self.test_steps = test_steps

    def _fit(self, signals: np.ndarray, labels: np.ndarray, features: np.ndarray | None) -> None:
        small = decimate(signals)
        self.scaler_ = ChannelScaler().fit(small)
        x = torch.as_tensor(self.scaler_.transform(small))
        gen = torch.Generator().manual_seed(self.seed)
        meta = [p.requires_grad_(True) for p in init_cnn(5, gen, copies=1)]
        opt = torch.optim.Adam(meta, lr=self.outer_lr)
        batch = meta_training_episodes(
            labels, episodes=self.meta_iterations * self.meta_batch, seed=self.seed
        )
        way, shot = batch.n_way, batch.k_shot
        for it in range(self.meta_iterations):
            sl = slice(it * self.meta_batch, (it + 1) * self.meta_batch)
            s, q, ql = batch.support[sl], batch.query[sl], batch.query_labels[sl]
            fast = _adapt(x, s, meta, way, shot, self.inner_steps, self.inner_lr)
            logits = cnn_forward(episode_inputs(x, q), fast)  # (M, B, N)
            tgt = torch.as_tensor(ql.T).reshape(-1)
            loss = torch.nn.functional.cross_entropy(logits.reshape(-1, way), tgt)
            grads = torch.autograd.grad(loss, fast)
            opt.zero_grad(set_to_none=True)
            # First-order MAML: the adapted weights' gradient, averaged over tasks, is the
            # meta-gradient of the body (the head restarts at zero for every task).
            for p, g in zip(meta[:-2], grads[:-2], strict=True):
                p.grad = g.mean(dim=0, keepdim=True) * len(q)
            opt.step()
        self.body_ = [p.detach() for p in meta]

    def _predict(
        self,
        signals: np.ndarray,
        support: np.ndarray,
        query: np.ndarray,
        features: np.ndarray | None,
    ) -> np.ndarray:
        x = torch.as_tensor(self.scaler_.transform(decimate(signals)))
        _, n_way, k_shot = support.shape
        out = np.empty(query.shape, dtype=np.int64)
        step = episodes_per_chunk(n_way * k_shot, cap=CHUNK, rows=ROWS)
        for start in range(0, support.shape[0], step):
            s = support[start : start + step]
            q = query[start : start + step]
            fast = _adapt(x, s, self.body_, n_way, k_shot, self.test_steps, self.inner_lr)
            with torch.no_grad():
                logits = cnn_forward(episode_inputs(x, q), fast)
                out[start : start + s.shape[0]] = logits.argmax(dim=-1).T.numpy()
        return out
