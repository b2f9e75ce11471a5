"""Grids, the Zarr store, resume logic, export/inspect/plot — with a fast fake simulator.

The fake returns deterministic per-spec signals from the spec's seed, so these tests check
the dataset machinery (order, chunks, done mask, errors) in milliseconds; the real MuJoCo
simulator is exercised end to end in tests/test_generate.py.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
import zarr

import synth.config
import synth.generation as generation
from synth import CLASS_NAMES, PRESETS, GenerationConfig, SynthConfig, load_dataset, store
from synth.dataset_cli import register  # noqa: F401 - the CLI module must import cleanly
from synth.export import export
from synth.presets import load_toml, plan, trial_seed, trial_seeds
from synth.summary import summarize
from tactile_synth import atomic

FAKE_SYNTH = {"fake": True}


class FakeSimulator:
    """Signals from the spec's seed and condition; counts the trials it simulated."""

    def __init__(self, fail_after_chunks: int | None = None) -> None:
        self.calls: list[int] = []  # trial seeds simulated, in call order
        self.fail_after_chunks = fail_after_chunks

    def __call__(self, specs, synth, threads):
        if self.fail_after_chunks is not None and len(self.calls) >= self.fail_after_chunks:
            raise OSError("No space left on device (simulated)")
        self.calls.append(len(specs))
        rows = []
        for s in specs:
            rng = np.random.default_rng(s.seed)
            base = rng.standard_normal((4, 2000)) * s.force_n + s.speed_mm_s
            rows.append(base.astype(np.float32))
        return np.stack(rows)


@pytest.fixture(autouse=True)
def _no_real_synth_config(monkeypatch):
    monkeypatch.setattr(synth.config, "validate_synth_config", lambda synth: None)
    monkeypatch.setattr(synth.config, "default_synth_config", lambda: dict(FAKE_SYNTH))


def tiny(**changes) -> GenerationConfig:
    base = dict(
        preset="custom",
        shapes=("square", "circle"),
        materials=("wood",),
        trials_per_class=3,
        forces_n=(1.0, 1.4),
        chunk_trials=4,
    )
    return GenerationConfig(**{**base, **changes})


def run(config, out, sim=None, **kw):
    return generation.generate(
        config, out, workers=1, progress=False, simulator=sim or FakeSimulator(), **kw
    )


# -- grids -----------------------------------------------------------------------------
def test_presets_have_the_paper_sizes():
    assert PRESETS["quick"].n_trials == 36 * 4
    assert PRESETS["paper"].n_trials == 2160
    pert = PRESETS["perturbation"]
    assert len(pert.conditions) == 8 and (1.0, 10.0) not in pert.conditions
    assert pert.n_trials == 8 * 36 * 10


def test_config_is_canonical_and_validated():
    cfg = tiny()
    assert cfg.shapes == ("circle", "square")  # paper order, whatever the input order
    assert GenerationConfig.from_dict(json.loads(json.dumps(cfg.to_dict()))) == cfg
    for bad, word in [
        (dict(shapes=("circel",)), "did you mean 'circle'"),
        (dict(materials=("wood", "wood")), "twice"),
        (dict(trials_per_class=0), "trials_per_class"),
        (dict(forces_n=(-1.0,)), "forces_n"),
        (dict(forces_n=(1.0,), speeds_mm_s=(10.0,), include_nominal=False), "empty"),
    ]:
        with pytest.raises(ValueError, match=word):
            tiny(**bad)
    with pytest.raises(ValueError, match="generation config key"):
        GenerationConfig.from_dict({"trials": 3})


def test_toml_grid(tmp_path):
    path = tmp_path / "grid.toml"
    path.write_text('preset = "perturbation"\nshapes = ["moon"]\ntrials_per_class = 2\n')
    cfg = load_toml(path)
    assert cfg.shapes == ("moon",) and cfg.trials_per_class == 2 and len(cfg.conditions) == 8
    path.write_text("shapes = [")
    with pytest.raises(ValueError, match="not valid TOML"):
        load_toml(path)
    path.write_text("# nothing set\n")  # would run the whole paper grid
    with pytest.raises(ValueError, match=rf"^--config {path} sets nothing"):
        load_toml(path)
    with pytest.raises(ValueError, match=rf"^--config {tmp_path} is a directory"):
        load_toml(tmp_path)


