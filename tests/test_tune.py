"""Model selection: the committed tuned values follow from the committed evidence by the
stated rules, the methods use them by default, and ``scripts/tune.py`` runs end to end on
training data only."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from models.afo_mlp import AFOMLPML, AFOMLPMLMeta
from models.afop import AFOPML
from models.cwt_resnet import CWTResNetML
from models.direct_prot import DirectProtML
from models.tuned import TUNED_FILE, tuned_values
from tests.support import load_script

ROOT = Path(__file__).resolve().parents[1]


def _tune_module():
    return load_script("tune")


def test_committed_values_follow_from_the_committed_evidence():
    tune = _tune_module()
    values = json.loads(TUNED_FILE.read_text())
    evidence = json.loads((ROOT / "docs" / "tuning.json").read_text())
    assert values["command"] == evidence["command"] and values["data"] == evidence["data"]
    steps = evidence["steps"]
    expected: dict[str, dict] = {}
    for st in steps:
        chosen = tune.apply_rule(st)
        names = [p.strip() for p in st["parameter"].split(",")]
        picks = chosen if len(names) > 1 else [chosen]
        for name, value in zip(names, picks, strict=True):
            expected.setdefault(st["method"], {})[name] = value
    assert values["values"] == expected
    # Every candidate has a score and a CI; the evidence page names every chosen value.
    page = (ROOT / "docs" / "tuning.md").read_text()
    for st in steps:
        assert len(st["candidates"]) == len(st["score"]) == len(st["ci95"]) >= 2
        assert f"`{st['parameter']}`" in page


def test_the_evidence_page_is_the_scripts_rendering_of_the_committed_evidence():
    """docs/tuning.md is generated: its text (the model-selection section included) is
    exactly what ``scripts/tune.py --write`` writes for the committed values and evidence."""
    tune = _tune_module()
    values = json.loads(TUNED_FILE.read_text())
    evidence = json.loads((ROOT / "docs" / "tuning.json").read_text())
    meta = {k: evidence[k] for k in ("command", "data", "seed", "episodes")}
    page = tune.evidence_markdown(meta, values["values"], evidence["steps"])
    assert (ROOT / "docs" / "tuning.md").read_text() == page
    assert "## How the values are chosen" in page


def test_methods_use_the_tuned_values_by_default():
    v = tuned_values()
    a = AFOPML()
    assert (a.alpha, a.ncfs_lam_n, a.ncfs_max_iter) == (
        v["AFOP-ML"]["alpha"],
        v["AFOP-ML"]["ncfs_lam_n"],
        v["AFOP-ML"]["ncfs_max_iter"],
    )
    assert DirectProtML().alpha == v["Direct-Prot-ML"]["alpha"]
    assert AFOMLPML().alpha == v["AFO-MLP-ML"]["alpha"]
    assert CWTResNetML().alpha == v["CWT-ResNet-ML"]["alpha"]
    m = AFOMLPMLMeta()
    assert (m.alpha, m.meta_lr, m.meta_iterations) == (
        v["AFO-MLP-ML+meta"]["alpha"],
        v["AFO-MLP-ML+meta"]["meta_lr"],
        v["AFO-MLP-ML+meta"]["meta_iterations"],
    )
    # The paper's values are not tuned: the head's 250 steps at lr 1.5e-3 for both heads,
    # entropy weight 0.10 for every head.
    assert (a.steps, a.lr, a.lam) == (250, 1.5e-3, 0.10)
    assert (m.adapt_steps, m.adapt_lr, m.lam) == (250, 1.5e-3, 0.10)
    assert AFOMLPML().lam == CWTResNetML().lam == 0.10


def test_selection_rules():
    tune = _tune_module()
    assert tune.choose_best([0.5, 0.7, 0.7]) == 1
    # 0.69 lies within the best's CI (0.70 - 0.02): the cheaper candidate 1 wins.
    assert tune.choose_cheapest_within_ci([0.5, 0.69, 0.70], [0.01, 0.01, 0.02]) == 1
    assert tune.choose_cheapest_within_ci([0.5, 0.60, 0.70], [0.01, 0.01, 0.02]) == 2
    assert tune.choose_lowest([0.3, 0.1, 0.1]) == 1


@pytest.mark.slow
def test_tune_runs_on_training_data_only(tmp_path):
    import torch

    from tests.synthetic_data import make_dataset

    tune = _tune_module()
    data = make_dataset(trials_per_class=10, n_samples=400, noise=0.3)
    from benchmark.protocols.closed_set import split_halves
    from models.features import extract

    feats = extract(data.signals)
    _, test = split_halves(data.label, seed=0)
    # Poison the test half: if any step read it, the scores would change.
    poisoned = feats.copy()
    poisoned[test] = np.random.default_rng(0).standard_normal(poisoned[test].shape) * 1e3
    signals = data.signals.copy()
    signals[test] = np.random.default_rng(1).standard_normal(signals[test].shape) * 1e3
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        a = tune.tune(feats, data.label, data.signals, seed=0, episodes=20, quick=True)
        b = tune.tune(poisoned, data.label, signals, seed=0, episodes=20, quick=True)
    finally:
        torch.set_num_threads(before)

    def untimed(result):
        chosen, steps = result
        return chosen, [{k: v for k, v in st.items() if k != "seconds"} for st in steps]

    assert untimed(a) == untimed(b)
    chosen, steps = a
    assert set(chosen) == {
        "AFOP-ML",
        "Direct-Prot-ML",
        "AFO-MLP-ML",
        "CWT-ResNet-ML",
        "AFO-MLP-ML+meta",
    }
    assert set(chosen["AFOP-ML"]) == {"ncfs_lam_n", "ncfs_max_iter", "alpha"}
    assert all(tune.apply_rule(st) is not None for st in steps)
