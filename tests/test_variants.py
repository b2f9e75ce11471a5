"""The paper's seven methods and the variants beyond the paper: naming, ordering in every
table, the paper's AFO-MLP-ML (no meta-training, a fresh network per episode), method
options on the command line, and the per-episode schedules chosen on validation."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import torch

from benchmark import paper_reference
from benchmark.report import render
from benchmark.tables import BEYOND_THE_PAPER, table_one_lines
from models import afo_mlp, nets
from models.afo_mlp import AFOMLPML, AFOMLPMLMeta
from models.afop import AFOPML
from models.episodes import sample_episodes
from models.features import extract
from models.registry import (
    DEFAULT_METHODS,
    METHOD_NAMES,
    VARIANT_NAMES,
    VARIANT_NOTES,
    available_methods,
    check_method_options,
    check_methods,
    method_class,
    options_from_args,
    paper_first,
    parse_method_option,
)
from tests.synthetic_data import make_dataset


@pytest.fixture(scope="module")
def easy():
    data = make_dataset(
        trials_per_class=6,
        shapes=("circle", "square", "moon", "triangle", "hexagon"),
        n_samples=600,
        noise=0.2,
    )
    return data, extract(data.signals)


def test_paper_methods_then_variants():
    assert METHOD_NAMES == tuple(paper_reference.TABLE_ONE_ACCURACY_PCT)  # Table I order
    assert VARIANT_NAMES == ("AFO-MLP-ML+meta",)
    assert DEFAULT_METHODS == (*METHOD_NAMES, *VARIANT_NAMES)
    assert available_methods()[: len(DEFAULT_METHODS)] == DEFAULT_METHODS
    assert set(VARIANT_NOTES) == set(VARIANT_NAMES)
    assert all(note and "\n" not in note for note in VARIANT_NOTES.values())
    assert method_class("AFO-MLP-ML") is AFOMLPML
    assert method_class("AFO-MLP-ML+meta") is AFOMLPMLMeta
    assert check_methods(["AFO-MLP-ML+meta", "CNN"]) == ("AFO-MLP-ML+meta", "CNN")
    mixed = ["x.py:Mine", "AFO-MLP-ML+meta", "BiLSTM", "AFOP-ML", "MAML"]
    assert paper_first(mixed) == (["AFOP-ML", "MAML", "BiLSTM"], ["AFO-MLP-ML+meta", "x.py:Mine"])
    with pytest.raises(ValueError, match="did you mean"):
        check_methods(["AFO-MLP-ML+meat"])


def _acc(method, way, shot, acc):
    return {
        "record": "accuracy",
        "protocol": "closed-set",
        "fold": None,
        "condition": None,
        "method": method,
        "way": way,
        "shot": shot,
        "query": 5,
        "episodes": 10,
        "accuracy": acc,
        "ci95": 0.01,
        "pretrain_s": 1.0,
        "adapt_ms_per_episode": 1.0,
        "latency_ms_per_episode": None,
        "latency_with_features_ms_per_episode": None,
        "latency_episodes": 0,
        "feature_dim": None,
    }


def test_tables_and_report_list_the_paper_first_then_beyond_the_paper():
    order = ["AFO-MLP-ML+meta", "CNN", "AFOP-ML", "AFO-MLP-ML"]
    records = [
        _acc(m, n, k, 0.5 + 0.01 * i)
        for i, m in enumerate(order)
        for k, n in paper_reference.TABLE_ONE_COLUMNS
    ]
    lines = table_one_lines(records, timing=False)
    rows = [line.split(" | ")[0].lstrip("| ") for line in lines[2:]]
    assert rows == ["AFOP-ML", "AFO-MLP-ML", "CNN", f"**{BEYOND_THE_PAPER}**", "AFO-MLP-ML+meta"]
    text = render(records, {"seed": 0, "methods": order})
    # One line per variant saying what differs from the paper, under the heading.
    beyond = text[text.index(f"## {BEYOND_THE_PAPER}") : text.index("## Closed-set")]
    assert f"- **AFO-MLP-ML+meta**: {VARIANT_NOTES['AFO-MLP-ML+meta']}." in beyond
    assert "- methods: AFOP-ML, AFO-MLP-ML, CNN, AFO-MLP-ML+meta" in text
    # Every method's 1-shot row beside the paper's: here, paper and difference rows for
    # the paper's methods, only "here" for the variant (Table I has no row for it).
    side = text[text.index("### Every method's 1-shot row") :]
    assert "| AFO-MLP-ML | here | 53.00 ± 1.00 |" in side
    ref = paper_reference.TABLE_ONE_ACCURACY_PCT["AFO-MLP-ML"][(1, 5)]
    assert f"|  | paper | {ref:.2f} |" in side
    assert f"|  | here − paper (pp) | {53.0 - ref:+.2f} |" in side
    tail = side[side.index(f"**{BEYOND_THE_PAPER}**") :]
    assert "| AFO-MLP-ML+meta | here |" in tail and "paper |" not in tail.split("\n\n")[0]


@pytest.mark.slow
def test_paper_afo_mlp_trains_nothing_at_fit_but_the_feature_optimisation(easy, monkeypatch):
    """Its fit is AFOP-ML's feature optimisation and the choice of the per-episode steps
    and rate on validation episodes: every network it trains there starts fresh and is
    thrown away; no weights survive the fit, and every test episode's network starts from
    a fresh initialisation."""
    data, feats = easy
    idx = np.arange(len(data))
    train, test = idx[idx % 6 < 3], idx[idx % 6 >= 3]
    afop_fits, trainers = [], []
    afop_fit = AFOPML.fit
    monkeypatch.setattr(
        AFOPML, "fit", lambda self, *a, **k: afop_fits.append(self) or afop_fit(self, *a, **k)
    )
    init = nets.EpisodeTrainer.__init__

    def spy(self, net, x, support, query, **kw):
        init(self, net, x, support, query, **kw)
        trainers.append((len(x), [p.detach().clone() for p in self.params], self))

    monkeypatch.setattr(nets.EpisodeTrainer, "__init__", spy)
    model = AFOMLPML(seed=3).fit(data.signals[train], data.label[train], features=feats[train])
    assert len(afop_fits) == 1  # AFOP-ML's feature optimisation, once
    assert model.D_ == afop_fits[0].D_ and np.array_equal(model.selected_, afop_fits[0].selected_)
    # At fit, networks are trained only on validation episodes of the training trials.
    assert trainers and {n for n, _, _ in trainers} == {len(train)}
    # Nothing learned survives but the feature optimisation and the schedule (beside the
    # tested cells the caller told it, None here).
    learned = {k for k in vars(model) if k.endswith("_")}
    assert model.test_cells_ is None
    assert learned - {"test_cells_"} == {
        "afop_",
        "D_",
        "selected_",
        "feature_dim_",
        "schedule_",
        "fitted_",
    }
    assert not any(isinstance(v, torch.Tensor) for v in vars(model).values())
    # At test time, every chunk's networks start from the seeded initialisation.
    trainers.clear()
    batch = sample_episodes(data.label[test], n_way=3, k_shot=1, n_query=2, episodes=4, seed=1)
    pa = model.predict_episodes(
        data.signals[test], batch.support, batch.query, features=feats[test]
    )
    pb = model.predict_episodes(
        data.signals[test], batch.support, batch.query, features=feats[test]
    )
    np.testing.assert_array_equal(pa, pb)
    assert len(trainers) == 2
    first, second = trainers[0][1], trainers[1][1]
    fresh = afo_mlp.episode_net(model.D_, alpha=model.alpha, lam=model.lam).init(
        4, 3, torch.Generator().manual_seed(3)
    )
    for a, b, f in zip(first[:4], second[:4], fresh[:4], strict=True):
        assert torch.equal(a, b) and torch.equal(a, f)
    # The head starts at the normalised prototypes of the projected support, b at 0.
    assert torch.allclose(first[4].norm(dim=-1), torch.ones(4, 3))
    assert torch.equal(first[5], torch.zeros(4, 1, 3))
    # Trained: the weights moved from their start.
    assert not torch.equal(trainers[0][2].params[0].detach(), first[0])


def test_meta_variant_meta_trains(easy):
    data, feats = easy
    idx = np.arange(len(data))
    train = idx[idx % 6 < 3]
    model = AFOMLPMLMeta(seed=0, meta_iterations=3, adapt_steps=2)
    model.fit(data.signals[train], data.label[train], features=feats[train])
    assert len(model.mlp_) == 4 and model.mlp_[0].shape == (1, model.D_, 64)
    assert model.name == "AFO-MLP-ML+meta"


def test_choose_setting_and_nearest_cell():
    acc = np.array([[0.5, 0.6], [0.8, 0.8], [0.9, 0.9], [0.91, 0.91]])  # (marks, episodes)
    # Best 0.91 ± 0 (no spread): only the last mark qualifies.
    assert nets.choose_setting([(0.01, [5, 10, 20, 40], acc)]) == (0.01, 40)
    noisy = np.array([[0.2, 0.8], [0.85, 0.95], [0.8, 1.0]])  # CI ~ 0.1 at the best
    lr, steps = nets.choose_setting([(0.01, [5, 10, 20], noisy), (0.03, [5, 10], noisy[:2])])
    assert steps == 10 and lr == 0.01  # fewest steps within the CI; the smaller rate on ties
    plan = nets.Schedule(
        (
            nets.Setting(1, 5, 0.01, 20),
            nets.Setting(1, 36, 0.03, 80),
            nets.Setting(5, 5, 0.01, 40),
            nets.Setting(5, 12, 0.01, 60),
        )
    )
    assert plan.of(1, 5).steps == 20 and plan.of(1, 28).steps == 80  # log(28/36) < log(28/5)
    assert plan.of(1, 12).steps == 20  # log(12/5) < log(36/12)
    assert plan.of(3, 12).steps == 20 and plan.of(4, 12).steps == 60  # shot first, smaller on ties
    assert plan.of(5, 36).steps == 60
    assert nets.Schedule.fixed(0.1, 7).of(3, 30) == nets.Setting(0, 0, 0.1, 7)


def test_method_options_are_parsed_and_checked():
    assert parse_method_option("CWT-ResNet-ML:weights=/a/b:c=d.pth") == (
        "CWT-ResNet-ML",
        "weights",
        "/a/b:c=d.pth",
    )
    assert parse_method_option("examples/nearest_mean.py:NearestClassMean:seed=3")[0] == (
        "examples/nearest_mean.py:NearestClassMean"
    )
    assert parse_method_option("CNN:lr=1e-3") == ("CNN", "lr", 1e-3)
    assert parse_method_option("CNN:steps=30")[2] == 30
    for bad in ("CNN", "CNN:lr", "lr=3", "CNN:2x=1"):
        with pytest.raises(ValueError, match=r"^--method-option .* is not METHOD:NAME=VALUE"):
            parse_method_option(bad)
    assert options_from_args(["CNN:steps=5", "CNN:steps=7"], ["CNN"]) == {"CNN": {"steps": 7}}
    with pytest.raises(ValueError, match=r"^--method-option CNN:width: CNN has no option 'width'"):
        check_method_options({"CNN": {"width": 3}}, ["CNN"])
    with pytest.raises(ValueError, match="not among the methods of this run"):
        check_method_options({"MAML": {"inner_lr": 0.1}}, ["CNN"])
    with pytest.raises(ValueError, match=r"^--method-option CNN:steps=0: CNN: steps must be"):
        check_method_options({"CNN": {"steps": 0}}, ["CNN"])
    with pytest.raises(ValueError, match="weights must be the path of a ResNet-18"):
        check_method_options({"CWT-ResNet-ML": {"weights": "/no/such.pth"}}, ["CWT-ResNet-ML"])


@pytest.mark.slow
def test_bad_method_option_on_the_command_line_is_one_line(tmp_path):
    cmd = [
        sys.executable,
        "-m",
        "benchmark.cli",
        "benchmark",
        "closed-set",
        "--data",
        str(tmp_path),
        "--out",
        str(tmp_path / "out"),
        "--method-option",
        "CWT-ResNet-ML:depth=50",
    ]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("tactile-synth benchmark: error: ")
    assert "--method-option CWT-ResNet-ML:depth: CWT-ResNet-ML has no option 'depth'" in lines[0]


def test_meta_fine_tuning_gradient_is_autograds():
    from models.prototypes import normalise

    gen = torch.Generator().manual_seed(5)
    e, n, k, d = 3, 4, 2, 7
    xs = torch.randn(e, n * k, d, generator=gen, dtype=torch.float64)
    shapes = ((e, d, 64), (e, 1, 64), (e, 64, 32), (e, 1, 32), (e, n, 32), (e, 1, n))
    params = [0.3 * torch.randn(*s, generator=gen, dtype=torch.float64) for s in shapes]
    onehot = torch.eye(n, dtype=torch.float64).repeat_interleave(k, dim=0)
    grads = afo_mlp.mlp_head_grads(xs, params, onehot, alpha=7.0, lam=0.2)
    leaves = [p.clone().requires_grad_(True) for p in params]
    z = normalise(afo_mlp._mlp(xs, leaves[:4]))
    logits = 7.0 * torch.bmm(z, normalise(leaves[4]).transpose(1, 2)) + leaves[5]
    loss = afo_mlp._head_loss(0.2)(logits, torch.arange(n).repeat_interleave(k).expand(e, -1))
    loss.backward()
    for mine, leaf in zip(grads, leaves, strict=True):
        assert leaf.grad.abs().max() > 0
        assert torch.allclose(mine, leaf.grad, rtol=1e-10, atol=1e-12)
