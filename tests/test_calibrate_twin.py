"""``tactile-synth calibrate``: the parameter registry, finger files, the summaries, the
inference on a stand-in simulator whose answer is known, resume, the Dask path's
identical results, and the command's one-line refusals."""

from __future__ import annotations

import json

import numpy as np
import pytest

import synth
from benchmark.cli import main as cli_main
from benchmark.twin import calibrate as cal
from benchmark.twin import cli as twin_cli
from benchmark.twin.summaries import summarize, summary_names
from benchmark.twin.world import world_of
from synth.calibration.finger_file import apply_finger, load_finger, write_finger
from synth.calibration.parameters import PARAMETERS, parameter, parse_parameters
from synth.calibration.settings import SWEEP, CalibrationError
from synth.presets import preset

T = np.arange(2000) / 1000.0


def stand_in(specs, synth_dict, threads) -> np.ndarray:
    """A stand-in simulator whose signals follow two of the configuration's parameters:
    the mains pickup (a 50 Hz line on every channel) and the gauges' amplifier gain (their
    level); the rest is class-dependent shape and noise seeded per trial."""
    config = synth.SynthConfig.from_dict(dict(synth_dict))
    mains = config.acquisition.mains_v
    gain = config.strain_gauge.amplifier_gain / 2000.0
    rows = []
    for s in specs:
        rng = np.random.default_rng(s.seed)
        x = 0.005 * rng.standard_normal((4, T.size))
        x += 0.2 * np.sin(2 * np.pi * (3 + len(s.shape)) * T)[None]
        x[2:] += gain * (0.5 + 0.05 * len(s.shape) + 0.05 * rng.standard_normal((2, 1)))
        pickup = mains * np.exp(0.1 * rng.standard_normal((4, 1)))  # a stroke's own pickup
        x += pickup * np.sin(2 * np.pi * 50 * T + rng.uniform(0, 6.28, (4, 1)))
        rows.append(x.astype(np.float32))
    return np.stack(rows)


def _recordings(tmp_path, mains_v=2e-3, gain=3000.0, trials=4):
    config = synth.SynthConfig()
    config = synth.SynthConfig.from_dict(
        {
            **config.to_dict(),
            "acquisition": {**config.to_dict()["acquisition"], "mains_v": mains_v},
            "strain_gauge": {**config.to_dict()["strain_gauge"], "amplifier_gain": gain},
        }
    )
    grid = preset("paper").replace(
        shapes=("circle", "square"), trials_per_class=trials, synth=config.to_dict(), seed=3
    )
    path = tmp_path / "rec"
    synth.generate(grid, path, progress=False, simulator=stand_in)
    return path


@pytest.fixture
def fake_physics(monkeypatch):
    import synth.generation

    monkeypatch.setattr(synth.generation, "mujoco_simulator", stand_in)


# -- the registry --------------------------------------------------------------------------
def test_every_swept_parameter_is_calibratable_over_its_cited_candidates():
    for section, field, values, _ in SWEEP:
        p = PARAMETERS[f"{section}.{field}"]
        assert (p.low, p.high) == (min(values), max(values))
    p = parameter("pvdf.feedback_resistance_ohm")
    assert p.log and p.to_unit(p.from_unit(0.3)) == pytest.approx(0.3)
    assert not parameter("strain_gauge.amplifier_gain").log


@pytest.mark.parametrize(
    ("items", "message"),
    [
        (["finger.skin_modulus"], "unknown parameter 'finger.skin_modulus' (did you mean"),
        (["finger.skin_modulus_pa=1:2"], "outside its cited range"),
        (["finger.skin_modulus_pa=3e5"], "bounds must be LOW:HIGH"),
        (["finger.skin_modulus_pa=4e5:2e5"], "LOW < HIGH"),
        (["acquisition.mains_v", "acquisition.mains_v"], "names acquisition.mains_v twice"),
    ],
)
def test_bad_parameters_are_refused_naming_the_option(items, message):
    with pytest.raises(CalibrationError, match="--parameters") as info:
        parse_parameters(items)
    assert message in str(info.value)


