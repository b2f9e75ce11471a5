"""Physics checks of the simulator: the scenes, the contact and its friction, the force
loop, determinism and the failures it reports; each asserts a measurable physical
property."""

from __future__ import annotations

import time

import mujoco
import numpy as np
import pytest

import synth
from shapes import SHAPE_NAMES
from synth import contact, sensors, skin_fit
from synth import scene as scene_mod
from synth import simulator as sim
from synth.config import Motion, SynthConfig
from synth.materials import FrictionLaw, Material, Periodic, Texture
from synth.simulator import SimulationError, simulate_batch
from synth.trial import TrialSpec
from tests.physics_support import (
    COMPLIANT,
    FLAT,
    NOMINAL,
    SG,
    STEADY,
    flat_trial,
    roll_plans,
    with_material,
    with_motion,
)


@pytest.mark.parametrize("shape", SHAPE_NAMES)
def test_every_scene_compiles_and_steps_without_warnings(shape):
    """All 12 scenes compile; the finger rests under load for 0.1 s with no warning."""
    config = SynthConfig()
    plan = sim.plan(TrialSpec(shape, "wood", seed=1), config)
    data = mujoco.MjData(plan.model)
    data.qpos[:] = plan.initial_qpos
    data.ctrl[:] = (plan.loop.x_ref[0], plan.loop.y_ref[0], plan.loop.z_ref0)
    for _ in range(200):
        mujoco.mj_step(plan.model, data)
    assert [w.number for w in data.warning] == [0] * len(data.warning), shape
    assert np.all(np.isfinite(data.qpos))


def test_all_36_classes_simulate_cleanly():
    specs = [TrialSpec(s, m, seed=7) for s in SHAPE_NAMES for m in synth.MATERIAL_NAMES]
    trials = simulate_batch(specs, threads=2)
    for spec, trial in zip(specs, trials, strict=True):
        assert trial.spec == spec
        assert trial.signals.shape == (4, 2000) and trial.signals.dtype == np.float32
        assert np.all(np.isfinite(trial.signals))
        assert np.all(trial.truth["contacts"] >= 0)
        assert abs(np.median(trial.truth["normal_force_n"]) - 1.0) < 0.1


@pytest.mark.parametrize("speed", [6.0, 10.0, 14.0])
def test_slides_start_clear_of_the_outline_without_a_force_spike(speed):
    """Every shape at every preset speed: the skin starts outside the raised outline (no
    penetration of any of its pieces) and the normal force stays below 1.3 times the
    command until the skin first reaches the outline."""
    config = SynthConfig()
    plans = [sim.plan(TrialSpec(s, "resin", speed_mm_s=speed, seed=3), config) for s in SHAPE_NAMES]
    for plan in plans:
        model = plan.model
        data = mujoco.MjData(model)
        data.qpos[:] = plan.initial_qpos
        mujoco.mj_forward(model, data)
        sc = scene_mod.scene(plan.spec.shape, config)
        pieces = sc.specimen_geoms[1:]
        gap = min(
            mujoco.mj_geomDistance(model, data, sc.skin_geom, int(g), 0.01, None) for g in pieces
        )
        assert gap >= 0.0, (plan.spec.shape, gap)
    cols = scene_mod.sensor_columns()
    for plan in plans:
        sens, _ = roll_plans([plan], config)
        normal = -sens[0, : plan.touch_step, cols["contact"].start + 3]
        assert normal.max() < 1.3 * plan.loop.force_n, (plan.spec.shape, normal.max())


def test_the_window_is_centred_on_the_contact_phase_at_every_speed():
    """Slower runs see less of the shape around its middle: the window, cut where the
    recorded films ring at the two edges, is centred on the skin's contact with the
    outline whatever the speed. The films ring from the moment the skin loads the entry
    edge to the moment the lagging pad leaves the exit edge, so the cut's middle lies a
    little past the outline's centre (0.5-1.0 mm of path from 6 to 14 mm/s)."""
    config = NOMINAL
    for speed in (6.0, 10.0, 14.0):
        trial = synth.simulate("square", "resin", speed_mm_s=speed, config=config)
        x = trial.truth["commanded_x_m"]  # the square's contact phase is centred on x = 0
        assert 0.0 < x[1000] < 1.5e-3, (speed, x[1000])
        assert x[-1] - x[0] == pytest.approx(2.0 * speed * 1e-3, rel=0.01)


