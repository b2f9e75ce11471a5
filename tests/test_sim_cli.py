"""``tactile-synth plot-trial`` and ``view``."""

from __future__ import annotations

import mujoco
import pytest

import synth
from benchmark.cli import main
from synth.generation import simulate_trials


def test_plot_trial_writes_a_png(tmp_path, capsys):
    out = tmp_path / "trial.png"
    assert main(["plot-trial", "--shape", "moon", "--material", "wood", "--out", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "normal force" in capsys.readouterr().out


def test_plot_trial_rejects_bad_arguments(tmp_path, capsys):
    out = str(tmp_path / "x.png")
    assert main(["plot-trial", "--shape", "mooon", "--material", "wood", "--out", out]) == 2
    assert "did you mean 'moon'" in capsys.readouterr().err
    args = ["plot-trial", "--shape", "moon", "--material", "wood", "--speed", "0", "--out", out]
    assert main(args) == 2
    assert "--speed must be > 0" in capsys.readouterr().err
    bad_suffix = ["plot-trial", "--shape", "moon", "--material", "wood", "--out", out + ".jpg"]
    assert main(bad_suffix) == 2
    assert f"--out {out}.jpg must end in .png" in capsys.readouterr().err
    store = tmp_path / "data"
    store.mkdir()
    (store / "zarr.json").write_text("{}")  # any dataset store's root
    inside = ["plot-trial", "--shape", "moon", "--material", "wood", "--out", store / "t.png"]
    assert main([str(a) for a in inside]) == 2
    assert f"--out {store / 't.png'} lies inside the dataset {store}" in capsys.readouterr().err
    assert not (store / "t.png").exists()


def test_view_explains_when_there_is_no_display(monkeypatch, capsys):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    assert main(["view", "--shape", "moon", "--material", "wood"]) == 2
    err = capsys.readouterr().err
    assert "no display" in err and "plot-trial" in err


@pytest.mark.parametrize(
    "option, value, expect",
    [
        ("--force", "1000", "--force must lie in 0.4..3 N"),
        ("--force", "0.01", "--force must lie in 0.4..3 N"),
        ("--speed", "23", "--speed must lie in 0.1..22 mm/s"),
        ("--seed", "-1", "--seed must be >= 0"),
    ],
)
def test_plot_trial_checks_the_bounds_of_generate_before_simulating(
    tmp_path, capfd, monkeypatch, option, value, expect
):
    monkeypatch.chdir(tmp_path)
    args = ["plot-trial", "--shape", "moon", "--material", "wood", option, value]
    assert main([*args, "--out", "a.png"]) == 2
    err = capfd.readouterr().err.strip()
    assert expect in err and len(err.splitlines()) == 1
    assert list(tmp_path.iterdir()) == []  # no plot, no MUJOCO_LOG.TXT


def test_unstable_physics_is_named_without_mujoco_log_or_warning_text(tmp_path, capfd, monkeypatch):
    monkeypatch.chdir(tmp_path)
    mujoco.set_mju_user_warning(None)  # MuJoCo's default handler, whatever ran before
    spec = synth.TrialSpec("moon", "wood", force_n=1000.0, speed_mm_s=10.0, seed=0)
    with pytest.raises(synth.SimulationError, match=r"shape='moon'.*force_n=1000"):
        simulate_trials([spec], synth.SynthConfig(), threads=1)
    assert "WARNING" not in capfd.readouterr().err
    assert list(tmp_path.iterdir()) == []
