"""The six baselines and the variants behind the one interface: above chance on easy data,
at chance on label-shuffled data, deterministic, no leaks, malformed episodes rejected."""

from __future__ import annotations

import re

import numpy as np
import pytest

from benchmark.episodes import sample_episodes
from benchmark.evaluate import evaluate
from models import cnn, maml, nets
from models.features import extract
from models.registry import METHOD_NAMES, VARIANT_NAMES, make_method
from tests.synthetic_data import make_dataset

# Small settings: these tests check behaviour, not the paper's budgets.
FAST = {
    "AFO-MLP-ML": dict(steps=20, lr=5e-3),
    "AFO-MLP-ML+meta": dict(meta_iterations=40, adapt_steps=20),
    "Direct-Prot-ML": dict(steps=50),
    "MAML": dict(max_iterations=40, eval_every=20, val_episodes=10, inner_lr=0.1, test_steps=10),
    "CWT-ResNet-ML": dict(max_epochs=4, steps=50, val_episodes=20),
    "CNN": dict(steps=30, lr=1e-2),
    "BiLSTM": dict(steps=30, lr=1e-2),
}
BASELINES = [m for m in (*METHOD_NAMES, *VARIANT_NAMES) if m != "AFOP-ML"]


@pytest.fixture(scope="module")
def easy():
    data = make_dataset(
        trials_per_class=6,
        shapes=("circle", "square", "moon", "triangle", "hexagon"),
        n_samples=600,
        noise=0.2,
    )
    return data, extract(data.signals)


def _split(labels):
    idx = np.arange(labels.size)
    return idx[idx % 6 < 3], idx[idx % 6 >= 3]


def _fitted(name, data, feats, train, seed=0):
    model = make_method(name, seed=seed, **FAST[name])
    return model.fit(data.signals[train], data.label[train], features=feats[train])


def test_every_paper_method_is_registered():
    assert set(BASELINES) == set(FAST)


@pytest.mark.parametrize(
    ("name", "settings", "arg"),
    [
        ("AFOP-ML", {"alpha": -1.0}, "alpha"),
        ("AFOP-ML", {"steps": -1}, "steps"),
        ("AFOP-ML", {"dscan_episodes": 0}, "dscan_episodes"),
        ("AFO-MLP-ML", {"steps": 0}, "steps"),
        ("AFO-MLP-ML", {"lam": -0.1}, "lam"),
        ("AFO-MLP-ML+meta", {"meta_iterations": 0}, "meta_iterations"),
        ("AFO-MLP-ML+meta", {"lam": -0.1}, "lam"),
        ("Direct-Prot-ML", {"lr": float("nan")}, "lr"),
        ("CNN", {"steps": 0}, "steps"),
        ("BiLSTM", {"steps": "10"}, "steps"),
        ("CWT-ResNet-ML", {"max_epochs": 0}, "max_epochs"),
        ("CWT-ResNet-ML", {"batch": 2.5}, "batch"),
        ("CWT-ResNet-ML", {"arch": "vgg"}, "arch"),
        ("MAML", {"lr_probe": -5}, "lr_probe"),
        ("MAML", {"eval_every": 0}, "eval_every"),
        ("MAML", {"inner_lr": True}, "inner_lr"),
        ("MAML", {"seed": -1}, "seed"),
    ],
)
def test_bad_settings_fail_at_construction_naming_the_setting(name, settings, arg):
    """A method checks its settings when built, with one line naming the method and the
    setting, not deep inside ``fit``; settings left None are chosen on training data."""
    with pytest.raises(ValueError, match=f"^{re.escape(name)}: {arg} must be"):
        make_method(name, **settings)
    if name in ("CNN", "BiLSTM", "MAML", "AFO-MLP-ML"):
        make_method(name, **{k: None for k in ("steps", "lr", "inner_lr") if k in settings})


@pytest.mark.parametrize("name", BASELINES)
def test_beats_chance_on_easy_data_and_not_on_shuffled_labels(name, easy):
    data, feats = easy
    train, test = _split(data.label)
    model = _fitted(name, data, feats, train)
    batch = sample_episodes(data.label[test], n_way=5, k_shot=1, n_query=2, episodes=60, seed=1)
    good = evaluate(model, data.signals[test], batch, features=feats[test])
    assert good.accuracy > 0.6, good.accuracy  # chance is 0.2
    shuffled = np.random.default_rng(9).permutation(data.label[test])
    batch = sample_episodes(shuffled, n_way=5, k_shot=1, n_query=2, episodes=150, seed=2)
    chance = evaluate(model, data.signals[test], batch, features=feats[test])
    assert abs(chance.accuracy - 0.2) < max(3 * chance.ci95, 0.07), chance.accuracy


