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
episodes drawn from the training split only; nothing from the test classes enters. A
network trained per episode (:class:`EpisodeNet`, :class:`EpisodeTrainer`) gets a
:class:`Schedule`: per validated (shot, way) cell the learning rate and step count
chosen on that cell's validation curves (:func:`select_schedule`), each curve read at
doubling step counts until a doubling brings no gain beyond the best point's 95 %
confidence interval, so the training length is where the validation accuracy stops
rising measurably, not a fixed budget.
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
from .prototypes import FusedAdam

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
    return linear_head(embed_cnn(x, params, layers), params[-2], params[-1])


def linear_head(emb: torch.Tensor, w_out: torch.Tensor, b_out: torch.Tensor) -> torch.Tensor:
    """Per-episode linear heads: embeddings ``(R, E, c)``, weights ``(E, c, n)`` and biases
    ``(E, n)`` -> logits ``(R, E, n)``."""
    return torch.einsum("rec,eco->reo", emb, w_out) + b_out[None]


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


@dataclass(frozen=True)
class EpisodeNet:
    """A network trained per episode: ``init(E, N, generator)`` -> fresh stacked weights
    of E episodes' networks, ``gather(x, idx (E, R))`` -> the model input of those trials
    of the pool ``x``, ``forward(input, weights)`` -> logits ``(E, R, N)``, and
    ``loss(logits (E, S, N), target (E, S))`` -> the sum over episodes of each episode's
    support loss (None: cross-entropy); ``grads(input, weights, target)`` -> that loss's
    gradient with respect to every weight, written out (None: autograd's, through
    ``forward`` and ``loss``); ``start(weights, support input, N, K)`` -> the
    weights a network starts from, when part of them is set from its support set (a
    prototype head; None: ``init``'s as they are); ``chunk`` and ``rows`` bound the
    episodes trained together (:func:`episodes_per_chunk`)."""

    init: Callable[[int, int, torch.Generator], list[torch.Tensor]]
    gather: Callable[[torch.Tensor, np.ndarray], torch.Tensor]
    forward: Callable[[torch.Tensor, list[torch.Tensor]], torch.Tensor]
    loss: Callable[[torch.Tensor, torch.Tensor], torch.Tensor] | None = None
    grads: Callable[[torch.Tensor, list[torch.Tensor], torch.Tensor], list[torch.Tensor]] | None = (
        None
    )
    start: Callable[[list[torch.Tensor], torch.Tensor, int, int], list[torch.Tensor]] | None = None
    chunk: int = 64
    rows: int = 3072


