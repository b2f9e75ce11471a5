"""CWT-ResNet-ML (paper Table I): continuous-wavelet scalograms of the four channels fed
to a ResNet feature extractor, then the (adapted) cosine prototypical head of AFOP-ML.

- Scalograms (:func:`scalograms`): analytic Morlet wavelet transform (omega0 = 6,
  Torrence & Compo 1998) of the z-scored raw 1 kHz signals at :data:`N_SCALES` centre
  frequencies log-spaced over :data:`FREQ_RANGE_HZ` (1-250 Hz), magnitude, ``log1p``,
  time averaged over 32 ms bins: ``(4, 20, 62)`` images. The transform runs in the
  frequency domain (one FFT per signal, one short inverse FFT per scale, zero-padded
  against wrap-around): PyWavelets' ``cwt`` convolves every scale separately, which at
  1 kHz and down to 1 Hz is tens of times slower.
- ResNet: a small ResNet written in plain torch (stem + three BasicBlock stages, 16/32/64
  channels, global average pooling -> 64-d embedding). ImageNet weights cannot be
  downloaded here (and never saw tactile scalograms), so it is pretrained from scratch by
  classifying training classes; the report says so. Adam at its default rate (1e-3),
  batches of 64. The number of epochs is chosen by early stopping: a quarter of the
  training classes are held out, and after every epoch the embedding's cosine
  nearest-prototype accuracy on 5-way 1- and 5-shot episodes of those classes is
  measured; training stops after ``patience`` epochs without a gain and the best epoch's
  network is kept (``epoch_curve_``: epoch, validation accuracy).
- Episode time: embeddings z-scored with training statistics go through
  :func:`models.prototypes.adapt_cosine_head` with AFOP-ML's paper values (250 Adam steps
  at 1.5e-3, entropy weight 0.10, scale 10).
"""

from __future__ import annotations

import numpy as np
import scipy.fft
import torch
from torch import nn

from synth import SAMPLE_RATE_HZ

from .base import FewShotMethod
from .nets import ChannelScaler, PoolCache, accuracy, holdout_classes, validation_episodes
from .prototypes import adapt_cosine_head, nearest_prototype
from .scaling import FeatureScaler

#: Centre frequencies of the wavelet bank (Hz): log-spaced over this range.
FREQ_RANGE_HZ = (1.0, 250.0)
N_SCALES = 20
#: Morlet non-dimensional frequency (Torrence & Compo's 6: admissible, ~6 cycles wide).
OMEGA0 = 6.0
#: Time bin of the scalogram (samples at 1 kHz).
POOL = 32
WIDTHS = (16, 32, 64)
#: Trials transformed at once (bounds the complex coefficient array).
CWT_CHUNK = 64


