"""``tactile-synth plot-trial`` and ``view``."""

from __future__ import annotations

from benchmark.cli import main


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
    assert "speed_mm_s" in capsys.readouterr().err
    bad_suffix = ["plot-trial", "--shape", "moon", "--material", "wood", "--out", out + ".jpg"]
    assert main(bad_suffix) == 2
    capsys.readouterr()
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
