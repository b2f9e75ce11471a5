"""The stress suite's test sets: trial seeds shared across a family's severities, and
each physical family's configuration at severity 0 the nominal one."""

from __future__ import annotations

import numpy as np
import pytest

from benchmark.stress import families
from synth.presets import PRESETS, GenerationConfig, plan


def test_without_seed_by_condition_every_condition_repeats_the_same_strokes():
    base = PRESETS["quick"].replace(seed_by_condition=False)
    nominal = plan(PRESETS["quick"])
    for forces, speeds in (((2.0,), (10.0,)), ((1.0,), (20.0,)), ((0.6,), (6.0,))):
        other = plan(base.replace(forces_n=forces, speeds_mm_s=speeds))
        np.testing.assert_array_equal(other.seed, nominal.seed)
    # the default keeps the condition in the seed, and the stored layout of earlier stores
    assert not np.array_equal(plan(PRESETS["quick"].replace(forces_n=(2.0,))).seed, nominal.seed)
    assert "seed_by_condition" not in PRESETS["paper"].to_dict()
    assert GenerationConfig.from_dict(base.to_dict()) == base


def test_every_physical_family_is_the_nominal_configuration_at_severity_0():
    base = PRESETS["quick"].replace(seed_by_condition=False)
    for name in families.FAMILY_NAMES:
        fam = families.get(name)
        if fam.kind == "physical":
            assert fam.configure(base, fam.value(0)) == base


# -- each physical family's top severity, measured in the simulated physics ----------------
def _simulate(name: str, value: float, shape: str = "square", seed: int = 3):
    import synth
    from synth import SynthConfig

    fam = families.get(name)
    config = fam.configure(PRESETS["quick"].replace(seed_by_condition=False), value)
    sc = SynthConfig() if config.synth is None else SynthConfig.from_dict(config.synth)
    force, speed = config.conditions[0]
    return synth.simulate(shape, "wood", force_n=force, speed_mm_s=speed, seed=seed, config=sc)


def _top_span_mm(trial) -> float:
    """How far (mm) the pad slides while on top of the raised outline."""
    z, x = trial.truth["finger_z_m"], trial.truth["finger_x_m"]
    top = z > z.max() - 0.3e-3
    return float(x[top].max() - x[top].min()) * 1e3


@pytest.mark.slow
@pytest.mark.parametrize("seed", [3, 4])
def test_physical_families_change_the_simulated_physics_as_they_say(seed):
    import math

    nominal = {n: _simulate(n, families.get(n).nominal, seed=seed) for n in ("yaw", "force")}
    # yaw: the path crosses the specimen at the family's angle
    turned = _simulate("yaw", 30.0, seed=seed)
    slope = np.polyfit(turned.truth["finger_x_m"], turned.truth["finger_y_m"], 1)[0]
    assert math.degrees(math.atan(slope)) == pytest.approx(30.0, abs=0.5)
    # offset: towards the apex's other side, the triangle's chord along the path grows by
    # its side over its height, 16 / 13.86 mm per mm
    a = _simulate("offset", 0.0, "triangle", seed=seed)
    b = _simulate("offset", 4.0, "triangle", seed=seed)
    shift = np.mean(b.truth["finger_y_m"]) - np.mean(a.truth["finger_y_m"])
    assert shift == pytest.approx(-4e-3, abs=0.05e-3)
    assert _top_span_mm(b) - _top_span_mm(a) == pytest.approx(4 * 16 / 13.86, rel=0.1)
    # skin: Hertz's indentation falls as the modulus to the power -2/3
    stiff = _simulate("skin", 4.0, seed=seed)
    ratio = np.median(stiff.truth["indentation_m"]) / np.median(
        nominal["yaw"].truth["indentation_m"]
    )
    assert ratio == pytest.approx(4 ** (-2 / 3), rel=0.1)
    # friction: the sliding coefficient scales by the factor

    def mu(trial):
        t = trial.truth
        return np.median(np.abs(t["friction_force_x_n"]) / t["normal_force_n"])

    assert mu(_simulate("friction", 0.3, seed=seed)) / mu(nominal["yaw"]) == pytest.approx(
        0.3, rel=0.05
    )
    # force and speed: the robot's load and pace scale by the factor
    heavy = _simulate("force", 2.0, seed=seed)
    load = np.mean(heavy.truth["normal_force_n"]) / np.mean(
        nominal["force"].truth["normal_force_n"]
    )
    assert load == pytest.approx(2.0, rel=0.05)

    def pace(trial):
        return np.polyfit(trial.truth["time_s"], trial.truth["finger_x_m"], 1)[0]

    assert pace(_simulate("speed", 2.0, seed=seed)) / pace(nominal["yaw"]) == pytest.approx(
        2.0, rel=0.05
    )
    # pitch: the front gauge reads the loads turned by the pitch (its mean moves about as
    # sin(pitch)), and the films, turned with the pad, record something else
    tilted = {p: _simulate("pitch", p, seed=seed) for p in (5.0, 10.0)}
    shifts = {
        p: np.mean(t.signals[2]) - np.mean(nominal["yaw"].signals[2]) for p, t in tilted.items()
    }
    assert np.sign(shifts[5.0]) == np.sign(shifts[10.0]) and abs(shifts[5.0]) > 5e-3
    assert 1.6 < shifts[10.0] / shifts[5.0] < 2.2
    assert np.abs(tilted[10.0].signals[:2] - nominal["yaw"].signals[:2]).max() > 0.05


@pytest.mark.slow
def test_test_sets_simulated_on_a_dask_cluster_are_the_local_bits(tmp_path):
    """``--scheduler``: the stress suite's test sets simulated on a Dask cluster's workers
    hold the same bits as those simulated in this process."""
    from dask.distributed import Client, LocalCluster

    from benchmark.stress.families import get
    from benchmark.stress.suite import clean_set_config, prepare_test_sets
    from synth import load_dataset
    from synth.presets import PRESETS

    nominal = PRESETS["quick"].replace(shapes=("circle", "moon"), materials=("wood",))
    base = clean_set_config(nominal, trials_per_class=2, seed=0)
    yaw = [get("yaw")]
    local = prepare_test_sets(base, yaw, [5], tmp_path / "local", progress=False, workers=None)
    with (
        LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None) as cluster,
        Client(cluster) as client,
    ):
        remote = prepare_test_sets(
            base,
            yaw,
            [5],
            tmp_path / "dask",
            progress=False,
            workers=2,
            executor=client.get_executor(),
        )
    assert sorted(local) == sorted(remote) == ["clean", "yaw/5"]
    for key in local:
        a, b = load_dataset(local[key]), load_dataset(remote[key])
        assert a.signals.tobytes() == b.signals.tobytes(), key
