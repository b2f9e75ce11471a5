"""End-to-end dataset generation with the real MuJoCo simulator (tiny grids).

Determinism across worker counts, chunking and a Dask cluster; any row re-simulated alone;
the CLI killed mid-run (SIGKILL, Ctrl-C and SIGTERM) and resumed; --from-config regeneration; a
damaged chunk repaired by re-simulation to the original bytes.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import zarr

import synth
from benchmark.cli import main as cli
from synth import GenerationConfig, load_dataset

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]


def tiny(**changes) -> GenerationConfig:
    base = dict(
        shapes=("square", "triangle"),
        materials=("wood",),
        trials_per_class=5,
        forces_n=(1.0, 1.4),
        chunk_trials=2,
    )
    return GenerationConfig(**{**base, **changes})


def chunk_bytes(path: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(path)): p.read_bytes()
        for p in sorted((path / "signals" / "c").rglob("*"))
        if p.is_file()
    }


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    """The tiny grid generated in this process (rollout threads on all cores)."""
    out = tmp_path_factory.mktemp("ref") / "ds"
    synth.generate(tiny(), out, workers=1, progress=False)
    return out


def test_rows_resimulate_alone(reference):
    data = load_dataset(reference)
    assert data.signals.shape == (20, 4, synth.N_SAMPLES) and np.isfinite(data.signals).all()
    config = synth.SynthConfig.from_dict(data.attrs["config"]["synth"])
    for i in (0, 5):
        trial = synth.simulate(
            str(data.shape[i]),
            str(data.material[i]),
            force_n=float(data.force_n[i]),
            speed_mm_s=float(data.speed_mm_s[i]),
            seed=int(data.seed[i]),
            config=config,
        )
        np.testing.assert_array_equal(trial.signals, data.signals[i])
    # different seeds of one class really differ (the seed reaches the simulator)
    assert not np.array_equal(data.signals[0], data.signals[1])


def test_trials_of_other_forces_batch_together_bit_for_bit():
    """A batch mixing forces (paths of different lengths) gives each trial the bits it has
    simulated alone."""
    specs = [
        synth.TrialSpec("circle", "resin", force_n=0.6, speed_mm_s=10.0, seed=3),
        synth.TrialSpec("circle", "resin", force_n=1.4, speed_mm_s=10.0, seed=3),
    ]
    together = synth.simulate_batch(specs, threads=1)
    for spec, trial in zip(specs, together, strict=True):
        alone = synth.simulate_batch([spec], threads=1)[0]
        np.testing.assert_array_equal(trial.signals, alone.signals)


def test_same_bytes_for_process_pool_and_other_chunking(reference, tmp_path):
    pool = synth.generate(tiny(), tmp_path / "pool", workers=2, progress=False)
    assert chunk_bytes(pool) == chunk_bytes(reference)
    wide = synth.generate(tiny(chunk_trials=3), tmp_path / "wide", workers=1, progress=False)
    np.testing.assert_array_equal(load_dataset(wide).signals, load_dataset(reference).signals)


def test_dask_local_cluster_matches_single_process(reference, tmp_path):
    from dask.distributed import Client, LocalCluster

    with (
        LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None) as cluster,
        Client(cluster) as client,
    ):
        out = synth.generate(
            tiny(), tmp_path / "dask", executor=client.get_executor(), workers=2, progress=False
        )
    assert chunk_bytes(out) == chunk_bytes(reference)
    np.testing.assert_array_equal(load_dataset(out).seed, load_dataset(reference).seed)


def test_cli_from_config_reproduces_bit_for_bit(reference, tmp_path, capsys):
    out = tmp_path / "again"
    assert cli(["generate", "--from-config", str(reference), "--out", str(out)]) == 0
    assert "20 trials (2 classes x 2 conditions x 5 trials)" in capsys.readouterr().out
    assert chunk_bytes(out) == chunk_bytes(reference)
    assert cli(["generate", "--from-config", str(reference), "--out", str(out)]) == 2
    assert "--resume" in capsys.readouterr().err
    assert cli(["inspect", str(out)]) == 0
    text = capsys.readouterr().out
    assert "complete   yes: 10/10 chunks, 20/20 trials" in text


#: Trials per class of the interrupted runs: 30 chunks of 2 trials, so that an interruption
#: sent once the first chunk is done lands mid-run even when the test's polling process
#: waits behind a busy machine's other jobs.
LONG_TRIALS = 15


@pytest.fixture(scope="module")
def long_reference(tmp_path_factory) -> Path:
    """The interrupted runs' grid generated in this process, uninterrupted."""
    out = tmp_path_factory.mktemp("long") / "ds"
    synth.generate(tiny(trials_per_class=LONG_TRIALS), out, workers=1, progress=False)
    return out


