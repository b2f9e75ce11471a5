"""BiLSTM without meta-learning (paper Table I): a bidirectional LSTM trained from scratch
on each episode's support set only, then applied to its queries.

Input sequence (:func:`frame_features`): the z-scored 1 kHz window cut into 25 frames,
80 ms apart (0.8 mm of travel at 10 mm/s); each frame (160 ms Hann window) is described
per channel by its mean and its log energy in the 14 :data:`BANDS` (15 values per
channel, 60 per step). The mean carries the slow waveform (strain-gauge levels, edge
transients); the band energies carry the spectrum from 3 to 500 Hz (bands of 6-12.5 Hz
below 62.5 Hz, then of about constant relative width), so tones at any frequency of
that range reach the recurrence. The frame features are standardised with training-set
statistics. Running the recurrence over 25 frames instead of 1,000+ raw samples keeps
one network per episode, 500 episodes per column, within a 2-core budget.

Training: Adam on the support cross-entropy (full batch); the learning rate and step count
are chosen per validated shot (1, 3, 5) and way (5, 12, 36) on validation episodes from
the training split, read at doubling step counts until a doubling brings no gain beyond
the best point's 95 % CI, as for the CNN baseline (:func:`models.nets.select_schedule`,
rates :data:`LRS`); ``schedule_`` records the settings and the curves. On the paper
preset's training half its curves level off early at every way (at the fastest rate
after 5-10 steps at 5 ways and 20-40 at 36 ways), unlike the CNN's, whose 36-way curves
need 40-160 steps: the shot and the way are both validated all the same, since which of
them matters is the data's to say.
Hidden size 16 per direction; the two final hidden states (32 values) feed a linear head.

The E networks of a chunk of episodes are trained together: their weights are stacked
``(E, ...)`` and every product is a batched matmul, so episodes never interact.
"""

from __future__ import annotations

import numpy as np
import torch

from synth import SAMPLE_RATE_HZ

from .base import FewShotMethod
from .cnn import predict_scheduled
from .nets import ChannelScaler, EpisodeNet, PoolCache, schedule

FRAMES = 25
#: Frame window (samples at 1 kHz): 160 ms, two hops, so frames overlap by half.
WINDOW = 160
#: Energy bands (Hz, [low, high)) of each frame's spectrum (bins every 6.25 Hz).
BANDS: tuple[tuple[float, float], ...] = (
    (3.0, 9.0),
    (9.0, 15.0),
    (15.0, 25.0),
    (25.0, 37.5),
    (37.5, 50.0),
    (50.0, 62.5),
    (62.5, 87.5),
    (87.5, 112.5),
    (112.5, 150.0),
    (150.0, 187.5),
    (187.5, 250.0),
    (250.0, 312.5),
    (312.5, 400.0),
    (400.0, 500.1),
)
HIDDEN = 16
#: Candidate Adam learning rates of the validation.
LRS = (3e-3, 1e-2, 3e-2)
#: Episodes trained together, and support examples in all (cache-sized: see
#: :func:`models.nets.episodes_per_chunk`).
CHUNK = 128
ROWS = 6144


def frame_features(z: np.ndarray, frames: int = FRAMES) -> np.ndarray:
    """``(n, 4, T)`` z-scored 1 kHz signals -> ``(n, frames, 4 * (1 + len(BANDS)))``:
    per frame and channel the mean and ``log(1e-6 + band energy)`` of each band."""
    n, _, t = z.shape
    hop = t // frames
    pad = (WINDOW - hop) // 2
    x = np.pad(np.asarray(z, dtype=np.float64), ((0, 0), (0, 0), (pad, WINDOW)), mode="reflect")
    win = np.lib.stride_tricks.sliding_window_view(x, WINDOW, axis=-1)[..., ::hop, :][
        ..., :frames, :
    ]  # (n, c, frames, WINDOW)
    mean = win.mean(axis=-1)
    spec = np.abs(np.fft.rfft((win - mean[..., None]) * np.hanning(WINDOW), axis=-1)) ** 2
    freqs = np.fft.rfftfreq(WINDOW, d=1.0 / SAMPLE_RATE_HZ)
    energy = (
        np.stack(
            [spec[..., (freqs >= lo) & (freqs < hi)].sum(axis=-1) for lo, hi in BANDS], axis=-1
        )
        / WINDOW
    )
    feats = np.concatenate([mean[..., None], np.log(1e-6 + energy)], axis=-1)  # (n,c,F,B+1)
    return feats.transpose(0, 2, 1, 3).reshape(n, frames, -1).astype(np.float32)


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


