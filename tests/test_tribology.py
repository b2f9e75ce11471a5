"""The derived friction (synth.tribology) and the skin's complex modulus
(synth.viscoelastic): numerical integrals against closed forms, limits, and the option
that selects the model."""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest
from scipy.special import erf

import synth
from synth import tribology
from synth.materials import MATERIALS, Periodic, Texture
from synth.viscoelastic import PronyTerm, Viscoelastic

FINGER = synth.SynthConfig().finger


def test_the_complex_modulus_runs_from_the_relaxed_to_the_unrelaxed_modulus():
    skin = Viscoelastic(3e5, (PronyTerm(0.5, 1e-3), PronyTerm(1.0, 1e-1)))
    low, high = skin.complex_modulus_pa([1e-6, 1e9])
    assert low.real == pytest.approx(3e5, rel=1e-6) and abs(low.imag) < 1.0
    assert high.real == pytest.approx(3e5 * 2.5, rel=1e-5)
    w = np.geomspace(1e-2, 1e6, 200)
    e = skin.complex_modulus_pa(w)
    assert (np.diff(e.real) > 0).all() and (e.imag > 0).all()
    # One Maxwell arm's loss peaks at omega tau = 1, with the closed form's height.
    one = Viscoelastic(1.0, (PronyTerm(2.0, 1e-2),))
    assert one.complex_modulus_pa(100.0).imag == pytest.approx(1.0, rel=1e-12)


def _elastic(shear_pa: float, cutoff_m: float) -> tribology.SkinTribology:
    return tribology.SkinTribology(
        prony=(), interfacial_shear_stress_pa=shear_pa, roughness_cutoff_m=cutoff_m
    )


@pytest.mark.parametrize("rms_m, length_m", [(3e-6, 40e-6), (7e-6, 120e-6), (0.3e-6, 15e-6)])
def test_an_elastic_skin_has_persson_contact_area_of_the_closed_form_and_no_hysteresis(
    rms_m, length_m
):
    # For an elastic skin, G(q1) = (E* / sigma0)^2 <|grad h|^2> / 8, and the exponential
    # texture's spectrum integrates to a closed form: <|grad h|^2> = (h / l)^2 [s(u)]_uL^u1
    # with s(u) = sqrt(1 + u^2) + 1 / sqrt(1 + u^2), u = q l.
    cutoff = 10e-6
    tri = _elastic(5e4, cutoff)
    texture = Texture(roughness_rms_m=rms_m, correlation_length_m=length_m)
    got = tribology.friction(texture, FINGER, tri, speed_m_s=0.01, force_n=1.0)
    sigma0 = tribology.nominal_pressure_pa(FINGER, 1.0)
    e_star = FINGER.skin_modulus_pa / (1 - FINGER.skin_poisson**2)
    q_lo = 2 * math.pi / tribology._contact_diameter_m(FINGER, 1.0)
    q_hi = 2 * math.pi / cutoff

    def s(u):
        return math.sqrt(1 + u * u) + 1 / math.sqrt(1 + u * u)

    slope2 = (rms_m / length_m) ** 2 * (s(q_hi * length_m) - s(q_lo * length_m))
    g = (e_star / sigma0) ** 2 * slope2 / 8
    want = erf(1 / (2 * math.sqrt(g)))
    assert got.contact_fraction == pytest.approx(want, rel=2e-3)
    assert got.hysteresis == 0.0
    assert got.adhesion == pytest.approx(5e4 * want / sigma0, rel=2e-3)


def test_a_smooth_surface_is_in_full_contact_and_its_friction_is_the_interfaces_shear():
    flat = Texture(roughness_rms_m=0.0, correlation_length_m=5e-6)
    got = tribology.friction(flat, FINGER, tribology.SILICONE_TRIBOLOGY, speed_m_s=0.01, force_n=1)
    sigma0 = tribology.nominal_pressure_pa(FINGER, 1.0)
    assert got.contact_fraction == 1.0 and got.hysteresis == 0.0
    assert got.total == pytest.approx(
        tribology.SILICONE_TRIBOLOGY.interfacial_shear_stress_pa / sigma0, rel=1e-12
    )


def test_a_periodic_mark_adds_the_sinusoids_closed_form_hysteresis():
    # A sinusoid alone, small enough to stay in full contact: mu_h = k^2 A^2 Im E*(k v)
    # / (4 (1 - nu^2) sigma0).
    wave, amp, v = 100e-6, 0.05e-6, 0.01
    texture = Texture(0.0, 5e-6, (Periodic(wavelength_m=wave, amplitude_m=amp),))
    tri = tribology.SILICONE_TRIBOLOGY
    got = tribology.friction(texture, FINGER, tri, speed_m_s=v, force_n=1.0)
    k = 2 * math.pi / wave
    sigma0 = tribology.nominal_pressure_pa(FINGER, 1.0)
    loss = tri.skin(FINGER).complex_modulus_pa(k * v).imag
    want = k**2 * amp**2 * loss / (4 * (1 - FINGER.skin_poisson**2) * sigma0)
    assert got.contact_fraction > 0.999
    assert got.hysteresis == pytest.approx(want, rel=2e-3)