@pytest.mark.parametrize("name", BASELINES)
def test_deterministic_no_leak_and_rejects_malformed_support(name, easy):
    data, feats = easy
    train, test = _split(data.label)
    a = _fitted(name, data, feats, train, seed=4)
    b = _fitted(name, data, feats, train, seed=4)
    batch = sample_episodes(data.label[test], n_way=3, k_shot=1, n_query=2, episodes=6, seed=3)
    sig, f = data.signals[test], feats[test]
    pa = a.predict_episodes(sig, batch.support, batch.query, features=f)
    np.testing.assert_array_equal(
        pa, b.predict_episodes(sig, batch.support, batch.query, features=f)
    )
    # Leak check: query labels never reach a method, and each query is labelled from the
    # support set alone, so shuffling the queries shuffles the predictions.
    perm = np.random.default_rng(1).permutation(batch.query.shape[1])
    pp = a.predict_episodes(sig, batch.support, batch.query[:, perm], features=f)
    np.testing.assert_array_equal(pp, pa[:, perm])
    with pytest.raises(ValueError, match="support"):
        a.predict_episodes(sig, batch.support[:, :1], batch.query)  # N = 1
    with pytest.raises(ValueError, match="same trial twice"):
        dup = batch.support.copy()
        dup[:, 1] = dup[:, 0]
        a.predict_episodes(sig, dup, batch.query)


@pytest.mark.slow
def test_raw_signal_baselines_choose_their_settings_on_training_data(easy, monkeypatch):
    """Without given values, CNN and BiLSTM pick a rate and a step count per validated shot
    and way on validation episodes of the training split, each curve read until a doubling
    brings no gain beyond the best point's 95 % CI; MAML picks its inner rate and test
    steps and stops early on held-out training classes; each records the evidence."""
    data, _ = easy
    train, _ = _split(data.label)
    sig, lab = data.signals[train], data.label[train]
    monkeypatch.setattr(nets, "VALIDATION_QUERIES", 100)  # fewer episodes: a faster test
    for name in ("CNN", "BiLSTM"):
        m = make_method(name, seed=1).fit(sig, lab)
        # 15 training classes of 3 trials: shots lowered to 2 (one query), 36 ways to 15.
        cells = nets.validation_cells(lab)
        assert cells == [(k, n, 3 - k) for k in (1, 2) for n in (5, 12, 15)]
        assert [(c.shot, c.way) for c in m.schedule_.settings] == [(k, n) for k, n, _ in cells]
        # Told it is tested on 1-shot 4- and 12-way episodes only, the method validates the
        # two cells these take their settings from, to the same settings and predictions.
        told = make_method(name, seed=1).fit(sig, lab, cells=[(12, 1), (4, 1)])
        assert told.test_cells_ == ((4, 1), (12, 1))
        assert told.schedule_.settings == tuple(
            c for c in m.schedule_.settings if (c.shot, c.way) in {(1, 5), (1, 12)}
        )
        for way in (4, 12):
            ep = sample_episodes(lab, n_way=way, k_shot=1, n_query=2, episodes=6, seed=way)
            assert np.array_equal(
                told.predict_episodes(sig, ep.support, ep.query),
                m.predict_episodes(sig, ep.support, ep.query),
            )
        for setting in m.schedule_.settings:
            curves = [
                c
                for c in m.schedule_.curves
                if (c["shot"], c["way"]) == (setting.shot, setting.way)
            ]
            assert [c["lr"] for c in curves] == list(cnn.LRS)
            for c in curves:
                # Doubling step counts from 5, until the first without a gain (or the bound).
                assert c["steps"] == [5 * 2**i for i in range(len(c["steps"]))]
                acc, ci = c["accuracy"], c["ci95"]

                def bar(upto, acc=acc, ci=ci):
                    """The best mean before mark ``upto`` plus that point's CI: what a
                    doubling must exceed to count as a gain (recorded values are rounded
                    to 1e-4)."""
                    i = int(np.argmax(acc[:upto]))
                    return acc[i] + ci[i] + 2e-4

                n = len(acc)
                # A doubling within the best's CI is no gain: past chance it ends the curve.
                for j in range(1, n - 1):
                    if acc[j] < bar(j) - 4e-4:
                        assert max(acc[:j]) < 2 / c["way"], (c, j)
                if c["plateaued"]:  # the last doubling brought no gain, after leaving
                    # chance or as the third in a row
                    assert acc[-1] <= bar(n - 1)
                    flat = n >= 4 and all(acc[j] <= bar(j) for j in range(n - 3, n))
                    assert max(acc[:-1]) >= 2 / c["way"] or flat
                else:
                    assert c["steps"][-1] == nets.MAX_MARK
            # The setting: the fewest steps within the 95 % CI of the best accuracy.
            points = [
                (a, ci, st, c["lr"])
                for c in curves
                for a, ci, st in zip(c["accuracy"], c["ci95"], c["steps"], strict=True)
            ]
            best = max(points, key=lambda p: (p[0], -p[2]))
            ok = [p for p in points if p[0] >= best[0] - best[1] - 1e-4]
            assert setting.steps == min(p[2] for p in ok)
    m = make_method("MAML", seed=1, max_iterations=80, eval_every=20, lr_probe=40, patience=1)
    m.fit(sig, lab)
    curve = m.meta_curve_
    assert curve.ndim == 2 and curve.shape[1] == 2 and np.all(np.diff(curve[:, 0]) > 0)
    assert m.inner_lr_ in maml.INNER_LRS and m.test_steps_ in maml.TEST_STEPS
    # inner_lr: the best-scoring candidate after the whole probe (two periods), where the
    # curve starts.
    probe = m.lr_probe_
    assert probe["inner_lr"] == list(maml.INNER_LRS) and len(probe["accuracy"]) == 2
    assert m.inner_lr_ == maml.INNER_LRS[int(np.argmax(probe["accuracy"]))]
    assert curve[0, 0] == 40
    # test_steps: the best-scoring step count for the kept body, fewest on ties.
    scores = m.test_step_scores_
    assert scores["test_steps"] == list(maml.TEST_STEPS) and len(scores["accuracy"]) == 3
    assert m.test_steps_ == maml.TEST_STEPS[int(np.argmax(scores["accuracy"]))]
    assert m.best_iteration_ in curve[:, 0] and m.iterations_ == curve[-1, 0]
    kept = curve[curve[:, 0] == m.best_iteration_, 1][0]
    assert kept >= curve[:, 1].max() - m.min_delta
    # patience=1: training stops at the first evaluation without a gain (or at the cap).
    assert m.plateaued_ or m.iterations_ >= m.max_iterations