def _run(xf: torch.Tensor, xb: torch.Tensor, w_hh: torch.Tensor) -> torch.Tensor:
    """LSTM recurrences over precomputed input projections ``(E, R, T, 4H)`` of the forward
    (``xf``) and the backward (``xb``, already time-reversed) direction, with recurrent
    weights ``(2E, H, 4H)`` (forward directions first); returns the final hidden states
    ``(2E, R, H)``.

    Gate columns are ordered (input, forget, output, cell), so the three sigmoid gates
    take one ``sigmoid`` call. Both directions of all E networks run as one batch of
    ``2E`` recurrences: half the Python steps and autograd nodes of two separate loops.
    The two projections are paired step by step (no stacked copy of the whole sequence).
    """
    e, r = xf.shape[:2]
    h = xf.new_zeros(2 * e, r, HIDDEN)
    c = xf.new_zeros(2 * e, r, HIDDEN)
    # unbind once: indexing a time step per iteration would make autograd write a full
    # zero tensor of the projection's size per step in the backward pass.
    for f_t, b_t in zip(xf.unbind(dim=2), xb.unbind(dim=2), strict=True):
        g = torch.baddbmm(torch.cat([f_t, b_t]), h, w_hh)
        i, f, o = torch.sigmoid(g[..., : 3 * HIDDEN]).chunk(3, dim=-1)
        c = f * c + i * torch.tanh(g[..., 3 * HIDDEN :])
        h = o * torch.tanh(c)
    return h


def bilstm_forward(x: torch.Tensor, params: list[torch.Tensor]) -> torch.Tensor:
    """x ``(E, R, T, D)`` -> logits ``(E, R, N)``."""
    w_f, h_f, b_f, w_b, h_b, b_b = params[:6]
    e = x.shape[0]
    xf = torch.baddbmm(b_f, x.flatten(1, 2), w_f).unflatten(1, x.shape[1:3])
    xb = torch.baddbmm(b_b, x.flip(2).flatten(1, 2), w_b).unflatten(1, x.shape[1:3])
    final = _run(xf, xb, torch.cat([h_f, h_b]))
    w_out, b_out = params[-2], params[-1]
    return torch.bmm(torch.cat([final[:e], final[e:]], dim=-1), w_out) + b_out


def bilstm_grads(
    x: torch.Tensor, params: list[torch.Tensor], target: torch.Tensor
) -> list[torch.Tensor]:
    """The gradient of every episode's support cross-entropy (mean over its R examples)
    with respect to its weights (:func:`_init`'s order), by backpropagation through time
    written out: one forward pass over the 25 frames keeping each step's gates and cell
    state, one backward pass over them, no autograd graph. x ``(E, R, T, D)``, target
    ``(E, R)`` classes.

    Per step, with gates ``i, f, o = sigmoid(.)``, ``g = tanh(.)``,
    ``c_t = f c_{t-1} + i g`` and ``h_t = o tanh(c_t)``: ``dc_t += dh_t o (1 - tanh^2
    c_t)``, then ``di = dc_t g``, ``df = dc_t c_{t-1}``, ``do = dh_t tanh(c_t)``,
    ``dg = dc_t i`` through the gates' derivatives to the pre-activations ``da``;
    ``dh_{t-1} = da W_hh^T``, ``dc_{t-1} = dc_t f``; the weights' gradients are the
    products of ``da`` with each step's inputs, summed over the steps."""
    w_f, h_f, b_f, w_b, h_b, b_b, w_out, b_out = params
    e, r, t_len = x.shape[:3]
    n_out = w_out.shape[-1]
    xs = (x.flatten(1, 2), x.flip(2).flatten(1, 2))  # (E, R*T, D), forward and reversed
    proj = [
        torch.baddbmm(b, xi, w).unflatten(1, (r, t_len))
        for xi, w, b in ((xs[0], w_f, b_f), (xs[1], w_b, b_b))
    ]
    w_hh = torch.cat([h_f, h_b])  # (2E, H, 4H)
    h = x.new_zeros(2 * e, r, HIDDEN)
    c = x.new_zeros(2 * e, r, HIDDEN)
    hs, cs, gates, tcs = [h], [c], [], []
    for f_t, b_t in zip(proj[0].unbind(dim=2), proj[1].unbind(dim=2), strict=True):
        a = torch.baddbmm(torch.cat([f_t, b_t]), h, w_hh)
        sig = torch.sigmoid(a[..., : 3 * HIDDEN])
        g = torch.tanh(a[..., 3 * HIDDEN :])
        i, f, o = sig.chunk(3, dim=-1)
        c = f * c + i * g
        tc = torch.tanh(c)
        h = o * tc
        hs.append(h)
        cs.append(c)
        gates.append((sig, g))
        tcs.append(tc)
    feat = torch.cat([h[:e], h[e:]], dim=-1)  # (E, R, 2H)
    logits = torch.baddbmm(b_out, feat, w_out)
    onehot = torch.nn.functional.one_hot(target, n_out).to(logits.dtype)
    dz = (torch.softmax(logits, dim=-1) - onehot) / r  # (E, R, N)
    d_w_out = torch.bmm(feat.transpose(1, 2), dz)
    d_b_out = dz.sum(dim=1, keepdim=True)
    d_feat = torch.bmm(dz, w_out.transpose(1, 2))
    dh = torch.cat([d_feat[..., :HIDDEN], d_feat[..., HIDDEN:]])  # (2E, R, H)
    dc = torch.zeros_like(dh)
    da_all = x.new_empty(t_len, 2 * e, r, 4 * HIDDEN)
    d_w_hh = torch.zeros_like(w_hh)
    w_hh_t = w_hh.transpose(1, 2)
    for step in range(t_len - 1, -1, -1):
        sig, g = gates[step]
        i, f, o = sig.chunk(3, dim=-1)
        tc = tcs[step]
        dc = dc + dh * o * (1 - tc * tc)
        da = da_all[step]
        d_sig = torch.cat([dc * g, dc * cs[step], dh * tc], dim=-1)
        torch.mul(d_sig, sig * (1 - sig), out=da[..., : 3 * HIDDEN])
        torch.mul(dc * i, 1 - g * g, out=da[..., 3 * HIDDEN :])
        d_w_hh.baddbmm_(hs[step].transpose(1, 2), da)
        dh = torch.bmm(da, w_hh_t)
        dc = dc * f
    # Each direction's pre-activation gradients in its projection's row order (R, then T).
    d_f, d_b = (
        d.permute(1, 2, 0, 3).reshape(e, r * t_len, 4 * HIDDEN)
        for d in (da_all[:, :e], da_all[:, e:])
    )
    return [
        torch.bmm(xs[0].transpose(1, 2), d_f),
        d_w_hh[:e],
        d_f.sum(dim=1, keepdim=True),
        torch.bmm(xs[1].transpose(1, 2), d_b),
        d_w_hh[e:],
        d_b.sum(dim=1, keepdim=True),
        d_w_out,
        d_b_out,
    ]


