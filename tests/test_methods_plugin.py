"""A user's own method, benchmarked without editing tactile-synth: ``--methods module:Class``
(or ``file.py:Class``) and an installed entry point in the ``tactile_synth.methods`` group,
with the shipped example ``examples/nearest_mean.py``."""

from __future__ import annotations

from pathlib import Path

import pytest

from benchmark.results import read_results, select
from models import registry
from models.base import FewShotMethod
from tests.support import class_signals

REPO = Path(__file__).resolve().parents[1]
SPEC = "examples.nearest_mean:NearestClassMean"


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    import synth

    path = tmp_path_factory.mktemp("plugin") / "ds"
    config = synth.PRESETS["quick"].replace(trials_per_class=6)
    synth.generate(config, path, workers=1, progress=False, simulator=class_signals)
    return path


@pytest.fixture
def plugin(tmp_path, monkeypatch):
    """An installed distribution declaring the example under the entry-point name
    ``nearest-mean`` (a dist-info directory on sys.path, as pip would leave it)."""
    site = tmp_path / "site"
    info = site / "my_methods-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: my-methods\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        f"[tactile_synth.methods]\nnearest-mean = {SPEC}\nbroken = examples.nearest_mean:Nope\n"
    )
    monkeypatch.syspath_prepend(str(site))
    monkeypatch.syspath_prepend(str(REPO))
    return "nearest-mean"


def _benchmark(store, out, *methods, capsys=None):
    from benchmark.cli import main

    args = ["benchmark", "closed-set", "--data", str(store), "--out", str(out)]
    return main([*args, "--episodes", "20", "--methods", *methods])


def _check_results(store: Path, out: Path, name: str) -> None:
    """The plug-in's records hold what the example itself scores on the closed-set
    protocol's own split and episodes, and the table and report list it."""
    import synth
    from benchmark.engine import child_seed
    from benchmark.episodes import sample_episodes
    from benchmark.protocols.closed_set import PROTOCOL, split_halves
    from examples.nearest_mean import NearestClassMean

    records = read_results(out / "results.json")
    mine = select(records, "accuracy", method=name)
    assert {(r["shot"], r["way"]) for r in mine} == {(1, n) for n in (5, 10, 12, 28, 36)}
    assert all(r["episodes"] == 20 and r["feature_dim"] == 386 for r in mine)
    data = synth.load_dataset(store)
    train, test = split_halves(data.label, seed=0)
    model = NearestClassMean().fit(data.signals[train], data.label[train])
    for r in mine:
        batch = sample_episodes(
            data.label[test],
            n_way=r["way"],
            k_shot=1,
            n_query=r["query"],
            episodes=20,
            seed=child_seed(0, PROTOCOL, r["way"], 1),
        )
        pred = model.predict_episodes(data.signals[test], batch.support, batch.query)
        assert r["accuracy"] == pytest.approx((pred == batch.query_labels).mean(), abs=1e-12)
        assert r["accuracy"] > 1.5 / r["way"]  # the example learns something
    assert f"| {name} |" in (out / "table1.md").read_text()
    assert name in (out / "report.md").read_text()


def test_module_class_and_file_specs_on_the_command_line(store, tmp_path, monkeypatch):
    monkeypatch.chdir(REPO)  # module:Class is found from the current directory too
    assert _benchmark(store, tmp_path / "a", SPEC) == 0
    _check_results(store, tmp_path / "a", SPEC)
    spec = "examples/nearest_mean.py:NearestClassMean"
    assert _benchmark(store, tmp_path / "b", spec) == 0
    _check_results(store, tmp_path / "b", spec)
    # The same class, the same episodes: the same accuracies whichever way it was named.
    a = select(read_results(tmp_path / "a" / "results.json"), "accuracy")
    b = select(read_results(tmp_path / "b" / "results.json"), "accuracy")
    assert [r["accuracy"] for r in a] == [r["accuracy"] for r in b]