# -- finger files ---------------------------------------------------------------------------
def test_a_finger_file_round_trips_and_sets_a_grid_and_an_experiment(tmp_path):
    from synth.dataset_cli import with_finger
    from synth.experiment import load_experiment

    path = write_finger(
        tmp_path / "finger.toml",
        {"pvdf.post_gain": 1.5, "materials.texture_scale": 0.5, "acquisition.mains_v": 2e-3},
    )
    assert load_finger(path)[("pvdf", "post_gain")] == 1.5
    config = apply_finger(synth.SynthConfig(), path)
    assert config.pvdf.post_gain == 1.5
    base = synth.SynthConfig().materials["wood"].texture.roughness_rms_m
    assert config.materials["wood"].texture.roughness_rms_m == pytest.approx(0.5 * base)
    grid = with_finger(preset("quick"), str(path))
    assert grid.synth["acquisition"]["mains_v"] == 2e-3
    (tmp_path / "lab.toml").write_text(
        'trials_per_class = 2\nmaterials = ["wood"]\nfinger = "finger.toml"\n'
        "[conditions]\nforce_n = [1.0]\nspeed_mm_s = [10.0]\n"
        '[[specimen]]\nname = "circle"\n'
    )
    assert load_experiment(tmp_path / "lab.toml").synth["pvdf"]["post_gain"] == 1.5


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[pvdf]\nno_such = 1\n", "--finger"),
        ("[pvdf]\npost_gain = 'x'\n", "must be a number"),
        ("post_gain = 1\n", "must be a table"),
        ("", "sets nothing"),
    ],
)
def test_a_bad_finger_file_is_refused_in_one_line(tmp_path, text, message):
    path = tmp_path / "finger.toml"
    path.write_text(text)
    with pytest.raises(CalibrationError, match=message) as info:
        apply_finger(synth.SynthConfig(), path)
    assert "\n" not in str(info.value) and str(path) in str(info.value)


