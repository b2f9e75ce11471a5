"""AFO-MLP-ML (paper Sec. V): AFOP-ML's top-D features through a D -> 64 -> 32 MLP
(ReLU) before the cosine prototypical head, in the spirit of TapNet's task-adaptive
projection.

Offline: AFOP-ML's feature optimisation (z-scoring, NCA ranking, D-scan) on the source
classes, then the MLP is meta-trained with prototypical episodes (5-way 5-shot) on the
same classes. Per episode: a copy of the MLP and the head ``(W, b)`` (W initialised from
the projected prototypes) are fine-tuned together on the support set (cross-entropy +
``lam`` entropy, Adam); queries are only forwarded. All episodes of a chunk are one
batched problem: per-episode weights are ``(E, ...)`` tensors multiplied with ``bmm``.

Hyper-parameters: the 64/32 widths are the paper's; the episodic adaptation uses the
paper's head settings (250 Adam steps at lr 1.5e-3, entropy weight 0.10), as AFOP-ML does.
``alpha``, ``meta_iterations`` and ``meta_lr`` default to the values ``scripts/tune.py``
chose on validation data of the closed-set training half (:mod:`models.tuned`);
``meta_batch`` = 16 tasks per meta-step is a fixed compute budget (not tuned).
``ncfs_lam_n`` / ``ncfs_max_iter`` are passed to the AFOP-ML feature optimisation (None:
AFOP-ML's defaults).
"""

from __future__ import annotations

import itertools

import numpy as np
import torch

from .afop import AFOPML
from .base import FewShotMethod
from .episodes import meta_training_episodes
from .features import pool_of
from .prototypes import EPISODE_CHUNK, normalise
from .tuned import tuned

HIDDEN = (64, 32)


def _mlp(x: torch.Tensor, params: list[torch.Tensor]) -> torch.Tensor:
    """Batched MLP: x ``(E, R, D)``, params ``[W1 (E,D,64), b1 (E,1,64), W2, b2]``."""
    w1, b1, w2, b2 = params
    return torch.bmm(torch.relu(torch.bmm(x, w1) + b1), w2) + b2


