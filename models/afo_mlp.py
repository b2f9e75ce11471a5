"""AFO-MLP-ML (paper Sec. V) and its meta-trained variant ``AFO-MLP-ML+meta``.

**AFO-MLP-ML, as the paper describes it** (:class:`AFOMLPML`): "a small 3-layer MLP
(D -> 64 -> 32 -> N with ReLU) is inserted before the prototypical head to nonlinearly
project the Top-D embeddings, echoing TapNet's task-adaptive projection". Its pretrain is
AFOP-ML's ("~2 s" in Table I, the same as AFOP-ML's and Direct-Prot-ML's): the feature
optimisation alone (z-scoring, NCA ranking, D-scan), nothing trained on the training
classes. Its adaptation is 26 times AFOP-ML's in Table I (10,241.72 ms per episode): per
episode a freshly initialised D -> 64 -> 32 MLP (ReLU) and the cosine prototypical head
(``W`` initialised with the normalised prototypes of the projected support, ``b = 0``)
are trained together on that episode's support set only, minimising the head's loss
(cross-entropy + ``lam`` times the Shannon entropy of the posteriors, logits ``alpha *
cos(z, w_n) + b_n``), with Adam; queries are only forwarded.

- The MLP starts from torch's ``nn.Linear`` initialisation (weights and biases uniform in
  +-1/sqrt(fan-in)), drawn anew for every episode.
- ``lam`` = 0.10 is the head's paper value; the 64/32 widths are the paper's; ``alpha``
  (the head's temperature, not given in the paper) defaults to the value
  ``scripts/tune.py`` chose for this method on validation data of the closed-set training
  half (:mod:`models.tuned`).
- The step count and the learning rate of the per-episode training are not the paper's
  head settings (250 steps at 1.5e-3 adapt two small matrices; here a whole network
  starts from random weights): ``fit`` chooses them on validation episodes drawn from the
  training split, per validated shot and way, reading each rate's validation curve at
  doubling step counts until a doubling brings no gain beyond the best point's 95 % CI,
  exactly as for the CNN and BiLSTM baselines (:func:`models.nets.select_schedule`, rates
  :data:`LRS`, which include the head's 1.5e-3). ``schedule_`` records the settings and
  the curves. The validation episodes come from the same training trials the feature
  optimisation saw, so their accuracy is optimistic; they only decide how long and how
  fast a support set is fitted.
- All episodes of a chunk are one batched problem: per-episode weights are ``(E, ...)``
  tensors multiplied with ``bmm``, so episodes never interact; the loss's gradient is
  written out (:func:`mlp_head_grads`) and PyTorch's fused Adam kernel steps it.

**AFO-MLP-ML+meta** (:class:`AFOMLPMLMeta`, a variant beyond the paper): the same MLP is
meta-trained with prototypical episodes (5-way 5-shot) on the training classes after the
feature optimisation; per episode a copy of it and the head are fine-tuned together on
the support set (the head's paper settings: 250 Adam steps at lr 1.5e-3, entropy weight
0.10). In the closed-set protocol the training classes are the test classes, so its
meta-training is supervised metric learning on them. ``alpha``, ``meta_iterations`` and
``meta_lr`` default to the values ``scripts/tune.py`` chose for this variant;
``meta_batch`` = 16 tasks per meta-step is a fixed compute budget (not tuned). The
fine-tuning of a chunk of episodes is one tensor program (:func:`adapt_mlp_head`): the
loss's gradient written out (:func:`mlp_head_grads`, checked against autograd by the
tests) and PyTorch's fused Adam kernel, with no autograd graph per step.

Both take ``ncfs_lam_n`` / ``ncfs_max_iter`` for the AFOP-ML feature optimisation (None:
AFOP-ML's defaults).
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import torch

from tactile_synth.validation import check_int

from .afop import AFOPML
from .base import FewShotMethod
from .cnn import predict_scheduled
from .episodes import meta_training_episodes
from .features import pool_of
from .nets import EpisodeNet, schedule, train_per_episode
from .prototypes import EPISODE_CHUNK, normalise
from .tuned import tuned

HIDDEN = (64, 32)
#: Candidate Adam learning rates of the per-episode training (the head's paper rate
#: 1.5e-3, and faster ones for a network that starts from random weights).
LRS = (1.5e-3, 5e-3, 1.5e-2)
#: Episodes trained together, and support examples in all.
CHUNK = 512
ROWS = 16384
#: Weights (floats, episodes x MLP-and-head parameters) a chunk of the meta variant's
#: fine-tuning holds at most: a larger chunk spreads each Adam step's fixed cost (a few
#: dozen small batched kernels) over more episodes, a smaller one keeps the weights, their
#: gradient and both moments, read and rewritten on every step, nearer the CPU. 2**20
#: floats (4 MiB per array; about 150 episodes of 64-d features) lies inside the flat
#: optimum of chunk sizes measured on one thread.
MLP_FLOATS = 2**20


def _mlp(x: torch.Tensor, params: list[torch.Tensor]) -> torch.Tensor:
    """Batched MLP: x ``(E, R, D)``, params ``[W1 (E,D,64), b1 (E,1,64), W2, b2]``."""
    w1, b1, w2, b2 = params
    return torch.bmm(torch.relu(torch.baddbmm(b1, x, w1)), w2) + b2


def mlp_head_grads(
    xs: torch.Tensor,
    params: list[torch.Tensor],
    onehot: torch.Tensor,
    *,
    alpha: float,
    lam: float,
) -> list[torch.Tensor]:
    """The gradient of every episode's support loss (cross-entropy + ``lam`` times the
    posteriors' entropy, mean over its S support examples) with respect to its MLP and
    head ``[W1, b1, W2, b2, W (E,N,32), b (E,1,N)]``, written out (no autograd graph):
    support ``xs (E, S, D)``, ``onehot (S, N)`` (or ``(E, S, N)``) its labels.

    With ``z = MLP(x)``, ``u = z / |z|``, ``v_n = w_n / |w_n|``, cosines ``c = u v^T``,
    logits ``alpha c + b`` and ``g = dL/dlogits = (p - y - lam p (log p + H)) / S``:
    ``dL/du = alpha g v`` and ``dL/dv = alpha g^T u``; a normalisation ``u = z / |z|``
    passes ``(dL/du - (dL/du . u) u) / |z|`` back to ``z``; the two linear layers and
    the ReLU then pass it back as any MLP does."""
    w1, b1, w2, b2, w, b = params
    s = xs.shape[1]
    z1 = torch.baddbmm(b1, xs, w1)
    h = torch.relu(z1)
    z = torch.baddbmm(b2, h, w2)
    inv_z = z.norm(dim=-1, keepdim=True).clamp_min(1e-12).reciprocal_()
    u = z * inv_z
    inv_w = w.norm(dim=-1, keepdim=True).clamp_min(1e-12).reciprocal_()
    v = w * inv_w
    logp = torch.log_softmax(alpha * torch.bmm(u, v.transpose(1, 2)) + b, dim=-1)
    p = logp.exp()
    entropy = -(p * logp).sum(dim=-1, keepdim=True)
    g = (p - onehot - lam * p * (logp + entropy)) / s  # (E, S, N)
    gc = g * alpha
    gu = torch.bmm(gc, v)
    gv = torch.bmm(gc.transpose(1, 2), u)
    gw = (gv - (gv * v).sum(dim=-1, keepdim=True) * v).mul_(inv_w)
    gz = (gu - (gu * u).sum(dim=-1, keepdim=True) * u).mul_(inv_z)
    gh = torch.bmm(gz, w2.transpose(1, 2)).mul_(z1 > 0)
    return [
        torch.bmm(xs.transpose(1, 2), gh),
        gh.sum(dim=1, keepdim=True),
        torch.bmm(h.transpose(1, 2), gz),
        gz.sum(dim=1, keepdim=True),
        gw,
        g.sum(dim=1, keepdim=True),
    ]


def mlp_chunk(d_in: int, n_way: int, *, cap: int = EPISODE_CHUNK) -> int:
    """Episodes fine-tuned together: at most ``cap``, and at most :data:`MLP_FLOATS`
    MLP-and-head weights in all (at least one episode)."""
    per_episode = d_in * HIDDEN[0] + HIDDEN[0] + HIDDEN[0] * HIDDEN[1] + HIDDEN[1]
    per_episode += n_way * (HIDDEN[1] + 1)
    return max(1, min(cap, MLP_FLOATS // per_episode))


def meta_net(
    mlp: list[torch.Tensor],
    support_shape: tuple[int, int, int],
    *,
    alpha: float,
    lam: float,
    chunk: int | None = None,
) -> EpisodeNet:
    """The meta variant's per-episode network for episodes of ``support_shape`` (E, N,
    K): :func:`episode_net`'s MLP and head, the MLP starting from a copy of the
    meta-trained ``mlp`` (``[W1 (1,D,64), b1, W2, b2]``) instead of a fresh draw;
    ``chunk`` episodes trained together (None: :func:`mlp_chunk`, cache-sized)."""
    _, n_way, k_shot = support_shape
    d_in = mlp[0].shape[1]
    step_e = mlp_chunk(d_in, n_way) if chunk is None else check_int("chunk", chunk, minimum=1)

    def init(e: int, n: int, gen: torch.Generator) -> list[torch.Tensor]:
        body = [p.expand(e, -1, -1).clone() for p in mlp]
        return [*body, torch.zeros(e, n, HIDDEN[-1]), torch.zeros(e, 1, n)]

    net = episode_net(d_in, alpha=alpha, lam=lam)
    return dataclasses.replace(net, init=init, chunk=step_e, rows=step_e * n_way * k_shot)


def adapt_mlp_head(
    x: torch.Tensor,
    support: np.ndarray,
    query: np.ndarray,
    mlp: list[torch.Tensor],
    *,
    steps: int,
    lr: float,
    lam: float,
    alpha: float,
    chunk: int | None = None,
) -> np.ndarray:
    """The meta variant's per-episode fine-tuning: predictions ``(E, M)``.

    Per episode a copy of the MLP ``mlp`` and the cosine head (``W`` the normalised
    prototypes of the projected support, ``b = 0``) are trained together on its support
    set by ``steps`` Adam steps (:class:`models.nets.EpisodeTrainer`: the gradient
    :func:`mlp_head_grads` writes out, PyTorch's fused Adam); queries are only forwarded.
    ``x``: the pool's embeddings ``(P, D)``; ``chunk``: as :func:`meta_net`'s. Episodes
    never interact.
    """
    net = meta_net(mlp, support.shape, alpha=alpha, lam=lam, chunk=chunk)
    return train_per_episode(net, x, support, query, steps=steps, lr=lr, seed=0)


def _head_loss(lam: float) -> object:
    def loss(logits: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
        e, _, n = logits.shape
        logp = torch.log_softmax(logits, dim=-1)
        ce = torch.nn.functional.nll_loss(logp.reshape(-1, n), target.reshape(-1))
        entropy = -(logp.exp() * logp).sum(dim=-1).mean()
        return (ce + lam * entropy) * e  # each episode's own mean loss, summed

    return loss


def episode_net(d_in: int, *, alpha: float, lam: float) -> EpisodeNet:
    """The paper's per-episode network: a fresh D -> 64 -> 32 MLP (``nn.Linear``'s
    initialisation) and the cosine head, W started at the normalised prototypes of the
    projected support, b at 0; weights ``[W1, b1, W2, b2, W (E,N,32), b (E,1,N)]``."""

    def init(e: int, n: int, gen: torch.Generator) -> list[torch.Tensor]:
        params = []
        for a, b in itertools.pairwise((d_in, *HIDDEN)):
            bound = a**-0.5
            params.append((torch.rand(e, a, b, generator=gen) * 2 - 1) * bound)
            params.append((torch.rand(e, 1, b, generator=gen) * 2 - 1) * bound)
        params.append(torch.zeros(e, n, HIDDEN[-1]))
        params.append(torch.zeros(e, 1, n))
        return params

    def start(params: list[torch.Tensor], xs: torch.Tensor, n: int, k: int) -> list[torch.Tensor]:
        z = _mlp(xs, params[:4])  # (E, N*K, 32), class-major rows
        w = normalise(z.reshape(z.shape[0], n, k, -1).mean(dim=2))
        return [*params[:4], w, params[5]]

    def forward(x: torch.Tensor, params: list[torch.Tensor]) -> torch.Tensor:
        z = normalise(_mlp(x, params[:4]))
        return alpha * torch.bmm(z, normalise(params[4]).transpose(1, 2)) + params[5]

    def grads(x: torch.Tensor, params: list[torch.Tensor], target: torch.Tensor) -> list:
        onehot = torch.nn.functional.one_hot(target, params[4].shape[1]).to(x.dtype)
        return mlp_head_grads(x, params, onehot, alpha=alpha, lam=lam)

    return EpisodeNet(
        init=init,
        gather=lambda x, idx: x[torch.as_tensor(idx)],
        forward=forward,
        loss=_head_loss(lam),
        grads=grads,
        start=start,
        chunk=CHUNK,
        rows=ROWS,
    )


class AFOMLPML(FewShotMethod):
    """AFO-MLP-ML as the paper describes it: AFOP-ML's top-D features through a fresh
    D -> 64 -> 32 MLP and the cosine head, trained on each episode's support set.

    Parameters
    ----------
    seed : int, default 0
        Seeds the feature optimisation, the networks and the validation episodes.
    steps : int or None
        Adam steps per episode (None: chosen on validation episodes of the training
        split, per shot and way).
    lr : float or None
        Adam learning rate (None: chosen likewise, from :data:`LRS`).
    lam : float, default 0.10
        Weight of the posteriors' entropy in the head's loss (paper).
    alpha : float or None
        The head's temperature (None: the tuned value, :mod:`models.tuned`).
    ncfs_lam_n, ncfs_max_iter : float, "cv", int or None
        AFOP-ML's feature-optimisation settings (None: AFOP-ML's defaults).

    Attributes
    ----------
    afop_ : models.afop.AFOPML
        The feature optimisation (z-scoring, NCA ranking, D-scan); nothing else is
        trained at fit time.
    D_ : int
        The chosen size D.
    selected_ : numpy.ndarray
        Indices of the top-D features.
    schedule_ : models.nets.Schedule
        Rate and steps of the per-episode training per validated shot and way, with the
        validation curves.
    feature_dim_ : int
        32: the projection's output.

    Examples
    --------
    >>> from tests.synthetic_data import make_dataset
    >>> data = make_dataset(trials_per_class=3, shapes=("circle", "square", "moon"),
    ...                     n_samples=1000, noise=0.1)
    >>> from models.episodes import sample_episodes
    >>> batch = sample_episodes(data.label, n_way=3, k_shot=1, n_query=2, episodes=4, seed=0)
    >>> model = AFOMLPML(steps=20, lr=5e-3).fit(data.signals, data.label)
    >>> model.predict_episodes(data.signals, batch.support, batch.query).shape
    (4, 6)
    """

    name = "AFO-MLP-ML"
    cost_hint = (7.0, 2.0)

    def __init__(
        self,
        *,
        seed: int = 0,
        steps: int | None = None,
        lr: float | None = None,
        lam: float = 0.10,
        alpha: float | None = None,
        ncfs_lam_n: float | str | None = None,
        ncfs_max_iter: int | None = None,
    ) -> None:
        super().__init__(seed=seed)
        self.steps = steps
        self.lr = lr
        self.lam = lam
        self.alpha = tuned(self.name, "alpha") if alpha is None else alpha
        self.ncfs_lam_n = ncfs_lam_n  # None: AFOP-ML's own defaults
        self.ncfs_max_iter = ncfs_max_iter
        self._check_settings(
            steps="count", lr="rate", lam="weight", alpha="rate", ncfs_max_iter="count"
        )

    def _net(self) -> EpisodeNet:
        return episode_net(self.D_, alpha=self.alpha, lam=self.lam)

    def _fit(self, signals: np.ndarray, labels: np.ndarray, features: np.ndarray | None) -> None:
        raw = pool_of(signals, features)
        self.afop_ = AFOPML(
            seed=self.seed, ncfs_lam_n=self.ncfs_lam_n, ncfs_max_iter=self.ncfs_max_iter
        ).fit(signals, labels, features=raw)
        self.D_ = self.afop_.D_
        self.selected_ = self.afop_.selected_
        self.feature_dim_ = HIDDEN[-1]
        self.schedule_ = schedule(
            self._net(),
            steps=self.steps,
            lr=self.lr,
            inputs=lambda: torch.as_tensor(self.afop_.embed(signals, raw)),
            labels=labels,
            seed=self.seed,
            lrs=LRS,
            needed=self.test_cells_,
        )

    def _predict(
        self,
        signals: np.ndarray,
        support: np.ndarray,
        query: np.ndarray,
        features: np.ndarray | None,
    ) -> np.ndarray:
        x = torch.as_tensor(self.afop_.embed(signals, features))
        return predict_scheduled(self._net(), x, support, query, self.schedule_, self.seed)


class AFOMLPMLMeta(FewShotMethod):
    """AFO-MLP-ML+meta (a variant beyond the paper): AFO-MLP-ML's MLP meta-trained on
    prototypical episodes of the training classes, then fine-tuned per episode.

    Parameters
    ----------
    seed : int, default 0
        Seeds the feature optimisation, the initialisation and the meta-training episodes.
    meta_iterations : int or None
        Meta-training steps (None: the tuned value).
    meta_batch : int, default 16
        Tasks (5-way 5-shot) per meta-step.
    meta_lr : float or None
        The meta-training Adam rate (None: the tuned value).
    adapt_steps : int, default 250
        Adam steps of the per-episode fine-tuning (the head's paper value).
    adapt_lr : float, default 1.5e-3
        Its Adam rate (the head's paper value).
    lam : float, default 0.10
        Weight of the posteriors' entropy in the head's loss.
    alpha : float or None
        The head's temperature (None: the tuned value).
    ncfs_lam_n, ncfs_max_iter : float, "cv", int or None
        AFOP-ML's feature-optimisation settings (None: AFOP-ML's defaults).

    Attributes
    ----------
    afop_ : models.afop.AFOPML
        The feature optimisation.
    mlp_ : list of torch.Tensor
        The meta-trained MLP weights.
    D_ : int
        The chosen size D.
    selected_ : numpy.ndarray
        Indices of the top-D features.
    feature_dim_ : int
        32: the projection's output.

    Examples
    --------
    >>> from tests.synthetic_data import make_dataset
    >>> data = make_dataset(trials_per_class=3, shapes=("circle", "square", "moon"),
    ...                     n_samples=1000, noise=0.1)
    >>> from models.episodes import sample_episodes
    >>> batch = sample_episodes(data.label, n_way=3, k_shot=1, n_query=2, episodes=4, seed=0)
    >>> model = AFOMLPMLMeta(meta_iterations=5, adapt_steps=10).fit(data.signals, data.label)
    >>> model.predict_episodes(data.signals, batch.support, batch.query).shape
    (4, 6)
    """

    name = "AFO-MLP-ML+meta"
    cost_hint = (8.0, 15.0)

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
        return adapt_mlp_head(
            x,
            support,
            query,
            self.mlp_,
            steps=self.adapt_steps,
            lr=self.adapt_lr,
            lam=self.lam,
            alpha=self.alpha,
        )