def _cross_entropy(logits: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    # Sum over episodes of each episode's mean loss: episodes do not interact.
    e, _, n = logits.shape
    return F.cross_entropy(logits.reshape(-1, n), target.reshape(-1)) * e


class EpisodeTrainer:
    """The networks of a chunk of E episodes, each trained from a fresh initialisation on
    its own support set only (Adam, full batch), advanced a number of steps at a time and
    asked for its queries' labels in between. Weights are stacked ``(E, ...)``: episodes
    never interact (each episode's loss has its own weights only).

    A network whose gradient is written out (``EpisodeNet.grads``) is stepped by
    torch.optim's functional Adam with its fused kernel (PyTorch's defaults besides the
    rate, as ``torch.optim.Adam``), without autograd; any other by ``torch.optim.Adam`` on
    autograd's gradient."""

    def __init__(
        self,
        net: EpisodeNet,
        x: torch.Tensor,
        support: np.ndarray,
        query: np.ndarray,
        *,
        lr: float,
        generator: torch.Generator,
    ) -> None:
        e, n_way, k_shot = support.shape
        self.net = net
        self.xs = net.gather(x, support.reshape(e, n_way * k_shot))
        self.xq = net.gather(x, query)
        params = net.init(e, n_way, generator)
        if net.start is not None:
            with torch.no_grad():
                params = net.start(params, self.xs, n_way, k_shot)
        self.target = torch.arange(n_way).repeat_interleave(k_shot).expand(e, -1)
        self.steps = 0
        if net.grads is not None:
            self.params = params
            self.adam = FusedAdam(params, lr)
            return
        self.params = [p.requires_grad_(True) for p in params]
        self.opt = torch.optim.Adam(self.params, lr=lr)
        self.loss = net.loss or _cross_entropy

    def advance(self, steps: int) -> None:
        """Train ``steps`` more Adam steps."""
        if self.net.grads is not None:
            with torch.no_grad():
                for _ in range(steps):
                    self.adam.step(self.net.grads(self.xs, self.params, self.target))
            self.steps += steps
            return
        for _ in range(steps):
            loss = self.loss(self.net.forward(self.xs, self.params), self.target)
            self.opt.zero_grad(set_to_none=True)
            loss.backward()
            self.opt.step()
        self.steps += steps

    def predict(self) -> np.ndarray:
        """The queries' episode classes ``(E, M)`` with the weights as they stand."""
        with torch.no_grad():
            return self.net.forward(self.xq, self.params).argmax(dim=-1).numpy()


def _chunks(support: np.ndarray, net: EpisodeNet) -> list[slice]:
    e_total, n_way, k_shot = support.shape
    step = episodes_per_chunk(n_way * k_shot, cap=net.chunk, rows=net.rows)
    return [slice(i, i + step) for i in range(0, e_total, step)]


def train_per_episode(
    net: EpisodeNet,
    x: torch.Tensor,
    support: np.ndarray,
    query: np.ndarray,
    *,
    steps: int | Sequence[int],
    lr: float,
    seed: int,
) -> np.ndarray:
    """Train one network per episode from scratch on its support set (:class:`EpisodeNet`),
    a chunk of episodes at a time (see :func:`episodes_per_chunk`), and label its queries:
    predictions ``(E, M)``.

    ``steps`` may be a sorted sequence of step counts: the queries are then labelled after
    each of them during one training run, and the result is ``(len(steps), E, M)``.
    """
    marks = [steps] if isinstance(steps, int) else list(steps)
    out = np.empty((len(marks), *query.shape), dtype=np.int64)
    gen = torch.Generator().manual_seed(seed)
    for sl in _chunks(support, net):
        trainer = EpisodeTrainer(net, x, support[sl], query[sl], lr=lr, generator=gen)
        for m_i, mark in enumerate(marks):
            trainer.advance(mark - trainer.steps)
            out[m_i, sl] = trainer.predict()
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


#: Shots and ways of the validation cells a per-episode network's schedule is chosen on:
#: Table I's shots, and its smallest, a middle and its largest way (each lowered to what
#: the training classes hold).
VALIDATION_SHOTS: tuple[int, ...] = (1, 3, 5)
VALIDATION_WAYS: tuple[int, ...] = (5, 12, 36)
#: The first step count the validation curves are read at; each next one doubles it.
FIRST_MARK = 5
#: The curve of one learning rate is extended (step counts doubled) until a doubling brings
#: no gain beyond the best point's 95 % CI (:func:`_curve`); this bounds it for curves
#: that keep gaining, and the schedule records whether a curve reached it.
MAX_MARK = FIRST_MARK * 2**11
#: Doublings in a row without gain that end a validation curve still below twice chance.
CHANCE_PATIENCE = 3
#: Queries a validation cell's episodes hold in all (about): episodes per cell are
#: ``ceil(VALIDATION_QUERIES / (way * queries per class))``, within
#: :data:`MIN_VALIDATION_EPISODES` .. :data:`MAX_VALIDATION_EPISODES`, so every cell's
#: accuracy is about equally precise (the bounds matter for tiny training pools only).
VALIDATION_QUERIES = 1000
MIN_VALIDATION_EPISODES = 8
MAX_VALIDATION_EPISODES = 100


@dataclass(frozen=True)
class Setting:
    """The Adam learning rate and step count of one validated (shot, way) cell."""

    shot: int
    way: int
    lr: float
    steps: int


@dataclass(frozen=True)
class Schedule:
    """How long, and at which rate, a per-episode network trains on a support set of K
    shots and N ways: the setting of the validated cell nearest to (K, N) (:meth:`of`).

    settings: one per validated cell; curves: per cell and learning rate, the validation
    accuracy (mean and 95 % CI over episodes) at each step count read, and whether the
    curve levelled off before :data:`MAX_MARK` (``plateaued``); empty when the setting
    was given, not chosen.
    """

    settings: tuple[Setting, ...]
    curves: tuple[dict, ...] = ()

    def of(self, shot: int, way: int) -> Setting:
        """The setting for K = ``shot``, N = ``way``: the validated cell of the nearest shot
        (the smaller on ties), among its cells the one of the nearest way on a log scale
        (the smaller on ties); a schedule of one setting gives it for every episode."""
        if len(self.settings) == 1:
            return self.settings[0]
        shots = sorted({c.shot for c in self.settings})
        k = min(shots, key=lambda v: (abs(v - shot), v))
        cells = [c for c in self.settings if c.shot == k]
        return min(cells, key=lambda c: (abs(np.log(c.way / way)), c.way))

    @classmethod
    def fixed(cls, lr: float, steps: int) -> Schedule:
        """One setting for every support set (given, not chosen)."""
        return cls((Setting(0, 0, float(lr), int(steps)),))

    def as_dict(self) -> dict:
        return {
            "settings": [vars(c) for c in self.settings],
            "curves": list(self.curves),
        }


def validation_cells(
    labels: np.ndarray,
    shots: Sequence[int] = VALIDATION_SHOTS,
    ways: Sequence[int] = VALIDATION_WAYS,
) -> list[tuple[int, int, int]]:
    """``(shot, way, queries per class)`` of the validation cells ``labels`` (the training
    split) can hold: ways above the class count lowered to it, shots to what the smallest
    class holds with one query; repeats dropped."""
    classes, counts = np.unique(labels, return_counts=True)
    smallest = int(counts.min())
    if classes.size < 2 or smallest < 2:
        raise ValueError(
            "validation needs at least 2 classes with at least 2 trials each in the training "
            f"split; got {classes.size} classes with >= {smallest} trials"
        )
    out: list[tuple[int, int, int]] = []
    for shot in dict.fromkeys(min(k, smallest - 1) for k in shots):
        for way in dict.fromkeys(min(n, classes.size) for n in ways):
            cell = (shot, way, min(5, smallest - shot))
            if cell not in out:
                out.append(cell)
    return out


def used_cells(
    cells: Sequence[tuple[int, int, int]], needed: Sequence[tuple[int, int]] | None
) -> set[int]:
    """Indices into ``cells`` (``(shot, way, queries)`` validation cells) of those the
    ``needed`` ``(way, shot)`` test cells take their settings from under
    :meth:`Schedule.of`; all of them when ``needed`` is None."""
    if needed is None:
        return set(range(len(cells)))
    probe = Schedule(tuple(Setting(shot, way, 0.0, i) for i, (shot, way, _) in enumerate(cells)))
    return {probe.of(shot, way).steps for way, shot in needed}


def _curve(
    net: EpisodeNet, x: torch.Tensor, batch: EpisodeBatch, lr: float, seed: int
) -> tuple[list[int], np.ndarray, bool]:
    """Step counts read and per-episode validation accuracies ``(marks, E)`` of one rate:
    from :data:`FIRST_MARK`, doubled until a doubling brings no gain (or :data:`MAX_MARK`);
    while the best is below twice chance (2 / N), only :data:`CHANCE_PATIENCE` doublings in
    a row without gain end it. A doubling gains when its mean accuracy exceeds the best so
    far by more than that best point's 95 % CI half-width: the tolerance
    :func:`choose_setting` applies, so the curve stops where a longer training could only
    add points the choice cannot tell from the best (validation episodes are few, and a
    mean creeping up by a fraction of its CI would otherwise keep doubling the cost). All
    chunks of the batch are trained in lockstep."""
    gen = torch.Generator().manual_seed(seed)
    trainers = [
        (sl, EpisodeTrainer(net, x, batch.support[sl], batch.query[sl], lr=lr, generator=gen))
        for sl in _chunks(batch.support, net)
    ]
    marks: list[int] = []
    accs: list[np.ndarray] = []
    mark, best, best_ci, flat = FIRST_MARK, -1.0, 0.0, 0
    while True:
        pred = np.empty(batch.query.shape, dtype=np.int64)
        for sl, trainer in trainers:
            trainer.advance(mark - trainer.steps)
            pred[sl] = trainer.predict()
        acc = (pred == batch.query_labels).mean(axis=1)
        marks.append(mark)
        accs.append(acc)
        # A doubling without gain ends the curve once the networks have left chance (a
        # slow rate's first marks can sit at chance before the accuracy rises), and
        # :data:`CHANCE_PATIENCE` of them in a row end it in any case.
        mean = float(acc.mean())
        flat = flat + 1 if mean <= best + best_ci else 0
        if flat and (best >= 2.0 / batch.n_way or flat >= CHANCE_PATIENCE):
            return marks, np.stack(accs), True
        if mean > best:
            best, best_ci = mean, _ci95(acc)
        if mark >= MAX_MARK:
            return marks, np.stack(accs), False
        mark *= 2


def _ci95(acc: np.ndarray) -> float:
    return float(1.96 * acc.std() / np.sqrt(acc.size)) if acc.size > 1 else 0.0


def choose_setting(curves: Sequence[tuple[float, list[int], np.ndarray]]) -> tuple[float, int]:
    """``(lr, steps)`` from validation curves ``(lr, marks, per-episode accuracies (marks,
    E))``: the fewest steps whose mean accuracy lies within the 95 % CI of the best mean
    (the cheapest training validation cannot tell from the best); among those the highest
    mean, then the smaller rate."""
    points = [
        (float(acc[i].mean()), _ci95(acc[i]), marks[i], lr)
        for lr, marks, acc in curves
        for i in range(len(marks))
    ]
    best = max(points, key=lambda p: (p[0], -p[2], -p[3]))
    ok = [p for p in points if p[0] >= best[0] - best[1]]
    pick = min(ok, key=lambda p: (p[2], -p[0], p[3]))
    return pick[3], pick[2]


def select_schedule(
    net: EpisodeNet,
    x: torch.Tensor,
    labels: np.ndarray,
    *,
    seed: int,
    lrs: Sequence[float],
    steps: int | None = None,
    shots: Sequence[int] = VALIDATION_SHOTS,
    ways: Sequence[int] = VALIDATION_WAYS,
    needed: Sequence[tuple[int, int]] | None = None,
) -> Schedule:
    """The :class:`Schedule` of a per-episode network chosen on validation episodes of
    ``labels`` (the training split; ``x`` its network input): for every validation cell
    (:func:`validation_cells`) and rate of ``lrs``, the validation curve over step counts
    (:func:`_curve`, or only ``steps`` when given), then :func:`choose_setting`. The same
    episodes serve every rate, and every rate's networks start from the same weights.

    ``needed``: the ``(way, shot)`` cells the network will be tested on, or None for any.
    Only the validation cells these take their settings from (:meth:`Schedule.of`) are
    validated, each on the episodes it has among all cells, so every needed cell gets the
    very setting the full validation gives it."""
    cells = validation_cells(labels, shots, ways)
    keep = used_cells(cells, needed)
    settings, curves = [], []
    for i, (shot, way, query) in enumerate(cells):
        if i not in keep:
            continue
        episodes = min(
            MAX_VALIDATION_EPISODES,
            max(MIN_VALIDATION_EPISODES, -(-VALIDATION_QUERIES // (way * query))),
        )
        batch = sample_episodes(
            labels,
            n_way=way,
            k_shot=shot,
            n_query=query,
            episodes=episodes,
            seed=_seed_of(seed, 0x5C4E0, i),
        )
        cell = []
        for lr in lrs:
            if steps is None:
                marks, acc, plateaued = _curve(net, x, batch, lr, _seed_of(seed, 0x1417))
            else:
                pred = train_per_episode(
                    net, x, batch.support, batch.query, steps=steps, lr=lr, seed=seed
                )
                marks, acc, plateaued = [steps], (pred == batch.query_labels).mean(-1)[None], True
            cell.append((float(lr), marks, acc))
            curves.append(
                {
                    "shot": shot,
                    "way": way,
                    "episodes": episodes,
                    "lr": float(lr),
                    "steps": marks,
                    "accuracy": [round(float(a.mean()), 4) for a in acc],
                    "ci95": [round(_ci95(a), 4) for a in acc],
                    "plateaued": plateaued,
                }
            )
        lr_, steps_ = choose_setting(cell)
        settings.append(Setting(shot, way, lr_, steps_))
    return Schedule(tuple(settings), tuple(curves))


def schedule(
    net: EpisodeNet,
    *,
    steps: int | None,
    lr: float | None,
    inputs: Callable[[], torch.Tensor],
    labels: np.ndarray,
    seed: int,
    lrs: Sequence[float],
    needed: Sequence[tuple[int, int]] | None = None,
) -> Schedule:
    """The given ``steps`` and ``lr`` when both are given, otherwise
    :func:`select_schedule` on validation episodes of the training ``labels`` (a given
    value fixes its axis; ``needed``: the tested ``(way, shot)`` cells, None for any).
    ``inputs()`` -> the training pool's network input."""
    if steps is not None and lr is not None:
        return Schedule.fixed(lr, steps)
    return select_schedule(
        net,
        inputs(),
        labels,
        seed=seed,
        lrs=lrs if lr is None else (lr,),
        steps=steps,
        needed=needed,
    )