def test_skin_indentation_follows_hertz():
    """One contact model for every material: the skin's penetration under load is the
    Hertz indentation of a ``skin_modulus_pa`` sphere of the pad's radius (within 10 %)."""
    finger = NOMINAL.finger
    forces = np.array([0.5, 1.0, 1.5])
    got = skin_fit.measure_indentation(NOMINAL, forces)
    want = contact.hertz_indentation_m(
        forces, finger.pad_radius_m, finger.skin_modulus_pa, finger.skin_poisson
    )
    np.testing.assert_allclose(got, want, rtol=0.10)
    assert 0.3e-3 < want[1] < 2e-3  # a fingertip-like fraction of a millimetre to 2 mm


def test_the_skin_defaults_are_what_the_calibration_fits():
    """``Finger``'s skin contact parameters are the fit's output on the default scene
    (``scripts/calibrate.py skin``), so the calibration is reproduced by its script."""
    solref, solimp = skin_fit.fit_skin_contact(synth.SynthConfig())
    finger = synth.SynthConfig().finger
    np.testing.assert_allclose(solref, finger.skin_solref, rtol=1e-3)
    np.testing.assert_allclose(solimp, finger.skin_solimp, rtol=1e-3)


def test_strain_gauge_level_scales_with_normal_force():
    """Flat-plate sliding: 2 N gives about twice the strain-gauge level of 1 N; the
    friction coefficient falls with load (exponent -0.21), so the friction-driven bending
    grows by 2^0.79 rather than 2."""
    zero = sensors.bridge_zero_v(FLAT.strain_gauge)
    one, two = (flat_trial(force_n=f).signals[SG].mean(axis=1) - zero for f in (1.0, 2.0))
    assert np.all(np.abs(one) > 0.02), one  # well above the noise
    ratio = two / one
    assert np.all((ratio > 1.5) & (ratio < 2.1)), ratio


def test_friction_ratio_follows_each_materials_law():
    """Steady flat sliding: tangential / normal = the material's kinetic coefficient at the
    measured load; materials ordered by it."""
    ratios = {}
    for material in synth.MATERIAL_NAMES:
        truth = flat_trial(material).truth
        normal = truth["normal_force_n"][STEADY]
        ratios[material] = truth["tangential_force_n"][STEADY].mean() / normal.mean()
        law = FLAT.materials[material].friction
        want = law.kinetic * normal.mean() ** law.load_exponent
        assert ratios[material] == pytest.approx(want, rel=0.05), (material, ratios[material])
    # A law of another coefficient is followed as well (the default materials share one).
    law = FrictionLaw(kinetic=0.5, static=0.6)
    truth = flat_trial("wood", config=with_material(FLAT, "wood", friction=law)).truth
    normal = truth["normal_force_n"][STEADY]
    ratio = truth["tangential_force_n"][STEADY].mean() / normal.mean()
    assert ratio == pytest.approx(0.5 * normal.mean() ** law.load_exponent, rel=0.05)


def test_static_friction_gives_stick_slip_that_emerges_from_the_simulation():
    """A velocity-weakening law (static well above kinetic) on a compliant finger (a 4 mm
    PDMS support: the default 3 mm one is too stiff for this law to stick) sticks and
    slips: the skin's slip speed alternates between near zero and several times the
    robot's speed, while the robot moves steadily."""
    law = FrictionLaw(kinetic=0.4, static=1.6, stribeck_velocity_m_s=2e-3, load_exponent=0.0)
    config = with_material(COMPLIANT, "aluminum", friction=law)
    slip = flat_trial("aluminum", config=config).truth["slip_speed_m_s"]
    assert (slip < 2e-3).mean() > 0.2  # stuck a good part of the time
    assert slip.max() > 50e-3  # and snapping free well above the 10 mm/s drive
    steady = flat_trial("aluminum").truth["slip_speed_m_s"][STEADY]
    assert (steady < 2e-3).mean() < 0.02  # the kinetic-dominated law slides throughout