# -- summaries ------------------------------------------------------------------------------
def test_summaries_read_the_mains_line_and_the_level_scatter():
    rng = np.random.default_rng(0)
    n = 12
    material = np.array(["wood", "resin"] * (n // 2))
    label = np.repeat(np.arange(n // 3), 3)
    base = 0.01 * rng.standard_normal((n, 4, 2000))
    names = summary_names(("wood", "resin"))
    quiet = summarize(base, material, label, ("wood", "resin"))
    line = base + 0.01 * np.sin(2 * np.pi * 50 * T)
    loud = summarize(line, material, label, ("wood", "resin"))
    k = names.index("pvdf1.mains")
    assert loud[k] > quiet[k] + 3
    spread = base.copy()
    spread[:, 2] += 1.0 + 0.2 * rng.standard_normal((n, 1))
    steady = base.copy()
    steady[:, 2] += 1.0 + 0.02 * rng.standard_normal((n, 1))
    k = names.index("sg1.level_scatter")
    assert summarize(spread, material, label, ("wood", "resin"))[k] > (
        summarize(steady, material, label, ("wood", "resin"))[k] + 1.5
    )
    assert len(quiet) == len(names)


# -- the inference, on the stand-in --------------------------------------------------------
def test_calibrate_recovers_hidden_parameters_of_the_stand_in_and_writes_its_outputs(
    tmp_path, fake_physics
):
    rec = _recordings(tmp_path, mains_v=2e-3, gain=3000.0)
    params = parse_parameters(["acquisition.mains_v", "strain_gauge.amplifier_gain"])
    out = tmp_path / "twin"
    result = cal.calibrate(rec, out, parameters=params, budget=200, progress=False, report=False)
    found = {e.name: e for e in result.estimates}
    mains, gain = found["acquisition.mains_v"], found["strain_gauge.amplifier_gain"]
    # within a tenth of the range (log scale for the mains), neither posterior flat
    # (over ten seeds of the calibration the errors stay under 0.07)
    for e, truth in ((mains, 2e-3), (gain, 3000.0)):
        p = parameter(e.name)
        assert abs(p.to_unit(e.median) - p.to_unit(truth)) < 0.1
        assert not e.flat
    fitted = load_finger(out / "finger.toml")
    assert fitted[("strain_gauge", "amplifier_gain")] == pytest.approx(gain.median)
    report = (out / "report.md").read_text()
    assert "`acquisition.mains_v`" in report and "pinned down" in report
    record = json.loads((out / "calibration.json").read_text())
    assert record["n_simulations"] == 200


def test_a_parameter_the_summaries_do_not_see_is_reported_flat(tmp_path, fake_physics):
    rec = _recordings(tmp_path, gain=2000.0)  # the default gain: the twin's, as it is not fitted
    params = parse_parameters(["acquisition.mains_v", "variability.yaw_rad"])
    result = cal.calibrate(rec, tmp_path / "twin", parameters=params, budget=200, progress=False)
    found = {e.name: e for e in result.estimates}

    def width(e):
        p = parameter(e.name)
        return p.to_unit(e.high) - p.to_unit(e.low)

    # over ten seeds the unseen parameter's 90 % interval covers 0.62-0.83 of its range,
    # the mains' at most half
    assert width(found["variability.yaw_rad"]) > 0.5 > width(found["acquisition.mains_v"])
    assert "`variability.yaw_rad`" in (tmp_path / "twin" / "report.md").read_text()


def test_the_report_names_the_flat_parameters():
    from benchmark.twin.report import markdown

    flat = cal.Estimate("variability.yaw_rad", 0.01, 0.001, 0.019, 0.0, 0.02, flat=True)
    sharp = cal.Estimate("acquisition.mains_v", 2e-3, 1.8e-3, 2.2e-3, 3e-4, 3e-3, flat=False)
    result = cal.Calibration(None, [], [flat, sharp], np.zeros((1, 2)), 10, 1, None, None)
    result.world = type("W", (), {"classes": ("a/b",), "conditions": ((0, 1.0, 10.0),)})()
    text = markdown(result, "rec", 2, None)
    assert "do not pin down `variability.yaw_rad`:" in text
    assert "| `acquisition.mains_v` | 0.002 | 0.0018 .. 0.0022 | 0.0003 .. 0.003 | yes |" in text


def test_an_interrupted_calibration_resumes_without_repeating_a_simulation(
    tmp_path, fake_physics, monkeypatch
):
    rec = _recordings(tmp_path)
    params = parse_parameters(["acquisition.mains_v"])
    out = tmp_path / "twin"
    calls = []
    real = cal.simulate

    def counted(*a, **k):
        calls.append(k["index"])
        if len(calls) == 25:
            raise KeyboardInterrupt
        return real(*a, **k)

    monkeypatch.setattr(cal, "simulate", counted)
    with pytest.raises(KeyboardInterrupt):
        cal.calibrate(rec, out, parameters=params, budget=40, progress=False, report=False)
    assert cal.Simulations.load(out / cal.SIMULATIONS_FILE).done.sum() == 24
    with pytest.raises(CalibrationError, match=r"--out .* exists and is not empty"):
        cal.calibrate(rec, out, parameters=params, budget=40, progress=False)
    calls.clear()
    resumed = cal.calibrate(
        rec, out, parameters=params, budget=40, progress=False, report=False, resume=True
    )
    assert sorted(calls) == list(range(24, 40))
    monkeypatch.setattr(cal, "simulate", real)
    whole = cal.calibrate(
        rec, tmp_path / "whole", parameters=params, budget=40, progress=False, report=False
    )
    assert np.array_equal(resumed.samples, whole.samples)  # the same as an uninterrupted run
    other = parse_parameters(["strain_gauge.amplifier_gain"])
    with pytest.raises(CalibrationError, match=r"--resume: .* other settings \(parameters"):
        cal.calibrate(rec, out, parameters=other, budget=40, progress=False, resume=True)


def test_world_refuses_a_store_without_forces_and_unknown_materials():
    from tests.synthetic_data import make_dataset

    data = make_dataset()
    bad = type(data)(**{**data.__dict__, "force_n": np.full(len(data), np.nan)})
    with pytest.raises(CalibrationError, match="--recordings: every trial needs its normal force"):
        world_of(bad)


def test_the_command_refuses_bad_input_in_one_line(tmp_path, capsys):
    for argv, message in (
        (["--recordings", "x", "--out", "y", "--budget", "0"], "--budget must be at least 1"),
        (["--recordings", str(tmp_path / "none"), "--out", "y"], "does not exist"),
        (["--out", "y"], "--recordings is required"),
        (["--recordings", "x", "--out", "y", "--parameters", "foo"], "unknown parameter 'foo'"),
    ):
        assert cli_main(["calibrate", *argv]) == 2
        err = capsys.readouterr().err
        assert err.startswith("tactile-synth calibrate: error: ") and message in err
        assert err.count("\n") == 1
    assert cli_main(["calibrate", "--list-parameters"]) == 0
    assert "finger.skin_modulus_pa  100000..580000" in capsys.readouterr().out
    with pytest.raises(SystemExit, match="--closed-set and --keep go with --whatif"):
        twin_cli.main(["--sweep", "--keep", str(tmp_path / "k")])


# -- real physics ---------------------------------------------------------------------------
@pytest.mark.slow
def test_simulations_on_a_dask_cluster_equal_those_in_this_process(tmp_path):
    from dask.distributed import Client, LocalCluster

    grid = preset("paper").replace(shapes=("circle",), materials=("wood", "resin"))
    base = synth.SynthConfig().to_dict()
    base["specimens"] = {}
    from benchmark.twin.world import World

    world = World(tuple(grid.classes), ((0, 1.0, 10.0), (1, 1.0, 10.0)), base)
    params = parse_parameters(["acquisition.mains_v", "materials.texture_scale"])

    def fresh():
        n = len(cal.summary_size(world))
        return cal.Simulations(
            cal.draws(3, 2, 0), np.full((3, n), np.nan), np.zeros(3, bool), np.zeros(3, bool)
        )

    here = cal.run_simulations(world, params, fresh(), trials_per_class=2, seed=0, progress=False)
    with (
        LocalCluster(n_workers=2, threads_per_worker=1, processes=True) as cluster,
        Client(cluster) as client,
    ):
        there = cal.run_simulations(
            world,
            params,
            fresh(),
            trials_per_class=2,
            seed=0,
            progress=False,
            executor=client.get_executor(),
        )
    assert here.done.all() and np.isfinite(here.x).any()
    assert np.array_equal(here.x, there.x, equal_nan=True)
