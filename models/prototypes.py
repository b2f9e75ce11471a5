"""Prototypical heads on fixed embeddings, batched over episodes.

- :func:`nearest_prototype`: plain cosine prototypical classifier (no adaptation), used by
  the D-scan and by Direct-Prot-ML's initial prototypes.
- :func:`adapt_cosine_head`: the AFOP-ML episodic head (paper Sec. IV-D): logits
  ``alpha * cos(x, w_n) + b_n``, ``W`` initialised with the l2-normalised prototypes and
  ``b = 0``; only ``(W, b)`` are trained on the support set, minimising cross-entropy plus
  ``lam`` times the Shannon entropy of the posteriors, with Adam (250 steps, lr 1.5e-3);
  queries are only forwarded. All episodes of a batch are one tensor problem
  (``W`` is ``(E, N, D)``), not a Python loop per episode.

``alpha`` is fixed per method, not learned per episode: with K <= 5 shots per class a
learnable scale keeps growing to sharpen the support posteriors (the entropy term rewards
it) and overfits the support set. The paper does not state its value; each method's
``alpha`` is chosen on validation episodes of its training data (``scripts/tune.py``).
Rows of ``W`` are l2-normalised in the forward pass, so the logit is a true cosine.

Tensor shapes: ``F`` (P, D) embeddings of the pool; support ``(E, N, K)``, query ``(E, M)``
indices into it.
"""

from __future__ import annotations

import numpy as np
import torch
from torch.optim.adam import adam

from tactile_synth.validation import check_int

#: Episodes adapted together, at most (bounds memory for 36-way episodes with 386-d
#: features).
EPISODE_CHUNK = 512
#: Support-embedding values (floats, episodes x support examples x D) an adapted head's
#: chunk holds at most: every Adam step reads the chunk's support embeddings twice and
#: rewrites its ``(E, N, D)`` weights and moments about twenty times, so a chunk that
#: stays in the CPU's caches (8 MiB of support embeddings) costs less per episode than
#: one streamed from memory on every step. Episodes never interact, so the chunking
#: changes no prediction beyond the last bits of a vectorised kernel's tail.
HEAD_FLOATS = 2**21
#: The head's Adam settings besides the rate: PyTorch's defaults (the paper gives only the
#: steps and the rate). The head calls torch.optim's functional Adam with its fused
#: kernel, which counts the steps itself, so no optimiser object's bookkeeping runs per
#: step.
ADAM = dict(
    fused=True, amsgrad=False, beta1=0.9, beta2=0.999, weight_decay=0.0, eps=1e-8, maximize=False
)


class FusedAdam:
    """torch.optim's functional Adam (:data:`ADAM`, its fused kernel) on plain tensors
    whose gradient the caller computes: ``step(grads)`` updates ``params`` in place, with
    the moments and step counts kept here."""

    def __init__(self, params: list[torch.Tensor], lr: float) -> None:
        self.params = params
        self.lr = lr
        self.moments = [torch.zeros_like(p) for p in params]
        self.squares = [torch.zeros_like(p) for p in params]
        self.counts = [torch.zeros((), dtype=torch.float32) for _ in params]

    def step(self, grads: list[torch.Tensor]) -> None:
        adam(self.params, grads, self.moments, self.squares, [], self.counts, **ADAM, lr=self.lr)