def _onset(t: np.ndarray, deviation: np.ndarray, threshold: float, after: float = -1.0) -> float:
    idx = np.flatnonzero((deviation > threshold) & (t > after))
    assert idx.size, "no transient found"
    return float(t[idx[0]])


def _time_at_x(truth: dict, x: float) -> float:
    return float(np.interp(x, truth["finger_x_m"], truth["time_s"]))


def test_edge_transients_occur_at_the_geometric_entry_and_exit():
    """Square on its centre line at 16 mm/s, so the 2 s window holds both edges.

    Entry: the skin (indented by ``pen``) first touches the raised edge when the pad centre
    is ``a = sqrt(r^2 - (r - h - pen)^2)`` ahead of it, and the contact force turns. Exit:
    the contact moves onto the far corner as the pad centre passes it (the force tilts),
    and the skin, rolling down the corner under the force loop, is back on the plate when
    the pad centre is ``a`` past the corner.
    """
    smooth = with_material(with_motion(NOMINAL, path_y_m=0.0), "resin", texture=Texture(0.0, 1e-4))
    trial = synth.simulate("square", "resin", speed_mm_s=16.0, config=smooth)
    truth = trial.truth
    r, h = smooth.finger.pad_radius_m, 0.002
    half = 0.007  # the square's half side (14 mm)
    t, x, z = truth["time_s"], truth["finger_x_m"], truth["finger_z_m"]
    total = np.hypot(truth["normal_force_n"], truth["tangential_force_n"])
    plate = x < -half - 0.0065
    pen = np.median(truth["indentation_m"][plate])
    assert 0.3e-3 < pen < 1.5e-3  # the soft skin is indented by most of a millimetre
    a = np.sqrt(r**2 - (r - h - pen) ** 2)
    level = np.median(total[plate])
    entry = _onset(t, np.abs(total - level), 0.05 * level)
    assert entry == pytest.approx(_time_at_x(truth, -half - a), abs=0.020)
    on_top = (x > -0.004) & (x < 0.004)
    top_level = np.median(total[on_top])
    crest = _time_at_x(truth, half)
    exit_t = _onset(t, np.abs(total - top_level), 0.02 * top_level, after=crest - 0.1)
    assert exit_t == pytest.approx(crest, abs=0.020)
    plate_z = np.median(z[plate])
    landed = _onset(t, -np.abs(z - plate_z), -0.05e-3, after=crest)
    assert landed == pytest.approx(_time_at_x(truth, half + a), abs=0.030)


def test_finger_drops_into_the_moon_notch():
    """Crossing the moon's notch the skin reaches the plate and the normal force
    returns to its plate level (with a single convex hull it would ride over at 2 mm)."""
    config = with_motion(NOMINAL, path_y_m=0.003)
    truth = synth.simulate("moon", "wood", config=config).truth
    x = truth["finger_x_m"]
    notch = np.abs(x) < 0.0005  # the notch's middle (it spans |x| < 6 mm at y = 0..3 mm)
    assert notch.sum() > 50
    on_top = truth["finger_z_m"] > 0.001  # skin bottom on the 2 mm top, indented ~0.8 mm
    assert on_top.sum() > 100, "the finger must first cross a horn of the moon"
    assert truth["finger_z_m"][notch].max() < 0.25e-3
    assert np.mean(truth["normal_force_n"][notch]) == pytest.approx(1.0, rel=0.05)


def test_same_seed_is_bit_identical_whatever_the_batch():
    """Determinism: same seed, same bits (alone or in a batch, any thread count)."""
    spec = TrialSpec("pentagram", "aluminum", force_n=1.2, speed_mm_s=9.0, seed=11)
    alone = synth.simulate("pentagram", "aluminum", force_n=1.2, speed_mm_s=9.0, seed=11)
    others = [TrialSpec(s, "wood", seed=3) for s in ("moon", "pentagram", "circle")]
    others.append(TrialSpec("pentagram", "aluminum", force_n=1.2, speed_mm_s=9.0, seed=4))
    batch = simulate_batch([*others, spec], threads=2)
    np.testing.assert_array_equal(alone.signals, batch[-1].signals)
    for name, values in alone.truth.items():
        np.testing.assert_array_equal(values, batch[-1].truth[name])
    other_seed = synth.simulate("pentagram", "aluminum", force_n=1.2, speed_mm_s=9.0, seed=12)
    assert not np.array_equal(alone.signals, other_seed.signals)


