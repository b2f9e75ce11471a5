"""CWT-ResNet-ML (paper Table I): continuous-wavelet scalograms of the four channels fed
to a ResNet feature extractor, then the (adapted) cosine prototypical head of AFOP-ML.

- Scalograms: PyWavelets ``cwt`` (Morlet, 16 log-spaced scales, 1.7-50 Hz) of the
  z-scored signals at 125 Hz, magnitude, ``log1p``, time pooled by 4: ``(4, 16, 62)``.
- ResNet: a small ResNet written in plain torch (stem + three BasicBlock stages, 16/32/64
  channels, global average pooling -> 64-d embedding). ImageNet weights cannot be
  downloaded here (and never saw tactile scalograms), so it is pretrained from scratch by
  classifying the training classes of the split it is fitted on; the report says so.
- Episode time: embeddings z-scored with training statistics go through
  :func:`models.prototypes.adapt_cosine_head`.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pywt
import torch
from torch import nn

from .base import FewShotMethod
from .nets import ChannelScaler, decimate
from .prototypes import adapt_cosine_head
from .scaling import FeatureScaler

SCALES = np.geomspace(2.0, 60.0, 16)
POOL = 4
WIDTHS = (16, 32, 64)


def scalograms(z: np.ndarray) -> np.ndarray:
    """``(n, 4, T)`` z-scored 125 Hz signals -> ``(n, 4, 16, T // 4)`` log-magnitudes."""
    coef, _ = pywt.cwt(z, SCALES, "morl", sampling_period=1.0 / 125.0, method="fft", axis=-1)
    mag = np.log1p(np.abs(coef)).transpose(1, 2, 0, 3)  # (n, 4, scales, T)
    t = mag.shape[-1] // POOL * POOL
    return mag[..., :t].reshape(*mag.shape[:-1], t // POOL, POOL).mean(-1).astype(np.float32)


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
    """Learned: ``scaler_``, ``net_`` (pretrained ResNet), ``embed_scaler_``;
    ``feature_dim_`` = 64."""

    name = "CWT-ResNet-ML"

    def __init__(
        self,
        *,
        seed: int = 0,
        epochs: int = 12,
        batch: int = 64,
        lr: float = 2e-3,
        steps: int = 250,
        head_lr: float = 1.5e-3,
        lam: float = 0.10,
        alpha: float = 10.0,
    ) -> None:
        super().__init__(seed=seed)
        self.epochs = epochs
        self.batch = batch
        self.lr = lr
        self.steps = steps
        self.head_lr = head_lr
        self.lam = lam
        self.alpha = alpha

    def _images(self, signals: np.ndarray) -> torch.Tensor:
        small = decimate(signals)
        key = hashlib.sha1(np.ascontiguousarray(small).tobytes()).hexdigest()
        cache = self.__dict__.setdefault("_cache", {})
        if key not in cache:
            cache.clear()  # one pool at a time (the pools are large)
            cache[key] = torch.as_tensor(scalograms(self.scaler_.transform(small)))
        return cache[key]

    def _embed(self, images: torch.Tensor) -> np.ndarray:
        self.net_.eval()
        with torch.no_grad():
            return np.concatenate(
                [self.net_(images[i : i + 256]).numpy() for i in range(0, len(images), 256)]
            )

    def _fit(self, signals: np.ndarray, labels: np.ndarray, features: np.ndarray | None) -> None:
        self.scaler_ = ChannelScaler().fit(decimate(signals))
        images = self._images(signals)
        classes, y = np.unique(labels, return_inverse=True)
        # nn.Module initialisation draws from torch's global RNG: seed it inside a fork so
        # the caller's RNG state is left as it was.
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(self.seed)
            self.net_ = ResNet()
            head = nn.Linear(WIDTHS[-1], classes.size)
        opt = torch.optim.Adam([*self.net_.parameters(), *head.parameters()], lr=self.lr)
        gen = np.random.default_rng(self.seed)
        target = torch.as_tensor(y)
        self.net_.train()
        for _ in range(self.epochs):
            order = gen.permutation(len(y))
            for i in range(0, len(y), self.batch):
                idx = torch.as_tensor(order[i : i + self.batch])
                if idx.numel() < 2:
                    continue  # batch norm needs two examples
                loss = nn.functional.cross_entropy(head(self.net_(images[idx])), target[idx])
                opt.zero_grad(set_to_none=True)
                loss.backward()
                opt.step()
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