def test_a_toml_synth_table_sets_only_the_fields_it_names(tmp_path):
    path = tmp_path / "grid.toml"
    path.write_text('preset = "quick"\n[synth.motion]\nsurface_update_s = 0.001\n')
    cfg = load_toml(path)
    expected = SynthConfig().to_dict()
    expected["motion"]["surface_update_s"] = 0.001
    assert cfg.synth == expected and cfg.trials_per_class == 4
    path.write_text("[synth.motion]\nno_such_field = 1.0\n")
    with pytest.raises(ValueError, match="unknown keys \\['no_such_field'\\]"):
        load_toml(path)


def test_seeds_do_not_depend_on_the_rest_of_the_grid():
    small = plan(tiny(shapes=("square",)))
    big = plan(tiny(shapes=("square", "circle", "moon")))
    key = lambda p: {  # noqa: E731
        (p.classes[p.label[i]], float(p.force_n[i]), int(p.trial_index[i])): int(p.seed[i])
        for i in range(len(p))
    }
    small_seeds, big_seeds = key(small), key(big)
    assert all(big_seeds[k] == v for k, v in small_seeds.items())
    assert len(set(big_seeds.values())) == len(big_seeds)  # no two trials share a seed
    # The paper's classes keep their index into CLASS_NAMES as their seed key.
    assert small_seeds[("square/wood", 1.4, 2)] == trial_seed(
        0, CLASS_NAMES.index("square/wood"), 1.4, 10.0, 2
    )


@pytest.mark.parametrize("seed", range(10))
def test_vectorised_trial_seeds_equal_numpys_seed_sequence(seed):
    """The plan's seeds (checked on every load) computed for all trials at once are
    numpy's SeedSequence words, whatever the inputs (small, large, 32-bit edges)."""
    rng = np.random.default_rng(seed)
    n = 400
    cls = rng.integers(0, 36, n)
    force = rng.choice([0.01, 0.6, 1.0, 1.4, 3.3333333, 10.0], n)
    speed = rng.choice([0.1, 6.0, 10.0, 12.345, 500.0], n)
    trial = rng.integers(0, 10**6, n)
    for base in (int(rng.integers(0, 2**31)), 2**32 - 1, 2**32 + int(rng.integers(0, 2**40))):
        got = trial_seeds(base, cls, force, speed, trial)
        want = [trial_seed(base, int(c), float(f), float(s), int(k))
                for c, f, s, k in zip(cls, force, speed, trial, strict=True)]  # fmt: skip
        np.testing.assert_array_equal(got, want)


# -- the store -------------------------------------------------------------------------
def test_store_round_trip_and_plain_zarr(tmp_path):
    out = run(tiny(), tmp_path / "ds")
    data = load_dataset(out)
    cfg = tiny()
    assert len(data) == cfg.n_trials == 12
    assert data.signals.dtype == np.float32 and data.signals.shape == (12, 4, 2000)
    # canonical order: condition-major, then class (paper order), then trial index
    assert list(data.force_n) == [1.0] * 6 + [1.4] * 6
    assert list(data.shape[:6]) == ["circle"] * 3 + ["square"] * 3
    assert [data.classes[i] for i in data.label[:4]] == ["circle/wood"] * 3 + ["square/wood"]
    # each row is its own spec's signals (fake: seed + condition)
    rng = np.random.default_rng(int(data.seed[7]))
    expect = (rng.standard_normal((4, 2000)) * 1.4 + 10.0).astype(np.float32)
    np.testing.assert_array_equal(data.signals[7], expect)
    attrs = data.attrs
    assert attrs["format_version"] == store.FORMAT_VERSION and attrs["complete"]
    assert attrs["config"]["synth"] == FAKE_SYNTH and attrs["mujoco_version"]
    assert GenerationConfig.from_dict(attrs["config"]) == cfg.replace(synth=FAKE_SYNTH)
    group = zarr.open_group(out, mode="r")
    np.testing.assert_array_equal(group["signals"][:], data.signals)
    assert group["signals"].chunks == (4, 4, 2000)
    assert list(group["done"][:]) == [1, 1, 1]
    assert (out / "signals" / "c" / "2" / "0" / "0").is_file()  # the layout write_chunk fsyncs


