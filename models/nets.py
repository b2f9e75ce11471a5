"""Building blocks of the deep baselines: signal preparation and a 1-D CNN whose weights
can be stacked per episode (grouped convolutions), so many episodes train at once.

Input rate: the 1 kHz windows are block-averaged by 8 to 125 Hz (T = 250 samples): the
baselines' small convolutional receptive fields then span 40-200 ms, the time scale of
edge crossings at 10 mm/s, and the cost of training one network per episode (CNN, MAML
adaptation) drops 8x. Texture vibration above ~60 Hz is averaged out; the 386-feature
methods keep it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import torch
import torch.nn.functional as F

DECIMATE = 8
#: Channels and widths of the per-episode 1-D CNN.
CONV = ((4, 8, 7), (8, 16, 5), (16, 16, 5))  # (in, out, kernel)


class ChannelScaler:
    """Per-channel z-scoring of raw signals with training-set statistics."""

    def fit(self, signals: np.ndarray) -> ChannelScaler:
        x = np.asarray(signals, dtype=np.float64)
        self.mean_ = x.mean(axis=(0, 2))
        std = x.std(axis=(0, 2))
        self.scale_ = np.where(std > 1e-12, std, 1.0)
        return self

    def transform(self, signals: np.ndarray) -> np.ndarray:
        x = np.asarray(signals, dtype=np.float64)
        z = (x - self.mean_[None, :, None]) / self.scale_[None, :, None]
        return z.astype(np.float32)


def decimate(signals: np.ndarray, factor: int = DECIMATE) -> np.ndarray:
    """Block-average along time: ``(n, C, T)`` -> ``(n, C, T // factor)``."""
    x = np.asarray(signals, dtype=np.float32)
    t = x.shape[-1] // factor * factor
    return x[..., :t].reshape(*x.shape[:-1], t // factor, factor).mean(axis=-1)


def init_cnn(n_out: int, generator: torch.Generator, copies: int = 1) -> list[torch.Tensor]:
    """He-initialised weights of the CNN (conv stack + linear head to ``n_out``), each with
    a leading ``copies`` axis: ``[w1 (E,o,i,k), b1 (E,o), ..., wl (E,16,n_out), bl (E,n_out)]``."""
    params = []
    for c_in, c_out, k in CONV:
        std = (2.0 / (c_in * k)) ** 0.5
        params.append(torch.randn(copies, c_out, c_in, k, generator=generator) * std)
        params.append(torch.zeros(copies, c_out))
    c_last = CONV[-1][1]
    params.append(torch.randn(copies, c_last, n_out, generator=generator) * (1.0 / c_last) ** 0.5)
    params.append(torch.zeros(copies, n_out))
    return params


def cnn_forward(x: torch.Tensor, params: list[torch.Tensor]) -> torch.Tensor:
    """Per-episode CNNs on per-episode inputs.

    x: ``(R, E, 4, T)`` (R examples of each of E episodes); params from :func:`init_cnn`
    with ``copies = E``. Returns logits ``(R, E, n_out)``. Episode e's examples only meet
    episode e's weights (grouped convolutions, ``groups = E``).
    """
    w_out, b_out = params[-2], params[-1]
    return torch.einsum("rec,eco->reo", embed_cnn(x, params), w_out) + b_out[None]


def embed_cnn(x: torch.Tensor, params: list[torch.Tensor]) -> torch.Tensor:
    """The pooled conv features ``(R, E, 16)`` (the CNN without its linear head)."""
    r, e = x.shape[:2]
    h = x.reshape(r, e * x.shape[2], x.shape[3])
    for layer, (c_in, c_out, k) in enumerate(CONV):
        w, b = params[2 * layer], params[2 * layer + 1]
        h = F.conv1d(h, w.reshape(e * c_out, c_in, k), b.reshape(-1), padding=k // 2, groups=e)
        if layer < len(CONV) - 1:
            # max-pool by 2 (as F.max_pool1d, odd tail dropped), before the ReLU (the two
            # commute): the strided maximum is several times cheaper than max_pool1d's
            # indexed kernel on these many-group tensors.
            t = h.shape[-1] // 2 * 2
            h = torch.maximum(h[..., 0:t:2], h[..., 1:t:2])
        h = F.relu(h)
    return h.mean(dim=-1).reshape(r, e, CONV[-1][1])


def episodes_per_chunk(support_rows: int, *, cap: int, rows: int) -> int:
    """Episodes trained together: at most ``cap``, and at most ``rows`` support examples in
    all (at least one episode). Per-episode cost grows with the stacked tensors once they
    outgrow the CPU caches: a 36-way-5-shot CNN step cost 22.8 ms per episode at 64
    episodes and 8.5 ms at 16 (2-core machine; ``scripts/bench_closed_set.py``)."""
    return max(1, min(cap, rows // max(1, support_rows)))


def episode_inputs(x: torch.Tensor, index: np.ndarray) -> torch.Tensor:
    """Gather ``(E, R)`` trial indices of a pool ``(P, 4, T)`` into ``(R, E, 4, T)``."""
    return x[torch.as_tensor(index)].transpose(0, 1)


def train_per_episode(
    x: torch.Tensor,
    support: np.ndarray,
    query: np.ndarray,
    *,
    init: Callable[[int, int, torch.Generator], list[torch.Tensor]],
    gather: Callable[[torch.Tensor, np.ndarray], torch.Tensor],
    forward: Callable[[torch.Tensor, list[torch.Tensor]], torch.Tensor],
    steps: int,
    lr: float,
    seed: int,
    chunk: int,
    rows: int,
) -> np.ndarray:
    """Train one network per episode from scratch on its support set (Adam, cross-entropy),
    up to ``chunk`` episodes and ``rows`` support examples at once (see
    :func:`episodes_per_chunk`), and label its queries: predictions ``(E, M)``.

    ``init(E, N, generator)`` -> stacked weights; ``gather(x, idx (E, R))`` -> the model
    input of those trials; ``forward(input, weights)`` -> logits ``(E, R, N)``.
    """
    e_total, n_way, k_shot = support.shape
    out = np.empty(query.shape, dtype=np.int64)
    gen = torch.Generator().manual_seed(seed)
    target = torch.arange(n_way).repeat_interleave(k_shot)
    step = episodes_per_chunk(n_way * k_shot, cap=chunk, rows=rows)
    for start in range(0, e_total, step):
        s = support[start : start + step].reshape(-1, n_way * k_shot)
        q = query[start : start + step]
        e = s.shape[0]
        params = [p.requires_grad_(True) for p in init(e, n_way, gen)]
        opt = torch.optim.Adam(params, lr=lr)
        xs = gather(x, s)
        tgt = target.expand(e, -1).reshape(-1)
        for _ in range(steps):
            logits = forward(xs, params)
            # Sum over episodes of each episode's mean loss: episodes do not interact.
            loss = F.cross_entropy(logits.reshape(-1, n_way), tgt) * e
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
        with torch.no_grad():
            out[start : start + e] = forward(gather(x, q), params).argmax(dim=-1).numpy()
    return out
