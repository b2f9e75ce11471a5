"""A hostile user's faults, each reproduced and answered: concurrent writers, damaged or
swapped chunk files, an overwrite failing half-way, version mismatches, overlapping
perturbation data, huge arguments, physics failures, Ctrl-C advice, foreign output
directories. Every CLI failure must be one line on stderr, a non-zero exit, and leave
every complete dataset as it was.

A fast stand-in simulator (signals from each trial's seed and condition) keeps these
tests about the dataset machinery; the real one runs only where physics is the point.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import zarr

import synth
import synth.generation as generation
from benchmark.cli import main
from synth import GenerationConfig, SimulationError, load_dataset, store
from synth.presets import plan
from tactile_synth import atomic

ROOT = Path(__file__).resolve().parents[1]
FAKE_SYNTH = {"fake": True}
GRID = [
    "--shapes", "square", "circle", "--materials", "wood", "--trials-per-class", "3",
    "--force", "1.0", "1.4", "--chunk-trials", "4",
]  # fmt: skip


class FakeSimulator:
    """Signals from the spec's seed and condition; ``fail_at``: raise ``error`` when asked
    for that chunk (counted from 0 in call order); ``calls``: trials per call."""

    def __init__(self, fail_at: int | None = None, error: BaseException | None = None) -> None:
        self.calls: list[int] = []
        self.fail_at = fail_at
        self.error = error

    def __call__(self, specs, synth, threads):
        if self.fail_at is not None and len(self.calls) >= self.fail_at:
            raise self.error or OSError("No space left on device (simulated)")
        self.calls.append(len(specs))
        rows = []
        for s in specs:
            rng = np.random.default_rng(s.seed)
            rows.append(rng.standard_normal((4, 2000)) * s.force_n + s.speed_mm_s)
        return np.stack(rows).astype(np.float32)


@pytest.fixture(autouse=True)
def _fake_simulator(monkeypatch):
    """The CLI's generate uses the stand-in too (threads in this process look it up)."""
    monkeypatch.setattr(synth.config, "validate_synth_config", lambda synth: None)
    monkeypatch.setattr(generation, "validate_grid", lambda config: None)
    monkeypatch.setattr(synth.config, "default_synth_config", lambda: dict(FAKE_SYNTH))
    monkeypatch.setattr(generation, "mujoco_simulator", FakeSimulator())


def tiny(**changes) -> GenerationConfig:
    base = dict(
        shapes=("square", "circle"),
        materials=("wood",),
        trials_per_class=3,
        forces_n=(1.0, 1.4),
        chunk_trials=4,
    )
    return GenerationConfig(**{**base, **changes})


def make(out: Path, sim=None, **kw) -> Path:
    return generation.generate(
        kw.pop("config", tiny()), out, workers=1, progress=False, simulator=sim or FakeSimulator(),
        **kw,
    )  # fmt: skip


def files(path: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(path)): p.read_bytes() for p in sorted(path.rglob("*")) if p.is_file()
    }


def data_files(path: Path) -> dict[str, bytes]:
    """Every file but the group's zarr.json (which holds the store id and creation time)."""
    return {k: v for k, v in files(path).items() if k != "zarr.json"}


def cli(args: list[str], capsys) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def one_line(err: str) -> str:
    """The error line of a failed command: its only line, or the last after progress lines."""
    lines = err.strip().splitlines()
    errors = [x for x in lines if x.startswith("tactile-synth ")]
    assert len(errors) == 1 and errors[0] == lines[-1] and "Traceback" not in err, err
    if len(lines) > 1:
        assert all(x.startswith("[tactile-synth] ") for x in lines[:-1]), err
    return lines[-1]


@pytest.fixture
def complete(tmp_path) -> tuple[Path, dict[str, bytes]]:
    out = make(tmp_path / "ds")
    return out, files(out)


# -- 1. two writers ----------------------------------------------------------------------
_HOLDER = """
import pathlib, sys, time
import numpy as np
import synth.config
import synth.generation as g
from synth import GenerationConfig
synth.config.validate_synth_config = lambda synth: None
g.validate_grid = lambda config: None
synth.config.default_synth_config = lambda: {"fake": True}
out, gate = sys.argv[1], pathlib.Path(sys.argv[2])

def sim(specs, synth, threads):
    while not gate.exists():  # hold the store until the test lets go
        time.sleep(0.01)
    rows = [np.random.default_rng(s.seed).standard_normal((4, 2000)) * s.force_n
            + s.speed_mm_s for s in specs]
    return np.stack(rows).astype(np.float32)

cfg = GenerationConfig(shapes=("square", "circle"), materials=("wood",), trials_per_class=3,
                       forces_n=(1.0, 1.4), chunk_trials=4)
g.generate(cfg, out, workers=1, progress=False, simulator=sim)
"""