class _FrameScaler:
    """Per-dimension z-scoring of frame features with training statistics."""

    def fit(self, f: np.ndarray) -> _FrameScaler:
        self.mean_ = f.mean(axis=(0, 1))
        std = f.std(axis=(0, 1))
        self.scale_ = np.where(std > 1e-6, std, 1.0)
        return self

    def transform(self, f: np.ndarray) -> np.ndarray:
        return ((f - self.mean_) / self.scale_).astype(np.float32)


def _net(d_in: int) -> EpisodeNet:
    return EpisodeNet(
        init=lambda e, n, gen: _init(e, d_in, n, gen),
        gather=lambda xs, idx: xs[torch.as_tensor(idx)],
        forward=bilstm_forward,
        grads=bilstm_grads,
        chunk=CHUNK,
        rows=ROWS,
    )


class BiLSTMBaseline(FewShotMethod):
    """BiLSTM: a bidirectional LSTM over frame features, trained from scratch on each
    episode's support set.

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
    frame_scaler_ : object
        Standardisation of the frame features with training statistics.
    schedule_ : models.nets.Schedule
        Rate and steps per validated shot and way, with the validation curves.
    feature_dim_ : int
        32: both directions' final hidden states.

    Examples
    --------
    >>> from tests.synthetic_data import make_dataset
    >>> data = make_dataset(trials_per_class=3, shapes=("circle", "square", "moon"),
    ...                     n_samples=1000, noise=0.1)
    >>> from models.episodes import sample_episodes
    >>> batch = sample_episodes(data.label, n_way=3, k_shot=1, n_query=2, episodes=4, seed=0)
    >>> model = BiLSTMBaseline(steps=10, lr=1e-2).fit(data.signals, data.label)
    >>> model.predict_episodes(data.signals, batch.support, batch.query).shape
    (4, 6)
    """

    name = "BiLSTM"
    cost_hint = (30.0, 30.0)

    def __init__(self, *, seed: int = 0, steps: int | None = None, lr: float | None = None):
        super().__init__(seed=seed)
        self.steps = steps
        self.lr = lr
        self._check_settings(steps="count", lr="rate")

    def _fit(self, signals: np.ndarray, labels: np.ndarray, features: np.ndarray | None) -> None:
        self._cache = PoolCache()
        self.scaler_ = ChannelScaler().fit(signals)
        frames = frame_features(self.scaler_.transform(signals))
        self.frame_scaler_ = _FrameScaler().fit(frames)
        self.feature_dim_ = 2 * HIDDEN
        self.schedule_ = schedule(
            _net(frames.shape[-1]),
            steps=self.steps,
            lr=self.lr,
            inputs=lambda: torch.as_tensor(self.frame_scaler_.transform(frames)),
            labels=labels,
            seed=self.seed,
            lrs=LRS,
            needed=self.test_cells_,
        )

    def _inputs(self, signals: np.ndarray) -> torch.Tensor:
        return torch.as_tensor(
            self.frame_scaler_.transform(frame_features(self.scaler_.transform(signals)))
        )

    def _predict(
        self,
        signals: np.ndarray,
        support: np.ndarray,
        query: np.ndarray,
        features: np.ndarray | None,
    ) -> np.ndarray:
        x = self._cache.get(signals, self._inputs)
        return predict_scheduled(_net(x.shape[-1]), x, support, query, self.schedule_, self.seed)