def _start(out: Path) -> subprocess.Popen:
    cmd = [
        sys.executable, "-m", "benchmark.cli", "generate", "--out", str(out),
        "--shapes", "square", "triangle", "--materials", "wood",
        "--trials-per-class", str(LONG_TRIALS), "--force", "1.0", "1.4",
        "--chunk-trials", "2", "--workers", "1",
    ]  # fmt: skip
    # A job started in the background of a non-interactive shell (e.g. a CI script's
    # `cmd &`) inherits SIGINT as ignored; Ctrl-C must reach the generator as it does
    # from a terminal.
    return subprocess.Popen(
        cmd,
        cwd=ROOT,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )


def _wait_for_done_chunks(out: Path, proc: subprocess.Popen, at_least: int) -> None:
    """Wait until ``at_least`` done flags are in place. zarr writes each chunk file as a
    ``<name>.<uuid>.partial`` file beside it and renames it into place, so only the
    chunks' own names (their indices) count."""
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        done_dir = out / "done" / "c"
        if done_dir.is_dir() and sum(f.name.isdigit() for f in done_dir.iterdir()) >= at_least:
            return
        assert proc.poll() is None, "the generation finished before it could be interrupted"
        time.sleep(0.02)
    raise AssertionError("no chunk finished within 120 s")


@pytest.mark.parametrize(
    "sig", [signal.SIGKILL, signal.SIGINT, signal.SIGTERM], ids=["SIGKILL", "SIGINT", "SIGTERM"]
)
def test_cli_interrupted_then_resumed(long_reference, tmp_path, sig):
    out = tmp_path / "ds"
    proc = _start(out)
    try:
        _wait_for_done_chunks(out, proc, at_least=1)
        os.kill(proc.pid, sig)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:  # never leave a generator running behind a failed test
            proc.kill()
            proc.communicate()
    done = np.asarray(zarr.open_group(out, mode="r")["done"][:])
    assert 1 <= done.sum() < done.size, "the interruption must land mid-run"
    if sig != signal.SIGKILL:  # Ctrl-C, and `kill` as Ctrl-C: a message, the lock let go
        assert proc.returncode == 130, err
        last = err.strip().splitlines()[-1]
        assert last.startswith("tactile-synth generate: interrupted; ") and "--resume" in last
        assert not (tmp_path / ".ds.tactile-synth-lock").exists()
    with pytest.raises(ValueError, match="incomplete"):
        load_dataset(out)
    assert cli(["generate", "--resume", "--out", str(out)]) == 0
    assert chunk_bytes(out) == chunk_bytes(long_reference)
    np.testing.assert_array_equal(load_dataset(out).signals, load_dataset(long_reference).signals)


def test_repair_resimulates_a_damaged_chunk_to_the_original_bytes(reference, tmp_path, capsys):
    out = tmp_path / "ds"
    shutil.copytree(reference, out)
    damaged = out / "signals" / "c" / "3" / "0" / "0"
    raw = bytearray(damaged.read_bytes())
    raw[len(raw) // 2] ^= 0x01  # one flipped bit
    damaged.write_bytes(bytes(raw))
    with pytest.raises(ValueError, match=r"chunk 3 \(trials 6-7, file .*signals/c/3/0/0\)"):
        load_dataset(out)
    assert cli(["generate", "--resume", "--out", str(out)]) == 2
    assert "--resume --repair" in capsys.readouterr().err
    assert cli(["generate", "--resume", "--repair", "--out", str(out)]) == 0
    assert chunk_bytes(out) == chunk_bytes(reference)  # the real simulator, bit for bit
    np.testing.assert_array_equal(load_dataset(out).signals, load_dataset(reference).signals)


def test_an_out_holding_other_files_is_refused_without_suggesting_resume(tmp_path, capsys):
    folder = tmp_path / "papers"
    folder.mkdir()
    (folder / "thesis.tex").write_text("precious")
    assert cli(["generate", "--preset", "quick", "--out", str(folder)]) == 2
    err = capsys.readouterr().err
    assert f"--out {folder} exists and is not a tactile-synth dataset" in err
    assert "choose another --out" in err and "--resume" not in err and "pass --overwrite" not in err
    assert [p.name for p in folder.iterdir()] == ["thesis.tex"]


def test_every_built_in_slides_on_the_plate_up_to_the_top_of_the_speed_range(monkeypatch):
    """The speed range's top (22 mm/s) is one every built-in's slide fits with every
    trial's scatter at its 3-sigma clip (the fastest, longest slide), at both ends of
    the force range; at 24 mm/s none fits, which is why the range stops short of it."""
    from shapes import SHAPE_NAMES
    from synth import planning
    from synth.presets import FORCE_RANGE_N, SPEED_RANGE_MM_S
    from synth.trial import TrialSpec

    monkeypatch.setattr(planning, "_scatter", lambda rng, rel, size=None: 1.0 + 3.0 * rel)
    config = synth.SynthConfig()
    for shape in SHAPE_NAMES:
        for force in FORCE_RANGE_N:
            planning.plan(
                TrialSpec(shape, "wood", force_n=force, speed_mm_s=SPEED_RANGE_MM_S[1]), config
            )
        with pytest.raises(ValueError, match=r"speed_mm_s=24\.0 makes the finger travel"):
            planning.plan(TrialSpec(shape, "wood", speed_mm_s=24.0), config)
