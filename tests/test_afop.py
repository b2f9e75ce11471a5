"""AFOP-ML: the head's closed-form gradient, accuracy on separable vs shuffled data,
determinism, and that nothing but support/pool indices reaches the method."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from benchmark.episodes import sample_episodes
from benchmark.evaluate import evaluate
from models.afop import AFOPML
from models.base import NotFittedError
from models.features import extract
from models.prototypes import adapt_cosine_head
from tests.synthetic_data import make_dataset

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def _autograd_head(f, support, query, steps, lr=1.5e-3, lam=0.1, alpha=10.0):
    """Reference: the paper's loss written with autograd and torch's Adam, one episode."""
    x = torch.as_tensor(f)
    n_way, k_shot = support.shape[1:]
    xs = torch.nn.functional.normalize(x[torch.as_tensor(support[0])].reshape(-1, x.shape[1]))
    w = torch.nn.functional.normalize(x[torch.as_tensor(support[0])].mean(1)).clone()
    w.requires_grad_(True)
    b = torch.zeros(n_way, requires_grad=True)
    opt = torch.optim.Adam([w, b], lr=lr)
    y = torch.arange(n_way).repeat_interleave(k_shot)
    for _ in range(steps):
        logits = alpha * xs @ torch.nn.functional.normalize(w).T + b
        logp = torch.log_softmax(logits, -1)
        loss = torch.nn.functional.nll_loss(logp, y) - lam * (logp.exp() * logp).sum(-1).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
    xq = torch.nn.functional.normalize(x[torch.as_tensor(query[0])])
    return (alpha * xq @ torch.nn.functional.normalize(w).T + b).detach().numpy()


def test_closed_form_gradient_matches_autograd():
    rng = np.random.default_rng(0)
    f = rng.standard_normal((40, 6)).astype(np.float32)
    support = rng.permutation(40)[:15].reshape(1, 5, 3)
    query = np.setdiff1d(np.arange(40), support.ravel())[None, :]
    # Many steps at a large rate so that a wrong gradient would change the decisions.
    ours = adapt_cosine_head(f, support, query, steps=200, lr=0.05)
    ref = _autograd_head(f, support, query, steps=200, lr=0.05)
    np.testing.assert_array_equal(ours[0], ref.argmax(-1))


@pytest.fixture(scope="module")
def separable():
    data = make_dataset(trials_per_class=8, n_samples=500, noise=0.3)
    return data, extract(data.signals)


def _halves(labels):
    idx = np.arange(labels.size)
    return idx[idx % 8 < 4], idx[idx % 8 >= 4]


def test_separable_classes_are_recognised_and_shuffled_ones_are_not(separable):
    data, feats = separable
    train, test = _halves(data.label)
    model = AFOPML(seed=0, dscan_episodes=50).fit(
        data.signals[train], data.label[train], features=feats[train]
    )
    assert 1 <= model.D_ <= 386 and model.selected_.shape == (model.D_,)
    assert set(model.dscan_) == {"D", "mean", "ci95"}
    batch = sample_episodes(data.label[test], n_way=5, k_shot=1, n_query=3, episodes=100, seed=1)
    good = evaluate(model, data.signals[test], batch, features=feats[test])
    assert good.accuracy > 0.95
    rng = np.random.default_rng(5)
    shuffled = rng.permutation(data.label[test])
    batch = sample_episodes(shuffled, n_way=5, k_shot=1, n_query=3, episodes=300, seed=2)
    chance = evaluate(model, data.signals[test], batch, features=feats[test])
    assert abs(chance.accuracy - 0.2) < max(2 * chance.ci95, 0.05)


def test_deterministic_and_query_order_equivariant(separable):
    data, feats = separable
    train, test = _halves(data.label)
    fit = dict(features=feats[train])
    a = AFOPML(seed=3, dscan_episodes=30).fit(data.signals[train], data.label[train], **fit)
    b = AFOPML(seed=3, dscan_episodes=30).fit(data.signals[train], data.label[train], **fit)
    np.testing.assert_array_equal(a.selected_, b.selected_)
    batch = sample_episodes(data.label[test], n_way=4, k_shot=2, n_query=2, episodes=20, seed=4)
    pa = a.predict_episodes(data.signals[test], batch.support, batch.query, features=feats[test])
    pb = b.predict_episodes(data.signals[test], batch.support, batch.query, features=feats[test])
    np.testing.assert_array_equal(pa, pb)
    # Leak check: a query's label comes only from the support set, so permuting the
    # queries permutes the predictions and nothing else.
    perm = np.random.default_rng(0).permutation(batch.query.shape[1])
    pp = a.predict_episodes(
        data.signals[test], batch.support, batch.query[:, perm], features=feats[test]
    )
    np.testing.assert_array_equal(pp, pa[:, perm])


def test_refuses_use_before_fit_and_malformed_episodes(separable):
    data, feats = separable
    with pytest.raises(NotFittedError):
        AFOPML().predict_episodes(data.signals, np.zeros((1, 2, 1), int), np.ones((1, 2), int))
    train, _ = _halves(data.label)
    model = AFOPML(dscan_episodes=20).fit(
        data.signals[train], data.label[train], features=feats[train]
    )
    with pytest.raises(ValueError, match="same trial twice"):
        model.predict_episodes(data.signals, np.array([[[0], [0]]]), np.array([[1, 2]]))
    with pytest.raises(ValueError, match="support"):
        model.predict_episodes(data.signals, np.array([[0, 1]]), np.array([[2]]))


def test_feature_dim_is_the_embedding_width(separable):
    from benchmark.methods import feature_dim
    from models.afo_mlp import AFOMLPML, AFOMLPMLMeta

    data, feats = separable
    train, _ = _halves(data.label)
    afop = AFOPML(dscan_episodes=20).fit(
        data.signals[train], data.label[train], features=feats[train]
    )
    assert feature_dim(afop) == afop.D_
    for mlp in (AFOMLPML(steps=5, lr=1e-2), AFOMLPMLMeta(meta_iterations=5)):
        mlp.fit(data.signals[train], data.label[train], features=feats[train])
        assert mlp.D_ != 32 and feature_dim(mlp) == 32  # the projection, not the top-D input


def test_single_episode_latency_adapts_each_episode_alone(separable):
    from benchmark.evaluate import _episode_pool

    data, feats = separable
    train, test = _halves(data.label)
    model = AFOPML(dscan_episodes=20).fit(
        data.signals[train], data.label[train], features=feats[train]
    )
    batch = sample_episodes(data.label[test], n_way=5, k_shot=2, n_query=2, episodes=6, seed=3)
    r = evaluate(model, data.signals[test], batch, features=feats[test], latency_episodes=4)
    assert r.latency_episodes == 4
    assert r.latency_ms_per_episode > 0 and r.latency_with_features_ms_per_episode > 0
    assert r.adapt_ms_per_episode == r.batch_ms_per_episode
    # The pool of one episode holds its own trials only and re-indexes them faithfully.
    trials, s, q = _episode_pool(batch, 2)
    assert trials.size == 5 * 2 + 5 * 2
    np.testing.assert_array_equal(trials[s[0]], batch.support[2])
    np.testing.assert_array_equal(trials[q[0]], batch.query[2])
    alone = model.predict_episodes(data.signals[test][trials], s, q, features=feats[test][trials])
    np.testing.assert_array_equal(alone[0], r.predictions[2])
    # Not measured unless asked for.
    assert evaluate(model, data.signals[test], batch, features=feats[test]).latency_episodes == 0


def test_single_episode_latency_prepares_every_timed_episode_anew():
    # A method that keeps the prepared input of the last pool must not find a timed
    # episode's pool already prepared: each timed call is a new episode of new trials.
    from benchmark.evaluate import single_episode_latency
    from models.base import FewShotMethod
    from models.nets import PoolCache

    class Counting(FewShotMethod):
        name = "counting"

        def _fit(self, signals, labels, features):
            self._cache, self.prepared = PoolCache(), 0

        def _prepare(self, signals):
            self.prepared += 1
            return signals

        def _predict(self, signals, support, query, features):
            self._cache.get(signals, self._prepare)
            return np.zeros(query.shape, dtype=np.int64)

    labels = np.repeat(np.arange(6), 6)
    signals = np.random.default_rng(0).standard_normal((labels.size, 4, 50))
    model = Counting().fit(signals, labels, features=np.zeros((labels.size, 3)))
    batch = sample_episodes(labels, n_way=3, k_shot=1, n_query=2, episodes=5, seed=0)
    single_episode_latency(model, signals, batch, np.zeros((labels.size, 3)), 4)
    assert model.prepared == 1 + 2 * 4  # the untimed call, then every timed one


def _overlapping_pool(n_classes: int = 12, per_class: int = 12, dim: int = 48):
    # Classes whose means differ by about their spread: adapted heads score well above
    # chance and well below 100 %, so a mixed-up episode would show in its accuracy.
    rng = np.random.default_rng(7)
    means = rng.standard_normal((n_classes, dim))
    labels = np.repeat(np.arange(n_classes), per_class)
    x = means[labels] + 2.5 * rng.standard_normal((labels.size, dim))
    return x.astype(np.float32), labels


@pytest.mark.parametrize(("way", "shot"), [(5, 1), (12, 5)])
def test_the_head_adapted_in_chunks_labels_each_episode_as_adapted_alone(way, shot):
    # Episodes never interact: adapting them in cache-sized chunks of many episodes gives
    # each episode the predictions it gets adapted on its own.
    x, labels = _overlapping_pool()
    batch = sample_episodes(labels, n_way=way, k_shot=shot, n_query=4, episodes=24, seed=3)
    kw = dict(steps=60, lr=1.5e-3, lam=0.1, alpha=10.0)
    together = adapt_cosine_head(x, batch.support, batch.query, **kw, chunk=16)
    default = adapt_cosine_head(x, batch.support, batch.query, **kw)
    alone = np.concatenate(
        [
            adapt_cosine_head(x, batch.support[e : e + 1], batch.query[e : e + 1], **kw)
            for e in range(batch.episodes)
        ]
    )
    acc = (alone == batch.query_labels).mean(axis=1)
    assert 0.3 < acc.mean() < 0.95  # the episodes are neither trivial nor hopeless
    for pred in (together, default):
        # Float tolerance: a vectorised kernel may round an episode's last bits otherwise
        # when it sits elsewhere in a chunk; at most one query in a hundred may flip.
        assert np.mean(pred != alone) <= 0.01
        assert np.abs((pred == batch.query_labels).mean(axis=1) - acc).max() <= 0.25


def test_head_chunk_holds_the_cache_budget_and_refuses_a_bad_chunk():
    from models.prototypes import EPISODE_CHUNK, HEAD_FLOATS, head_chunk

    assert head_chunk(180, 386) == HEAD_FLOATS // (180 * 386) < EPISODE_CHUNK
    assert head_chunk(5, 8) == EPISODE_CHUNK
    assert head_chunk(10**6, 386) == 1
    x, labels = _overlapping_pool()
    batch = sample_episodes(labels, n_way=5, k_shot=1, n_query=2, episodes=2, seed=0)
    with pytest.raises(ValueError, match="chunk"):
        adapt_cosine_head(x, batch.support, batch.query, chunk=0)
