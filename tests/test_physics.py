"""Physics checks of the simulator: each asserts a measurable physical property."""

from __future__ import annotations

import dataclasses
import math
import time

import mujoco
import numpy as np
import pytest
from scipy import signal

import synth
from shapes import SHAPE_NAMES
from synth import contact, sensors, skin_fit
from synth import scene as scene_mod
from synth import simulator as sim
from synth.config import Motion, SynthConfig
from synth.materials import FrictionLaw, Material, Periodic, Texture
from synth.simulator import SimulationError, simulate_batch
from synth.trial import SAMPLE_RATE_HZ, TrialSpec

NOMINAL = SynthConfig(variability=SynthConfig().variability.nominal())
FLAT = dataclasses.replace(NOMINAL, motion=dataclasses.replace(NOMINAL.motion, raised_shape=False))
#: A softer PDMS support (4 mm thick), on which a velocity-weakening law sticks and slips.
COMPLIANT = dataclasses.replace(
    FLAT, finger=dataclasses.replace(FLAT.finger, pdms_thickness_m=0.004)
)
PVDF, SG = slice(0, 2), slice(2, 4)
STEADY = slice(300, None)


def _config(base: SynthConfig, **motion) -> SynthConfig:
    return dataclasses.replace(base, motion=dataclasses.replace(base.motion, **motion))


def _with_material(config: SynthConfig, material: str, **changes) -> SynthConfig:
    return config.with_material(dataclasses.replace(config.materials[material], **changes))


def _run(plans: list, config: SynthConfig) -> tuple[np.ndarray, list]:
    """Full-length sensordata ``(b, steps, n)`` and the windows' trials of ``plans``."""
    datas = [mujoco.MjData(plans[0].model)]
    sens, heights = sim._roll(plans, datas, config)
    return sens, sim._process(plans, sens, heights, config)


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
        sens, _ = _run([plan], config)
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


def _flat(material="wood", force_n=1.0, speed_mm_s=10.0, seed=0, config=FLAT):
    return synth.simulate(
        "square", material, force_n=force_n, speed_mm_s=speed_mm_s, seed=seed, config=config
    )


def test_strain_gauge_level_scales_with_normal_force():
    """Flat-plate sliding: 2 N gives about twice the strain-gauge level of 1 N; the
    friction coefficient falls with load (exponent -0.21), so the friction-driven bending
    grows by 2^0.79 rather than 2."""
    zero = sensors.bridge_zero_v(FLAT.strain_gauge)
    one, two = (_flat(force_n=f).signals[SG].mean(axis=1) - zero for f in (1.0, 2.0))
    assert np.all(np.abs(one) > 0.02), one  # well above the noise
    ratio = two / one
    assert np.all((ratio > 1.5) & (ratio < 2.1)), ratio


def test_friction_ratio_follows_each_materials_law():
    """Steady flat sliding: tangential / normal = the material's kinetic coefficient at the
    measured load; materials ordered by it."""
    ratios = {}
    for material in synth.MATERIAL_NAMES:
        truth = _flat(material).truth
        normal = truth["normal_force_n"][STEADY]
        ratios[material] = truth["tangential_force_n"][STEADY].mean() / normal.mean()
        law = FLAT.materials[material].friction
        want = law.kinetic * normal.mean() ** law.load_exponent
        assert ratios[material] == pytest.approx(want, rel=0.05), (material, ratios[material])
    # A law of another coefficient is followed as well (the default materials share one).
    law = FrictionLaw(kinetic=0.5, static=0.6)
    truth = _flat("wood", config=_with_material(FLAT, "wood", friction=law)).truth
    normal = truth["normal_force_n"][STEADY]
    ratio = truth["tangential_force_n"][STEADY].mean() / normal.mean()
    assert ratio == pytest.approx(0.5 * normal.mean() ** law.load_exponent, rel=0.05)


def test_static_friction_gives_stick_slip_that_emerges_from_the_simulation():
    """A velocity-weakening law (static well above kinetic) on a compliant finger (a 4 mm
    PDMS support: the default 3 mm one is too stiff for this law to stick) sticks and
    slips: the skin's slip speed alternates between near zero and several times the
    robot's speed, while the robot moves steadily."""
    law = FrictionLaw(kinetic=0.4, static=1.6, stribeck_velocity_m_s=2e-3, load_exponent=0.0)
    config = _with_material(COMPLIANT, "aluminum", friction=law)
    slip = _flat("aluminum", config=config).truth["slip_speed_m_s"]
    assert (slip < 2e-3).mean() > 0.2  # stuck a good part of the time
    assert slip.max() > 50e-3  # and snapping free well above the 10 mm/s drive
    steady = _flat("aluminum").truth["slip_speed_m_s"][STEADY]
    assert (steady < 2e-3).mean() < 0.02  # the kinetic-dominated law slides throughout


@pytest.mark.xfail(
    strict=True,
    reason="the films' RMS on flat wood is 0.99x from 5 to 20 mm/s (3 seeds), not the 1.25x "
    "this checks: the films read the texture's push with the same gain from 40 to 250 Hz "
    "(scripts/bench_texture.py --transfer), and the push of a fixed relief, its slope "
    "times the load, does not grow with speed; only in the 20-400 Hz band does more of "
    "the roughness spectrum enter as the speed rises",
)
def test_pvdf_rises_with_speed():
    """The films' RMS on steady flat sliding over wood rises by a quarter or more from 5 to
    20 mm/s (mean of 3 seeds)."""

    def rms(speed_mm_s):
        specs = [TrialSpec("square", "wood", speed_mm_s=speed_mm_s, seed=k) for k in range(3)]
        return np.mean([_pvdf_rms(t) for t in simulate_batch(specs, config=FLAT)])

    assert rms(20.0) > 1.25 * rms(5.0)


def _fine_texture_config(base: SynthConfig, law: FrictionLaw | None = None) -> SynthConfig:
    """A finger with one narrow ridge, so 0.1 mm marks (0.15 um deep) pass unfiltered, on a
    surface that slides steadily unless ``law`` says otherwise."""
    finger = dataclasses.replace(base.finger, ridges_in_contact=1, ridge_width_m=10e-6)
    marks = Texture(0.0, 1e-4, (Periodic(wavelength_m=0.1e-3, amplitude_m=0.15e-6),))
    steady = FrictionLaw(kinetic=0.6, static=0.6, load_exponent=0.0)
    return _with_material(
        dataclasses.replace(base, finger=finger), "aluminum", texture=marks, friction=law or steady
    )