class AFOMLPML(FewShotMethod):
    """Learned: ``afop_`` (feature optimisation), ``mlp_`` (meta-trained weights),
    ``D_``, ``selected_``, ``feature_dim_`` (= 32, the projection's output)."""

    name = "AFO-MLP-ML"

    def __init__(
        self,
        *,
        seed: int = 0,
        meta_iterations: int | None = None,
        meta_batch: int = 16,
        meta_lr: float | None = None,
        adapt_steps: int = 250,
        adapt_lr: float = 1.5e-3,
        lam: float = 0.10,
        alpha: float | None = None,
        ncfs_lam_n: float | str | None = None,
        ncfs_max_iter: int | None = None,
    ) -> None:
        super().__init__(seed=seed)
        self.ncfs_lam_n = ncfs_lam_n  # None: AFOP-ML's own defaults
        self.ncfs_max_iter = ncfs_max_iter
        self.meta_iterations = (
            tuned(self.name, "meta_iterations") if meta_iterations is None else meta_iterations
        )
        self.meta_batch = meta_batch
        self.meta_lr = tuned(self.name, "meta_lr") if meta_lr is None else meta_lr
        self.adapt_steps = adapt_steps
        self.adapt_lr = adapt_lr
        self.lam = lam
        self.alpha = tuned(self.name, "alpha") if alpha is None else alpha
        self._check_settings(
            meta_iterations="count",
            meta_batch="count",
            meta_lr="rate",
            adapt_steps="steps",
            adapt_lr="rate",
            lam="weight",
            alpha="rate",
            ncfs_max_iter="count",
        )

    def _fit(self, signals: np.ndarray, labels: np.ndarray, features: np.ndarray | None) -> None:
        raw = pool_of(signals, features)
        self.afop_ = AFOPML(
            seed=self.seed, ncfs_lam_n=self.ncfs_lam_n, ncfs_max_iter=self.ncfs_max_iter
        ).fit(signals, labels, features=raw)
        self.D_ = self.afop_.D_
        self.selected_ = self.afop_.selected_
        self.feature_dim_ = HIDDEN[-1]
        x = torch.as_tensor(self.afop_.embed(signals, raw))
        gen = torch.Generator().manual_seed(self.seed)
        sizes = (self.D_, *HIDDEN)
        params = []
        for d_in, d_out in itertools.pairwise(sizes):
            bound = 1.0 / np.sqrt(d_in)
            params.append((torch.rand(1, d_in, d_out, generator=gen) * 2 - 1) * bound)
            params.append(torch.zeros(1, 1, d_out))
        for p in params:
            p.requires_grad_(True)
        opt = torch.optim.Adam(params, lr=self.meta_lr)
        batch = meta_training_episodes(
            labels, episodes=self.meta_iterations * self.meta_batch, seed=self.seed
        )
        way, shot = batch.n_way, batch.k_shot
        for it in range(self.meta_iterations):
            sl = slice(it * self.meta_batch, (it + 1) * self.meta_batch)
            s, q = batch.support[sl], batch.query[sl]
            e = s.shape[0]
            batched = [p.expand(e, -1, -1) for p in params]
            zs = _mlp(x[torch.as_tensor(s)].reshape(e, way * shot, -1), batched)
            protos = normalise(zs.reshape(e, way, shot, -1).mean(dim=2))
            zq = normalise(_mlp(x[torch.as_tensor(q)], batched))
            logits = self.alpha * torch.bmm(zq, protos.transpose(1, 2))
            target = torch.as_tensor(batch.query_labels[sl]).reshape(-1)
            loss = torch.nn.functional.cross_entropy(logits.reshape(-1, way), target)
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
        self.mlp_ = [p.detach() for p in params]

    def _predict(
        self,
        signals: np.ndarray,
        support: np.ndarray,
        query: np.ndarray,
        features: np.ndarray | None,
    ) -> np.ndarray:
        x = torch.as_tensor(self.afop_.embed(signals, features))
        out = np.empty(query.shape, dtype=np.int64)
        _, n_way, k_shot = support.shape
        target = torch.arange(n_way).repeat_interleave(k_shot)
        for start in range(0, support.shape[0], EPISODE_CHUNK):
            s = support[start : start + EPISODE_CHUNK]
            q = query[start : start + EPISODE_CHUNK]
            e = s.shape[0]
            xs = x[torch.as_tensor(s)].reshape(e, n_way * k_shot, -1)
            params = [p.expand(e, -1, -1).clone().requires_grad_(True) for p in self.mlp_]
            with torch.no_grad():
                protos = _mlp(xs, params).reshape(e, n_way, k_shot, -1).mean(dim=2)
            w = normalise(protos).clone().requires_grad_(True)
            b = torch.zeros(e, 1, n_way, requires_grad=True)
            opt = torch.optim.Adam([*params, w, b], lr=self.adapt_lr)
            tgt = target.expand(e, -1).reshape(-1)
            for _ in range(self.adapt_steps):
                z = normalise(_mlp(xs, params))
                logits = self.alpha * torch.bmm(z, normalise(w).transpose(1, 2)) + b
                logp = torch.log_softmax(logits, dim=-1)
                ce = torch.nn.functional.nll_loss(logp.reshape(-1, n_way), tgt)
                entropy = -(logp.exp() * logp).sum(dim=-1).mean()
                opt.zero_grad(set_to_none=True)
                ((ce + self.lam * entropy) * e).backward()  # each episode's own gradient
                opt.step()
            with torch.no_grad():
                zq = normalise(_mlp(x[torch.as_tensor(q)], params))
                logits = self.alpha * torch.bmm(zq, normalise(w).transpose(1, 2)) + b
                out[start : start + e] = logits.argmax(dim=-1).numpy()
        return out
