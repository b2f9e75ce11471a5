"""Building blocks of the deep raw-signal baselines: signal preparation, validation on the
training split, and a 1-D CNN whose weights can be stacked per episode (grouped
convolutions), so many episodes train at once.

Input rate: the 1 kHz windows are resampled to :data:`INPUT_RATE_HZ` (500 Hz) by
polyphase filtering (``scipy.signal.resample_poly``, its default Kaiser FIR: flat to
200 Hz, -3 dB at 240 Hz, -6 dB at the new 250 Hz Nyquist frequency), so texture
vibration up to 250 Hz (machining marks at 10-20 mm/s) reaches the networks without
aliasing, at half the samples of the raw rate. The CNNs' first layer is a strided
convolution (a learned filter bank over 32 ms windows, stride 16 ms), which brings the
time axis down to 62.5 Hz right away: the per-episode training cost then stays that of a
network on a coarse sequence while every frequency band up to 250 Hz is seen.

Hyper-parameters that no paper fixes (steps, learning rates) are chosen on validation
episodes drawn from the training split only (:func:`validation_episodes`,
:func:`select_steps_lr`); nothing from the test classes enters.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F
from scipy.signal import resample_poly

from synth import SAMPLE_RATE_HZ

from .episodes import EpisodeBatch, sample_episodes

#: Sample rate of the networks' input (Hz): keeps the band up to 250 Hz.
INPUT_RATE_HZ = 500


@dataclass(frozen=True)
class ConvLayer:
    """One convolution of a per-episode CNN: ``c_in -> c_out`` channels, ``kernel`` taps,
    ``stride``, then a max-pool by ``pool`` (1: none) and a ReLU."""

    c_in: int
    c_out: int
    kernel: int
    stride: int = 1
    pool: int = 1

    @property
    def padding(self) -> int:
        # "same"-style padding: a strided layer keeps T // stride outputs.
        return (self.kernel - self.stride) // 2 if self.stride > 1 else self.kernel // 2


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


def resample(signals: np.ndarray, rate_hz: int = INPUT_RATE_HZ) -> np.ndarray:
    """Anti-aliased resampling ``(n, C, T)`` at 1 kHz -> ``(n, C, T * rate_hz / 1000)``
    (polyphase FIR of ``scipy.signal.resample_poly``), float32."""
    if not 0 < rate_hz <= SAMPLE_RATE_HZ or SAMPLE_RATE_HZ % rate_hz:
        raise ValueError(f"rate_hz must divide the {SAMPLE_RATE_HZ} Hz sample rate; got {rate_hz}")
    x = np.asarray(signals, dtype=np.float32)
    down = SAMPLE_RATE_HZ // rate_hz
    if down == 1:
        return x.copy()
    return resample_poly(x, 1, down, axis=-1).astype(np.float32)


class PoolCache:
    """The prepared input of the last pool of trials seen (methods label every column of a
    table on the same pool): ``get(signals, prepare)`` returns ``prepare(signals)``,
    computed once per distinct pool (keyed by a SHA-1 of its bytes)."""

    def __init__(self) -> None:
        self._key: str | None = None
        self._value: object = None

    def get(self, signals: np.ndarray, prepare: Callable[[np.ndarray], object]) -> object:
        x = np.ascontiguousarray(signals)
        key = hashlib.sha1(x.tobytes()).hexdigest() + str(x.shape) + str(x.dtype)
        if key != self._key:
            self._key, self._value = None, None  # one pool at a time (pools are large)
            self._value = prepare(x)
            self._key = key
        return self._value


def init_cnn(
    layers: Sequence[ConvLayer], n_out: int, generator: torch.Generator, copies: int = 1
) -> list[torch.Tensor]:
    """He-initialised weights of a CNN (conv stack + linear head to ``n_out``), each with
    a leading ``copies`` axis: ``[w1 (E,o,i,k), b1 (E,o), ..., wl (E,c,n_out), bl (E,n_out)]``."""
    params = []
    for layer in layers:
        std = (2.0 / (layer.c_in * layer.kernel)) ** 0.5
        shape = (copies, layer.c_out, layer.c_in, layer.kernel)
        params.append(torch.randn(*shape, generator=generator) * std)
        params.append(torch.zeros(copies, layer.c_out))
    c_last = layers[-1].c_out
    params.append(torch.randn(copies, c_last, n_out, generator=generator) * (1.0 / c_last) ** 0.5)
    params.append(torch.zeros(copies, n_out))
    return params


def cnn_forward(
    x: torch.Tensor, params: list[torch.Tensor], layers: Sequence[ConvLayer]
) -> torch.Tensor:
    """Per-episode CNNs on per-episode inputs.

    x: ``(R, E, C, T)`` (R examples of each of E episodes); params from :func:`init_cnn`
    with ``copies = E``. Returns logits ``(R, E, n_out)``. Episode e's examples only meet
    episode e's weights (grouped convolutions, ``groups = E``).
    """
    w_out, b_out = params[-2], params[-1]
    return torch.einsum("rec,eco->reo", embed_cnn(x, params, layers), w_out) + b_out[None]


def embed_cnn(
    x: torch.Tensor, params: list[torch.Tensor], layers: Sequence[ConvLayer]
) -> torch.Tensor:
    """The time-averaged features of the last conv layer ``(R, E, c_last)`` (the CNN
    without its linear head)."""
    r, e = x.shape[:2]
    h = x.reshape(r, e * x.shape[2], x.shape[3])
    for i, layer in enumerate(layers):
        w, b = params[2 * i], params[2 * i + 1]
        h = F.conv1d(
            h,
            w.reshape(e * layer.c_out, layer.c_in, layer.kernel),
            b.reshape(-1),
            stride=layer.stride,
            padding=layer.padding,
            groups=e,
        )
        if layer.pool > 1:
            # max-pool (as F.max_pool1d, tail dropped), before the ReLU (the two commute):
            # a max over a reshaped axis has the cheapest backward (one index scatter) on
            # these many-group tensors.
            t = h.shape[-1] // layer.pool * layer.pool
            h = h[..., :t].unflatten(-1, (t // layer.pool, layer.pool)).max(dim=-1).values
        h = F.relu(h)
    return h.mean(dim=-1).reshape(r, e, layers[-1].c_out)


def episodes_per_chunk(support_rows: int, *, cap: int, rows: int) -> int:
    """Episodes trained together: at most ``cap``, and at most ``rows`` support examples in
    all (at least one episode). Per-episode cost grows with the stacked tensors once they
    outgrow the CPU caches, so large episodes are trained a few at a time."""
    return max(1, min(cap, rows // max(1, support_rows)))


def episode_inputs(x: torch.Tensor, index: np.ndarray) -> torch.Tensor:
    """Gather ``(E, R)`` trial indices of a pool ``(P, C, T)`` into ``(R, E, C, T)``."""
    return x[torch.as_tensor(index)].transpose(0, 1)


def train_per_episode(
    x: torch.Tensor,
    support: np.ndarray,
    query: np.ndarray,
    *,
    init: Callable[[int, int, torch.Generator], list[torch.Tensor]],
    gather: Callable[[torch.Tensor, np.ndarray], torch.Tensor],
    forward: Callable[[torch.Tensor, list[torch.Tensor]], torch.Tensor],
    steps: int | Sequence[int],
    lr: float,
    seed: int,
    chunk: int,
    rows: int,
) -> np.ndarray:
    """Train one network per episode from scratch on its support set (Adam, cross-entropy),
    up to ``chunk`` episodes and ``rows`` support examples at once (see
    :func:`episodes_per_chunk`), and label its queries: predictions ``(E, M)``.

    ``steps`` may be a sorted sequence of step counts: the queries are then labelled after
    each of them during one training run, and the result is ``(len(steps), E, M)``.
    ``init(E, N, generator)`` -> stacked weights; ``gather(x, idx (E, R))`` -> the model
    input of those trials; ``forward(input, weights)`` -> logits ``(E, R, N)``.
    """
    marks = [steps] if isinstance(steps, int) else list(steps)
    e_total, n_way, k_shot = support.shape
    out = np.empty((len(marks), *query.shape), dtype=np.int64)
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
        xq = gather(x, q)
        tgt = target.expand(e, -1).reshape(-1)
        done = 0
        for m_i, mark in enumerate(marks):
            for _ in range(mark - done):
                logits = forward(xs, params)
                # Sum over episodes of each episode's mean loss: episodes do not interact.
                loss = F.cross_entropy(logits.reshape(-1, n_way), tgt) * e
                opt.zero_grad(set_to_none=True)
                loss.backward()
                opt.step()
            done = mark
            with torch.no_grad():
                out[m_i, start : start + e] = forward(xq, params).argmax(dim=-1).numpy()
    return out[0] if isinstance(steps, int) else out


def _seed_of(*words: int) -> int:
    return int(np.random.SeedSequence(list(words)).generate_state(1)[0])


def validation_episodes(
    labels: np.ndarray, *, seed: int, episodes: int, shots: Sequence[int] = (1, 5)
) -> list[EpisodeBatch]:
    """5-way (fewer if the pool has fewer classes) validation episodes on ``labels`` (the
    training split, or classes held out of it), one batch per K in ``shots``; K and the
    queries per class are lowered to what the smallest class holds."""
    classes, counts = np.unique(labels, return_counts=True)
    smallest = int(counts.min())
    if classes.size < 2 or smallest < 2:
        raise ValueError(
            "validation needs at least 2 classes with at least 2 trials each in the training "
            f"split; got {classes.size} classes with >= {smallest} trials"
        )
    out = []
    for i, shot in enumerate(dict.fromkeys(min(k, smallest - 1) for k in shots)):
        out.append(
            sample_episodes(
                labels,
                n_way=min(5, classes.size),
                k_shot=shot,
                n_query=min(5, smallest - shot),
                episodes=episodes,
                seed=_seed_of(seed, 0x7A11D, i),
            )
        )
    return out


def holdout_classes(labels: np.ndarray, *, fraction: float, seed: int) -> np.ndarray:
    """A seeded boolean mask of the trials whose class is held out for validation: about
    ``fraction`` of the classes, at least 2, and at least 2 left for training."""
    classes = np.unique(labels)
    if classes.size < 4:
        raise ValueError(
            "labels must hold at least 4 training classes (some to train on, at least 2 "
            f"held out for validation); got {classes.size}"
        )
    n_val = min(classes.size - 2, max(2, round(fraction * classes.size)))
    rng = np.random.default_rng(_seed_of(seed, 0x401D))
    held = rng.choice(classes, size=n_val, replace=False)
    return np.isin(labels, held)


def accuracy(pred: np.ndarray, batch: EpisodeBatch) -> float:
    """Mean query accuracy of predictions ``(E, M)`` on ``batch``."""
    return float((pred == batch.query_labels).mean())


def select_steps_lr(
    run: Callable[[EpisodeBatch, float, Sequence[int]], np.ndarray],
    batches: Sequence[EpisodeBatch],
    *,
    lrs: Sequence[float],
    steps: Sequence[int],
) -> tuple[float, int, dict]:
    """Pick the learning rate and step count with the best mean validation accuracy over
    ``batches`` (ties: fewer steps, then the smaller rate).

    ``run(batch, lr, steps)`` trains on the batch's support sets and returns predictions
    ``(len(steps), E, M)``. Returns ``(lr, steps, table)``; ``table`` holds the grid and
    the accuracies ``(len(lrs), len(steps))`` as lists, for the record.
    """
    marks = sorted(steps)
    acc = np.zeros((len(lrs), len(marks)))
    for i, lr in enumerate(lrs):
        for batch in batches:
            pred = run(batch, lr, marks)
            acc[i] += [accuracy(p, batch) for p in pred]
    acc /= len(batches)
    best = max(
        (acc[i, j], -marks[j], -lrs[i], i, j) for i in range(len(lrs)) for j in range(len(marks))
    )
    i, j = best[3], best[4]
    table = {"lr": list(lrs), "steps": marks, "accuracy": acc.round(4).tolist()}
    return float(lrs[i]), int(marks[j]), table


def steps_and_lr(
    *,
    steps: int | None,
    lr: float | None,
    inputs: Callable[[], torch.Tensor],
    labels: np.ndarray,
    train: Callable[..., np.ndarray],
    seed: int,
    lrs: Sequence[float],
    grid_steps: Sequence[int],
    episodes: int,
) -> tuple[float, int, dict | None]:
    """``(lr, steps, table)`` of a per-episode network: the given values when both are
    given (no table), otherwise the grid's best on validation episodes of the training
    labels (:func:`select_steps_lr`; a given value fixes its axis of the grid).

    ``inputs()`` -> the training pool's network input ``(P, ...)``; ``train(x, support,
    query, steps=, lr=, seed=)`` -> predictions as :func:`train_per_episode` returns them.
    """
    if steps is not None and lr is not None:
        return float(lr), int(steps), None
    x = inputs()
    batches = validation_episodes(labels, seed=seed, episodes=episodes)
    return select_steps_lr(
        lambda b, rate, marks: train(x, b.support, b.query, steps=marks, lr=rate, seed=seed),
        batches,
        lrs=lrs if lr is None else (lr,),
        steps=grid_steps if steps is None else (steps,),
    )