def test_the_derived_laws_differ_between_the_paper_materials_and_rougher_means_less_contact():
    laws = {m: tribology.derived_law(MATERIALS[m], FINGER) for m in synth.MATERIAL_NAMES}
    kinetic = sorted(law.kinetic for law in laws.values())
    assert kinetic[0] > 0 and all(b > 1.05 * a for a, b in itertools.pairwise(kinetic))
    parts = {
        m: tribology.friction(
            MATERIALS[m].texture,
            FINGER,
            tribology.SILICONE_TRIBOLOGY,
            speed_m_s=0.01,
            force_n=1.0,
        )
        for m in synth.MATERIAL_NAMES
    }
    assert parts["aluminum"].contact_fraction > parts["resin"].contact_fraction
    assert parts["aluminum"].contact_fraction > parts["wood"].contact_fraction
    for law in laws.values():
        assert law.static == pytest.approx(tribology.STATIC_OVER_KINETIC * law.kinetic, abs=2e-4)


def test_the_friction_model_option_keeps_or_derives_the_laws_and_names_a_bad_model():
    config = synth.SynthConfig()
    same = tribology.with_friction_model(config.materials, config.finger, "shared")
    assert same == config.materials
    derived = tribology.with_friction_model(config.materials, config.finger, "derived")
    for name, mat in derived.items():
        assert mat.texture == config.materials[name].texture
        assert mat.friction == tribology.derived_law(config.materials[name], config.finger)
    # The derived laws round-trip through a stored configuration.
    cfg = dataclasses.replace(config, materials=derived)
    assert synth.SynthConfig.from_dict(cfg.to_dict()) == cfg
    with pytest.raises(ValueError, match="friction_model must be one of shared, derived"):
        tribology.with_friction_model(config.materials, config.finger, "persson")


def test_the_law_rate_term_follows_the_velocity_exponent():
    law = synth.materials.FrictionLaw(
        kinetic=0.8, static=0.9, velocity_exponent=0.1, reference_speed_m_s=0.01
    )
    mu = synth.contact.friction_coefficient(law, np.array([0.01, 0.02]), 1.0)
    assert mu[0] == pytest.approx(0.8, rel=1e-9)
    assert mu[1] / mu[0] == pytest.approx(2**0.1, rel=1e-9)
    with pytest.raises(ValueError, match=r"velocity_exponent must lie in -1\.\.1"):
        synth.materials.FrictionLaw(kinetic=0.8, static=0.9, velocity_exponent=2.0)


@pytest.mark.parametrize("freq_hz", [5.0, 20.0, 40.0, 100.0, 170.0])
def test_the_sampled_prony_arms_answer_a_sinusoid_with_the_complex_modulus(freq_hz):
    """The Prony arms as recursive filters at the physics step (ramp-invariant) answer a
    steady sinusoidal strain with ``E*(omega) / E_inf``: within 0.5 % in magnitude and
    0.01 rad in phase up to 170 Hz, where the 0.5 ms step samples a period 12 times
    (7e-6 at 5 Hz, 4e-3 at 170 Hz)."""
    from synth import kernels
    from synth.viscoelastic import SILICONE_PRONY, Viscoelastic

    skin = Viscoelastic(0.29e6, SILICONE_PRONY)
    step = 5e-4
    t = np.arange(round(12.0 / step)) * step  # 12 s: the 1 s arm settles
    x = np.sin(2 * np.pi * freq_hz * t)[None, :]
    h, slope = x.copy(), -x.copy()
    arms, last = np.zeros((1, len(SILICONE_PRONY), 2)), np.array([[x[0, 0], -x[0, 0]]])
    kernels.viscoelastic_felt(h, slope, *skin.sampled_arms(step), arms, last)
    assert np.array_equal(slope, -h)  # height and slope go through the same skin
    late = slice(t.size // 2, None)
    phasor = np.exp(-2j * np.pi * freq_hz * t[late])
    gain = np.mean(h[0, late] * phasor) / np.mean(x[0, late] * phasor)
    want = complex(skin.complex_modulus_pa(2 * np.pi * freq_hz)) / skin.relaxed_modulus_pa
    assert abs(gain) == pytest.approx(abs(want), rel=5e-3)
    assert np.angle(gain) == pytest.approx(np.angle(want), abs=0.01)


def test_the_skins_answer_to_the_texture_is_named_and_checked():
    finger = synth.SynthConfig().finger
    assert finger.skin_texture_response == "elastic"
    assert dataclasses.replace(finger, skin_texture_response="viscoelastic")
    with pytest.raises(ValueError, match=r"^Finger.skin_texture_response must be one of elastic"):
        dataclasses.replace(finger, skin_texture_response="plastic")
    with pytest.raises(ValueError, match="step_s must be > 0"):
        tribology.SILICONE_TRIBOLOGY.skin(finger).sampled_arms(0.0)