def test_interrupted_run_resumes_without_recomputing(tmp_path):
    ref = load_dataset(run(tiny(), tmp_path / "ref"))
    out = tmp_path / "ds"
    with pytest.raises(OSError, match="No space"):
        run(tiny(), out, FakeSimulator(fail_after_chunks=1))
    with pytest.raises(ValueError, match=r"incomplete \(1/3 chunks done\).*--resume"):
        load_dataset(out)
    partial = load_dataset(out, allow_incomplete=True)
    assert len(partial) == 4 and not partial.attrs["complete"]
    np.testing.assert_array_equal(partial.signals, ref.signals[:4])
    assert "NO: 1/3 chunks" in summarize(out)
    # a torn chunk: data file present but never marked done -> not data, redone on resume
    group = zarr.open_group(out, mode="r+")
    group["signals"][4:8] = np.full((4, 4, 2000), 7.0, np.float32)
    (out / "signals" / "c" / "2.0.0.deadbeef.partial").write_bytes(b"torn")
    assert len(load_dataset(out, allow_incomplete=True)) == 4
    sim = FakeSimulator()
    run(None, out, sim, resume=True)
    assert sim.calls == [4, 4]  # only the two unfinished chunks
    assert not list(out.rglob("*.partial"))
    done = load_dataset(out)
    np.testing.assert_array_equal(done.signals, ref.signals)
    np.testing.assert_array_equal(done.seed, ref.seed)


def test_plot_refuses_an_incomplete_dataset_naming_the_fix(tmp_path):
    from synth.plot import plot_examples

    out = tmp_path / "ds"
    with pytest.raises(OSError, match="No space"):
        run(tiny(), out, FakeSimulator(fail_after_chunks=1))
    with pytest.raises(ValueError) as caught:
        plot_examples(out, tmp_path / "ex.png")
    assert str(caught.value) == (
        f"dataset {out} is incomplete (1/3 chunks done); finish it with "
        f"`tactile-synth generate --resume --out {out}`"
    )
    assert not (tmp_path / "ex.png").exists()


def test_lock_is_exclusive_and_released(tmp_path):
    target = tmp_path / "ds"
    with atomic.PathLock(target):
        with pytest.raises(atomic.LockedError) as info:
            atomic.PathLock(target).acquire()  # a second holder, even in this process
        assert info.value.pid == os.getpid()
        with pytest.raises(store.DatasetLocked, match=rf"being written by process {os.getpid()}"):
            run(tiny(), target)
    assert not atomic.sibling(target, "lock").exists()
    with atomic.PathLock(target):  # free again
        pass


def test_a_lock_that_cannot_be_created_names_the_path_asked_for(tmp_path, monkeypatch):
    target = tmp_path / "ds"

    def refuse(path, *args):
        raise PermissionError(13, "Permission denied", str(path))

    monkeypatch.setattr(atomic.os, "open", refuse)
    with pytest.raises(PermissionError) as info:
        atomic.PathLock(target).acquire()
    assert info.value.filename == str(target)
    assert "cannot create the lock file beside it" in info.value.strerror


def test_lock_makes_missing_parents_and_a_failed_job_removes_them(tmp_path):
    target = tmp_path / "a" / "b" / "ds"
    with pytest.raises(RuntimeError), store.locked(target):
        assert (tmp_path / "a" / "b").is_dir()  # the lock file lives there
        raise RuntimeError("the job fails")
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(KeyboardInterrupt), store.locked(target):
        (tmp_path / "a" / "notes.txt").write_text("made meanwhile")
        raise KeyboardInterrupt
    assert [p.name for p in (tmp_path / "a").iterdir()] == ["notes.txt"]  # only b went
    with store.locked(target):  # a job that succeeds keeps them
        pass
    assert (tmp_path / "a" / "b").is_dir() and not atomic.sibling(target, "lock").exists()