def scalograms(z: np.ndarray) -> np.ndarray:
    """``(n, 4, T)`` z-scored 1 kHz signals -> ``(n, 4, N_SCALES, T // POOL)``
    log-magnitudes of the analytic Morlet transform.

    The analytic wavelet's spectrum is one-sided and narrow (below ``(1 + 4 / omega0)``
    times its centre frequency up to a factor ``exp(-8)``), so each scale's coefficients
    are computed at the lowest power-of-two fraction of 1 kHz that holds that band (an
    inverse FFT of the spectrum's first bins), before the time bins are averaged.
    """
    x = np.asarray(z, dtype=np.float32)
    n, c, t = x.shape
    size = 1 << int(np.ceil(np.log2(2 * t)))  # zero padding against wrap-around
    omega = 2 * np.pi * scipy.fft.rfftfreq(size, d=1.0 / SAMPLE_RATE_HZ)  # rad/s, >= 0
    freqs = np.geomspace(*FREQ_RANGE_HZ, N_SCALES)
    # Scale s of centre frequency f: the Morlet peak (s * omega = omega0) sits at 2 pi f.
    s = OMEGA0 / (2 * np.pi * freqs)
    # Gain 2 at the centre frequency on the one-sided spectrum: a sinusoid's coefficient
    # magnitude is its amplitude, at every scale.
    bank = 2 * np.exp(-0.5 * (s[:, None] * omega[None, :] - OMEGA0) ** 2)
    bank = bank.astype(np.complex64)
    bins = t // POOL
    # Decimation per scale: 1 kHz / d must exceed the top of the wavelet's band.
    f_top = freqs * (1 + 4 / OMEGA0)
    dec = [int(min(POOL, 2 ** np.floor(np.log2(SAMPLE_RATE_HZ / f)))) for f in f_top]
    out = np.empty((n, c, N_SCALES, bins), dtype=np.float32)
    for i in range(0, n, CWT_CHUNK):
        spec = scipy.fft.rfft(x[i : i + CWT_CHUNK], size, axis=-1)  # (b, c, size/2+1)
        for j, d in enumerate(dec):
            m = size // d
            coef = scipy.fft.ifft(spec[..., :m] * bank[j, :m], axis=-1)[..., : bins * POOL // d]
            mag = np.log1p(np.abs(coef) / d)  # ifft of m bins: coefficients times d
            out[i : i + CWT_CHUNK, :, j] = mag.reshape(*mag.shape[:-1], bins, POOL // d).mean(-1)
    return out


class _Block(nn.Module):
    def __init__(self, c_in: int, c_out: int, stride: int) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(c_in, c_out, 3, stride, 1, bias=False)
        self.bn1 = nn.BatchNorm2d(c_out)
        self.conv2 = nn.Conv2d(c_out, c_out, 3, 1, 1, bias=False)
        self.bn2 = nn.BatchNorm2d(c_out)
        self.skip = (
            nn.Sequential(nn.Conv2d(c_in, c_out, 1, stride, bias=False), nn.BatchNorm2d(c_out))
            if stride != 1 or c_in != c_out
            else nn.Identity()
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = torch.relu(self.bn1(self.conv1(x)))
        return torch.relu(self.bn2(self.conv2(h)) + self.skip(x))


class ResNet(nn.Module):
    """Stem + BasicBlock stages; ``forward`` returns the pooled embedding."""

    def __init__(self, c_in: int = 4) -> None:
        super().__init__()
        self.stem = nn.Sequential(
            nn.Conv2d(c_in, WIDTHS[0], 3, 1, 1, bias=False), nn.BatchNorm2d(WIDTHS[0]), nn.ReLU()
        )
        blocks, c = [], WIDTHS[0]
        for i, w in enumerate(WIDTHS):
            blocks.append(_Block(c, w, 1 if i == 0 else 2))
            c = w
        self.blocks = nn.Sequential(*blocks)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.blocks(self.stem(x)).mean(dim=(2, 3))


class CWTResNetML(FewShotMethod):
    """Learned: ``scaler_``, ``net_`` (pretrained ResNet), ``embed_scaler_``,
    ``epochs_`` (the kept epoch), ``epoch_curve_`` (``(n, 2)``: epoch, validation
    accuracy); ``feature_dim_`` = 64."""

    name = "CWT-ResNet-ML"

    def __init__(
        self,
        *,
        seed: int = 0,
        max_epochs: int = 30,
        patience: int = 3,
        batch: int = 64,
        lr: float = 1e-3,
        steps: int = 250,
        head_lr: float = 1.5e-3,
        lam: float = 0.10,
        alpha: float = 10.0,
        val_episodes: int = 100,
    ) -> None:
        super().__init__(seed=seed)
        self.max_epochs = max_epochs
        self.patience = patience
        self.batch = batch
        self.lr = lr
        self.steps = steps
        self.head_lr = head_lr
        self.lam = lam
        self.alpha = alpha
        self.val_episodes = val_episodes
        self._check_settings(
            max_epochs="count",
            patience="count",
            batch="count",
            lr="rate",
            steps="steps",
            head_lr="rate",
            lam="weight",
            alpha="rate",
            val_episodes="count",
        )

    def _images(self, signals: np.ndarray) -> torch.Tensor:
        return self._cache.get(
            signals, lambda s: torch.as_tensor(scalograms(self.scaler_.transform(s)))
        )

    def _embed(self, images: torch.Tensor) -> np.ndarray:
        self.net_.eval()
        with torch.no_grad():
            return np.concatenate(
                [self.net_(images[i : i + 256]).numpy() for i in range(0, len(images), 256)]
            )

    def _fit(self, signals: np.ndarray, labels: np.ndarray, features: np.ndarray | None) -> None:
        self._cache = PoolCache()
        self.scaler_ = ChannelScaler().fit(signals)
        images = self._images(signals)
        held = holdout_classes(labels, fraction=0.25, seed=self.seed)
        train_idx, val_idx = np.flatnonzero(~held), np.flatnonzero(held)
        val = validation_episodes(labels[val_idx], seed=self.seed, episodes=self.val_episodes)
        classes, y = np.unique(labels[train_idx], return_inverse=True)
        # nn.Module initialisation draws from torch's global RNG: seed it inside a fork so
        # the caller's RNG state is left as it was.
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(self.seed)
            self.net_ = ResNet()
            head = nn.Linear(WIDTHS[-1], classes.size)
        opt = torch.optim.Adam([*self.net_.parameters(), *head.parameters()], lr=self.lr)
        gen = np.random.default_rng(self.seed)
        target = torch.as_tensor(y)
        x_train, x_val = images[torch.as_tensor(train_idx)], images[torch.as_tensor(val_idx)]

        def score() -> float:
            emb = FeatureScaler().fit_transform(self._embed(x_val))
            return float(
                np.mean([accuracy(nearest_prototype(emb, b.support, b.query), b) for b in val])
            )

        def snapshot() -> dict[str, torch.Tensor]:
            return {k: v.clone() for k, v in self.net_.state_dict().items()}

        curve = [(0, score())]
        best = (curve[0][1], 0, snapshot())
        for epoch in range(1, self.max_epochs + 1):
            self.net_.train()
            order = gen.permutation(len(y))
            for i in range(0, len(y), self.batch):
                idx = torch.as_tensor(order[i : i + self.batch])
                if idx.numel() < 2:
                    continue  # batch norm needs two examples
                loss = nn.functional.cross_entropy(head(self.net_(x_train[idx])), target[idx])
                opt.zero_grad(set_to_none=True)
                loss.backward()
                opt.step()
            curve.append((epoch, score()))
            if curve[-1][1] > best[0]:
                best = (curve[-1][1], epoch, snapshot())
            elif epoch - best[1] >= self.patience:
                break
        self.net_.load_state_dict(best[2])
        self.epochs_ = best[1]
        self.epoch_curve_ = np.asarray(curve, dtype=np.float64)
        self.embed_scaler_ = FeatureScaler().fit(self._embed(images))
        self.feature_dim_ = WIDTHS[-1]

    def _predict(
        self,
        signals: np.ndarray,
        support: np.ndarray,
        query: np.ndarray,
        features: np.ndarray | None,
    ) -> np.ndarray:
        emb = self.embed_scaler_.transform(self._embed(self._images(signals)))
        return adapt_cosine_head(
            emb, support, query, steps=self.steps, lr=self.head_lr, lam=self.lam, alpha=self.alpha
        )