@pytest.mark.slow
def test_second_writer_fails_at_once_naming_the_holder(tmp_path):
    out, gate = tmp_path / "ds", tmp_path / "gate"
    holder = subprocess.Popen(
        [sys.executable, "-c", _HOLDER, str(out), str(gate)], cwd=ROOT, stderr=subprocess.PIPE
    )
    try:
        deadline = time.monotonic() + 60
        while not store.is_store(out) or not atomic.sibling(out, "lock").exists():
            assert holder.poll() is None and time.monotonic() < deadline, "holder never started"
            time.sleep(0.02)
        t0 = time.monotonic()
        second = subprocess.run(
            [sys.executable, "-m", "benchmark.cli", "generate", "--out", out, *GRID,
             "--overwrite", "--seed", "1"],
            cwd=ROOT, capture_output=True, text=True, timeout=120,
        )  # fmt: skip
        assert second.returncode == 2
        line = one_line(second.stderr)
        assert f"dataset {out} is being written by process {holder.pid}" in line
        assert time.monotonic() - t0 < 60  # fails at once, does not wait for the holder
        assert not store.pending_path(out).exists()  # the second writer touched nothing
    finally:
        gate.touch()
        holder.wait(timeout=120)
    assert holder.returncode == 0, holder.stderr.read().decode()
    data = load_dataset(out)  # complete, checked, and all the holder's (seed 0)
    np.testing.assert_array_equal(data.seed, plan(tiny()).seed)
    assert data.attrs["config"]["seed"] == 0
    assert not atomic.sibling(out, "lock").exists()  # released and cleaned up


def test_a_task_never_writes_into_a_store_that_was_replaced(complete, tmp_path):
    out, before = complete
    specs = plan(tiny()).specs(0, 4)
    signals = np.zeros((4, 4, 2000), np.float32)
    with pytest.raises(store.DatasetError, match="replaced by another writer"):
        store.write_chunk(out, 0, signals, specs, store_id="an-earlier-store")
    assert files(out) == before


# -- 2. missing, swapped, truncated, bit-flipped chunks -----------------------------------
def test_deleted_signal_chunk_is_named_and_repaired_bit_identical(complete, capsys):
    out, before = complete
    (out / "signals/c/1/0/0").unlink()
    with pytest.raises(store.DatasetDamaged) as info:
        load_dataset(out)
    msg = str(info.value)
    assert f"chunk 1 (trials 4-7, file {out / 'signals/c/1/0/0'}) is missing" in msg
    assert "is missing" in msg and store.repair_command(out) in msg
    code, text, _ = cli(["inspect", out], capsys)
    assert code == 1 and "integrity  DAMAGED: chunk 1" in text and "complete   yes" in text
    code, _, err = cli(["export", out, "--format", "npz"], capsys)
    assert code == 2 and "signals/c/1/0/0" in one_line(err)
    # --resume alone refuses (it would not redo a chunk marked done); --repair redoes it
    code, _, err = cli(["generate", "--resume", "--out", out], capsys)
    assert code == 2 and "--resume --repair" in one_line(err)
    sim = FakeSimulator()
    make(out, sim, config=None, resume=True, repair=True)
    assert sim.calls == [4]  # exactly the damaged chunk
    assert files(out) == before  # bit-identical


def test_deleted_label_chunk_is_caught_and_rewritten_without_simulating(complete, capsys):
    out, before = complete
    (out / "label/c/0").unlink()
    with pytest.raises(store.DatasetDamaged, match=r"label \(.*label/c/0\) is missing"):
        load_dataset(out)
    code, _, err = cli(
        ["benchmark", "closed-set", "--data", out, "--out", out.parent / "b"], capsys
    )
    assert code == 2 and "label/c/0" in one_line(err)
    assert not (out.parent / "b").exists()
    code, _, err = cli(["generate", "--resume", "--repair", "--out", out], capsys)
    assert code == 0, err
    assert files(out) == before
    assert len(load_dataset(out)) == 12


def test_swapped_chunks_are_caught_and_repaired(complete):
    out, before = complete
    a, b = out / "signals/c/0/0/0", out / "signals/c/2/0/0"
    data_a, data_b = a.read_bytes(), b.read_bytes()
    a.write_bytes(data_b)
    b.write_bytes(data_a)
    with pytest.raises(store.DatasetDamaged) as info:
        load_dataset(out)
    assert {p.chunk for p in info.value.problems} == {0, 2}
    assert "fails its checksum" in str(info.value)
    sim = FakeSimulator()
    make(out, sim, config=None, resume=True, repair=True)
    assert sim.calls == [4, 4] and files(out) == before