def test_user_errors_leave_disk_untouched(tmp_path):
    out = run(tiny(), tmp_path / "ds")
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    with pytest.raises(FileExistsError, match=r"--resume.*--overwrite"):
        run(tiny(), out)
    with pytest.raises(ValueError, match=r"different configuration.*seed"):
        run(tiny(seed=1), out, resume=True)
    with pytest.raises(ValueError, match="exclude each other"):
        run(tiny(), out, resume=True, overwrite=True)
    # a dataset is never written into another one: --overwrite would replace its arrays
    for inner in (out / "signals", out / "reports" / "ds"):
        with pytest.raises(ValueError, match=rf"^--out {inner} lies inside the dataset {out};"):
            run(tiny(), inner, overwrite=True)
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    assert not (out / "reports").exists()
    # --overwrite never deletes something that is not a dataset
    folder = tmp_path / "papers"
    folder.mkdir()
    (folder / "thesis.tex").write_text("precious")
    with pytest.raises(FileExistsError, match="not a tactile-synth dataset"):
        run(tiny(), folder, overwrite=True)
    assert (folder / "thesis.tex").read_text() == "precious"


def test_counts_in_messages_take_the_number_they_need():
    from synth.summary import counted

    assert counted(1, "class", "classes") == "1 class"
    assert counted(36, "class", "classes") == "36 classes"
    conditions = [counted(n, "condition") for n in (0, 1, 8)]
    assert conditions == ["0 conditions", "1 condition", "8 conditions"]


def test_chunk_counts_and_sizes_are_the_trials_chunks_really_hold(tmp_path):
    from synth.summary import chunking

    assert chunking(2160, 36) == "60 chunks of 36"
    assert chunking(8, 36) == "1 chunk of 8"
    assert chunking(12, 5) == "3 chunks of 5, the last of 2"
    out = run(tiny(trials_per_class=2, forces_n=(1.0,), chunk_trials=36), tmp_path / "ds")
    assert "(4 trials, 1 chunk of 4)" in summarize(out)


def test_incompatible_format_version(tmp_path):
    out = run(tiny(), tmp_path / "ds")
    group = zarr.open_group(out, mode="r+")
    meta = dict(group.attrs[store.ATTR_KEY])
    meta["format_version"] = 99
    group.attrs[store.ATTR_KEY] = meta
    reads = rf"format version 99.*reads version {store.FORMAT_VERSION}"
    with pytest.raises(ValueError, match=reads):
        load_dataset(out)
    with pytest.raises(ValueError, match="format version 99"):
        run(None, out, resume=True)


def test_an_old_store_whose_parameters_this_version_no_longer_reads_is_told_its_preset(
    tmp_path, monkeypatch
):
    """A store of an older format whose simulator parameters were renamed since (its
    configuration no longer loads) is refused with the command that regenerates its grid
    from its preset, not with a --from-config that would fail."""
    out = run(tiny(), tmp_path / "ds")
    monkeypatch.undo()  # the real check of a stored simulator configuration
    group = zarr.open_group(out, mode="r+")
    meta = dict(group.attrs[store.ATTR_KEY])
    meta["format_version"] = store.FORMAT_VERSION - 1
    config = dict(meta["config"])
    synth_cfg = dict(config["synth"] or {})
    synth_cfg["finger"] = {**synth_cfg.get("finger", {}), "pdms_shear_stiffness_n_m": 1500.0}
    config["synth"] = synth_cfg
    for preset, advice in (
        ("quick", r"generate --preset quick --out .* --overwrite"),
        ("custom", r"your original `tactile-synth generate` command plus --overwrite"),
    ):
        meta["config"] = {**config, "preset": preset}
        group.attrs[store.ATTR_KEY] = meta
        with pytest.raises(ValueError, match=advice):
            load_dataset(out)