def test_used_cells_are_the_validated_cells_the_tested_ones_take_settings_from():
    cells = [(k, n, 1) for k in (1, 3, 5) for n in (5, 12, 36)]
    assert nets.used_cells(cells, None) == set(range(9))
    # (way, shot): 1-shot 2..12-way -> the 1-shot 5- and 12-way cells; 36-way 4-shot ->
    # the 3-shot 36-way cell (shot 4 ties 3 and 5: the smaller).
    assert nets.used_cells(cells, [(w, 1) for w in range(2, 13)]) == {0, 1}
    assert nets.used_cells(cells, [(36, 4)]) == {5}
    assert nets.used_cells(cells, [(20, 5)]) == {7}  # 12-way: log(20/12) < log(36/20)


@pytest.mark.parametrize("cells", [[(5, 0)], [(5,)], [("5", 1)], [(True, 1)], []])
def test_bad_cells_are_refused_naming_cells(easy, cells):
    data, _ = easy
    with pytest.raises(ValueError, match="cells must"):
        make_method("CNN", seed=0, **FAST["CNN"]).fit(
            data.signals[:30], data.label[:30], cells=cells
        )


def test_maml_first_inner_step_moves_the_zero_head_alone_as_the_full_gradient_does():
    # The head starts at zero, so the full gradient of the first step is zero on every body
    # weight: the shortcut that takes the head's gradient alone must give the same weights.
    import torch
    import torch.nn.functional as F

    gen = torch.Generator().manual_seed(5)
    x = torch.randn(40, 4, 1000, generator=gen)
    body = nets.init_cnn(maml.LAYERS, 5, gen, copies=1)
    labels = np.repeat(np.arange(8), 5)
    batch = sample_episodes(labels, n_way=4, k_shot=2, n_query=1, episodes=3, seed=1)
    fast, _ = maml._adapt(x, batch.support, body, 1, 0.1)

    e, n_way, k_shot = batch.support.shape
    full = [p.detach().requires_grad_(True) for p in maml._zero_head(body, e, n_way)]
    xs = nets.episode_inputs(x, batch.support.reshape(e, -1))
    target = torch.arange(n_way).repeat_interleave(k_shot)[:, None].expand(-1, e).reshape(-1)
    logits = nets.cnn_forward(xs, full, maml.LAYERS)
    loss = F.cross_entropy(logits.reshape(-1, n_way), target) * e
    grads = torch.autograd.grad(loss, full)
    assert all(torch.count_nonzero(g) == 0 for g in grads[:-2])
    assert torch.count_nonzero(grads[-2]) > 0
    for p, g, got in zip(full, grads, fast, strict=True):
        torch.testing.assert_close(got, p - 0.1 * g, rtol=0, atol=0)


