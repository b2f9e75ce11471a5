"""Physics checks of the PVDF films: what strains them (the skin's bending and the
traction at the contact), how the texture reaches them, and what their readout passes;
each asserts a measurable physical property."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import signal

from synth import contact, sensors
from synth import simulator as sim
from synth.config import SynthConfig
from synth.materials import FrictionLaw, Periodic, Texture
from synth.simulator import simulate_batch
from synth.trial import SAMPLE_RATE_HZ, TrialSpec
from tests.physics_support import (
    COMPLIANT,
    FLAT,
    NOMINAL,
    PVDF,
    SG,
    STEADY,
    flat_trial,
    pvdf_rms,
    roll_plans,
    with_material,
)


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
        return np.mean([pvdf_rms(t) for t in simulate_batch(specs, config=FLAT)])

    assert rms(20.0) > 1.25 * rms(5.0)


def _fine_texture_config(base: SynthConfig, law: FrictionLaw | None = None) -> SynthConfig:
    """A finger with one narrow ridge, so 0.1 mm marks (0.15 um deep) pass unfiltered, on a
    surface that slides steadily unless ``law`` says otherwise."""
    finger = dataclasses.replace(base.finger, ridges_in_contact=1, ridge_width_m=10e-6)
    marks = Texture(0.0, 1e-4, (Periodic(wavelength_m=0.1e-3, amplitude_m=0.15e-6),))
    steady = FrictionLaw(kinetic=0.6, static=0.6, load_exponent=0.0)
    return with_material(
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
    sliding = flat_trial("aluminum", config=_fine_texture_config(bending))
    law = FrictionLaw(kinetic=0.4, static=2.0, stribeck_velocity_m_s=2e-3, load_exponent=0.0)
    sticky = flat_trial("aluminum", config=_fine_texture_config(bending, law))
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
    (trial,) = roll_plans([plan], config)[1]
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
    (trial,) = roll_plans([plan], config)[1]
    pad_x = trial.truth["finger_x_m"]
    for start in range(100, 1900, 200):
        block = slice(start, start + 200)
        speed = (pad_x[block][-1] - pad_x[block][0]) / 0.199
        f, p = signal.periodogram(trial.signals[0, block].astype(float), fs=SAMPLE_RATE_HZ)
        band = f > 30
        peak = f[band][np.argmax(p[band])]
        assert peak == pytest.approx(speed / 0.1e-3, rel=0.10), (start, peak, speed)


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
        return np.mean([pvdf_rms(t) for t in trials])

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
    assert pvdf_rms(flat_trial(config=with_material(FLAT, "wood", texture=rough))) > 1.5 * pvdf_rms(
        flat_trial()
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
    config = with_material(FLAT, "resin", texture=periodic)
    for speed in (8.0, 16.0):
        trial = flat_trial("resin", speed_mm_s=speed, config=config)
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
            config = with_material(config, "wood", texture=texture)
        return flat_trial(config=config)

    wood = FLAT.materials["wood"].texture
    rough = dataclasses.replace(wood, roughness_rms_m=3 * wood.roughness_rms_m)
    np.testing.assert_array_equal(pvdf(0.0).signals[PVDF], pvdf(0.0, rough).signals[PVDF])
    assert not np.array_equal(pvdf(0.0).signals[SG], pvdf(0.0, rough).signals[SG])

    noise = pvdf_rms(pvdf(0.0))
    default = FLAT.pvdf.neutral_axis_offset_m
    once, twice = (np.sqrt(pvdf_rms(pvdf(k * default)) ** 2 - noise**2) for k in (1, 2))
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
        config = with_material(SynthConfig(), "resin", texture=wave)
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
    config = with_material(SynthConfig(), "resin", texture=wave)
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


def test_a_viscoelastic_skin_meets_the_texture_with_its_complex_modulus():
    """The same pure sinusoid (slope amplitude 0.02) slid at 10 mm/s, the same seeds, under
    the elastic and the viscoelastic skin: the texture's push on the skin grows by
    ``|E*(omega)| / E_inf`` of the silicone at the sinusoid's frequency (1.23 at 20 Hz,
    1.30 at 170 Hz) within 1.5 %, and the films' reading within 2 % (over 10 seeds each
    within 0.42 % and 0.54 %)."""
    from synth.viscoelastic import SILICONE_PRONY, Viscoelastic

    skin = Viscoelastic(1.0, SILICONE_PRONY)
    for freq in (20.0, 170.0):
        wavelength = 10e-3 / freq
        wave = Texture(0.0, 1e-4, (Periodic(wavelength, 0.02 * wavelength / (2 * math.pi)),))
        elastic = with_material(SynthConfig(), "resin", texture=wave)
        finger = dataclasses.replace(elastic.finger, skin_texture_response="viscoelastic")
        sos = signal.butter(
            4, (0.85 * freq, 1.15 * freq), "bandpass", fs=SAMPLE_RATE_HZ, output="sos"
        )
        specs = [TrialSpec("square", "resin", seed=s) for s in range(2)]
        runs = [
            simulate_batch(specs, config=c)
            for c in (elastic, dataclasses.replace(elastic, finger=finger))
        ]
        want = abs(complex(skin.complex_modulus_pa(2 * math.pi * freq)))
        for plain, visco in zip(*runs, strict=True):
            x, y = plain.truth["finger_x_m"], plain.truth["finger_y_m"]
            top = np.flatnonzero((np.abs(x) < 5e-3) & (np.abs(y) < 5e-3))
            seg = slice(top[0], top[-1] + 1)
            push = [_sos_rms(t.truth["texture_push_n"][seg], sos) for t in (plain, visco)]
            films = [
                np.mean([_sos_rms(t.signals[c, seg], sos) for c in (0, 1)]) for t in (plain, visco)
            ]
            assert push[1] / push[0] == pytest.approx(want, rel=0.015), (freq, push)
            assert films[1] / films[0] == pytest.approx(want, rel=0.02), (freq, films)