@pytest.mark.parametrize("damage", ["truncated", "bit-flipped", "emptied"])
def test_corrupted_chunk_file_names_the_file(complete, capsys, damage):
    out, before = complete
    f = out / "signals/c/2/0/0"
    raw = bytearray(f.read_bytes())
    if damage == "truncated":
        raw = raw[: len(raw) // 2]
    elif damage == "bit-flipped":
        raw[len(raw) // 3] ^= 0x10
    else:
        raw = bytearray()
    f.write_bytes(bytes(raw))
    with pytest.raises(store.DatasetDamaged, match=r"chunk 2 .*signals/c/2/0/0\) cannot be read"):
        load_dataset(out)
    code, text, _ = cli(["inspect", out], capsys)
    assert code == 1 and "integrity  DAMAGED: chunk 2" in text and str(f) in text
    code, _, err = cli(["export", out, "--format", "csv"], capsys)
    assert code == 2 and str(f) in one_line(err) and "error during blosc" not in err
    make(out, FakeSimulator(), config=None, resume=True, repair=True)
    assert files(out) == before


def test_damaged_flag_and_checksum_files_are_caught(complete):
    out, before = complete
    flag = out / "done/c/1"
    raw = bytearray(flag.read_bytes())
    raw[0] ^= 0xFF
    flag.write_bytes(bytes(raw))
    (out / "checksum/c/2").unlink()
    with pytest.raises(store.DatasetDamaged) as info:
        load_dataset(out, allow_incomplete=True)
    text = str(info.value)
    assert "chunk 1's done flag" in text and "done/c/1" in text
    assert "has no checksum" in text and "checksum/c/2" in text
    sim = FakeSimulator()
    make(out, sim, config=None, resume=True, repair=True)
    assert sim.calls == [4, 4] and files(out) == before


def test_edited_configuration_is_caught(complete):
    out, _ = complete
    group = zarr.open_group(out, mode="r+")
    meta = dict(group.attrs[store.ATTR_KEY])
    meta["config"] = {**meta["config"], "seed": 7}  # someone edits zarr.json
    group.attrs[store.ATTR_KEY] = meta
    with pytest.raises(store.DatasetDamaged) as info:
        load_dataset(out)
    names = {p.what.split(" ")[0] for p in info.value.problems}
    assert "seed" in names and "chunk" in names  # the seeds and every chunk's checksum
    # repair makes the data those of the (edited) configuration, consistently
    make(out, FakeSimulator(), config=None, resume=True, repair=True)
    data = load_dataset(out)
    np.testing.assert_array_equal(data.seed, plan(tiny(seed=7)).seed)


GROUP_META = '{"zarr_format": 3, "node_type": "group", "attributes": {}}'


@pytest.mark.parametrize(
    ("part", "text"),
    [("zarr.json", ""), ("signals/zarr.json", ""), ("signals/zarr.json", GROUP_META)],
    ids=["store-empty", "array-empty", "array-made-a-group"],
)
def test_damaged_metadata_is_one_line_naming_the_file(complete, capsys, part, text):
    out, _ = complete
    (out / part).write_text(text)
    bench = ["benchmark", "closed-set", "--data", out, "--out", out.parent / "b"]
    for args in (["inspect", out], bench, ["generate", "--resume", "--out", out]):
        code, _, err = cli(args, capsys)
        line = one_line(err)
        assert code == 2 and str(out / part) in line and "--overwrite" in line
    if part != "zarr.json":  # the configuration survives: the advised command rebuilds it
        code, _, err = cli(["generate", "--from-config", out, "--out", out, "--overwrite"], capsys)
        assert code == 0, err
        assert len(load_dataset(out)) == 12


# -- 3. overwrite failing half-way ---------------------------------------------------------
def test_overwrite_failing_halfway_keeps_the_old_dataset(complete, capsys):
    out, before = complete
    with pytest.raises(OSError, match="No space"):
        make(out, FakeSimulator(fail_at=1), config=tiny(seed=1), overwrite=True)
    assert files(out) == before  # the old dataset, untouched and loadable
    assert len(load_dataset(out)) == 12
    pending = store.pending_path(out)
    assert store.is_store(pending)
    code, _, err = cli(["generate", "--out", out, *GRID, "--seed", "1"], capsys)
    assert code == 2 and "--resume finishes it" in one_line(err)
    # a fresh --overwrite copes with the leftover replacement
    make(out, FakeSimulator(), config=tiny(seed=1), overwrite=True)
    assert load_dataset(out).attrs["config"]["seed"] == 1
    assert not pending.exists() and not atomic.sibling(out, "old").exists()


def test_overwrite_refused_by_the_real_simulator_keeps_the_old_dataset(
    complete, capsys, monkeypatch
):
    """--speed 30 would slide off the plate: refused before any change."""
    monkeypatch.undo()  # the real simulator and its configuration
    out, before = complete
    code, _, err = cli(
        ["generate", "--out", out, "--shapes", "square", "--materials", "wood",
         "--trials-per-class", "1", "--speed", "30", "--overwrite"],
        capsys,
    )  # fmt: skip
    assert code == 2 and "--speed must lie in 0.1..22 mm/s" in one_line(err)
    assert files(out) == before


def test_interrupted_overwrite_leaves_the_old_dataset_and_resumes_into_place(
    complete, capsys, monkeypatch
):
    out, before = complete
    monkeypatch.setattr(
        generation, "mujoco_simulator", FakeSimulator(fail_at=1, error=KeyboardInterrupt())
    )
    code, _, err = cli(["generate", "--out", out, *GRID, "--seed", "1", "--overwrite"], capsys)
    assert code == 130
    assert f"{out} still holds its previous dataset" in err
    assert f"`tactile-synth generate --resume --out {out}`" in err
    assert files(out) == before
    monkeypatch.setattr(generation, "mujoco_simulator", FakeSimulator())
    code, _, err = cli(["generate", "--resume", "--out", out], capsys)
    assert code == 0, err
    data = load_dataset(out)
    assert data.attrs["config"]["seed"] == 1
    np.testing.assert_array_equal(data.seed, plan(tiny(seed=1)).seed)
    assert not store.pending_path(out).exists()


@pytest.mark.parametrize("pending_complete", [True, False])
def test_a_swap_killed_between_its_renames_is_finished(tmp_path, pending_complete):
    out = make(tmp_path / "ds")
    pending, old = store.pending_path(out), atomic.sibling(out, "old")
    if pending_complete:
        make(tmp_path / "new", config=tiny(seed=3))
    else:
        with pytest.raises(OSError):
            make(tmp_path / "new", FakeSimulator(fail_at=1), config=tiny(seed=3))
    os.rename(tmp_path / "new", pending)
    os.rename(out, old)  # killed right here, between the two renames
    with pytest.raises(FileNotFoundError, match="being replaced"):
        load_dataset(out)
    sim = FakeSimulator()
    make(out, sim, config=None, resume=True)
    # complete: the finished replacement goes in; else the old dataset goes back and the
    # replacement is resumed (what the interrupted --overwrite asked for) and swapped in
    assert sim.calls == ([] if pending_complete else [4, 4])
    assert load_dataset(out).attrs["config"]["seed"] == 3
    assert not pending.exists() and not old.exists()


# -- 5. versions -------------------------------------------------------------------------
def _edit_meta(out: Path, **changes) -> None:
    group = zarr.open_group(out, mode="r+")
    group.attrs[store.ATTR_KEY] = {**group.attrs[store.ATTR_KEY], **changes}


@pytest.mark.parametrize(
    "key, value, names",
    [
        ("package_version", "0.0.1", "tactile-synth 0.0.1 there"),
        ("mujoco_version", "2.3.0", "MuJoCo 2.3.0 there"),
    ],
)
def test_resume_refuses_chunks_from_other_versions(tmp_path, capsys, key, value, names):
    out = tmp_path / "ds"
    with pytest.raises(OSError):
        make(out, FakeSimulator(fail_at=1))
    _edit_meta(out, **{key: value})
    before = files(out)
    code, _, err = cli(["generate", "--resume", "--out", out], capsys)
    line = one_line(err)
    assert code == 2 and names in line and "pip install" in line and "--overwrite" in line
    assert files(out) == before
    # a complete store has nothing to mix: resuming it (as `run` does) is fine
    make(tmp_path / "full")
    _edit_meta(tmp_path / "full", **{key: value})
    make(tmp_path / "full", config=None, resume=True)


def test_other_format_version_is_refused_with_the_way_forward(complete, capsys):
    out, _ = complete
    _edit_meta(out, format_version=1)
    before = files(out)
    for args in (["inspect", out], ["generate", "--resume", "--out", out]):
        code, _, err = cli(args, capsys)
        line = one_line(err)
        assert code == 2 and "format version 1" in line and "--from-config" in line
    assert files(out) == before


# -- 4. overlapping perturbation data ------------------------------------------------------
def test_perturbation_data_overlapping_the_nominal_data_is_refused(complete, capsys, tmp_path):
    out, _ = complete
    code, _, err = cli(
        ["benchmark", "perturbation", "--data", out, "--perturbed", out, "--out", tmp_path / "b"],
        capsys,
    )
    assert code == 2 and "shares the condition(s) 1 N/10 mm/s" in one_line(err)
    assert not (tmp_path / "b").exists()
    from benchmark.guards import check_perturbation_pair
    from tests.synthetic_data import make_dataset

    nominal = make_dataset(trials_per_class=2, n_samples=100)
    other = make_dataset(trials_per_class=2, n_samples=100, force_n=1.4, speed_mm_s=6.0)
    with pytest.raises(ValueError, match="shares 72 trial seed"):
        check_perturbation_pair(nominal, other)  # same class and seed, other condition
    check_perturbation_pair(nominal, other, seeds=False)
    pert = make(tmp_path / "pert", config=tiny(forces_n=(0.6, 1.4), speeds_mm_s=(6.0,)))
    check_perturbation_pair(load_dataset(out), load_dataset(pert))  # generated: disjoint


def test_swapped_nominal_and_perturbation_datasets_are_refused(tmp_path, capsys):
    nominal = make(tmp_path / "nominal", config=tiny(forces_n=(1.0,)))
    pert = make(tmp_path / "pert", config=tiny(forces_n=(0.6, 1.4)))
    args = ["benchmark", "perturbation", "--data", pert, "--perturbed", nominal]
    code, _, err = cli([*args, "--out", tmp_path / "b"], capsys)
    line = one_line(err)
    assert code == 2 and "--data holds no trial at the nominal condition 1 N/10 mm/s" in line
    assert "0.6 N/10 mm/s, 1.4 N/10 mm/s" in line and "they look swapped" in line
    assert not (tmp_path / "b").exists()


def _no_work(what: str):
    """A stand-in for a step that does work: the test fails if it is called."""

    def called(*args, **kwargs):
        raise AssertionError(f"{what} before the input was refused")

    return called


# -- 8. unbounded inputs -------------------------------------------------------------------
@pytest.mark.parametrize(
    "args, expect",
    [
        (["--trials-per-class", "99999999999"], "at most 10,000,000 trials: lower --trials-per"),
        (["--force", "1e9"], "--force must lie in 0.4..3 N"),
        (["--force", "0.01"], "--force must lie in 0.4..3 N"),  # the pad loses contact
        (["--force", "5"], "--force must lie in 0.4..3 N"),  # the ADC saturates, the pad sticks
        (["--speed", "0"], "--speed must be > 0"),
        (["--speed", "23"], "--speed must lie in 0.1..22 mm/s"),  # the slide leaves the plate
        (["--chunk-trials", "1000000000"], "--chunk-trials must be at most 4096"),
        (["--workers", "1000000"], "--workers 1000000"),
        (["--threads", "1000000"], "--threads 1000000"),
    ],
)
def test_huge_generation_arguments_are_refused_at_once(tmp_path, capsys, monkeypatch, args, expect):
    monkeypatch.setattr(generation, "run_chunk", _no_work("a chunk was simulated"))
    out = tmp_path / "new" / "ds"
    code, _, err = cli(["generate", "--preset", "quick", "--out", out, *args], capsys)
    assert code == 2 and expect in one_line(err)
    assert list(tmp_path.iterdir()) == []  # nothing created, not even the parent


def test_a_grid_larger_than_the_free_disk_is_refused_with_the_estimate(tmp_path, monkeypatch):
    usage = shutil.disk_usage(tmp_path)
    monkeypatch.setattr(generation.shutil, "disk_usage", lambda p: usage._replace(free=100_000))
    out = tmp_path / "new" / "ds"
    with pytest.raises(ValueError, match=r"12 trials .* about 192.0 kB on disk, but .* 100.0 kB"):
        make(out)
    assert list(tmp_path.iterdir()) == []


def test_memory_refusal_counts_the_chunks_a_small_grid_really_has(tmp_path, monkeypatch):
    monkeypatch.setattr(generation, "available_memory", lambda: 1000)
    config = tiny(trials_per_class=2, forces_n=(1.0,), chunk_trials=36)  # 4 trials
    with pytest.raises(
        ValueError, match=r"\(4 trials .*, 1 chunk of 4 trials in flight, 1 worker\)"
    ):
        generation.generate(config, tmp_path / "ds", workers=3, progress=False)
    assert list(tmp_path.iterdir()) == []


def test_huge_episode_counts_are_refused_before_any_work(complete, capsys, tmp_path, monkeypatch):
    import models.features

    out, _ = complete
    monkeypatch.setattr(synth, "load_dataset", _no_work("the dataset was loaded"))
    monkeypatch.setattr(models.features, "extract", _no_work("features were extracted"))
    for n, expect in (("1000000000000", "at most 100,000"), ("0", "must be >= 1")):
        code, _, err = cli(
            ["benchmark", "closed-set", "--data", out, "--out", tmp_path / "b", "--episodes", n],
            capsys,
        )
        assert code == 2 and expect in one_line(err)
        assert not (tmp_path / "b").exists()


# -- physics failures ----------------------------------------------------------------------
def test_physics_failure_is_one_line_and_leaves_the_store_resumable(tmp_path, capsys, monkeypatch):
    out = tmp_path / "ds"
    reference = data_files(make(tmp_path / "ref"))
    error = SimulationError(
        "MuJoCo warning ['mjWARN_BADQACC'] while simulating shape='square', material='wood', "
        "force_n=1.0, speed_mm_s=10.0, seed=123"
    )
    monkeypatch.setattr(generation, "mujoco_simulator", FakeSimulator(fail_at=1, error=error))
    code, _, err = cli(["generate", "--out", out, *GRID], capsys)
    line = one_line(err)
    assert code == 1 and "the physics failed" in line
    for word in ("shape='square'", "material='wood'", "force_n=1.0", "speed_mm_s=10.0", "seed=123"):
        assert word in line
    assert "chunks of" in line and f"generate --resume --out {out}" in line
    done = np.asarray(zarr.open_group(out, mode="r")["done"][:])
    assert 1 <= done.sum() < done.size  # what finished is kept
    monkeypatch.setattr(generation, "mujoco_simulator", FakeSimulator())
    code, _, err = cli(["generate", "--resume", "--out", out], capsys)
    assert code == 0, err
    assert data_files(out) == reference  # the same bytes as an uninterrupted run


def test_a_saturated_adc_is_a_physics_failure_naming_the_trial(monkeypatch):
    """The sensor chain knows only a trial's place in its batch; generate names the trial."""
    import synth.simulator
    from synth.sensors import SaturationError
    from synth.trial import TrialSpec

    def saturating(specs, config, threads):
        if any(s.seed == 7 for s in specs):
            raise SaturationError("ADC saturated (10.50 V beyond +-10.0 V) in trial 1 of the batch")
        return []

    monkeypatch.setattr(synth.simulator, "simulate_batch", saturating)
    specs = [TrialSpec("moon", "resin", force_n=2.5, speed_mm_s=14.0, seed=k) for k in (6, 7)]
    with pytest.raises(SimulationError) as caught:
        generation.simulate_trials(specs, config=None, threads=1)
    assert str(caught.value) == (
        "ADC saturated (10.50 V beyond +-10.0 V) while simulating shape='moon', "
        "material='resin', force_n=2.5, speed_mm_s=14.0, seed=7"
    )


# -- 9. one line at the CLI boundary --------------------------------------------------------
def test_cli_errors_are_one_line_naming_the_path(tmp_path, capsys, monkeypatch):
    a_file = tmp_path / "file"
    a_file.write_text("x")
    code, _, err = cli(["generate", "--out", a_file / "ds", *GRID], capsys)
    assert code == 2 and f"--out {a_file / 'ds'}: {a_file} is a file" in one_line(err)
    code, _, err = cli(["run", "--out", a_file / "run", "--quick"], capsys)
    assert code == 2 and f"--out {a_file / 'run'}: {a_file} is a file" in one_line(err)
    # a file at --out itself: the same check for every command that writes a directory
    code, _, err = cli(["generate", "--out", a_file, *GRID], capsys)
    assert code == 2 and f"--out {a_file} is a file; choose a directory" in one_line(err)
    code, _, err = cli(["run", "--out", a_file, "--quick"], capsys)
    assert code == 2 and f"--out {a_file} is a file; choose a directory" in one_line(err)
    code, _, err = cli(["inspect", a_file], capsys)
    assert code == 2 and str(a_file) in one_line(err)
    code, _, err = cli(["inspect", tmp_path / "nothing"], capsys)
    assert code == 2 and "does not exist" in one_line(err)
    # diagnose checks --out before it loads (and would diagnose) the dataset
    code, _, err = cli(["diagnose", tmp_path / "nothing", "--out", a_file], capsys)
    assert code == 2 and f"--out {a_file} is a file" in one_line(err)
    code, _, err = cli(["diagnose", tmp_path / "nothing", "--out", a_file / "d"], capsys)
    assert code == 2 and f"--out {a_file / 'd'}: {a_file} is a file" in one_line(err)
    code, _, err = cli(["generate", "--out", tmp_path / "d", "--scheduler", "bad::addr"], capsys)
    assert code == 2 and "--scheduler bad::addr: cannot connect" in one_line(err)

    import synth.dataset_cli as dataset_cli

    def denied(args):
        raise PermissionError(13, "Permission denied", str(tmp_path / "ro" / "ds"))

    monkeypatch.setattr(dataset_cli, "_inspect", denied)
    code, _, err = cli(["inspect", tmp_path], capsys)
    assert code == 2 and one_line(err).endswith(f"Permission denied: {tmp_path / 'ro' / 'ds'}")

    def bug(args):
        raise KeyError("oops")

    monkeypatch.setattr(dataset_cli, "_inspect", bug)
    code, _, err = cli(["inspect", tmp_path], capsys)
    assert code == 1 and "internal error" in one_line(err) and "--debug" in err
    code, _, err = cli(["inspect", tmp_path, "--debug"], capsys)
    assert code == 1 and "Traceback" in err and "KeyError" in err


def test_version_flag_prints_package_and_mujoco(capsys):
    import mujoco

    with pytest.raises(SystemExit) as info:
        main(["--version"])
    out = capsys.readouterr().out
    assert info.value.code == 0
    assert out.startswith("tactile-synth ") and f"MuJoCo {mujoco.__version__}" in out


# -- 6. advice -------------------------------------------------------------------------------
def test_ctrl_c_during_planning_suggests_the_original_command(tmp_path, capsys, monkeypatch):
    out = tmp_path / "ds"

    def interrupted(synth):
        raise KeyboardInterrupt

    monkeypatch.setattr(synth.config, "validate_synth_config", interrupted)
    args = ["generate", "--out", str(out), *GRID]
    code, _, err = cli(args, capsys)
    assert code == 130
    assert f"start again with `tactile-synth {' '.join(args)}`" in err
    assert "--resume" not in err and not out.exists()


def test_ctrl_c_after_creation_resume_regenerates_what_was_asked(tmp_path, capsys, monkeypatch):
    out = tmp_path / "ds"
    monkeypatch.setattr(
        generation, "mujoco_simulator", FakeSimulator(fail_at=1, error=KeyboardInterrupt())
    )
    code, _, err = cli(["generate", "--out", out, *GRID], capsys)
    assert code == 130 and f"finish with `tactile-synth generate --resume --out {out}`" in err
    monkeypatch.setattr(generation, "mujoco_simulator", FakeSimulator())
    code, text, err = cli(["generate", "--resume", "--out", out], capsys)
    assert code == 0 and "12 trials (2 classes x 2 conditions x 3 trials)" in text
    code, _, err = cli(["generate", "--resume", "--out", tmp_path / "never"], capsys)
    assert code == 2 and "nothing to resume" in one_line(err)  # not the paper preset


def test_ctrl_c_in_run_keeps_its_datasets_and_says_how_to_continue(tmp_path, capsys, monkeypatch):
    runs = tmp_path / "runs"
    monkeypatch.setattr(
        generation, "mujoco_simulator", FakeSimulator(fail_at=1, error=KeyboardInterrupt())
    )
    code, _, err = cli(["run", "--out", runs, "--quick"], capsys)
    assert code == 130
    assert f"`tactile-synth run --out {runs} --quick` continues" in err
    done = store.Store.open(runs / "data" / "nominal").status()[0]
    assert done.sum() == 1  # the finished chunk is kept for the next run
    assert (runs / ".tactile-synth-output").is_file()  # and the next run accepts the DIR
    assert sorted(p.name for p in tmp_path.iterdir()) == ["runs"]


def test_ctrl_c_in_run_overwrite_advises_continuing_without_overwrite(
    tmp_path, capsys, monkeypatch
):
    runs = tmp_path / "runs"
    monkeypatch.setattr(
        generation, "mujoco_simulator", FakeSimulator(fail_at=1, error=KeyboardInterrupt())
    )
    code, _, err = cli(["run", "--out", runs, "--quick", "--overwrite"], capsys)
    assert code == 130 and f"`tactile-synth run --out {runs} --quick` continues" in err


@pytest.mark.parametrize("how", ["SIGINT", "SIGTERM"])
def test_an_interrupted_benchmark_says_what_is_kept_and_how_to_continue(
    complete, tmp_path, capsys, monkeypatch, how
):
    import signal

    import benchmark.single as single

    out, _ = complete
    new = tmp_path / "b"

    def interrupted(*a, **k):
        if how == "SIGTERM":  # what `kill` sends; handled as Ctrl-C
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(5)
        raise KeyboardInterrupt

    monkeypatch.setattr(single, "benchmark_protocol", interrupted)
    args = ["benchmark", "closed-set", "--data", out, "--out", new, "--overwrite"]
    code, _, err = cli(args, capsys)
    assert code == 130 and f"protocols and fits finished are kept in {new}/checkpoints" in err
    assert f"`tactile-synth benchmark closed-set --data {out} --out {new}` continues" in err
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL  # handed back


def test_run_advice_names_only_runs_options(tmp_path, capsys):
    runs = tmp_path / "runs"
    make(runs / "data" / "nominal")  # a dataset of another grid where run keeps its own
    (runs / ".tactile-synth-output").write_text("{}")
    code, _, err = cli(["run", "--out", runs, "--quick"], capsys)
    line = one_line(err)
    assert code == 2 and "different configuration" in line
    assert f"delete {runs / 'data' / 'nominal'}" in line and "--resume" not in line


# -- 7. output directories -------------------------------------------------------------------
def test_benchmark_refuses_a_foreign_output_directory(complete, capsys, tmp_path):
    out, _ = complete
    mine = tmp_path / "papers"
    mine.mkdir()
    (mine / "report.md").write_text("my own report")
    code, _, err = cli(["benchmark", "closed-set", "--data", out, "--out", mine], capsys)
    assert code == 2 and "not written by tactile-synth" in one_line(err) and "--overwrite" in err
    assert (mine / "report.md").read_text() == "my own report"
    code, _, err = cli(["run", "--out", mine, "--quick"], capsys)
    assert code == 2 and "--overwrite" in one_line(err)
    # a dataset inside the output directory would be deleted by the swap: refused
    inner = make(mine / "mine-ds")
    code, _, err = cli(
        ["benchmark", "closed-set", "--data", inner, "--out", mine, "--overwrite"], capsys
    )
    assert code == 2 and "lies inside --out" in one_line(err)
    assert len(load_dataset(inner)) == 12


@pytest.mark.parametrize(
    "extra",
    [[], ["--trials-per-class", "2"], ["--repair"]],
    ids=["stored-grid", "grid-options", "repair"],
)
def test_resume_of_a_directory_that_is_no_dataset_names_out(tmp_path, capsys, extra):
    folder = tmp_path / "papers"
    folder.mkdir()
    (folder / "thesis.tex").write_text("precious")
    code, _, err = cli(["generate", "--resume", "--out", folder, *extra], capsys)
    line = one_line(err)
    flag = "--resume --repair" if extra == ["--repair"] else "--resume"
    assert code == 2
    assert line.startswith(
        f"tactile-synth generate: error: --out {folder}: not a tactile-synth dataset (no "
    )
    assert f"drop {flag} and choose an empty or new --out" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["papers"]  # no lock file left
    assert [p.name for p in folder.iterdir()] == ["thesis.tex"]


def test_run_refuses_a_given_dataset_inside_its_output_directory(tmp_path, capsys):
    runs = tmp_path / "runs"
    runs.mkdir()
    (runs / ".tactile-synth-output").write_text("{}")  # a DIR run wrote before
    inner = make(runs / "mydata")
    before = files(inner)
    pert = make(tmp_path / "pert", config=tiny(forces_n=(0.6,)))
    for extra in ([], ["--overwrite"]):
        args = ["run", "--out", runs, "--quick", "--data", inner, "--perturbed", pert, *extra]
        code, _, err = cli(args, capsys)
        assert code == 2 and f"--data {inner} lies inside --out" in one_line(err)
        code, _, err = cli(["run", "--out", runs, "--quick", "--perturbed", inner], capsys)
        assert code == 2 and f"--perturbed {inner} lies inside --out" in one_line(err)
    assert files(inner) == before
    # run's own datasets under DIR/data are kept state, not inputs the swap deletes
    from benchmark.outputs import OutputDir

    kept = make(runs / "data" / "nominal")
    with OutputDir(runs, command="run", inputs={"--data": kept}) as tmp:
        (tmp / "report.md").write_text("report")
    assert len(load_dataset(kept)) == 12


def test_benchmark_names_the_dataset_argument_that_does_not_exist(complete, capsys, tmp_path):
    out, _ = complete
    for arg, data, pert in (("--data", tmp_path / "nope", out), ("--perturbed", out, "nope")):
        args = ["benchmark", "perturbation", "--data", data, "--perturbed", pert]
        code, _, err = cli([*args, "--out", tmp_path / "b"], capsys)
        assert code == 2 and f"{arg} " in one_line(err) and "is not a dataset directory" in err
    assert not (tmp_path / "b").exists()


def test_an_incomplete_dataset_is_finished_the_cli_way(complete, capsys, tmp_path):
    out, _ = complete
    part = tmp_path / "part"
    with pytest.raises(OSError, match="No space"):
        make(part, FakeSimulator(fail_at=1))
    for args in (
        ["benchmark", "closed-set", "--data", part, "--out", tmp_path / "b"],
        ["run", "--data", part, "--perturbed", out, "--out", tmp_path / "r"],
    ):
        code, _, err = cli(args, capsys)
        line = one_line(err)
        assert code == 2 and "is incomplete (1/" in line
        assert f"`tactile-synth generate --resume --out {part}`" in line
        assert "allow_incomplete" not in line
    with pytest.raises(ValueError, match="allow_incomplete=True"):  # the API keeps its hint
        load_dataset(part)


def test_a_read_only_out_is_named_as_given(complete, capsys, tmp_path, monkeypatch):
    import errno

    from benchmark.outputs import OutputDir

    def read_only(self, where):
        raise OSError(errno.EROFS, "Read-only file system", str(where / "marker.tmp"))

    monkeypatch.setattr(OutputDir, "_write_marker", read_only)
    monkeypatch.chdir(tmp_path)
    out, _ = complete
    code, _, err = cli(["benchmark", "closed-set", "--data", out, "--out", "romnt"], capsys)
    line = one_line(err)
    assert code == 2 and "--out romnt cannot be written (Read-only file system)" in line
    assert "marker.tmp" not in line and not (tmp_path / "romnt").exists()


def test_failed_checks_leave_no_new_output_directory(complete, capsys, tmp_path):
    out, _ = complete
    pert = make(tmp_path / "pert", config=tiny(forces_n=(0.6,)))
    new = tmp_path / "new" / "b"
    for args, expect in (
        (["benchmark", "all", "--perturbed", pert, "--methods", "Direct-Prot-ML"], "AFOP-ML"),
        (["benchmark", "closed-set"], "too small for any Table I column"),
        (["benchmark", "cross-shape", "--methods", "AFOP-ML"], "needs >= 2 classes on each side"),
    ):
        code, _, err = cli([*args, "--data", out, "--out", new, "--episodes", "1"], capsys)
        assert code == 2 and expect in one_line(err)
        assert sorted(p.name for p in tmp_path.iterdir()) == ["ds", "pert"]  # nor its parent
    code, _, err = cli(["run", "--out", new, "--quick", "--workers", "1000"], capsys)
    assert code == 2 and "--workers 1000" in one_line(err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds", "pert"]
    # a DIR that existed stays, as it was
    new.mkdir(parents=True)
    code, _, err = cli(["benchmark", "closed-set", "--data", out, "--out", new], capsys)
    assert code == 2 and list(new.iterdir()) == []


def test_output_set_is_replaced_whole_and_state_is_kept(tmp_path):
    from benchmark.outputs import MARKER, OutputDir

    out = tmp_path / "out"
    with OutputDir(out, command="benchmark closed-set") as tmp:
        (tmp / "results.json").write_text("[1]")
        (tmp / "table1.md").write_text("old table")
        (tmp / "checkpoints" / "closed-set.json").write_text("{}")
    (out / "data").mkdir()
    (out / "data" / "keep.txt").write_text("dataset")
    assert (out / "table1.md").is_file() and (out / MARKER).is_file()
    with pytest.raises(RuntimeError):
        with OutputDir(out, command="benchmark cross-shape") as tmp:
            (tmp / "results.json").write_text("[2]")
            raise RuntimeError("interrupted")
    assert (out / "results.json").read_text() == "[1]"  # the old set, untouched
    with OutputDir(out, command="benchmark cross-shape") as tmp:
        (tmp / "results.json").write_text("[2]")
    assert (out / "results.json").read_text() == "[2]"
    assert not (out / "table1.md").exists()  # no stale file from the earlier set
    assert (out / "data" / "keep.txt").read_text() == "dataset"
    assert (out / "checkpoints" / "closed-set.json").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no leftovers beside it
    # --overwrite starts over: the results it replaces give it no checkpoint
    with OutputDir(out, overwrite=True, command="benchmark closed-set") as tmp:
        assert list((tmp / "checkpoints").iterdir()) == []
        (tmp / "results.json").write_text("[3]")
    assert list((out / "checkpoints").iterdir()) == []
    assert (out / "data" / "keep.txt").read_text() == "dataset"


def test_ctrl_c_while_the_cli_loads_is_one_line(monkeypatch, capsys):
    """An interrupt during the imports that precede the command's own error boundary
    ends the console script with one line and status 130, not a traceback."""
    import importlib.abc

    from tactile_synth import entry

    class Interrupting(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name == "benchmark.cli":
                raise KeyboardInterrupt
            return None

    monkeypatch.delitem(sys.modules, "benchmark.cli")
    monkeypatch.setattr(sys, "meta_path", [Interrupting(), *sys.meta_path])
    assert entry.main() == 130
    assert capsys.readouterr().err == "tactile-synth: interrupted\n"


def test_the_console_script_is_the_interrupt_safe_entry():
    text = (ROOT / "pyproject.toml").read_text()
    assert 'tactile-synth = "tactile_synth.entry:main"' in text


# -- 9. progress -----------------------------------------------------------------------------
#: A plain progress line; the times after the percentage vary from run to run.
PROGRESS_LINE = re.compile(r"\[tactile-synth\] (.+): (\d+)/(\d+) trials \((\d+)%\) in .* s")


def progress_lines(err: str) -> list[tuple[str, int, int, int]]:
    """``(what, done, total, percent)`` of each progress line of ``err`` (its timing
    left out); every line of ``err`` must be one, and no bar redraws a line."""
    assert "\r" not in err, err
    found = []
    for line in err.splitlines():
        m = PROGRESS_LINE.fullmatch(line.split(", about ")[0])
        assert m, line
        found.append((m[1], int(m[2]), int(m[3]), int(m[4])))
    return found


def test_progress_is_plain_lines_when_stderr_is_not_a_terminal(tmp_path, capsys):
    out = tmp_path / "ds"
    code, _, err = cli(["generate", "--out", out, *GRID], capsys)  # 12 trials, chunks of 4
    assert code == 0
    assert progress_lines(err) == [
        ("generate paper", 4, 12, 33),
        ("generate paper", 8, 12, 66),
        ("generate paper", 12, 12, 100),
    ]
    for fmt in ("npz", "csv"):
        code, _, err = cli(["export", out, "--format", fmt], capsys)
        assert code == 0
        assert [(d, n, p) for _, d, n, p in progress_lines(err)] == [
            (4, 12, 33),
            (8, 12, 66),
            (12, 12, 100),
        ]
        assert progress_lines(err)[0][0] == f"export {fmt}"
    data = np.load(tmp_path / "ds.npz", allow_pickle=False)
    assert np.array_equal(data["signals"], load_dataset(out).signals)


def test_progress_lines_mark_each_tenth_once_and_the_end(capsys):
    from synth.progress import LineProgress

    bar = LineProgress(100, desc="generate big", unit="trial", initial=36)
    for _ in range(64):
        bar.update(1)
    bar.close()
    percents = [p for *_, p in progress_lines(capsys.readouterr().err)]
    assert percents == [40, 50, 60, 70, 80, 90, 100]


def test_progress_on_a_terminal_stays_a_bar(tmp_path, monkeypatch):
    import io

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    term = Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    generation.generate(tiny(), tmp_path / "ds", workers=1, simulator=FakeSimulator())
    text = term.getvalue()
    assert "\r" in text and "12/12" in text and "[tactile-synth]" not in text
