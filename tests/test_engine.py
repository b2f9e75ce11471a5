"""The protocol engine: it imports no protocol, runs a user's protocol from one file (by
engine call, ``module:Class``/file spec and entry point), shares fits between tasks that
ask for it, and writes the meta-training curve of any method that exposes one."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import ClassVar

import numpy as np
import pytest

from benchmark import engine, fits, protocols
from benchmark.results import MetaCurveRecord, read_results, select
from models.base import FewShotMethod
from synth import CLASS_NAMES, MATERIAL_NAMES
from tests.synthetic_data import make_dataset

REPO = Path(__file__).resolve().parents[1]
SPEC = "examples.leave_one_material_out:LeaveOneMaterialOut"


@pytest.mark.slow
def test_importing_the_engine_imports_no_protocol():
    code = (
        "import sys, benchmark.engine; "
        "print(sorted(m for m in sys.modules if m.startswith('benchmark.protocols')))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == "[]", out.stdout


class Spy(FewShotMethod):
    """Nearest mean of per-channel means; logs the classes it is fitted on and exposes a
    meta-training curve like MAML's."""

    name = "spy"
    meta_gradient = "second-order"
    fits: ClassVar[list[np.ndarray]] = []

    def _fit(self, signals, labels, features):
        Spy.fits.append(np.unique(labels))
        self.meta_curve_ = np.array([[0.0, 0.5], [50.0, 0.75]])

    def _predict(self, signals, support, query, features):
        x = signals.mean(axis=2)
        protos = x[support].mean(axis=2)
        d = ((x[query][:, :, None, :] - protos[:, None, :, :]) ** 2).sum(-1)
        return d.argmin(axis=2)


@pytest.fixture(scope="module")
def data():
    return make_dataset(trials_per_class=4, n_samples=200, noise=0.2)


def test_example_protocol_runs_through_the_engine(data, monkeypatch):
    from examples.leave_one_material_out import LeaveOneMaterialOut

    Spy.fits = []
    monkeypatch.setattr(fits, "make_method", lambda name, seed=0: Spy(seed=seed))
    records = protocols.run(LeaveOneMaterialOut(), data, methods=["Direct-Prot-ML"], episodes=8)
    # One fit per left-out material, never on its classes.
    assert len(Spy.fits) == 3
    for material, classes in zip(MATERIAL_NAMES, Spy.fits, strict=True):
        assert {CLASS_NAMES[c].split("/")[1] for c in classes} == set(MATERIAL_NAMES) - {material}
    acc = select(records, "accuracy", protocol="leave-one-material-out")
    assert {(r["fold"], r["way"]) for r in acc} == {
        (f, w) for f in (*MATERIAL_NAMES, None) for w in (2, 3, 4, 5)
    }
    assert all(r["episodes"] == (24 if r["fold"] is None else 8) for r in acc)
    # The generic meta-curve record: one per fit, as the method states it.
    curves = select(records, "meta_curve")
    assert [c["fold"] for c in curves] == list(MATERIAL_NAMES)
    assert all(isinstance(c, MetaCurveRecord) for c in curves)
    assert curves[0]["step"] == [0, 50] and curves[0]["accuracy"] == [0.5, 0.75]
    assert curves[0]["meta_gradient"] == "second-order" and curves[0]["method"] == "Direct-Prot-ML"


def test_tasks_with_one_fit_key_share_one_fit(data, monkeypatch):
    Spy.fits = []
    monkeypatch.setattr(fits, "make_method", lambda name, seed=0: Spy(seed=seed))
    idx = np.arange(len(data))
    tasks = [
        engine.Task(
            protocol="p",
            fold=None,
            condition=c,
            fit=engine.Pool(data, idx),
            test=engine.Pool(data, idx),
            grid=(engine.Cell(2, 1, seed=i),),
            episodes=engine.EpisodeBudget(3),
            fit_seed=7,
            fit_key="one",
        )
        for i, c in enumerate("ab")
    ]
    done = engine.run_tasks(tasks, ["Direct-Prot-ML"])
    assert len(Spy.fits) == 1 and len(done.scored) == 2 and len(done.fits) == 1


def test_plugin_protocol_on_the_command_line_and_as_entry_point(tmp_path, monkeypatch, capsys):
    import synth
    from benchmark.cli import main
    from tests.support import class_signals

    store = tmp_path / "ds"
    config = synth.PRESETS["quick"].replace(trials_per_class=4)
    synth.generate(config, store, workers=1, progress=False, simulator=class_signals)
    site = tmp_path / "site"
    info = site / "my_protocols-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: my-protocols\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[tactile_synth.protocols]\nlomo = {SPEC}\n")
    monkeypatch.syspath_prepend(str(site))
    monkeypatch.chdir(REPO)
    results = []
    for i, name in enumerate(("examples/leave_one_material_out.py:LeaveOneMaterialOut", "lomo")):
        out = tmp_path / f"out{i}"
        args = ["benchmark", name, "--data", str(store), "--out", str(out), "--episodes", "5"]
        assert main([*args, "--methods", "Direct-Prot-ML"]) == 0, capsys.readouterr().err
        results.append(select(read_results(out / "results.json"), "accuracy"))
        report = (out / "report.md").read_text()
        assert "protocol leave-one-material-out only" in report
        assert "## Protocol leave-one-material-out" in report and "1-shot 5-way" in report
    assert [r["accuracy"] for r in results[0]] == [r["accuracy"] for r in results[1]]
    assert {r["protocol"] for r in results[0]} == {"leave-one-material-out"}
    capsys.readouterr()
    assert main(["benchmark", "nope", "--data", str(store), "--out", str(tmp_path / "x")]) == 2
    assert "PROTOCOL must be one of" in capsys.readouterr().err


@pytest.mark.slow
def test_a_benchmark_run_with_maml_writes_its_meta_curve():
    """The real MAML (a small dataset, few episodes): its validation curve on held-out
    training classes lands in the records, with steps rising and first-order stated."""
    small = make_dataset(trials_per_class=4, n_samples=400, noise=0.2)
    records = protocols.run("closed-set", small, methods=["MAML"], episodes=5, seed=0)
    (curve,) = select(records, "meta_curve", protocol="closed-set", method="MAML")
    assert curve["fold"] is None and curve["meta_gradient"] == "first-order"
    assert len(curve["step"]) == len(curve["accuracy"]) >= 2
    assert np.all(np.diff(curve["step"]) > 0)
    assert all(0.0 <= a <= 1.0 for a in curve["accuracy"])
