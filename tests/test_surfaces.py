"""Physics checks of the felt surface: each material's roughness and marks, and how the
fingerprint's ridges average them under the simulated load; each asserts a measurable
physical property."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest

import synth
from synth import scene as scene_mod
from synth import simulator as sim
from synth.config import SynthConfig
from synth.materials import Periodic, Texture
from synth.trial import TrialSpec


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