def _band_rms(x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    sos = signal.butter(4, (lo, hi), btype="band", fs=SAMPLE_RATE_HZ, output="sos")
    return np.abs(signal.sosfiltfilt(sos, x.astype(float)))


def test_a_stuck_pad_feels_no_texture_while_the_robot_moves():
    """Texture is felt where the skin actually rubs. In the stick phases of stick-slip the
    robot keeps moving at 10 mm/s (the planned path would cross 0.1 mm marks at 100 Hz)
    but the skin stands still (it creeps by ~1 mm/s): the felt height changes an order of
    magnitude slower than in steady sliding. The finger's
    support is a compliant 6 mm one, on which the law sticks and slips."""
    bending = dataclasses.replace(
        COMPLIANT,
        finger=dataclasses.replace(FLAT.finger, pdms_thickness_m=0.006),
        pvdf=dataclasses.replace(FLAT.pvdf, shear_strain_per_n=0, post_gain=20.0),
        motion=dataclasses.replace(FLAT.motion, wrist_force_noise_n=0.0),
    )
    sliding = _flat("aluminum", config=_fine_texture_config(bending))
    law = FrictionLaw(kinetic=0.4, static=2.0, stribeck_velocity_m_s=2e-3, load_exponent=0.0)
    sticky = _flat("aluminum", config=_fine_texture_config(bending, law))
    slip = sticky.truth["slip_speed_m_s"]
    snapping = np.convolve(slip > 3e-3, np.ones(81), mode="same") > 0
    stuck = (slip < 2e-3) & ~snapping
    assert stuck.sum() > 50
    felt = np.abs(np.diff(sticky.truth["specimen_z_m"]))[stuck[1:]].mean()
    felt_sliding = np.abs(np.diff(sliding.truth["specimen_z_m"]))[STEADY].mean()
    assert felt < 0.25 * felt_sliding, (felt, felt_sliding)
    # The films' 80-120 Hz band in the stuck phases is not checked: on the PDMS support
    # the stick-slip's own load changes bend the films in that band (0.70 of the sliding
    # texture's level measured, where texture alone would leave it far quieter).


def test_a_pad_that_stops_stops_exciting_texture():
    """The robot stops half-way through the window: the texture band dies out."""
    config = _fine_texture_config(FLAT)
    plan = sim.plan(TrialSpec("square", "aluminum", seed=2), config)
    stop = plan.window_start + 1000 * sim.steps_per_sample(config)
    x = plan.loop.x_ref.copy()
    x[stop:] = x[stop]
    plan = dataclasses.replace(plan, loop=dataclasses.replace(plan.loop, x_ref=x))
    (trial,) = _run([plan], config)[1]
    band = _band_rms(trial.signals[0], 80, 120)
    before, after = band[300:900].mean(), band[1300:1900].mean()
    assert after < 0.1 * before, (after, before)


def test_texture_frequency_follows_the_actual_speed():
    """Decelerating from 16 to 6 mm/s over the window, the PVDF peak tracks the skin's
    measured speed over the 0.1 mm marks (f = v / wavelength) in each 0.2 s block. The
    films read the marks through the skin's traction (the marks' push) and their bending;
    the pad's modes on its mount lie above the marks' 60-160 Hz. Twenty times the gain
    lifts the marks above the DAQ's mains pickup, and a noiseless wrist sensor keeps the
    force loop still."""
    films = dataclasses.replace(FLAT.pvdf, post_gain=20.0)
    quiet = dataclasses.replace(FLAT.motion, wrist_force_noise_n=0.0)
    config = _fine_texture_config(dataclasses.replace(FLAT, pvdf=films, motion=quiet))
    plan = sim.plan(TrialSpec("square", "aluminum", speed_mm_s=16.0, seed=2), config)
    dt = config.motion.timestep_s
    w0 = plan.window_start
    n = plan.loop.x_ref.size
    t = (np.arange(n) - w0) * dt
    window = np.clip(t, 0.0, 2.0)
    v = np.where(t < 0, 16e-3, 16e-3 - 5e-3 * window)  # 16 -> 6 mm/s
    x = plan.loop.x_ref[w0] + np.concatenate([[0.0], np.cumsum(v[:-1] * dt)])
    x -= x[w0] - plan.loop.x_ref[w0]
    pre = slice(0, w0)
    x[pre] = plan.loop.x_ref[pre]
    plan = dataclasses.replace(plan, loop=dataclasses.replace(plan.loop, x_ref=x))
    (trial,) = _run([plan], config)[1]
    pad_x = trial.truth["finger_x_m"]
    for start in range(100, 1900, 200):
        block = slice(start, start + 200)
        speed = (pad_x[block][-1] - pad_x[block][0]) / 0.199
        f, p = signal.periodogram(trial.signals[0, block].astype(float), fs=SAMPLE_RATE_HZ)
        band = f > 30
        peak = f[band][np.argmax(p[band])]
        assert peak == pytest.approx(speed / 0.1e-3, rel=0.10), (start, peak, speed)


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
    smooth = _with_material(_config(NOMINAL, path_y_m=0.0), "resin", texture=Texture(0.0, 1e-4))
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
    config = _config(NOMINAL, path_y_m=0.003)
    truth = synth.simulate("moon", "wood", config=config).truth
    x = truth["finger_x_m"]
    notch = np.abs(x) < 0.0005  # the notch's middle (it spans |x| < 6 mm at y = 0..3 mm)
    assert notch.sum() > 50
    on_top = truth["finger_z_m"] > 0.001  # skin bottom on the 2 mm top, indented ~0.8 mm
    assert on_top.sum() > 100, "the finger must first cross a horn of the moon"
    assert truth["finger_z_m"][notch].max() < 0.25e-3
    assert np.mean(truth["normal_force_n"][notch]) == pytest.approx(1.0, rel=0.05)


def _pvdf_rms(trial) -> float:
    return float(np.sqrt(np.mean(trial.signals[PVDF, STEADY].astype(float) ** 2)))


def test_pvdf_is_ac_coupled_and_rises_with_roughness():
    """PVDF channels are zero-mean; their RMS rises with roughness.

    Measured on steady sliding, where the films' mean stays within their fluctuation (the
    wood's growth rings, a few hertz here, leave part of a period in the window); DC-
    coupled, the friction's steady shear alone would hold them some 0.4 V off zero, a
    hundred times their fluctuation. The strain gauges, DC-coupled, are far from zero-mean
    on the same samples.
    """

    def batch(speed_mm_s, config=FLAT):
        specs = [TrialSpec("square", "wood", speed_mm_s=speed_mm_s, seed=k) for k in range(3)]
        return simulate_batch(specs, config=config)

    def rms(trials):
        return np.mean([_pvdf_rms(t) for t in trials])

    slow, fast = batch(5.0), batch(20.0)
    for trial in (*slow, *fast):
        pv = trial.signals[PVDF, STEADY].astype(float)
        assert np.all(np.abs(pv.mean(axis=1)) < pv.std(axis=1)), pv.mean(axis=1)
        sg = trial.signals[SG, STEADY].astype(float)
        # The wood's growth rings move the gauges' level: over 10 seeds the smallest
        # |mean| / std is 5.0, the PVDF's largest 0.33.
        assert np.all(np.abs(sg.mean(axis=1)) > 3 * sg.std(axis=1))
    wood = FLAT.materials["wood"].texture
    rough = dataclasses.replace(wood, roughness_rms_m=3 * wood.roughness_rms_m)
    assert _pvdf_rms(_flat(config=_with_material(FLAT, "wood", texture=rough))) > 1.5 * _pvdf_rms(
        _flat()
    )


def test_pvdf_spectrum_peaks_at_speed_over_wavelength():
    """A purely periodic texture of wavelength L gives a PVDF peak at v / L.

    L = 0.45 mm, the fingerprint's ridge spacing, which the ridges pass best (Scheibert et
    al. 2009); 8 and 16 mm/s put v / L at 18 and 36 Hz. The marks are 2 um deep, so the
    push of their slope (about 0.02 N) leaves the sliding steady; marks several times
    deeper modulate the slip speed by about its mean and the response gains harmonics.
    """
    wavelength = 0.45e-3
    periodic = Texture(0.0, 1e-4, (Periodic(wavelength_m=wavelength, amplitude_m=2e-6),))
    config = _with_material(FLAT, "resin", texture=periodic)
    for speed in (8.0, 16.0):
        trial = _flat("resin", speed_mm_s=speed, config=config)
        f, p = signal.welch(trial.signals[0].astype(float), fs=SAMPLE_RATE_HZ, nperseg=1000)
        band = f > 3.0  # above the slow load changes
        peak = f[band][np.argmax(p[band])]
        assert peak == pytest.approx(speed * 1e-3 / wavelength, rel=0.10), (speed, peak)


def test_pvdf_film_capacitance_comes_from_its_geometry():
    """28 um PVDF has ~380 pF per cm^2 (eps_r 12-13)."""
    pv = NOMINAL.pvdf
    per_cm2 = pv.capacitance_f / (pv.area_m2 * 1e4)
    assert per_cm2 == pytest.approx(380e-12, rel=0.05)


def test_the_films_neutral_axis_offset_is_its_carriers():
    """The default offset is 28 um PVDF on 75 um polyester; 23 um stock puts the axis at the
    film's bonded face (14 um), a 125 um laminate at ~67 um; a thicker carrier moves the
    axis away from the film."""
    pv, finger = NOMINAL.pvdf, NOMINAL.finger
    for polyester_pa in (4.0e9, 4.5e9, 5.0e9):
        default, _ = sensors.film_on_carrier(pv, finger, 75e-6, polyester_pa)
        assert default == pytest.approx(pv.neutral_axis_offset_m, rel=0.08), polyester_pa
    default, _ = sensors.film_on_carrier(pv, finger, 75e-6, 4.5e9)
    assert default == pytest.approx(pv.neutral_axis_offset_m, rel=0.02)
    thinnest, _ = sensors.film_on_carrier(pv, finger, 23e-6, 4.5e9)
    assert thinnest == pytest.approx(pv.thickness_m / 2, rel=0.02)
    laminate, _ = sensors.film_on_carrier(pv, finger, 125e-6, 4.5e9)
    assert laminate == pytest.approx(67e-6, rel=0.03)
    assert laminate == pytest.approx(66.6e-6, rel=0.01)
    itself = dataclasses.replace(pv, youngs_modulus_pa=3e9)
    offset, _ = sensors.film_on_carrier(itself, finger, pv.thickness_m, 3e9)
    assert offset == pytest.approx(pv.thickness_m / 2)
    offsets = [sensors.film_on_carrier(pv, finger, t, 4.5e9)[0] for t in (10e-6, 50e-6, 1e-4)]
    assert offsets[0] < thinnest < offsets[1] < default < offsets[2] < laminate


def test_a_film_bending_about_its_own_mid_plane_gives_no_charge():
    """The films' bending signal is in proportion to the neutral axis's offset from their
    mid-plane: with no offset and no shear coupling the PVDF channels carry only the
    amplifier's and the DAQ's noise, the same whatever the surface; at twice the offset,
    twice the signal above it."""

    def pvdf(offset_m, texture=None):
        # Twenty times the gain lifts the flat plate's bending signal above the DAQ's noise.
        pv = dataclasses.replace(
            FLAT.pvdf, neutral_axis_offset_m=offset_m, shear_strain_per_n=0, post_gain=20.0
        )
        config = dataclasses.replace(FLAT, pvdf=pv)
        if texture is not None:
            config = _with_material(config, "wood", texture=texture)
        return _flat(config=config)

    wood = FLAT.materials["wood"].texture
    rough = dataclasses.replace(wood, roughness_rms_m=3 * wood.roughness_rms_m)
    np.testing.assert_array_equal(pvdf(0.0).signals[PVDF], pvdf(0.0, rough).signals[PVDF])
    assert not np.array_equal(pvdf(0.0).signals[SG], pvdf(0.0, rough).signals[SG])

    noise = _pvdf_rms(pvdf(0.0))
    default = FLAT.pvdf.neutral_axis_offset_m
    once, twice = (np.sqrt(_pvdf_rms(pvdf(k * default)) ** 2 - noise**2) for k in (1, 2))
    assert once > 2 * noise
    assert twice == pytest.approx(2 * once, rel=0.05)


def test_the_surface_slope_is_the_deflections_derivative():
    r, delta = FLAT.finger.pad_radius_m, 0.8e-3
    a = math.sqrt(r * delta)
    x = np.linspace(-9e-3, 9e-3, 18001)
    numeric = np.gradient(contact.surface_deflection_m(x, delta, r), x)
    slope = contact.surface_slope(x, delta, r)
    smooth = (np.abs(np.abs(x) - a) > 3e-5) & (np.abs(x) > 3e-6)  # off the kinks
    assert np.max(np.abs(slope - numeric)[smooth][2:-2]) < 1e-4 * np.max(np.abs(slope))
    np.testing.assert_allclose(slope, -contact.surface_slope(-x, delta, r), atol=1e-15)
    rim = contact.surface_slope(np.array([a * (1 - 1e-9), a * (1 + 1e-9)]), delta, r)
    np.testing.assert_allclose(rim, -a / r, rtol=1e-4)  # continuous at the rim
    assert np.all(contact.surface_slope(x, 0.0, r) == 0.0)


def _mech(ahead_m, indentation_m, traction_n=0.0) -> sensors.Mechanics:
    shape = np.broadcast(np.atleast_1d(ahead_m), indentation_m, traction_n).shape
    zeros = np.zeros((1, *shape, 3))
    return sensors.Mechanics(
        mount_force=zeros,
        mount_torque=zeros,
        contact_ahead_m=np.broadcast_to(ahead_m, shape)[None],
        indentation_m=np.broadcast_to(indentation_m, shape)[None],
        traction_n=np.broadcast_to(traction_n, shape)[None],
    )


def test_a_film_far_from_the_contact_strains_with_the_skins_curvature_not_its_sag():
    """A film that the skin only carries along, without bending it, has no strain: far
    from the contact the surface sags as 1/r but bends as 1/r^3, and the film's strain
    falls with the bend (a quarter of the distance: 64 times less, where the sag is 4
    times less)."""
    pv = dataclasses.replace(FLAT.pvdf, shear_strain_per_n=0.0)
    delta = 0.8e-3
    # The contact this far behind the axis: the front film's centre 20 and 80 mm from it.
    behind = pv.offset_m - np.array([20e-3, 80e-3])
    front = sensors.film_strains(_mech(behind, delta), FLAT.finger, pv)[0, 0]
    sag = contact.surface_deflection_m(pv.offset_m - behind, delta, FLAT.finger.pad_radius_m)
    assert sag[0] / sag[1] == pytest.approx(4.0, rel=0.01)
    assert front[0] / front[1] == pytest.approx(64.0, rel=0.05)


def test_the_traction_shortens_the_front_film_and_stretches_the_rear_one():
    pv = FLAT.pvdf
    strains = sensors.film_strains(_mech(0.0, 0.0, traction_n=0.5), FLAT.finger, pv)[0, :, 0]
    np.testing.assert_allclose(strains, [-0.5 * pv.shear_strain_per_n, 0.5 * pv.shear_strain_per_n])


def test_the_films_shear_coupling_is_the_cerruti_load_over_their_stiffness():
    """(1 + nu) / (pi x sum(E t)) for the skin's Poisson ratio, the film's distance from
    the contact, and the film on its 75 um polyester carrier (4-5 GPa); a thicker
    carrier stiffens the laminate and lowers it (1.83e-4 per newton on 125 um)."""
    pv, finger = FLAT.pvdf, FLAT.finger
    for polyester_pa in (4.0e9, 4.5e9, 5.0e9):
        stiffness = pv.youngs_modulus_pa * pv.thickness_m + polyester_pa * 75e-6
        derived = (1 + finger.skin_poisson) / (math.pi * pv.offset_m * stiffness)
        assert pv.shear_strain_per_n == pytest.approx(derived, rel=0.1), polyester_pa
        _, shear = sensors.film_on_carrier(pv, finger, 75e-6, polyester_pa)
        assert shear == pytest.approx(derived, rel=1e-12), polyester_pa
    _, default = sensors.film_on_carrier(pv, finger, 75e-6, 4.5e9)
    assert default == pytest.approx(pv.shear_strain_per_n, rel=0.02)
    _, laminate = sensors.film_on_carrier(pv, finger, 125e-6, 4.5e9)
    assert laminate == pytest.approx(1.83e-4, rel=0.01)
    shears = [sensors.film_on_carrier(pv, finger, t, 4.5e9)[1] for t in (10e-6, 50e-6, 1e-4)]
    assert shears[0] > shears[1] > default > shears[2] > laminate


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
    config = _with_material(FLAT, "wood", texture=grain)
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


def test_line_average_variance_matches_a_simulated_average():
    """The variance factor of roughness averaged along a ridge's line contact agrees with
    averaging a simulated exponentially correlated profile over windows of that length,
    and has the right limits (1 for a point, ~2 l / L for a long line)."""
    corr = 40e-6
    assert synth.texture.line_average_variance(corr, 0.0) == 1.0
    assert synth.texture.line_average_variance(corr, 1e-9) == pytest.approx(1.0, abs=1e-4)
    assert synth.texture.line_average_variance(corr, 1000 * corr) == pytest.approx(2e-3, rel=0.01)
    rough = Texture(roughness_rms_m=1e-6, correlation_length_m=corr)
    h = synth.texture.profile(rough, 2.0, np.random.default_rng(3))
    for length in (100e-6, 400e-6, 2e-3):
        w = round(length / synth.texture.GRID_M)
        means = np.convolve(h, np.ones(w) / w, mode="valid")
        expected = synth.texture.line_average_variance(corr, length)
        assert np.var(means) / np.var(h) == pytest.approx(expected, rel=0.15), length


def test_the_ridges_line_contact_averages_roughness_but_not_marks():
    """Random roughness felt through a contact of radius a is smaller than a point's by
    the line-average factor of the ridges' mean chord; periodic marks across the path are
    felt in full. (A fixed set of ridges, equally wide, so that only the chords change
    with a.)"""
    finger = dataclasses.replace(
        SynthConfig().finger, ridges_in_contact=7, ridge_width_pressure_exponent=0.0
    )
    rough = Texture(roughness_rms_m=2e-6, correlation_length_m=40e-6)
    marks = Texture(0.0, 1e-4, periodic=(Periodic(wavelength_m=0.5e-3, amplitude_m=1e-6),))

    def felt(texture, radius_m):
        rng = np.random.default_rng(5)
        return synth.texture.felt_surface(texture, finger, 0.0, 0.5, rng, contact_radius_m=radius_m)

    a = 2.4e-3
    offsets = synth.texture.ridge_offsets(finger)
    chord = float(np.mean(2 * np.sqrt(a**2 - offsets**2)))
    ratio = np.std(felt(rough, a).height_m) / np.std(felt(rough, 0.0).height_m)
    assert ratio == pytest.approx(np.sqrt(synth.texture.line_average_variance(40e-6, chord)))
    assert ratio < 0.2
    np.testing.assert_array_equal(felt(marks, a).height_m, felt(marks, 0.0).height_m)


def test_a_ridge_presses_as_a_hertzian_line_contact():
    """Each ridge averages the surface with the pressure across its width: elliptical
    (exponent 0.5, a Hertzian line contact), whose transfer at wavelength lambda is the
    continuous ellipse's ``2 J1(x) / x``, ``x = pi w / lambda``, and has no zero at the
    wavelengths a box of the same width removes whole; exponent 0 is that box."""
    from scipy.special import j1

    finger = SynthConfig().finger
    assert finger.ridge_profile_exponent == 0.5
    w = finger.ridge_width_m
    taps = synth.texture.ridge_taps(finger, w)
    half = round(w / (2 * synth.texture.GRID_M))
    assert taps.size == 2 * half - 1 and math.isclose(taps.sum(), 1.0, rel_tol=1e-12)
    np.testing.assert_array_equal(taps, taps[::-1])
    t = (np.arange(taps.size) - (taps.size - 1) / 2) / half
    np.testing.assert_allclose(taps / taps.max(), np.sqrt(1 - t * t), rtol=1e-12)
    for wavelength in (0.1e-3, 0.15e-3, 0.3e-3, 0.5e-3):
        x = math.pi * w / wavelength
        got = synth.texture.ridge_gains(finger, np.array([w]), wavelength)[0]
        assert got == pytest.approx(2 * j1(x) / x, abs=0.01), wavelength
    box = dataclasses.replace(finger, ridge_profile_exponent=0.0)
    cells = round(w / synth.texture.GRID_M)
    np.testing.assert_array_equal(synth.texture.ridge_taps(box, w), np.full(cells, 1 / cells))
    # A box as wide as the mark's wavelength removes it; the rounded ridge passes a part.
    lam = w
    assert abs(synth.texture.ridge_gains(box, np.array([w]), lam)[0]) < 1e-9
    assert abs(synth.texture.ridge_gains(finger, np.array([w]), lam)[0]) > 0.1
    # A ridge narrower than two cells samples the surface at its line.
    np.testing.assert_array_equal(synth.texture.ridge_taps(finger, 1e-6), [1.0])


def test_the_ridges_narrow_towards_the_contacts_rim():
    """A ridge's contact width grows as the square root of its load per length, which
    follows the pad's Hertz pressure ``sqrt(1 - (r / a)^2)`` where the ridge lies: the
    central ridge is ``ridge_width_m`` wide, one halfway to the rim ``(3/4)^(1/4)`` of
    that, the rim's none; with the exponent 0 (or in a point contact) all are equal."""
    finger = SynthConfig().finger
    a, w = 2.4e-3, finger.ridge_width_m
    offsets = np.array([0.0, a / 2, -a / 2, 0.9 * a, a, 1.2 * a])
    got = synth.texture.ridge_widths_m(finger, offsets, a)
    np.testing.assert_allclose(got[:4], w * np.array([1.0, 0.75**0.25, 0.75**0.25, 0.19**0.25]))
    assert got[4] == 0.0 and got[5] == 0.0
    even = dataclasses.replace(finger, ridge_width_pressure_exponent=0.0)
    np.testing.assert_array_equal(synth.texture.ridge_widths_m(even, offsets, a), np.full(6, w))
    np.testing.assert_array_equal(synth.texture.ridge_widths_m(finger, offsets, 0.0), np.full(6, w))
    # The loaded surface's ridges read the marks through their own widths: a layer's
    # marks equal the chord-weighted sum of every ridge's own transfer.
    wavelength = 0.1e-3
    marks = Texture(0.0, 1e-4, periodic=(Periodic(wavelength_m=wavelength, amplitude_m=1e-6),))
    surface = synth.texture.loaded_surface(
        marks, finger, 0.0, 0.02, np.random.default_rng(4), force_n=1.0
    )
    layer = list(synth.texture.LOAD_LAYERS).index(0)
    a = float(surface.radii_m[layer])
    offsets, weights = synth.texture.touching_ridges(finger, a)
    gains = synth.texture.ridge_gains(
        finger, synth.texture.ridge_widths_m(finger, offsets, a), wavelength
    )
    felt = np.abs(np.sum(weights * gains * np.exp(2j * np.pi * offsets / wavelength)))
    felt /= weights.sum()
    inner = surface.height_m[layer, 1000:-1000]
    assert np.sqrt(2) * np.std(inner) / 1e-6 == pytest.approx(felt, rel=0.02)


def _ridge_samples(finger, width_m):
    """``(taps, offsets_m)``: a ridge's weights across its width and where each samples
    the surface relative to the ridge, as ``np.convolve(..., mode="same")`` aligns a
    kernel of that length."""
    taps = synth.texture.ridge_taps(finger, width_m)
    return taps, (np.arange(taps.size) - taps.size // 2) * synth.texture.GRID_M


@pytest.mark.slow
def test_marks_at_an_angle_to_the_ridges_are_felt_as_their_mean_along_each_chord():
    """A turned specimen's marks cross each ridge's line contact at an angle: the felt
    surface equals the marks averaged numerically along every ridge's chord of the
    contact circle (then over the ridges), and is weaker than with aligned marks."""
    finger = SynthConfig().finger
    wavelength, amplitude, a = 85e-6, 1e-6, 2.4e-3
    marks = Texture(0.0, 1e-4, periodic=(Periodic(wavelength_m=wavelength, amplitude_m=amplitude),))
    offsets, weights = synth.texture.touching_ridges(finger, a)
    chords = 2 * np.sqrt(a**2 - offsets**2)
    np.testing.assert_array_equal(weights, chords)
    grid = synth.texture.GRID_M
    widths = synth.texture.ridge_widths_m(finger, offsets, a)

    def felt(angle):
        rng = np.random.default_rng(11)
        return synth.texture.felt_surface(
            marks, finger, 0.0, 0.02, rng, contact_radius_m=a, mark_angle_rad=angle
        )

    aligned = felt(0.0)
    phase = np.random.default_rng(11).uniform(0, 2 * np.pi)  # the profile's one draw
    s = np.arange(aligned.height_m.size) * grid  # the profile's own coordinate (phase 0 at 0)
    inner = slice(1000, -1000)  # away from the box filter's ends
    for angle in (0.004, 0.01, 0.03):
        # The surface at path coordinate x and across-path y: marks along the specimen's
        # y axis, turned by the angle. Each ridge averages it along its chord (y) and
        # across its width (x, weighted by the pressure across it), the pad over the
        # ridges, each weighted by its chord.
        y = np.linspace(-0.5, 0.5, 401)
        expected = np.zeros_like(s)
        for o, c, w in zip(offsets, chords, widths, strict=True):
            taps, at = _ridge_samples(finger, w)
            xs = s[:, None] + o + at[None, :]
            u = xs[..., None] + (c * y * np.tan(angle))[None, None, :]
            h = amplitude * np.cos(2 * np.pi * u / wavelength + phase)
            expected += c * (h.mean(axis=2) @ taps)
        expected /= chords.sum()
        got = felt(angle).height_m
        scale = np.abs(expected[inner]).max()
        assert np.abs(got[inner] - expected[inner]).max() < 0.02 * scale, angle
        assert np.std(got[inner]) < np.std(aligned.height_m[inner])


def test_the_ridges_inside_the_contact_touch_and_a_larger_load_brings_more_in():
    """The ridges that touch are the fingerprint's ridges inside the Hertz contact circle
    (weighted by their chords): a wider contact under a larger load holds more of them,
    and averages the random roughness further down."""
    finger = SynthConfig().finger
    everything = synth.texture.ridge_offsets(finger)
    assert everything.size == 32  # the fingerprint covers the 14 mm pad
    rough = Texture(roughness_rms_m=2e-6, correlation_length_m=40e-6)
    counts, felt_rms = [], []
    for force in (0.3, 1.0, 3.0):
        a = math.sqrt(
            finger.pad_radius_m
            * synth.contact.hertz_indentation_m(
                force, finger.pad_radius_m, finger.skin_modulus_pa, finger.skin_poisson
            )
        )
        offsets, weights = synth.texture.touching_ridges(finger, a)
        np.testing.assert_array_equal(offsets, everything[np.abs(everything) < a])
        assert np.all(weights > 0) and np.all(weights <= 2 * a)
        counts.append(offsets.size)
        rng = np.random.default_rng(3)
        felt = synth.texture.felt_surface(rough, finger, 0.0, 0.5, rng, contact_radius_m=a)
        felt_rms.append(np.std(felt.height_m))
    assert counts[0] < counts[1] < counts[2] and counts[1] == 10
    assert felt_rms[0] > 1.2 * felt_rms[1] and felt_rms[1] > 1.2 * felt_rms[2]  # ~1.4-1.5x
    # a point contact rests on the ridge nearest its centre
    offsets, weights = synth.texture.touching_ridges(finger, 0.0)
    assert offsets.size == 1 and abs(offsets[0]) == np.abs(everything).min()


def test_each_load_layer_is_felt_through_the_ridges_inside_its_contact():
    """A load-following surface holds one layer per tabulated load: the contact radius of
    that load (Hertz), and the marks as the ridges inside that contact feel them (each
    averaged over its width, weighted by its chord). A larger load brings more ridges in
    and averages the random roughness further down."""
    finger = SynthConfig().finger
    wavelength, amplitude, force = 0.45e-3, 1e-6, 1.0
    marks = Texture(0.0, 1e-4, periodic=(Periodic(wavelength_m=wavelength, amplitude_m=amplitude),))
    surface = synth.texture.loaded_surface(
        marks, finger, 0.0, 0.02, np.random.default_rng(11), force_n=force
    )
    ratios = synth.texture.LOAD_RATIO ** np.array(synth.texture.LOAD_LAYERS, dtype=float)
    np.testing.assert_allclose(surface.loads_n, force * ratios)
    np.testing.assert_allclose(
        surface.radii_m, synth.texture.contact_radius_m(finger, surface.loads_n)
    )
    assert surface.loads_n.min() <= 0.5 * force and surface.loads_n.max() >= 2.0 * force
    phase = np.random.default_rng(11).uniform(0, 2 * np.pi)  # the profile's one draw
    grid = synth.texture.GRID_M
    s = np.arange(surface.height_m.shape[1]) * grid  # the profile's own coordinate
    inner = slice(1000, -1000)
    counts = []
    for layer, a in zip(surface.height_m, surface.radii_m, strict=True):
        offsets, weights = synth.texture.touching_ridges(finger, a)
        counts.append(offsets.size)
        expected = np.zeros_like(s)
        widths = synth.texture.ridge_widths_m(finger, offsets, a)
        for o, c, w in zip(offsets, weights, widths, strict=True):
            taps, at = _ridge_samples(finger, w)
            xs = s[:, None] + o + at[None, :]
            expected += c * (np.cos(2 * np.pi * xs / wavelength + phase) @ taps)
        expected *= amplitude / weights.sum()
        scale = np.abs(expected[inner]).max()
        assert np.abs(layer[inner] - expected[inner]).max() < 0.01 * scale, a
    assert counts == sorted(counts) and counts[0] < counts[-1]
    rough = Texture(roughness_rms_m=2e-6, correlation_length_m=40e-6)
    felt = synth.texture.loaded_surface(
        rough, finger, 0.0, 0.2, np.random.default_rng(3), force_n=force
    )
    rms = np.std(felt.height_m, axis=1)
    assert np.all(np.diff(rms) < 0) and rms[0] > 1.3 * rms[-1]


def test_a_fixed_number_of_ridges_feels_the_same_surface_under_any_load():
    """With ``ridges_in_contact`` an integer the surface has one layer, the set-point
    force's felt surface bit for bit (a store made so regenerates unchanged), and the
    closed loop's table ignores the load."""
    finger = dataclasses.replace(SynthConfig().finger, ridges_in_contact=7)
    texture = synth.materials.MATERIALS["resin"].texture
    loaded = synth.texture.loaded_surface(
        texture, finger, 0.0, 0.02, np.random.default_rng(2), force_n=1.3
    )
    plain = synth.texture.felt_surface(
        texture,
        finger,
        0.0,
        0.02,
        np.random.default_rng(2),
        contact_radius_m=float(synth.texture.contact_radius_m(finger, 1.3)),
    )
    assert loaded.height_m.shape == (1, plain.height_m.size)
    np.testing.assert_array_equal(loaded.height_m[0], plain.height_m)
    np.testing.assert_array_equal(loaded.slope[0], plain.slope)
    table = synth.texture.texture_table([loaded])
    coord = np.array([[0.004, 0.01]])
    light, heavy = table(coord.copy(), np.array([0.2])), table(coord.copy(), np.array([3.0]))
    assert np.array_equal(light[0], heavy[0]) and np.array_equal(light[1], heavy[1])


def test_the_layered_table_reads_each_trial_at_its_own_load():
    """Under a tabulated load the table gives that layer (interpolated along the path);
    between two, a value between theirs, linear in the load's logarithm; beyond the
    outermost, the outermost layer; a trial's values do not depend on its batch."""
    finger = SynthConfig().finger
    texture = synth.materials.MATERIALS["wood"].texture
    surfaces = [
        synth.texture.loaded_surface(
            texture, finger, 0.0, 0.01, np.random.default_rng(seed), force_n=force
        )
        for seed, force in ((1, 1.0), (2, 0.6), (3, 1.4))
    ]
    table = synth.texture.texture_table(surfaces)
    assert isinstance(table, synth.texture.LayeredTable)
    coord = np.array([[0.002, 0.0050001], [0.003, 0.007], [0.001, 0.004]])

    def layer_values(i, j):
        s = surfaces[i]
        h = synth.texture.look_up(np.array([s.origin_m]), s.height_m[j][None], coord[i : i + 1])
        g = synth.texture.look_up(np.array([s.origin_m]), s.slope[j][None], coord[i : i + 1])
        return h[0], g[0]

    for j in range(surfaces[0].loads_n.size):
        loads = np.array([s.loads_n[j] for s in surfaces])
        h, g = table(coord.copy(), loads)
        for i in range(3):
            want_h, want_g = layer_values(i, j)
            np.testing.assert_allclose(h[i], want_h, rtol=1e-6, atol=1e-12)
            np.testing.assert_allclose(g[i], want_g, rtol=1e-6, atol=1e-6)
    # A third of the way (in log load) from layer 1 to layer 2.
    loads = np.array([s.loads_n[1] * synth.texture.LOAD_RATIO ** (1 / 3) for s in surfaces])
    h, _ = table(coord.copy(), loads)
    for i in range(3):
        low, high = layer_values(i, 1)[0], layer_values(i, 2)[0]
        np.testing.assert_allclose(h[i], low + (high - low) / 3, rtol=1e-5, atol=1e-12)
        at = surfaces[i].at(float(loads[i]))
        np.testing.assert_allclose(
            h[i],
            synth.texture.look_up(np.array([at.origin_m]), at.height_m[None], coord[i : i + 1])[0],
            rtol=1e-5,
            atol=1e-12,
        )
    # Beyond the layers: the outermost ones (no load at all: the lightest).
    h, _ = table(coord.copy(), np.array([0.0, 0.01, 100.0]))
    np.testing.assert_allclose(h[0], layer_values(0, 0)[0], rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(h[2], layer_values(2, -1)[0], rtol=1e-6, atol=1e-12)
    alone = synth.texture.texture_table(surfaces[1:2])(coord[1:2].copy(), np.array([0.9]))
    both = table(coord.copy(), np.array([1.0, 0.9, 1.4]))
    assert np.array_equal(alone[0], both[0][1:2]) and np.array_equal(alone[1], both[1][1:2])


def test_the_felt_surface_follows_the_simulated_load():
    """The closed loop reads the felt surface at the normal load it simulates: with
    layers of constant, distinct heights, the specimen is driven every update period to
    the height of the load the contact carried at the end of the period before."""
    config = SynthConfig()
    plan = sim.plan(TrialSpec("pentagram", "wood", seed=4), config)
    real = plan.loop.surface
    n = real.height_m.shape[1]
    levels = np.arange(real.loads_n.size) * 1e-6  # 1 um per layer
    marker = dataclasses.replace(
        real, height_m=np.repeat(levels[:, None], n, axis=1), slope=np.zeros((levels.size, n))
    )
    plan = dataclasses.replace(plan, loop=dataclasses.replace(plan.loop, surface=marker))
    sens, surface = sim._roll([plan], [mujoco.MjData(plan.model)], config)
    heights = surface[..., 0]
    cols = scene_mod.sensor_columns()
    found = sens[0, :, cols["contact"].start] > 0
    normal = np.where(found, -sens[0, :, cols["contact"].start + 3], 0.0)
    k = config.motion.surface_steps
    periods = heights.shape[1] // k
    load = np.concatenate([[plan.loop.force_n], normal[k - 1 :: k][: periods - 1]])
    pos = np.log(np.maximum(load, 1e-9) / real.loads_n[0]) / np.log(synth.texture.LOAD_RATIO)
    want = np.clip(pos, 0, levels.size - 1) * 1e-6
    got = heights[0, ::k][:periods]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert np.ptp(got) > 0.3e-6  # the load (and so the felt layer) changed at the edges


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


def test_a_fixed_number_of_ridges_is_accepted_or_refused_by_name():
    base = SynthConfig().finger
    assert dataclasses.replace(base, ridges_in_contact=7).ridges_in_contact == 7
    for bad in (0, 2.5, True, "7"):
        with pytest.raises(ValueError, match=r"Finger\.ridges_in_contact"):
            dataclasses.replace(base, ridges_in_contact=bad)


@pytest.mark.parametrize(
    ("material", "ra_range_m"),
    [("resin", (1e-6, 3e-6)), ("wood", (3e-6, 8e-6)), ("aluminum", (0.34e-6, 0.48e-6))],
)
def test_each_surface_profile_has_the_roughness_its_source_measured(material, ra_range_m):
    """A stylus profile of each specimen (roughness and marks along the path, no ridge
    averaging), filtered as a profilometer reports Ra (ISO 16610 Gaussian mean line,
    0.8 mm cut-off), has the Ra that ``synth.materials`` cites for the material."""
    from scipy.ndimage import gaussian_filter1d

    texture = synth.materials.MATERIALS[material].texture
    grid = synth.texture.GRID_M
    cutoff_m = 0.8e-3
    sigma = np.sqrt(np.log(2) / np.pi) * cutoff_m / np.sqrt(2 * np.pi) / grid
    edge = round(cutoff_m / grid)  # one cut-off at each end, where the filter runs out
    for seed in range(3):
        h = synth.texture.profile(texture, 0.04, np.random.default_rng(seed))
        rough = (h - gaussian_filter1d(h, sigma, mode="reflect"))[edge:-edge]
        ra = np.mean(np.abs(rough - rough.mean()))
        assert ra_range_m[0] <= ra <= ra_range_m[1], (seed, ra)


def test_the_texture_table_interpolates_as_look_up_does():
    """The closed loop's texture table gives each trial's own height and slope at its own
    coordinates, as the plain interpolation does (to the last bits), clamped at the ends."""
    rng = np.random.default_rng(3)
    b, n = 5, 200
    origins = rng.uniform(-1e-3, 1e-3, b)
    heights = rng.normal(0.0, 1e-6, (b, n))
    slopes = rng.normal(0.0, 1e-2, (b, n))
    grid = synth.texture.GRID_M
    # Inside the rows, off their start and past their end.
    coord = origins[:, None] + rng.uniform(-5 * grid, (n + 5) * grid, (b, 7))
    table = synth.texture.TextureTable(origins, heights, slopes)
    h, s = table(coord.copy())
    assert h.shape == s.shape == (b, 7)
    np.testing.assert_allclose(
        h, synth.texture.look_up(origins, heights, coord), rtol=1e-12, atol=1e-18
    )
    np.testing.assert_allclose(
        s, synth.texture.look_up(origins, slopes, coord), rtol=1e-12, atol=1e-14
    )
    # A trial's values do not depend on the rest of the batch.
    h1, s1 = synth.texture.TextureTable(origins[2:3], heights[2:3], slopes[2:3])(coord[2:3])
    assert np.array_equal(h1, h[2:3]) and np.array_equal(s1, s[2:3])
    # Clamped: before the first grid point the first value holds.
    before = np.full((b, 1), -1.0)
    assert np.allclose(table(before)[0][:, 0], heights[:, 0], rtol=0, atol=1e-18)


def _sos_rms(x: np.ndarray, sos: np.ndarray) -> float:
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(signal.sosfiltfilt(sos, x - x.mean()) ** 2)))


def test_the_films_read_the_textures_push_with_one_gain_across_the_band():
    """The texture's push reaches the films through the contact whatever its frequency: on
    a pure sinusoid (slope amplitude 0.02) slid at 10 mm/s over the square's top, the
    films' RMS per unit of push at 170 Hz is within 15 % of that at 40 Hz, trial by trial
    (0.96-0.98 over 10 seeds). A push the contact took up would fall with frequency: the
    contact's friction would change against it."""
    ratios = {}
    for freq in (40.0, 170.0):
        wavelength = 10e-3 / freq
        wave = Texture(0.0, 1e-4, (Periodic(wavelength, 0.02 * wavelength / (2 * math.pi)),))
        config = _with_material(SynthConfig(), "resin", texture=wave)
        sos = signal.butter(
            4, (0.85 * freq, 1.15 * freq), "bandpass", fs=SAMPLE_RATE_HZ, output="sos"
        )
        ratios[freq] = []
        for trial in simulate_batch(
            [TrialSpec("square", "resin", seed=s) for s in range(3)], config=config
        ):
            x, y = trial.truth["finger_x_m"], trial.truth["finger_y_m"]
            top = np.flatnonzero((np.abs(x) < 5e-3) & (np.abs(y) < 5e-3))  # 3 mm from the walls
            seg = slice(top[0], top[-1] + 1)

            films = np.mean([_sos_rms(trial.signals[c, seg], sos) for c in (0, 1)])
            ratios[freq].append(films / _sos_rms(trial.truth["texture_push_n"][seg], sos))
    gain = np.array(ratios[170.0]) / np.array(ratios[40.0])
    assert np.all(np.abs(gain - 1) < 0.15), gain


@pytest.mark.parametrize("speed", [6.0, 10.0, 14.0])
def test_a_sinusoidal_surface_peaks_the_films_at_speed_over_wavelength(speed):
    """A pure sinusoidal surface (0.24 mm wavelength, 2 um amplitude, no roughness): while the
    pad slides over the square's top (never stuck), the films' spectrum peaks at the
    measured speed over the wavelength within 5 %, with the default finger, films and
    acquisition, over several seeds."""
    wave = Texture(0.0, 1e-4, (Periodic(wavelength_m=0.24e-3, amplitude_m=2e-6),))
    config = _with_material(SynthConfig(), "resin", texture=wave)
    specs = [TrialSpec("square", "resin", speed_mm_s=speed, seed=s) for s in range(3)]
    for trial in simulate_batch(specs, config=config):
        x, y = trial.truth["finger_x_m"], trial.truth["finger_y_m"]
        top = np.flatnonzero((np.abs(x) < 5e-3) & (np.abs(y) < 5e-3))  # 3 mm from the walls
        seg = slice(top[0], top[-1] + 1)
        assert seg.stop - seg.start > 500, seg
        slip = trial.truth["slip_speed_m_s"][seg]
        assert slip.min() > 0.5 * speed * 1e-3, slip.min()  # sliding, not stuck
        v = (x[seg.stop - 1] - x[seg.start]) / ((seg.stop - seg.start - 1) / SAMPLE_RATE_HZ)
        f, p = signal.periodogram(
            trial.signals[0, seg].astype(float), fs=SAMPLE_RATE_HZ, nfft=8192, window="hann"
        )
        band = (f > 20) & (f < 400)
        peak = f[band][np.argmax(p[band])]
        assert peak == pytest.approx(v / 0.24e-3, rel=0.05), (trial.spec.seed, peak, v / 0.24e-3)