@pytest.mark.parametrize(
    ("kwargs", "arg"),
    [
        ({"shape": "hexagonn"}, "shape"),
        ({"material": "steel"}, "material"),
        ({"force_n": 0.0}, "force_n"),
        ({"force_n": -1.0}, "force_n"),
        ({"speed_mm_s": 0.0}, "speed_mm_s"),
        ({"speed_mm_s": 80.0}, "speed_mm_s"),
        ({"seed": -1}, "seed"),
        ({"config": {"motion": {}}}, "config"),
    ],
)
def test_invalid_arguments_name_the_argument(kwargs, arg):
    args = {"shape": "hexagon", "material": "wood", **kwargs}
    with pytest.raises(ValueError, match=arg):
        synth.simulate(args.pop("shape"), args.pop("material"), **args)


def test_config_round_trips_and_rejects_unknown_keys():
    config = SynthConfig()
    again = SynthConfig.from_dict(config.to_dict())
    assert again == config
    data = config.to_dict()
    data["motion"]["warp_drive"] = 1
    with pytest.raises(ValueError, match="warp_drive"):
        SynthConfig.from_dict(data)
    with pytest.raises(ValueError, match="timestep_s"):
        Motion(timestep_s=0.0003)
    with pytest.raises(ValueError, match="surface_update_s"):
        Motion(surface_update_s=0.0005)
    with pytest.raises(ValueError, match="kinetic"):
        FrictionLaw(kinetic=-0.1, static=0.5)
    with pytest.raises(ValueError, match="static must be >= kinetic"):
        FrictionLaw(kinetic=0.6, static=0.5)
    with pytest.raises(ValueError, match="friction"):
        Material("wood", 0.5, Texture(1e-6, 1e-4))


def test_a_finger_that_loses_contact_raises():
    """Lift-off is an error naming the trial, never silently returned data."""
    # 0.5 mm corrugations 4 mm apart at 20 mm/s shake the specimen far harder than a
    # 0.05 N push can hold the skin against: it takes off for over a tenth of a second.
    grain = Texture(0.0, 1e-4, (Periodic(wavelength_m=4e-3, amplitude_m=5e-4),))
    config = with_material(FLAT, "wood", texture=grain)
    with pytest.raises(SimulationError, match=r"lost contact.*shape='square'"):
        synth.simulate("square", "wood", force_n=0.05, speed_mm_s=20.0, config=config)


def test_a_mujoco_warning_in_any_period_raises(monkeypatch):
    """A MuJoCo warning raised in one controller period is reported even when the
    periods after it run clean: each rollout call clears the counters, so the loop must
    read them after every call."""
    from synth import closed_loop

    bad = int(mujoco.mjtWarning.mjWARN_BADQACC)
    real = closed_loop._rollout.Rollout

    class WarnsOnce:
        """MuJoCo's rollout, with a warning counted on the data after the third call."""

        def __init__(self, **kwargs):
            self.runner = real(**kwargs)
            self.calls = 0

        def rollout(self, models, datas, *args):
            self.runner.rollout(models, datas, *args)
            self.calls += 1
            if self.calls == 3:
                datas[0].warning[bad].number = 1

    monkeypatch.setattr(closed_loop, "_rollout", type("R", (), {"Rollout": WarnsOnce}))
    with pytest.raises(SimulationError, match=r"mjWARN_BADQACC.*shape='square'"):
        synth.simulate("square", "wood", config=NOMINAL)


