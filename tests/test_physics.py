"""Physics checks of the simulator (issue 3): each asserts a measurable physical property."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
from scipy import signal

import synth
from shapes import SHAPE_NAMES
from synth import scene as scene_mod
from synth import sensors
from synth.config import Motion, SynthConfig
from synth.materials import Material, Periodic, Texture
from synth.simulator import SimulationError, simulate_batch
from synth.trial import SAMPLE_RATE_HZ, TrialSpec

NOMINAL = SynthConfig(variability=SynthConfig().variability.nominal())
FLAT = dataclasses.replace(NOMINAL, motion=dataclasses.replace(NOMINAL.motion, raised_shape=False))
PVDF, SG = slice(0, 2), slice(2, 4)
STEADY = slice(300, None)


def _config(base: SynthConfig, **motion) -> SynthConfig:
    return dataclasses.replace(base, motion=dataclasses.replace(base.motion, **motion))


@pytest.mark.parametrize("shape", SHAPE_NAMES)
def test_every_scene_compiles_and_slides_one_second_without_warnings(shape):
    """1. All 36 scenes: compile, slide 1 s (Python mj_step loop), no MuJoCo warning."""
    config = SynthConfig()
    sc = scene_mod.scene(shape, config)
    for material in synth.MATERIAL_NAMES:
        mat = config.materials[material]
        model = sc.trial_model(mat, mat.friction, mat.contact_timeconst_s)
        data = mujoco.MjData(model)
        x0 = -0.015
        data.qpos[sc.qpos_index["robot_x"]] = x0
        data.qpos[sc.qpos_index["robot_z"]] = -1.0 / config.finger.pdms_normal_stiffness_n_m
        data.qpos[sc.qpos_index["pdms_z"]] = 1.0 / config.finger.pdms_normal_stiffness_n_m
        steps = round(1.0 / model.opt.timestep)
        for i in range(steps):
            data.ctrl[:] = (x0 + 0.010 * i * model.opt.timestep, 0.0, -1.0)
            mujoco.mj_step(model, data)
        assert [w.number for w in data.warning] == [0] * len(data.warning), (shape, material)
        assert np.all(np.isfinite(data.qpos))
        moved = data.qpos[sc.qpos_index["robot_x"]] - x0
        assert 0.008 < moved < 0.0105, (shape, material, moved)


def test_all_36_classes_simulate_cleanly():
    specs = [TrialSpec(s, m, seed=7) for s in SHAPE_NAMES for m in synth.MATERIAL_NAMES]
    trials = simulate_batch(specs, threads=2)
    for spec, trial in zip(specs, trials, strict=True):
        assert trial.spec == spec
        assert trial.signals.shape == (4, 2000) and trial.signals.dtype == np.float32
        assert np.all(np.isfinite(trial.signals))
        assert np.all(trial.truth["contacts"] >= 0)
        assert abs(np.median(trial.truth["normal_force_n"]) - 1.0) < 0.1


def _flat(material="wood", force_n=1.0, speed_mm_s=10.0, seed=0, config=FLAT):
    return synth.simulate(
        "square", material, force_n=force_n, speed_mm_s=speed_mm_s, seed=seed, config=config
    )


def test_strain_gauge_level_scales_with_normal_force():
    """2. Flat-plate sliding: 2 N gives twice the strain-gauge level of 1 N (within 10%)."""
    zero = sensors.bridge_zero_v(FLAT.strain_gauge)
    one, two = (_flat(force_n=f).signals[SG].mean(axis=1) - zero for f in (1.0, 2.0))
    assert np.all(np.abs(one) > 0.02), one  # well above the noise
    np.testing.assert_allclose(two / one, 2.0, rtol=0.10)


def test_friction_ratio_equals_each_materials_coefficient():
    """3. Steady flat sliding: tangential/normal = friction coefficient, materials ordered."""
    ratios = {}
    for material in synth.MATERIAL_NAMES:
        truth = _flat(material).truth
        steady = slice(200, None)  # after the start of the window
        ratios[material] = (
            truth["tangential_force_n"][steady].mean() / truth["normal_force_n"][steady].mean()
        )
        mu = FLAT.materials[material].friction
        assert ratios[material] == pytest.approx(mu, rel=0.10), (material, ratios[material], mu)
    by_mu = sorted(synth.MATERIAL_NAMES, key=lambda m: FLAT.materials[m].friction)
    assert sorted(ratios, key=ratios.get) == by_mu


def _onset(t: np.ndarray, deviation: np.ndarray, threshold: float, after: float = -1.0) -> float:
    idx = np.flatnonzero((deviation > threshold) & (t > after))
    assert idx.size, "no transient found"
    return float(t[idx[0]])


def _time_at_x(truth: dict, x: float) -> float:
    return float(np.interp(x, truth["finger_x_m"], truth["time_s"]))


def test_edge_transients_occur_at_the_geometric_entry_and_exit():
    """4. Square at y = 0, 16 mm/s so that the 2 s window holds both edges.

    The finger is force-controlled, so an edge shows in the contact force along the
    edge's normal, not in the vertical load the controller holds: the transients are
    detected in the magnitude of the skin-specimen contact force. Entry: the skin (indented
    by ``pen``) first touches the raised edge when the pad centre is
    ``a = sqrt(r^2 - (r - h - pen)^2)`` ahead of it. Exit: the contact moves onto the exit
    corner as the pad centre passes it (force drops), and the skin lands on the plate a
    further on (the normal force spikes). Predicted times are those positions divided by
    the finger's speed, i.e. read off its measured x.
    """
    smooth = _with_texture(NOMINAL, "resin", Texture(0.0, 1e-4))  # geometry alone
    trial = synth.simulate("square", "resin", speed_mm_s=16.0, config=smooth)
    truth = trial.truth
    r, h = smooth.finger.pad_radius_m, 0.002
    half = 0.007  # the square's half side (14 mm)
    t = truth["time_s"]
    total = np.hypot(truth["normal_force_n"], truth["tangential_force_n"])
    settled = t > t[0] + 0.1  # past the slide's start-up
    plate = settled & (truth["finger_x_m"] < -0.0126)
    pen = -np.median(truth["finger_z_m"][plate])
    assert 0 < pen < 0.5e-3  # the soft skin is indented a fraction of a millimetre
    a = np.sqrt(r**2 - (r - h - pen) ** 2)
    level = np.median(total[plate])
    entry = _onset(t, np.abs(total - level), 0.05 * level, after=t[plate][-1])
    assert entry == pytest.approx(_time_at_x(truth, -half - a), abs=0.020)
    on_top = (truth["finger_x_m"] > -0.004) & (truth["finger_x_m"] < 0.004)
    top_level = np.median(total[on_top])
    crest = _time_at_x(truth, half)
    # The force tilts smoothly as the pad rolls onto the corner: 2% (noise is ~0.2%).
    exit_t = _onset(t, np.abs(total - top_level), 0.02 * top_level, after=crest - 0.1)
    assert exit_t == pytest.approx(crest, abs=0.020)
    # Landing: the indented pad (radius r - pen on the corner too) touches down when its
    # centre is a' past the corner; the normal force spikes as the plate takes the load.
    a_land = np.sqrt((r - pen) ** 2 - (r - pen - h) ** 2)
    after = t > crest + 0.05
    landing = t[after][np.argmax(truth["normal_force_n"][after])]
    assert landing == pytest.approx(_time_at_x(truth, half + a_land), abs=0.020)


def test_finger_drops_into_the_moon_notch():
    """5. Crossing the moon's notch the skin reaches the plate and the normal force
    returns to its plate level (with a single convex hull it would ride over at 2 mm)."""
    config = _config(NOMINAL, path_y_m=0.003, window_center_x_m=0.0)
    truth = synth.simulate("moon", "wood", config=config).truth
    x = truth["finger_x_m"]
    notch = np.abs(x) < 0.0005  # the notch's middle (it spans |x| < 6 mm at y = 0..3 mm)
    assert notch.sum() > 50
    on_top = truth["finger_z_m"] > 0.0015
    assert on_top.sum() > 100, "the finger must first cross a horn of the moon"
    assert truth["finger_z_m"][notch].max() < 0.25e-3
    plate_level = 1.0  # the applied force: the plate carries it all when nothing else touches
    assert np.mean(truth["normal_force_n"][notch]) == pytest.approx(plate_level, rel=0.03)
    assert np.std(truth["normal_force_n"][notch]) < 0.03


def _with_texture(config: SynthConfig, material: str, texture: Texture) -> SynthConfig:
    return config.with_material(dataclasses.replace(config.materials[material], texture=texture))


def _pvdf_rms(trial) -> float:
    return float(np.sqrt(np.mean(trial.signals[PVDF, STEADY].astype(float) ** 2)))


def test_pvdf_is_ac_coupled_and_rises_with_speed_and_roughness():
    """6a. PVDF channels are zero-mean; their RMS rises with speed and roughness.

    Measured on steady sliding (from 0.3 s into the window, past the slide's start-up);
    the strain gauges, DC-coupled, are far from zero-mean on the same samples.
    """

    def batch(speed_mm_s, config=FLAT):
        specs = [TrialSpec("square", "wood", speed_mm_s=speed_mm_s, seed=k) for k in range(3)]
        return simulate_batch(specs, config=config)

    def rms(trials):
        return np.mean([_pvdf_rms(t) for t in trials])

    slow, fast = batch(5.0), batch(20.0)
    for trial in (*slow, *fast):
        pv = trial.signals[PVDF, STEADY].astype(float)
        assert np.all(np.abs(pv.mean(axis=1)) < 0.05 * pv.std(axis=1)), pv.mean(axis=1)
        sg = trial.signals[SG, STEADY].astype(float)
        assert np.all(np.abs(sg.mean(axis=1)) > 5 * sg.std(axis=1))
    assert rms(fast) > 1.25 * rms(slow)
    wood = FLAT.materials["wood"].texture
    rough = Texture(
        roughness_rms_m=3 * wood.roughness_rms_m,
        correlation_length_m=wood.correlation_length_m,
        periodic=wood.periodic,
    )
    assert _pvdf_rms(_flat(config=_with_texture(FLAT, "wood", rough))) > 1.5 * _pvdf_rms(_flat())


def test_pvdf_spectrum_peaks_at_speed_over_wavelength():
    """6b. A purely periodic texture of wavelength L gives a PVDF peak at v / L.

    L = 0.45 mm, the fingerprint's ridge spacing, which the ridges pass best (Scheibert et
    al. 2009); 8 and 16 mm/s put v / L at 18 and 36 Hz, where a force-controlled finger
    with soft skin transmits vibration.
    """
    wavelength = 0.45e-3
    periodic = Texture(
        roughness_rms_m=0.0,
        correlation_length_m=1e-4,
        periodic=(Periodic(wavelength_m=wavelength, amplitude_m=10e-6),),
    )
    config = _with_texture(FLAT, "resin", periodic)
    for speed in (8.0, 16.0):
        trial = _flat("resin", speed_mm_s=speed, config=config)
        f, p = signal.welch(trial.signals[0].astype(float), fs=SAMPLE_RATE_HZ, nperseg=1000)
        band = f > 3.0  # above the drift and the slide's slow load changes
        peak = f[band][np.argmax(p[band])]
        assert peak == pytest.approx(speed * 1e-3 / wavelength, rel=0.10), (speed, peak)


def test_same_seed_is_bit_identical_whatever_the_batch():
    """7. Determinism: same seed, same bits (alone or in a batch, any thread count)."""
    spec = TrialSpec("pentagram", "aluminum", force_n=1.2, speed_mm_s=9.0, seed=11)
    alone = synth.simulate("pentagram", "aluminum", force_n=1.2, speed_mm_s=9.0, seed=11)
    others = [TrialSpec(s, "wood", seed=3) for s in ("moon", "pentagram", "circle")]
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
    with pytest.raises(ValueError, match="friction"):
        Material("wood", -0.1, 0.003, 1.0, 700.0, Texture(1e-6, 1e-4))


def test_a_finger_that_loses_contact_raises():
    """Lift-off is an error naming the trial, never silently returned data."""
    # 0.3 mm corrugations 1 mm apart at 20 mm/s shake the specimen at 4.7 m/s^2; a 0.05 N
    # push cannot hold the 53 g finger against that: it takes off.
    grain = Texture(0.0, 1e-4, (Periodic(wavelength_m=1e-3, amplitude_m=3e-4),))
    config = _with_texture(NOMINAL, "wood", grain)
    with pytest.raises(SimulationError, match=r"lost contact.*shape='square'"):
        synth.simulate("square", "wood", force_n=0.05, speed_mm_s=20.0, config=config)
