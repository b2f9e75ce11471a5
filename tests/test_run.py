"""``benchmark all`` / ``run`` end to end: files written, same seed -> same numbers bit for
bit, resumability, and the real ``tactile-synth run --quick`` (slow)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import synth
from benchmark.budget import Budget
from benchmark.engine import Features
from benchmark.figures import FIGURE_FILES
from benchmark.report import strip_timing
from benchmark.results import TIMING_FIELDS, select
from benchmark.run import benchmark_all, run
from synth import Dataset
from tests.synthetic_data import make_dataset


def comparable(records: list[dict]) -> list[dict]:
    """Records without wall-clock fields (the only fields allowed to differ between runs)."""
    return [{k: v for k, v in r.items() if k not in TIMING_FIELDS} for r in records]


def _perturbed() -> Dataset:
    parts = [
        make_dataset(trials_per_class=3, n_samples=400, force_n=f, speed_mm_s=s, seed=i + 10)
        for i, (f, s) in enumerate(((0.6, 6.0), (0.6, 14.0), (1.4, 6.0), (1.4, 14.0)))
    ]
    cat = {
        k: np.concatenate([getattr(p, k) for p in parts])
        for k in ("signals", "shape", "material", "label", "force_n", "speed_mm_s", "seed")
    }
    return Dataset(**cat)


@pytest.fixture(scope="module")
def datasets():
    return make_dataset(trials_per_class=6, n_samples=400, noise=0.2), _perturbed()


@pytest.mark.slow
def test_benchmark_all_writes_everything_and_is_deterministic(datasets, tmp_path):
    data, pert = datasets
    kw = dict(methods=["AFOP-ML"], budget=Budget(default=20), seed=4, progress=False)
    a = benchmark_all(data, pert, tmp_path / "a", **kw)
    b = benchmark_all(data, pert, tmp_path / "b", **kw)
    for out in (tmp_path / "a", tmp_path / "b"):
        assert (out / "results.json").is_file() and (out / "report.md").is_file()
        for name in FIGURE_FILES.values():
            if name == FIGURE_FILES["dscan"] and not select(a, "dscan"):
                continue
            png = out / name
            assert png.is_file() and png.read_bytes()[:4] == b"\x89PNG", name
    # Same seed -> same numbers, bit for bit (timings excluded by design).
    assert comparable(a) == comparable(b)
    ja = json.loads((tmp_path / "a" / "results.json").read_text())
    jb = json.loads((tmp_path / "b" / "results.json").read_text())
    assert comparable(ja) == comparable(jb)
    ra = (tmp_path / "a" / "report.md").read_text()
    rb = (tmp_path / "b" / "report.md").read_text()
    assert strip_timing(ra) == strip_timing(rb)
    kinds = {r["record"] for r in a}
    assert {"accuracy", "selection", "tsne"} <= kinds
    protocols = {r["protocol"] for r in select(a, "accuracy")}
    assert protocols == {"closed-set", "cross-shape", "cross-material", "perturbation"}
    sel = {r["protocol"] for r in select(a, "selection")}
    assert sel == {"closed-set", "cross-shape", "cross-material", "perturbation"}
    # A different seed changes the numbers.
    c = benchmark_all(data, pert, tmp_path / "c", **{**kw, "seed": 5})
    assert comparable(c) != comparable(a)


@pytest.mark.slow
def test_benchmark_all_resumes_from_checkpoints(datasets, tmp_path, monkeypatch):
    data, pert = datasets
    kw = dict(methods=["AFOP-ML"], budget=Budget(default=10), seed=0, progress=False)
    first = benchmark_all(data, pert, tmp_path, **kw)
    import benchmark.run as run_mod

    def boom(*a, **k):
        raise AssertionError("protocol re-run although its checkpoint is valid")

    with monkeypatch.context() as m:
        m.setattr(run_mod, "run_task_sets", boom)
        again = benchmark_all(data, pert, tmp_path, **kw)
    assert comparable(again) == comparable(first)
    # Other hyper-parameters (a retuned default) make the checkpoints stale.
    from models.afop import AFOPML

    ran = []
    real = run_mod.run_task_sets

    def counting(*a, **k):
        ran.append(1)
        return real(*a, **k)

    original = AFOPML.__init__

    def retuned(self, *a, **k):
        original(self, *a, **k)
        self.alpha = self.alpha * 2

    monkeypatch.setattr(AFOPML, "__init__", retuned)
    monkeypatch.setattr(run_mod, "run_task_sets", counting)
    benchmark_all(data, pert, tmp_path, **kw)
    assert ran, "checkpoints made with other hyper-parameters were reused"


def test_checkpoints_are_recomputed_after_an_edit_to_a_plugin_file(datasets, tmp_path, monkeypatch):
    """Plug-in methods and protocols are keyed by their source file's bytes: an edit that
    keeps every setting still recomputes the protocol."""
    import shutil

    import benchmark.run as run_mod
    from benchmark.protocols import get

    data, _ = datasets
    root = Path(__file__).resolve().parents[1] / "examples"
    method_file = shutil.copy(root / "nearest_mean.py", tmp_path / "mine.py")
    protocol_file = shutil.copy(root / "leave_one_material_out.py", tmp_path / "lomo.py")
    method = f"{method_file}:NearestClassMean"
    protocol = get(f"{protocol_file}:LeaveOneMaterialOut")
    ran = []
    real = run_mod.run_task_sets

    def counting(*a, **k):
        ran.append(1)
        return real(*a, **k)

    monkeypatch.setattr(run_mod, "run_task_sets", counting)
    kw = dict(methods=[method], budget=Budget(default=5), seed=0, progress=False)
    kw.update(features=Features(), workers=1)
    out = tmp_path / "out"
    run_mod.run_protocols([protocol], data, None, out, **kw)
    run_mod.run_protocols([protocol], data, None, out, **kw)
    assert len(ran) == 1  # unchanged files: the checkpoint is reused
    for edited in (method_file, protocol_file):
        Path(edited).write_text(Path(edited).read_text() + "# edited\n")
        run_mod.run_protocols([protocol], data, None, out, **kw)
    assert len(ran) == 3, "a checkpoint made by other plug-in code was reused"


@pytest.mark.slow
def test_an_interrupted_run_keeps_its_finished_fits(datasets, tmp_path, monkeypatch):
    """Each fit is checkpointed as it finishes: a run interrupted part-way through its
    protocols continues with the fits that were not finished, gives the records of an
    uninterrupted run, and deletes the fit checkpoints once every protocol is saved."""
    import benchmark.engine as engine
    import benchmark.run as run_mod
    from benchmark.protocols import get

    data, pert = datasets
    protocols = [get("cross-shape"), get("perturbation")]
    kw = dict(methods=["AFOP-ML", "Direct-Prot-ML"], budget=Budget(default=5), seed=0)
    kw.update(progress=False, features=Features(), workers=1)
    whole = run_mod.run_protocols(protocols, data, pert, tmp_path / "whole", **kw).records

    real = engine.run_fit
    calls = []

    def counted(*a, interrupt_at=None, **k):
        calls.append(a[1])
        if len(calls) == interrupt_at:
            raise KeyboardInterrupt
        return real(*a, **k)

    out = tmp_path / "out"
    monkeypatch.setattr(engine, "run_fit", lambda *a, **k: counted(*a, interrupt_at=4, **k))
    with pytest.raises(KeyboardInterrupt):
        run_mod.run_protocols(protocols, data, pert, out, **kw)
    fits = out / "checkpoints" / "fits"
    assert len(list(fits.glob("*.json"))) == 3  # the three fits before the interrupt
    # A damaged fit checkpoint counts as none: that fit runs again.
    damaged = sorted(fits.glob("*.json"))[0]
    damaged.write_text(damaged.read_text()[:-10])
    calls.clear()
    monkeypatch.setattr(engine, "run_fit", lambda *a, **k: counted(*a, **k))
    resumed = run_mod.run_protocols(protocols, data, pert, out, **kw).records
    # 3 cross-shape folds and 1 perturbation fit, for each of the 2 methods: 8 fits, of
    # which the 2 intact checkpoints are reused.
    assert len(calls) == 6
    assert comparable([r.to_dict() for r in resumed]) == comparable([r.to_dict() for r in whole])
    assert not fits.exists()


def test_benchmark_all_validates_inputs(datasets, tmp_path):
    data, pert = datasets
    with pytest.raises(ValueError, match="AFOP-ML"):
        benchmark_all(data, pert, tmp_path, methods=["Direct-Prot-ML"], progress=False)
    with pytest.raises(ValueError, match="method must be one of"):
        benchmark_all(data, pert, tmp_path, methods=["AFOP-ML", "SVM"], progress=False)


class FakeSimulator:
    """Class-dependent signals from each spec (fast stand-in for MuJoCo)."""

    def __init__(self) -> None:
        self.trials = 0

    def __call__(self, specs, synth, threads):
        from synth import CLASS_NAMES

        self.trials += len(specs)
        t = np.arange(2000) / 1000.0
        rows = []
        for s in specs:
            c = CLASS_NAMES.index(f"{s.shape}/{s.material}")
            rng = np.random.default_rng(s.seed)
            base = np.stack([np.sin(2 * np.pi * (3 + c + 0.5 * k) * t) for k in range(4)])
            rows.append(
                (base * s.force_n + 0.3 * rng.standard_normal((4, 2000))).astype(np.float32)
            )
        return np.stack(rows)


@pytest.mark.slow
def test_run_quick_with_fake_simulator_is_resumable(tmp_path, monkeypatch):
    monkeypatch.setattr(synth.config, "validate_synth_config", lambda synth: None)
    monkeypatch.setattr(synth.config, "default_synth_config", lambda: {"fake": True})
    import benchmark.plan as plan

    monkeypatch.setattr(plan, "QUICK_METHODS", ("AFOP-ML",))
    sim = FakeSimulator()
    first = run(tmp_path, quick=True, progress=False, workers=1, simulator=sim)
    n_sim = sim.trials
    assert n_sim > 0
    assert (tmp_path / "report.md").is_file()
    again = run(tmp_path, quick=True, progress=False, workers=1, simulator=sim)
    assert sim.trials == n_sim  # datasets reused, nothing re-simulated
    assert comparable(again) == comparable(first)
    # run --data / --perturbed: existing stores are used as they are, nothing generated.
    given = run(
        tmp_path / "given",
        quick=True,
        progress=False,
        workers=1,
        simulator=sim,
        data=tmp_path / "data" / "nominal",
        perturbed=tmp_path / "data" / "perturbation",
    )
    assert sim.trials == n_sim
    assert not (tmp_path / "given" / "data").exists()
    assert comparable(given) == comparable(first)
    with pytest.raises(FileNotFoundError, match="--data"):
        run(tmp_path / "bad", quick=True, progress=False, data=tmp_path / "missing")


@pytest.mark.slow
def test_tactile_synth_run_quick_real(tmp_path):
    """The README's first-look command with the real generator and simulator, and again
    from nothing with other workers (generation in 2 processes instead of this one) and
    AFOP-ML alone: same seed, same data and same AFOP-ML numbers, bit for bit. The other
    methods' own determinism is tested with each method."""
    from benchmark.cli import main

    assert main(["run", "--out", str(tmp_path / "a"), "--quick"]) == 0
    argv_b = ["run", "--out", str(tmp_path / "b"), "--quick", "--methods", "AFOP-ML"]
    assert main([*argv_b, "--workers", "2"]) == 0
    for name in ("nominal", "perturbation"):
        da, db = (synth.load_dataset(tmp_path / d / "data" / name) for d in "ab")
        assert da.signals.tobytes() == db.signals.tobytes(), name
    # The two output directories' own paths are the only text allowed to differ.
    ja, jb = (
        json.loads((tmp_path / d / "results.json").read_text().replace(str(tmp_path / d), "OUT"))
        for d in "ab"
    )
    others = {r.get("method") for r in ja} - {None, "AFOP-ML"}
    assert others == {"AFO-MLP-ML", "Direct-Prot-ML"}
    assert comparable([r for r in ja if r.get("method") not in others]) == comparable(jb)
    ra, rb = (
        strip_timing((tmp_path / d / "report.md").read_text().replace(str(tmp_path / d), "OUT"))
        for d in "ab"
    )
    # b's report is a's without the other methods: only the lines listing every method
    # (run settings, figure captions) differ; the numbers are the records above.
    a_lines = set(ra.splitlines())
    extra = [line for line in rb.splitlines() if line not in a_lines]
    # ... and the perturbation readings' AFOP-ML - AFO-MLP-ML column, "-" without it.
    gaps = [line for line in extra if line.startswith("| ") and line.endswith("| - |")]
    assert len(gaps) == 3, gaps  # within-condition, pooled, enrolled
    extra = [line for line in extra if line not in gaps]
    listing = [
        "- methods",
        "- episode budgets",
        "- **generalisation.png**",
        "- **perturbation_heatmap.png**",
    ]
    assert [line.split(" — ")[0].split(":")[0] for line in extra] == listing, extra
    assert len(rb.splitlines()) < len(ra.splitlines())
    tmp_path = tmp_path / "a"
    records = json.loads((tmp_path / "results.json").read_text())
    assert {r["protocol"] for r in select(records, "accuracy")} == {
        "closed-set",
        "cross-shape",
        "cross-material",
        "perturbation",
    }
    text = (tmp_path / "report.md").read_text()
    assert "## Generalisation to unseen domains" in text
    for name in FIGURE_FILES.values():
        assert (tmp_path / name).is_file(), name