def test_mamls_embedding_is_its_bodys_per_trial_reading(easy):
    """MAML.embed gives each trial the body's pooled channels, the same alone as in a
    batch (the body has no batch statistics)."""
    data, feats = easy
    train, test = _split(data.label)
    model = _fitted("MAML", data, feats, train)
    whole = model.embed(data.signals[test])
    assert whole.shape == (test.size, maml.LAYERS[-1].c_out) and np.all(np.isfinite(whole))
    np.testing.assert_allclose(model.embed(data.signals[test[:3]]), whole[:3], rtol=1e-5, atol=1e-6)
    assert np.ptp(whole, axis=0).max() > 0  # trials differ in it


def test_written_out_gradients_are_autograds():
    # The BiLSTM's backpropagation through time and the AFO-MLP-ML head's gradient, in
    # float64, against autograd through the networks' forward passes and losses.
    import torch
    import torch.nn.functional as F

    from models import afo_mlp, bilstm

    gen = torch.Generator().manual_seed(3)
    e, r, t, d, n = 3, 4, 6, 5, 3
    x = torch.randn(e, r, t, d, dtype=torch.float64, generator=gen)
    params = [3 * p.double() for p in bilstm._init(e, d, n, gen)]
    params = [p + 0.1 * torch.randn(p.shape, dtype=torch.float64, generator=gen) for p in params]
    target = torch.randint(0, n, (e, r), generator=gen)
    nets_ = [
        (bilstm._net(d), x, params, target),
    ]
    head = afo_mlp.episode_net(d, alpha=6.0, lam=0.2)
    xh = torch.randn(e, 2 * n, d, dtype=torch.float64, generator=gen)
    ph = [p.double() for p in head.init(e, n, gen)]
    ph[4] = torch.randn(e, n, 32, dtype=torch.float64, generator=gen)
    ph[5] = 0.1 * torch.randn(e, 1, n, dtype=torch.float64, generator=gen)
    nets_.append((head, xh, ph, torch.arange(n).repeat_interleave(2).expand(e, -1)))
    for net, inputs, weights, tgt in nets_:
        mine = net.grads(inputs, weights, tgt)
        leaves = [p.clone().requires_grad_(True) for p in weights]
        loss_of = net.loss or (
            lambda z, y: F.cross_entropy(z.reshape(-1, z.shape[-1]), y.reshape(-1)) * z.shape[0]
        )
        loss_of(net.forward(inputs, leaves), tgt).backward()
        for got, leaf in zip(mine, leaves, strict=True):
            assert leaf.grad.abs().max() > 0
            torch.testing.assert_close(got, leaf.grad, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("name", ["CNN", "BiLSTM", "AFO-MLP-ML"])
def test_networks_trained_together_label_each_episode_as_trained_alone(name):
    # Episodes never interact: a chunk of stacked networks, each trained from its own
    # initialisation, labels every query as that episode's network trained on its own
    # from the same initialisation does (float tolerance: a vectorised kernel may round
    # an episode's last bits otherwise when it sits elsewhere in a chunk).
    import torch

    from models import afo_mlp, bilstm

    rng = np.random.default_rng(2)
    labels = np.repeat(np.arange(8), 6)
    shape = {"CNN": (4, 1000), "BiLSTM": (bilstm.FRAMES, 12), "AFO-MLP-ML": (24,)}[name]
    centres = rng.standard_normal((8, *shape))
    x = torch.as_tensor((centres[labels] + 2.0 * rng.standard_normal((48, *shape))).astype("f4"))
    net = {
        "CNN": cnn.NET,
        "BiLSTM": bilstm._net(12),
        "AFO-MLP-ML": afo_mlp.episode_net(24, alpha=10.0, lam=0.1),
    }[name]
    batch = sample_episodes(labels, n_way=5, k_shot=2, n_query=3, episodes=6, seed=1)
    lr = 1e-2

    def trainer(sl):
        gen = torch.Generator().manual_seed(0)
        return nets.EpisodeTrainer(net, x, batch.support[sl], batch.query[sl], lr=lr, generator=gen)

    together = trainer(slice(None))
    start = [p.detach().clone() for p in together.params]
    together.advance(12)
    pred = together.predict()
    alone = []
    for e in range(batch.episodes):
        one = trainer(slice(e, e + 1))
        with torch.no_grad():
            for p, p0 in zip(one.params, start, strict=True):
                p.copy_(p0[e : e + 1])
        one.advance(12)
        alone.append(one.predict()[0])
    alone = np.stack(alone)
    assert not np.array_equal(pred, trainer(slice(None)).predict())  # training moved labels
    assert np.mean(pred != alone) <= 0.01
