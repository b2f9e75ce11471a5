"""CWT-ResNet-ML (paper Table I): continuous-wavelet scalograms of the four channels fed
to a ResNet feature extractor, then the (adapted) cosine prototypical head of AFOP-ML.

- Scalograms (:func:`scalograms`): analytic Morlet wavelet transform (omega0 = 6,
  Torrence & Compo 1998) of the z-scored raw 1 kHz signals at :data:`N_SCALES` centre
  frequencies log-spaced over :data:`FREQ_RANGE_HZ` (1-250 Hz), magnitude, ``log1p``,
  time averaged over 32 ms bins: ``(4, 20, 62)`` images. The transform runs in the
  frequency domain (one FFT per signal, one short inverse FFT per scale, zero-padded
  against wrap-around): PyWavelets' ``cwt`` convolves every scale separately, which at
  1 kHz and down to 1 Hz is tens of times slower.
- ResNet: the paper "generates the features from a pretrained Resnet". Pretrained weights
  cannot be downloaded at run time, so by default (``arch="small"``) a small ResNet
  written in plain torch (stem + three BasicBlock stages, 16/32/64 channels, global
  average pooling -> 64-d embedding) is trained from scratch by classifying the training
  classes; the report says so. With ``weights=PATH`` (``--method-option
  CWT-ResNet-ML:weights=PATH``) the network is a ResNet-18 (:class:`ResNet18`, the
  layout and state-dict key names of torchvision's ``resnet18``, 512-d embedding)
  started from a torchvision ResNet-18 state dict the user already has
  (:func:`load_resnet18_weights`: read with ``torch.load(weights_only=True)``, no
  pickled objects, or a ``.safetensors`` file when the safetensors package is
  installed). Its stem takes the scalograms' 4 channels: each of the 4 input channels'
  filters is the sum of the RGB filters divided by 4, so a grey image on the 4 channels
  meets the response the RGB stem gives the same grey on its 3; a 4-channel stem in the
  file is used as it is. The classifier ``fc`` of the file is not used. Before the first
  validation the pretrained batch-norm statistics are re-estimated on the training
  scalograms (their inputs are no ImageNet photographs). ``arch="resnet18"`` without
  weights trains that layout from scratch.
- Training (either network): Adam (``lr``, default 1e-3; a pretrained start may want
  less), batches of 64, classifying training classes. The number of epochs is chosen
  by early stopping: a quarter of the training classes are held out, and after every
  epoch (epoch 0: the starting weights) the embedding's cosine nearest-prototype accuracy
  on 5-way 1- and 5-shot episodes of those classes is measured; training stops after
  ``patience`` epochs without a gain (``epoch_curve_``: epoch, validation accuracy).
  Then the network is trained anew from the same start on ALL training classes for the
  chosen number of epochs (``epochs_``), so that no training class is left unseen.
- Episode time: embeddings z-scored with training statistics go through
  :func:`models.prototypes.adapt_cosine_head` with AFOP-ML's paper values (250 Adam steps
  at 1.5e-3, entropy weight 0.10). ``alpha`` (the head's temperature, not given in the
  paper) defaults to the value ``scripts/tune.py`` chose for this method on validation
  data of the closed-set training half (:mod:`models.tuned`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.fft
import torch
from torch import nn

from synth import SAMPLE_RATE_HZ
from tactile_synth.validation import check_choice

from .base import FewShotMethod
from .nets import ChannelScaler, PoolCache, accuracy, holdout_classes, validation_episodes
from .prototypes import adapt_cosine_head, nearest_prototype
from .scaling import FeatureScaler
from .tuned import tuned

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


class BasicBlock(nn.Module):
    """torchvision's ResNet BasicBlock, with its attribute (state-dict key) names."""

    def __init__(self, c_in: int, c_out: int, stride: int) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(c_in, c_out, 3, stride, 1, bias=False)
        self.bn1 = nn.BatchNorm2d(c_out)
        self.relu = nn.ReLU(inplace=True)
        self.conv2 = nn.Conv2d(c_out, c_out, 3, 1, 1, bias=False)
        self.bn2 = nn.BatchNorm2d(c_out)
        self.downsample = (
            nn.Sequential(nn.Conv2d(c_in, c_out, 1, stride, bias=False), nn.BatchNorm2d(c_out))
            if stride != 1 or c_in != c_out
            else None
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = self.relu(self.bn1(self.conv1(x)))
        h = self.bn2(self.conv2(h))
        return self.relu(h + (x if self.downsample is None else self.downsample(x)))


#: The ResNet-18 stage widths (torchvision's ``resnet18``: BasicBlocks [2, 2, 2, 2]).
RESNET18_WIDTHS = (64, 128, 256, 512)


class ResNet18(nn.Module):
    """ResNet-18 in the layout and with the state-dict key names of torchvision's
    ``resnet18`` (``conv1``, ``bn1``, ``layer1``..``layer4``, each of two BasicBlocks with
    ``conv1``, ``bn1``, ``conv2``, ``bn2`` and ``downsample.0/1``), on ``c_in`` input
    channels and without the classifier ``fc``; ``forward`` returns the globally pooled
    512-d embedding."""

    def __init__(self, c_in: int = 4) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(c_in, 64, 7, 2, 3, bias=False)
        self.bn1 = nn.BatchNorm2d(64)
        self.relu = nn.ReLU(inplace=True)
        self.maxpool = nn.MaxPool2d(3, 2, 1)
        c = 64
        for i, w in enumerate(RESNET18_WIDTHS):
            stride = 1 if i == 0 else 2
            setattr(
                self, f"layer{i + 1}", nn.Sequential(BasicBlock(c, w, stride), BasicBlock(w, w, 1))
            )
            c = w
        for m in self.modules():  # torchvision's initialisation
            if isinstance(m, nn.Conv2d):
                nn.init.kaiming_normal_(m.weight, mode="fan_out", nonlinearity="relu")

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = self.maxpool(self.relu(self.bn1(self.conv1(x))))
        h = self.layer4(self.layer3(self.layer2(self.layer1(h))))
        return h.mean(dim=(2, 3))


def _read_state_dict(path: Path, arg: str) -> dict[str, torch.Tensor]:
    """The tensors of a state-dict file: ``.safetensors`` through the safetensors package,
    anything else through ``torch.load(weights_only=True)`` (plain tensors and containers
    only: a file holding other pickled objects is refused). A dict under ``state_dict`` or
    ``model`` is taken, and a ``module.`` prefix (DataParallel) stripped."""
    if not path.is_file():
        raise ValueError(f"{arg}: {path} is not a file")
    if path.suffix == ".safetensors":
        try:
            from safetensors.torch import load_file
        except ImportError:
            raise ValueError(
                f"{arg}: {path} is a .safetensors file and the safetensors package is not "
                "installed (pip install safetensors), or give a torch state-dict file"
            ) from None
        try:
            state = load_file(str(path))
        except Exception as exc:
            raise ValueError(f"{arg}: {path} is not a readable safetensors file: {exc}") from None
    else:
        try:
            state = torch.load(path, map_location="cpu", weights_only=True)
        except Exception as exc:  # pickle.UnpicklingError, RuntimeError, EOFError, ...
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise ValueError(
                f"{arg}: {path} is not a state dict of tensors that loads without pickled "
                f"objects (torch.load weights_only=True): {first}"
            ) from None
    for wrapper in ("state_dict", "model"):
        if isinstance(state, dict) and isinstance(state.get(wrapper), dict):
            state = state[wrapper]
    if not isinstance(state, dict) or not all(
        isinstance(k, str) and isinstance(v, torch.Tensor) for k, v in state.items()
    ):
        raise ValueError(f"{arg}: {path} does not hold a state dict (names -> tensors)")
    return {k.removeprefix("module."): v for k, v in state.items()}


def load_resnet18_weights(net: ResNet18, path: str | Path, *, arg: str = "weights") -> None:
    """Load a torchvision ResNet-18 state dict from ``path`` into ``net`` (``c_in`` input
    channels). The stem's RGB filters ``(64, 3, 7, 7)`` become ``c_in``-channel filters,
    each input channel's the RGB filters' sum divided by ``c_in`` (a grey input on all
    channels meets the RGB stem's response to the same grey); a stem with ``c_in``
    channels is loaded as it is. ``fc.*`` is ignored. ValueError naming ``arg`` for a
    file that is not a readable state dict or does not fit the layout."""
    state = _read_state_dict(Path(path), arg)
    state = {k: v for k, v in state.items() if not k.startswith("fc.")}
    own = net.state_dict()
    stem = state.get("conv1.weight")
    c_in = own["conv1.weight"].shape[1]
    if stem is not None and stem.ndim == 4 and stem.shape[1] == 3 and c_in != 3:
        state["conv1.weight"] = stem.sum(dim=1, keepdim=True).expand(-1, c_in, -1, -1) / c_in
    missing = sorted(set(own) - set(state))
    unexpected = sorted(set(state) - set(own))
    if missing or unexpected:
        parts = []
        if missing:
            parts.append(f"missing {', '.join(missing[:3])}{' ...' if len(missing) > 3 else ''}")
        if unexpected:
            parts.append(
                f"unexpected {', '.join(unexpected[:3])}{' ...' if len(unexpected) > 3 else ''}"
            )
        raise ValueError(
            f"{arg}: {path} is not a torchvision ResNet-18 state dict ({'; '.join(parts)})"
        )
    for k, v in own.items():
        if state[k].shape != v.shape:
            raise ValueError(
                f"{arg}: {path}: {k} has shape {tuple(state[k].shape)}, a ResNet-18 needs "
                f"{tuple(v.shape)}"
            )
    net.load_state_dict({k: state[k].to(v.dtype) for k, v in own.items()})


def _embed(net: nn.Module, images: torch.Tensor) -> np.ndarray:
    """Embeddings ``(n, width)`` of ``images`` (evaluation mode, batches of 256)."""
    net.eval()
    with torch.no_grad():
        return np.concatenate(
            [net(images[i : i + 256]).numpy() for i in range(0, len(images), 256)]
        )


def _reestimate_batch_norm(net: nn.Module, images: torch.Tensor, batch: int) -> None:
    """Replace the running statistics of every batch norm of ``net`` by the cumulative
    mean and variance over ``images`` (forward passes in training mode, no gradient):
    pretrained statistics describe other inputs."""
    norms = [m for m in net.modules() if isinstance(m, nn.BatchNorm2d)]
    for m in norms:
        m.reset_running_stats()
        m.momentum = None  # cumulative average
    net.train()
    with torch.no_grad():
        for i in range(0, len(images), batch):
            if len(images[i : i + batch]) > 1:
                net(images[i : i + batch])
    for m in norms:
        m.momentum = 0.1  # torch's default, for the training that follows


#: Network layouts: name -> embedding width.
ARCHS = {"small": WIDTHS[-1], "resnet18": RESNET18_WIDTHS[-1]}


class CWTResNetML(FewShotMethod):
    """CWT-ResNet-ML: wavelet scalograms, a ResNet embedding trained on the training
    classes, and AFOP-ML's adapted cosine prototypical head.

    Parameters
    ----------
    seed : int, default 0
        Seeds the network's initialisation, batches and validation episodes.
    max_epochs : int, default 30
        The most training epochs early stopping may choose.
    patience : int, default 3
        Epochs without a validation gain before early stopping ends training.
    batch : int, default 64
        Training batch size.
    lr : float, default 1e-3
        The network's Adam learning rate.
    steps : int, default 250
        Adam steps of the head's adaptation per episode (AFOP-ML's paper value).
    head_lr : float, default 1.5e-3
        The head's Adam learning rate (AFOP-ML's paper value).
    lam : float, default 0.10
        Weight of the posteriors' entropy in the head's loss.
    alpha : float or None
        The head's temperature (None: the tuned value, :mod:`models.tuned`).
    val_episodes : int, default 100
        Validation episodes per shot of the early stopping.
    weights : str or None
        Path of a torchvision ResNet-18 state dict to start from (then ``arch`` is
        ``"resnet18"``).
    arch : {"small", "resnet18"} or None
        The network (None: ``"resnet18"`` with ``weights``, else ``"small"``).

    Attributes
    ----------
    scaler_ : models.nets.ChannelScaler
        Per-channel z-scoring with training statistics.
    net_ : torch.nn.Module
        The ResNet trained on all training classes.
    embed_scaler_ : models.scaling.FeatureScaler
        z-scoring of the embeddings with training statistics.
    epochs_ : int
        The epoch count chosen on held-out training classes.
    epoch_curve_ : numpy.ndarray
        ``(n, 2)``: epoch, validation accuracy.
    feature_dim_ : int
        64 (``arch="small"``) or 512 (ResNet-18).

    Examples
    --------
    >>> from tests.synthetic_data import make_dataset
    >>> data = make_dataset(trials_per_class=3, shapes=("circle", "square", "moon"),
    ...                     n_samples=1000, noise=0.1)
    >>> from models.episodes import sample_episodes
    >>> batch = sample_episodes(data.label, n_way=3, k_shot=1, n_query=2, episodes=4, seed=0)
    >>> model = CWTResNetML(max_epochs=1, steps=10, val_episodes=4).fit(data.signals,
    ...                                                                  data.label)
    >>> model.predict_episodes(data.signals, batch.support, batch.query).shape
    (4, 6)
    """

    name = "CWT-ResNet-ML"
    cost_hint = (25.0, 11.0)

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
        alpha: float | None = None,
        val_episodes: int = 100,
        weights: str | None = None,
        arch: str | None = None,
    ) -> None:
        super().__init__(seed=seed)
        if weights is not None:
            if not isinstance(weights, str | Path) or not Path(weights).is_file():
                raise ValueError(
                    f"{self.name}: weights must be the path of a ResNet-18 state-dict file; "
                    f"got {weights!r}"
                )
            weights = str(weights)
        self.weights = weights
        self.arch = ("resnet18" if weights is not None else "small") if arch is None else arch
        check_choice(f"{self.name}: arch", self.arch, tuple(ARCHS))
        if weights is not None and self.arch != "resnet18":
            raise ValueError(
                f"{self.name}: weights are ResNet-18 weights: arch must be 'resnet18'; got "
                f"{self.arch!r}"
            )
        self.max_epochs = max_epochs
        self.patience = patience
        self.batch = batch
        self.lr = lr
        self.steps = steps
        self.head_lr = head_lr
        self.lam = lam
        self.alpha = tuned(self.name, "alpha") if alpha is None else alpha
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
        return torch.as_tensor(scalograms(self.scaler_.transform(signals)))

    def _network(self) -> nn.Module:
        """A new network at its starting weights (seeded; the user's weights if given)."""
        # nn.Module initialisation draws from torch's global RNG: seed it inside a fork so
        # the caller's RNG state is left as it was.
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(self.seed)
            net = ResNet() if self.arch == "small" else ResNet18()
        if self.weights is not None:
            load_resnet18_weights(net, self.weights, arg=f"{self.name}: weights")
        return net

    def _train(
        self, images: torch.Tensor, labels: np.ndarray, epochs: int, score=None
    ) -> tuple[nn.Module, list[tuple[int, float]]]:
        """A network trained on ``images`` of ``labels`` (classification, Adam) from its
        start. ``score(net) -> float``, when given, is read after every epoch (and before
        the first); training then stops ``patience`` epochs after the best score, and the
        returned network is the one after ``epochs`` epochs at most (the caller keeps the
        curve). Without ``score`` it trains exactly ``epochs`` epochs."""
        net = self._network()
        classes, y = np.unique(labels, return_inverse=True)
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(self.seed + 1)
            head = nn.Linear(ARCHS[self.arch], classes.size)
        if self.weights is not None:
            _reestimate_batch_norm(net, images, self.batch)
        opt = torch.optim.Adam([*net.parameters(), *head.parameters()], lr=self.lr)
        gen = np.random.default_rng(self.seed)
        target = torch.as_tensor(y)
        curve = [] if score is None else [(0, score(net))]
        best = (curve[0][1], 0) if curve else (0.0, 0)
        for epoch in range(1, epochs + 1):
            net.train()
            order = gen.permutation(len(y))
            for i in range(0, len(y), self.batch):
                idx = torch.as_tensor(order[i : i + self.batch])
                if idx.numel() < 2:
                    continue  # batch norm needs two examples
                loss = nn.functional.cross_entropy(head(net(images[idx])), target[idx])
                opt.zero_grad(set_to_none=True)
                loss.backward()
                opt.step()
            if score is None:
                continue
            curve.append((epoch, score(net)))
            if curve[-1][1] > best[0]:
                best = (curve[-1][1], epoch)
            elif epoch - best[1] >= self.patience:
                break
        return net, curve

    def _fit(self, signals: np.ndarray, labels: np.ndarray, features: np.ndarray | None) -> None:
        self.scaler_ = ChannelScaler().fit(signals)
        images = self._images(signals)
        # 1. The epoch count: trained on three quarters of the training classes, scored on
        # episodes of the held-out quarter after every epoch.
        held = holdout_classes(labels, fraction=0.25, seed=self.seed)
        train_idx, val_idx = np.flatnonzero(~held), np.flatnonzero(held)
        val = validation_episodes(labels[val_idx], seed=self.seed, episodes=self.val_episodes)
        x_val = images[torch.as_tensor(val_idx)]

        def score(net: nn.Module) -> float:
            emb = FeatureScaler().fit_transform(_embed(net, x_val))
            return float(
                np.mean([accuracy(nearest_prototype(emb, b.support, b.query), b) for b in val])
            )

        _, curve = self._train(
            images[torch.as_tensor(train_idx)], labels[train_idx], self.max_epochs, score
        )
        accs = [a for _, a in curve]
        self.epochs_ = int(curve[int(np.argmax(accs))][0])  # the first best epoch
        self.epoch_curve_ = np.asarray(curve, dtype=np.float64)
        # 2. The network: trained anew on all training classes for that many epochs.
        self.net_, _ = self._train(images, labels, self.epochs_)
        self.embed_scaler_ = FeatureScaler().fit(_embed(self.net_, images))
        self.feature_dim_ = ARCHS[self.arch]
        self._embeddings = PoolCache()

    def _predict(
        self,
        signals: np.ndarray,
        support: np.ndarray,
        query: np.ndarray,
        features: np.ndarray | None,
    ) -> np.ndarray:
        # Every cell of a table is labelled on the same pool: its embeddings are computed
        # once per pool (the scalograms are only needed on the way).
        emb = self._embeddings.get(
            signals,
            lambda s: self.embed_scaler_.transform(_embed(self.net_, self._images(s))),
        )
        return adapt_cosine_head(
            emb, support, query, steps=self.steps, lr=self.head_lr, lam=self.lam, alpha=self.alpha
        )