@pytest.mark.parametrize("break_it", ["weightless", "coarse_step"])
def test_an_unstable_trial_that_is_not_the_last_on_its_data_raises(break_it):
    """MuJoCo resets a trial whose state turns bad and clears a data's warning counters
    before each trial it runs there: a reset trial followed by a healthy one on the same
    data is still reported, by name, whether it fails in its first step or later."""
    plans = [sim.plan(TrialSpec("square", "wood", seed=s), NOMINAL) for s in (3, 4)]
    model = plans[0].model
    if break_it == "weightless":  # accelerations beyond MuJoCo's bound in the first step
        model.body_mass[1:] *= 1e-12
        model.body_inertia[1:] *= 1e-12
    else:  # a 10 ms step: the stiff drive diverges over a few steps
        model.opt.timestep = 0.01
    datas = [mujoco.MjData(plans[1].model)]  # both trials run on one data, in order
    with pytest.raises(SimulationError, match=r"mjWARN_BADQACC.*seed=3\b") as failed:
        sim._roll(plans, datas, NOMINAL)
    # the message says what may hold a diverging integration
    assert "diverged: a shorter simulator step than motion.timestep_s = 0.5 ms" in str(failed.value)


def test_the_loop_times_its_rollout_calls_without_changing_the_run():
    """``_roll_loop`` gives ``_roll``'s outputs bit for bit and the loop's time inside
    MuJoCo's rollout calls: positive, and a part of the whole run's wall time."""
    config = SynthConfig()
    plan = sim.plan(TrialSpec("circle", "resin", seed=2), config)
    data = [mujoco.MjData(plan.model)]
    sens, heights = sim._roll([plan], data, config)
    t0 = time.perf_counter()
    sens2, heights2, loop = sim._roll_loop([plan], data, config)
    wall = time.perf_counter() - t0
    np.testing.assert_array_equal(sens2, sens)
    np.testing.assert_array_equal(heights2, heights)
    assert 0.0 < loop.rollout_s_ < wall


def test_the_raw_rollout_times_only_its_rollout_calls():
    """``raw_rollout_times``: wall and CPU seconds of the rollout calls alone, so the
    planning of the trials (CPU spent in the same call) is left out of both."""
    specs = [TrialSpec("circle", "wood", seed=i) for i in range(2)]
    cpu0, wall0 = time.process_time(), time.perf_counter()
    wall, cpu = sim.raw_rollout_times(specs, threads=1)
    total_cpu, total_wall = time.process_time() - cpu0, time.perf_counter() - wall0
    assert 0.0 < wall < total_wall
    assert 0.0 < cpu < total_cpu


def test_a_non_finite_sensor_value_fails_its_trial_by_name():
    """A NaN anywhere in a trial's physics, even outside its window, fails that trial
    with a message naming it; the sensors period-major and trial-major alike."""
    config = SynthConfig()
    plans = [sim.plan(TrialSpec("circle", "wood", seed=s), config) for s in (1, 2)]
    datas = [mujoco.MjData(plans[0].model)]
    periods, heights, _ = sim._roll_loop(plans, datas, config, periods=True)
    assert len(sim._process(plans, periods, heights, config)) == 2
    periods[0, 1, 0, 0] = np.nan  # trial 1's first step, long before its window
    with pytest.raises(sim.SimulationError, match=r"non-finite physics .*seed=2"):
        sim._process(plans, periods, heights, config)
    with pytest.raises(sim.SimulationError, match=r"non-finite physics .*seed=2"):
        sim._process(plans, synth.closed_loop.trial_major(periods), heights, config)


def test_mujoco_runs_without_its_timers_and_gets_the_callers_clock_back():
    """While the simulator and the raw rollout run, MuJoCo's timer callback is the
    no-op clock (a clock of the caller's is not called); afterwards it is the caller's
    again, and nested uses keep it off until the outermost ends."""
    import mujoco

    from synth.closed_loop import timers_off

    calls = []

    def clock() -> float:
        calls.append(1)
        return 0.0

    spec = TrialSpec("circle", "wood", seed=3)
    model = sim.plan(spec, SynthConfig()).model  # the scene compiled (MuJoCo steps it then)
    mujoco.set_mjcb_time(clock)
    try:
        sim.simulate_batch([spec], threads=1)
        sim.raw_rollout_times([spec], threads=1)
        assert calls == []
        assert mujoco.get_mjcb_time() is clock
        with timers_off():
            with timers_off():
                pass
            assert mujoco.get_mjcb_time() is not clock
        assert mujoco.get_mjcb_time() is clock
        data = mujoco.MjData(model)
        mujoco.mj_step(model, data)
        assert calls  # the caller's clock runs outside the simulator
    finally:
        mujoco.set_mjcb_time(None)