# -- export, inspect, plot ---------------------------------------------------------------
def test_export_npz_and_csv(tmp_path):
    out = run(tiny(), tmp_path / "ds")
    data = load_dataset(out)
    npz = export(out, "npz")
    with np.load(npz, allow_pickle=False) as z:
        np.testing.assert_array_equal(z["signals"], data.signals)
        assert list(z["shape"]) == list(data.shape)
        assert json.loads(str(z["attrs_json"]))["config"]["seed"] == 0
    with pytest.raises(FileExistsError, match="--overwrite"):
        export(out, "npz")
    csv = export(out, "csv", tmp_path / "x.csv")
    lines = csv.read_text().splitlines()
    assert len(lines) == 1 + 12 * 4
    row = lines[1 + 5 * 4 + 2].split(",")  # trial 5, channel sg1
    assert row[0] == "5" and row[7] == "sg1"
    np.testing.assert_array_equal(np.array(row[8:], dtype=np.float32), data.signals[5, 2])
    with pytest.raises(ValueError, match="format must be one of npz, csv"):
        export(out, "hdf5")
    meta = (out / "zarr.json").read_bytes()
    for inside in (out / "zarr.json", out / "x.csv"):  # never among the store's files
        with pytest.raises(ValueError, match=rf"^--out {inside} lies inside the dataset {out};"):
            export(out, "csv", inside, overwrite=True)
    assert (out / "zarr.json").read_bytes() == meta and not (out / "x.csv").exists()


def test_export_refusals_name_the_cli_options_and_write_nothing(tmp_path, capsys):
    from benchmark.cli import main

    out = run(tiny(), tmp_path / "ds")
    (tmp_path / "dir").mkdir()
    cases = [
        (["--format", "csv", "--out", tmp_path / "x.npz"], "--out", "ends in .npz but --format"),
        (["--format", "npz", "--out", tmp_path / "dir"], "--out", "is a directory"),
    ]
    for args, *words in cases:
        assert main(["export", str(out), *map(str, args)]) == 2
        err = capsys.readouterr().err
        assert all(w in err for w in words) and len(err.strip().splitlines()) == 1, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dir", "ds"]
    partial = tmp_path / "partial"
    with pytest.raises(OSError, match="No space"):
        run(tiny(), partial, FakeSimulator(fail_after_chunks=1))
    assert main(["export", str(partial), "--format", "npz"]) == 2
    err = capsys.readouterr().err
    assert f"generate --resume --out {partial}`" in err and "allow_incomplete" not in err


def test_inspect_and_plot(tmp_path):
    out = run(tiny(), tmp_path / "ds")
    text = summarize(out)
    assert "complete   yes: 3/3 chunks, 12/12 trials" in text
    assert "1N 10mm/s" in text and "1.4N 10mm/s" in text
    assert any(line.split() == ["square/wood", "3", "3"] for line in text.splitlines())
    assert "sg2" in text.splitlines()[-1]
    from synth.plot import plot_examples

    png = plot_examples(out, tmp_path / "ex.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    chunk = next(p for p in (out / "signals").rglob("*") if p.is_file() and p.name != "zarr.json")
    before = chunk.read_bytes()
    with pytest.raises(ValueError, match=rf"^--out {chunk} lies inside the dataset {out};"):
        plot_examples(out, chunk)
    assert chunk.read_bytes() == before
    for other in ("noext", "ex.pdf"):  # matplotlib would write noext.png, or a PDF
        with pytest.raises(ValueError, match=rf"^--out {tmp_path / other} must end in \.png"):
            plot_examples(out, tmp_path / other)
        assert not list(tmp_path.glob(f"{other}*"))


def test_inspect_of_an_array_names_its_dataset(tmp_path, capsys):
    from benchmark.cli import main

    out = run(tiny(), tmp_path / "ds")
    for part, what in ((out / "signals", "an array of"), (out / "signals" / "c", "inside")):
        assert main(["inspect", str(part)]) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1, err
        assert f"{part} is {what} the dataset {out}, not a dataset itself" in err
        assert f"`tactile-synth inspect {out}`" in err and "--overwrite" not in err