def head_chunk(n_support: int, dim: int, *, cap: int = EPISODE_CHUNK) -> int:
    """Episodes of ``n_support`` support embeddings of ``dim`` values adapted together:
    at most ``cap``, and at most :data:`HEAD_FLOATS` support values in all (at least
    one episode)."""
    return max(1, min(cap, HEAD_FLOATS // max(1, n_support * dim)))


def normalise(x: torch.Tensor) -> torch.Tensor:
    return x / x.norm(dim=-1, keepdim=True).clamp_min(1e-12)


def prototypes(features: torch.Tensor, support: np.ndarray) -> torch.Tensor:
    """Class means ``(E, N, D)`` of the support embeddings."""
    return features[torch.as_tensor(support)].mean(dim=2)


def nearest_prototype(features: np.ndarray, support: np.ndarray, query: np.ndarray) -> np.ndarray:
    """Cosine nearest-prototype predictions ``(E, M)`` (no adaptation)."""
    f = torch.as_tensor(np.ascontiguousarray(features, dtype=np.float32))
    out = np.empty(query.shape, dtype=np.int64)
    for start in range(0, support.shape[0], EPISODE_CHUNK):
        s = support[start : start + EPISODE_CHUNK]
        q = query[start : start + EPISODE_CHUNK]
        protos = normalise(prototypes(f, s))
        sims = torch.einsum("emd,end->emn", normalise(f[torch.as_tensor(q)]), protos)
        out[start : start + EPISODE_CHUNK] = sims.argmax(dim=-1).numpy()
    return out


def adapt_cosine_head(
    features: np.ndarray,
    support: np.ndarray,
    query: np.ndarray,
    *,
    steps: int = 250,
    lr: float = 1.5e-3,
    lam: float = 0.10,
    alpha: float = 10.0,
    chunk: int | None = None,
) -> np.ndarray:
    """AFOP-ML's adapted cosine-softmax head: predictions ``(E, M)``.

    ``chunk``: episodes adapted together (None: :func:`head_chunk`, cache-sized).

    The loss's gradient is written out (no autograd graph per step) and PyTorch's Adam
    (its fused kernel: one pass over ``W``, its moments and gradient) updates ``W`` and
    ``b`` of all episodes at once; with ``(E, S, N)`` cosines ``c``, logits
    ``z = alpha c + b``, ``p = softmax(z)``, ``H = -sum p log p``, the per-example
    gradient is ``dL/dz = (p - y - lam p (log p + H)) / S`` (cross-entropy plus ``lam`` H,
    mean over the episode's S = N K support examples), and with ``g = dL/dz``
    ``dL/dw_n = alpha / |w_n| (g^T x)_n - alpha (sum_s g_sn c_sn) / |w_n|^2 w_n``: the
    normalised rows are never formed, the cosines' scale is applied to the small
    ``(E, S, N)`` tensors. Deterministic: W starts at the prototypes.
    """
    f = torch.as_tensor(np.ascontiguousarray(features, dtype=np.float32))
    out = np.empty(query.shape, dtype=np.int64)
    e_total, n_way, k_shot = support.shape
    n_support = n_way * k_shot
    onehot = torch.eye(n_way).repeat_interleave(k_shot, dim=0)  # (S, N), class-major rows
    step_e = (
        head_chunk(n_support, f.shape[1]) if chunk is None else check_int("chunk", chunk, minimum=1)
    )
    with torch.no_grad():
        for start in range(0, e_total, step_e):
            s = support[start : start + step_e]
            q = query[start : start + step_e]
            e = s.shape[0]
            xs = normalise(f[torch.as_tensor(s)].reshape(e, n_support, -1))  # (E, S, D)
            w = normalise(prototypes(f, s))  # (E, N, D)
            b = torch.zeros(e, 1, n_way)
            opt = FusedAdam([w, b], lr)
            for _ in range(steps):
                inv = w.norm(dim=-1).clamp_min(1e-12).reciprocal_()  # 1 / |w_n|, (E, N)
                cos = torch.bmm(xs, w.transpose(1, 2)).mul_(inv.unsqueeze(1))  # (E, S, N)
                logp = torch.log_softmax(alpha * cos + b, dim=-1)
                p = logp.exp()
                h = -(p * logp).sum(dim=-1, keepdim=True)
                gz = (p - onehot - lam * p * (logp + h)) / n_support
                radial = (gz * cos).sum(dim=1) * inv * inv * -alpha  # (E, N)
                gw = torch.bmm(gz.transpose(1, 2) * (alpha * inv).unsqueeze(2), xs)
                opt.step([gw.addcmul_(w, radial.unsqueeze(2)), gz.sum(dim=1, keepdim=True)])
            xq = normalise(f[torch.as_tensor(q)])
            logits = alpha * torch.bmm(xq, normalise(w).transpose(1, 2)) + b
            out[start : start + e] = logits.argmax(dim=-1).numpy()
    return out