def test_entry_point_plugin(store, tmp_path, plugin):
    assert plugin in registry.available_methods()
    assert registry.method_class(plugin).name == "nearest-class-mean"
    assert _benchmark(store, tmp_path / "c", plugin) == 0
    _check_results(store, tmp_path / "c", plugin)


class _NotAMethod:
    pass


class _Abstract(FewShotMethod):
    name = "abstract"


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("SVM", "--methods must be one of AFOP-ML"),
        ("nearest_mean:", "'nearest_mean:' is not module:Class"),
        ("examples.nope:NearestClassMean", "no module named 'examples.nope'"),
        ("examples/nope.py:NearestClassMean", "file examples/nope.py does not exist"),
        ("examples.nearest_mean:Missing", "has no attribute 'Missing'"),
        (f"{__name__}:_NotAMethod", "is not a FewShotMethod subclass"),
        (f"{__name__}:_Abstract", "does not implement _fit, _predict"),
        ("broken", "entry point 'examples.nearest_mean:Nope'"),
    ],
)
def test_bad_methods_fail_in_one_line_naming_the_argument(
    spec, message, store, tmp_path, plugin, monkeypatch, capsys
):
    monkeypatch.chdir(REPO)
    assert _benchmark(store, tmp_path / "d", spec) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--methods" in err and message in err, err
    assert not (tmp_path / "d").exists()  # refused before any work


class _FailsInFit(FewShotMethod):
    name = "fails-in-fit"

    def _fit(self, signals, labels, features):
        raise RuntimeError("my bug in fit")

    def _predict(self, signals, support, query, features):
        raise AssertionError("never reached")


class _FailsInPredict(_FailsInFit):
    name = "fails-in-predict"

    def _fit(self, signals, labels, features):
        pass

    def _predict(self, signals, support, query, features):
        return {}["no such key"]


@pytest.mark.parametrize(
    ("cls", "stage", "error"),
    [
        ("_FailsInFit", "fit", "RuntimeError: my bug in fit"),
        ("_FailsInPredict", "predict", "KeyError"),
    ],
)
def test_a_failing_plugin_is_reported_as_the_plugins_error(
    cls, stage, error, store, tmp_path, monkeypatch, capsys
):
    from benchmark.cli import main

    monkeypatch.chdir(REPO)
    spec = f"{__name__}:{cls}"
    args = ["benchmark", "closed-set", "--data", store, "--out", tmp_path / "e", "--episodes"]
    args = [str(a) for a in [*args, "5", "--workers", "1", "--methods", spec]]
    assert main(args) == 1
    err = capsys.readouterr().err
    line = err.strip().splitlines()[-1]  # after the progress lines
    assert line.startswith("tactile-synth benchmark: error: ") and "Traceback" not in err, err
    assert f"--methods {spec}: the plug-in method failed in {stage}: {error}" in line
    assert "internal error" not in line
    assert main([*args, "--debug"]) == 1
    err = capsys.readouterr().err
    assert "Traceback" in err and f"--methods {spec}" in err.splitlines()[-1]
    assert ("my bug in fit" if stage == "fit" else "no such key") in err


def test_run_refuses_a_bad_method_before_generating(tmp_path, capsys):
    from benchmark.cli import main

    out = tmp_path / "run"
    assert main(["run", "--out", str(out), "--quick", "--methods", "examples.nope:X"]) == 2
    assert "--methods" in capsys.readouterr().err and not out.exists()
    assert main(["run", "--out", str(out), "--quick", "--methods", "Direct-Prot-ML"]) == 2
    assert "must include AFOP-ML" in capsys.readouterr().err and not out.exists()


def test_run_plan_takes_the_methods_with_the_same_budget(plugin):
    from benchmark.run import run_plan

    plan = run_plan(False, methods=["AFOP-ML", plugin])
    assert plan.methods == ("AFOP-ML", plugin)
    assert plan.budget.for_protocol("cross-shape") == {"AFOP-ML": 100, plugin: 100}
    assert run_plan(True, methods=[plugin, plugin]).methods == (plugin,)
