"""The closed loop's compiled steps (synth.kernels) give the bits of their numpy forms,
the C library's functions and fixed summation orders; so the simulated data do not depend
on the CPU's vector instructions."""

from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest

import synth
from synth import kernels
from synth.config import SynthConfig


def _extrapolated(table, s, v, ahead, load):
    h, slope = np.empty((s.size, ahead.size)), np.empty((s.size, ahead.size))
    table.felt_into(s, v, ahead, load, h, slope)
    return h, slope


def test_the_compiled_texture_look_ups_give_the_tables_bits():
    """``felt_into`` reads a table at extrapolated coordinates as calling it does, to the
    last bit: in the rows, before and past their ends, under loads between, on and beyond
    the layers, for both kinds of table."""
    rng = np.random.default_rng(11)
    finger = SynthConfig().finger
    texture = synth.materials.MATERIALS["resin"].texture
    surfaces = [
        synth.texture.loaded_surface(
            texture, finger, 0.0, 0.004, np.random.default_rng(seed), force_n=force
        )
        for seed, force in ((1, 1.0), (2, 0.6), (3, 1.4), (4, 1.1))
    ]
    layered = synth.texture.texture_table(surfaces)
    assert isinstance(layered, synth.texture.LayeredTable)
    fixed = synth.texture.TextureTable(*synth.texture.stack_surfaces([s.at(1.0) for s in surfaces]))
    ahead = np.arange(1, 5) * 5e-4
    for _ in range(20):
        s = rng.uniform(-0.003, 0.007, 4)  # some past the surfaces' ends
        v = rng.normal(0.0, 0.02, 4)
        load = rng.choice([0.0, 0.3, 1.0, 1.7, 5.0]) * rng.uniform(0.8, 1.2, 4)
        coord = s[:, None] + v[:, None] * ahead
        for table in (layered, fixed):
            want = table(coord.copy(), load)
            got = _extrapolated(table, s, v, ahead, load)
            assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
    with pytest.raises(FloatingPointError, match="NaN"):
        _extrapolated(layered, np.array([np.nan, 0, 0, 0]), np.zeros(4), ahead, np.ones(4))


def test_height_at_reads_the_loaded_surface_as_look_up_reads_it():
    """``LoadedSurface.height_at`` gives the bits of ``look_up`` on ``at(load)``'s whole
    profile: under loads between, on and beyond the layers, inside and past the ends,
    for a layered and a fixed surface."""
    finger = SynthConfig().finger
    texture = synth.materials.MATERIALS["wood"].texture
    layered = synth.texture.loaded_surface(
        texture, finger, 0.0, 0.004, np.random.default_rng(3), force_n=1.0
    )
    fixed = synth.texture.LoadedSurface.fixed(layered.at(1.0))
    rng = np.random.default_rng(4)
    for surface in (layered, fixed):
        for load in (0.2, 0.5, 0.77, 1.0, 1.9, 2.0, 3.0):
            for s in (*rng.uniform(-0.002, 0.006, 6), layered.origin_m):
                felt = surface.at(load)
                want = synth.texture.look_up(
                    np.array([felt.origin_m]), felt.height_m[None], np.array([[s]])
                )[0, 0]
                assert surface.height_at(load, float(s)) == want


def test_the_compiled_controls_give_their_numpy_forms_bits():
    rng = np.random.default_rng(5)
    b, k, mz = 6, 4, 5
    h, slope = rng.normal(0, 1e-6, (b, k)), rng.normal(0, 1e-2, (b, k))
    normal, z_ref = rng.uniform(0, 2, b), rng.normal(0, 1e-3, b)
    xy = rng.normal(0, 1e-2, (b, 3, k, 2))[:, 1]  # a strided view, as the loop passes it
    angle = rng.normal(0, 0.01, b)
    direction = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    s_now, v_now = rng.normal(0, 1e-2, b), rng.uniform(0, 2e-2, b)
    ahead = np.arange(1, k + 1) * 5e-4
    got = np.zeros((b, k, 10))
    push = np.empty((b, k))
    kernels.controls(h, slope, normal, xy, z_ref, direction, s_now, v_now, ahead, mz, got, push)

    want = np.zeros((b, k, 10))
    want[:, :, 0:2] = xy
    want[:, :, 2] = z_ref[:, None]
    s = s_now[:, None] + v_now[:, None] * ahead
    want[:, :, mz] = h - slope * s
    cos_a = 1.0 / np.sqrt(1.0 + slope * slope)
    c2 = np.sqrt((1.0 + cos_a) / 2.0)
    s2 = slope * cos_a / (2.0 * c2)
    want[:, :, mz + 1] = c2
    want[:, :, mz + 2] = s2 * direction[:, 1:2]
    want[:, :, mz + 3] = -(s2 * direction[:, 0:1])
    assert np.array_equal(got, want)
    assert np.array_equal(push, slope * -normal[:, None])


def test_the_specimens_turn_puts_the_felt_plane_under_the_contact():
    """The quaternion turns the plate's normal to the felt slope's normal along the path,
    and the turned plate passes through the felt height at the contact's path coordinate."""
    from scipy.spatial.transform import Rotation

    b, k, mz = 1, 1, 5
    for slope, heading, s_m in ((0.02, 0.3, 0.004), (-0.05, -1.2, -0.007)):
        h = np.array([[3e-6]])
        direction = np.array([[math.cos(heading), math.sin(heading)]])
        got = np.zeros((b, k, 10))
        kernels.controls(
            h, np.array([[slope]]), np.array([1.0]), np.zeros((b, k, 2)), np.zeros(b),
            direction, np.array([s_m]), np.zeros(b), np.zeros(k), mz, got, np.empty((b, k)),
        )  # fmt: skip
        w, x, y, z = got[0, 0, mz + 1 : mz + 5]
        turn = Rotation.from_quat([x, y, z, w])
        normal = turn.apply([0.0, 0.0, 1.0])
        d = np.array([*direction[0], 0.0])
        want = np.array([-slope * d[0], -slope * d[1], 1.0]) / math.hypot(1.0, slope)
        assert np.allclose(normal, want, rtol=0, atol=1e-15)
        # The turned plate's plane through its origin (0, 0, z): its height above the
        # contact's point on the path, s_m along the direction, is the felt height.
        q = s_m * d
        height = got[0, 0, mz] - (normal[0] * q[0] + normal[1] * q[1]) / normal[2]
        assert height == pytest.approx(3e-6, rel=1e-9)


def _state_inputs(rng, b, k, nstate, nsens, dt):
    state = rng.normal(0, 1, (b, nstate))
    state[:, 0] = 1.0 + rng.uniform(0, 1, b)  # the clocks
    state_buf = rng.normal(0, 1, (b, k, nstate))
    state_buf[:, :, 0] = state[:, :1] + dt * np.arange(1, k + 1)
    sens = rng.normal(0, 1, (b, k, nsens))
    sens[:, :, 18] = rng.choice([0.0, 1.0, 2.0], (b, k))  # contacts found
    return state, state_buf, sens


def test_the_compiled_state_update_gives_its_numpy_forms_bits():
    """After a period: the state, warm start, load, path coordinate, slip and wrist sum
    as the numpy expressions give them; a trial whose clock did not advance is reported
    and leaves the state as it was."""
    rng = np.random.default_rng(8)
    b, k, nstate, nsens, nq, nv, dt = 5, 4, 15, 32, 6, 6, 5e-4
    cols = np.array([18, 21, 12, 15, 30])  # found, force z, skin x, slip x, wrist
    angle = rng.normal(0, 0.01, b)
    direction = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    state, state_buf, sens = _state_inputs(rng, b, k, nstate, nsens, dt)
    wrist_sum = rng.normal(0, 1, b)
    out = [np.zeros((b, nv)), *(np.zeros(b) for _ in range(4))]
    got_state, got_wrist, reset = state.copy(), wrist_sum.copy(), np.ones(b, dtype=bool)
    args = (state_buf, dt, 1 + nq, sens, direction, cols, got_state, *out, got_wrist, reset)
    assert not kernels.next_state(*args)
    assert not reset.any()

    qvel = slice(1 + nq, 1 + nq + nv)
    last = sens[:, k - 1]
    dx, dy = direction[:, 0], direction[:, 1]
    want = [
        (state_buf[:, k - 1, qvel] - state_buf[:, k - 2, qvel]) / dt,
        np.where(last[:, 18] > 0, -last[:, 21], 0.0),
        last[:, 12] * dx + last[:, 13] * dy,
        last[:, 15] * dx + last[:, 16] * dy,
        np.hypot(last[:, 15], last[:, 16]),
    ]
    assert np.array_equal(got_state, state_buf[:, k - 1])
    for got, expected in zip(out, want, strict=True):
        assert np.array_equal(got, expected)
    assert np.array_equal(got_wrist, wrist_sum - sens[:, :, 30].sum(axis=1))

    state_buf[3, k - 1, 0] = state[3, 0]  # MuJoCo restarted trial 3's clock
    before = state.copy()
    args = (state_buf, dt, 1 + nq, sens, direction, cols, state, *out, wrist_sum, reset)
    assert kernels.next_state(*args)
    assert np.flatnonzero(reset).tolist() == [3]
    assert np.array_equal(state, before)


def _touchable_numpy(outline, centre, reach_m):
    """:func:`synth.pieces.touchable` as numpy expressions."""
    normals = outline.normals
    excess = centre[:, 0:1] * normals[:, 0] + centre[:, 1:2] * normals[:, 1] - outline.offsets
    worst = np.maximum.reduceat(excess, outline.starts, axis=1)
    inside = worst <= 0.0
    out = inside & (np.cumsum(inside, axis=1) == 1)
    rows = np.flatnonzero(~out.any(axis=1))
    a, edge = outline.seg_a, outline.edges
    cx, cy = centre[rows, 0:1], centre[rows, 1:2]
    t = ((cx - a[:, 0]) * edge[:, 0] + (cy - a[:, 1]) * edge[:, 1]) / outline.edge_sq
    clamped = np.minimum(np.maximum(t, 0.0), 1.0)
    gap_x = cx - (a[:, 0] + clamped * edge[:, 0])
    gap_y = cy - (a[:, 1] + clamped * edge[:, 1])
    near = np.hypot(gap_x, gap_y) < reach_m
    interior = (t > 0.0) & (t < 1.0)
    corner = (t <= 0.0) & (t[:, outline.previous] >= 1.0)
    trial, seg = np.nonzero(near & (interior | corner))
    out[rows[trial], outline.seg_piece[seg]] = True
    return out


@pytest.mark.parametrize("shape", ["moon", "pentagram"])
def test_the_compiled_piece_choice_gives_its_numpy_forms_choice(shape):
    """Over centres on a grid across the specimen, from a strided view as the loop
    passes them, the pieces chosen are those of the numpy form, inside pieces, near the
    outline and far from it."""
    outline = synth.pieces.outline_pieces(shape)
    grid = np.linspace(-0.012, 0.012, 97)
    centres = np.stack(np.meshgrid(grid, grid), axis=-1).reshape(-1, 2)
    view = np.concatenate([centres, np.zeros_like(centres)], axis=1)[:, :2]
    chosen = synth.pieces.touchable(outline, view, 0.0025)
    assert np.array_equal(chosen, _touchable_numpy(outline, centres, 0.0025))
    assert chosen.any(axis=1).mean() > 0.3 and not chosen.all()


def test_the_compiled_mechanics_give_their_numpy_forms_bits():
    """The contact force, the mount's force and torque in the phalanx's frame (turned by
    the pitch's cosine and sine, numpy's), the contact's lead, the indentation and the
    traction as numpy expressions give them, with and without a contact and a
    penetration."""
    rng = np.random.default_rng(21)
    b, n = 3, 50
    cols = synth.scene.sensor_columns()
    sens = rng.normal(0, 1, (b, n, 32))
    sens[..., cols["contact"].start] = rng.choice([0.0, 1.0, 3.0], (b, n))
    sens[..., cols["contact_depth"].start] = rng.choice([0.0, 1.0], (b, n))
    sens[..., cols["pad_pitch"].start] = rng.normal(0, 0.3, (b, n))
    pitch = sens[..., cols["pad_pitch"].start]
    cos_pitch, sin_pitch = np.cos(pitch), np.sin(pitch)
    angle = rng.normal(0, 0.01, b)
    direction = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    names = ("contact", "pad_pos", "contact_depth", "mount_force", "mount_torque")
    got = [np.empty((b, n, 3)), np.empty((b, n, 3)), np.empty((b, n, 3))]
    got += [np.empty((b, n)) for _ in range(3)]
    index = np.array([cols[c].start for c in names])
    kernels.mechanics(sens[None], cols["pad_pitch"].start, 0.0, direction, index, *got)
    # The same sensors period-major (periods of 5 steps), as the closed loop writes them.
    periods = np.ascontiguousarray(np.moveaxis(sens.reshape(b, n // 5, 5, -1), 0, 1))
    again = [np.empty_like(g) for g in got]
    kernels.mechanics(periods, cols["pad_pitch"].start, 0.0, direction, index, *again)
    for g, a in zip(got, again, strict=True):
        assert np.array_equal(g, a)

    def unrock(v):
        x, y, z = v[..., 0], v[..., 1], v[..., 2]
        return np.stack([cos_pitch * x + sin_pitch * z, y, cos_pitch * z - sin_pitch * x], -1)

    contact = sens[..., cols["contact"]]
    found = contact[..., 0] > 0
    force = np.where(found[..., None], contact[..., 1:4], 0.0)
    rel = contact[..., 7:9] - sens[..., cols["pad_pos"]][..., :2]
    depth = sens[..., cols["contact_depth"]]
    d = direction[:, None, :]
    want = [
        force,
        unrock(sens[..., cols["mount_force"]]),
        unrock(sens[..., cols["mount_torque"]]),
        np.where(found, (rel * d).sum(axis=-1), 0.0),
        np.where(depth[..., 0] > 0, np.maximum(-depth[..., 1], 0.0), 0.0),
        -(force[..., :2] * d).sum(axis=-1),
    ]
    for g, w in zip(got, want, strict=True):
        assert np.array_equal(g, w)
    assert 0 < found.mean() < 1 and (want[4] > 0).any() and (want[4] == 0).any()


def test_store_at_writes_each_value_into_its_own_buffer():
    """The closed loop's friction write: one element of each trial's own MuJoCo model,
    the other elements and models untouched."""
    models = [synth.scene.scene("circle", SynthConfig()).trial_model(0.5) for _ in range(3)]
    before = [m.geom_friction.copy() for m in models]
    row = 1
    at = np.array(
        [m.geom_friction.ctypes.data + row * m.geom_friction.strides[0] for m in models],
        dtype=np.uint64,
    )
    kernels.store_at(at, np.array([0.7, 1.1, 2.3]))
    for m, old, value in zip(models, before, (0.7, 1.1, 2.3), strict=True):
        old[row, 0] = value
        assert np.array_equal(m.geom_friction, old)


def test_finite_trials_flags_every_trial_with_a_nan_or_an_infinity():
    rng = np.random.default_rng(23)
    sens = rng.normal(size=(7, 5, 4, 6))  # periods, trials, steps, sensors
    sens[0, 1, 0, 0] = np.nan
    sens[6, 3, 3, 5] = np.inf
    sens[3, 4, 2, 1] = -np.inf
    sens[2, 0, 1, 2] = 1e308  # large, finite
    out = np.ones(5, dtype=bool)
    kernels.finite_trials(sens, out)
    want = np.isfinite(np.moveaxis(sens, 1, 0)).reshape(5, -1).all(axis=1)
    assert np.array_equal(out, want) and want.tolist() == [True, False, True, False, False]


def test_the_compiled_film_strains_give_their_numpy_forms_bits():
    """The films' strains as numpy expressions of ``contact.surface_slope`` give them:
    films inside, across and outside the contact, no contact, a contact centred on a
    film's end."""
    from synth import contact, sensors

    rng = np.random.default_rng(22)
    cfg = SynthConfig()
    finger, pv = cfg.finger, cfg.pvdf
    b, n = 4, 400
    ahead = rng.normal(0.0, 3e-3, (b, n))
    ahead[0, :5] = pv.offset_m + pv.length_m / 2  # the front film's rear end at the centre
    ahead[0, 5:10] = -pv.offset_m - pv.length_m / 2
    indentation = rng.choice([0.0, 1.0], (b, n)) * rng.uniform(0.0, 1e-3, (b, n))
    traction = rng.normal(0.0, 0.3, (b, n))
    mech = sensors.Mechanics(
        mount_force=np.zeros((b, n, 3)),
        mount_torque=np.zeros((b, n, 3)),
        contact_ahead_m=ahead,
        indentation_m=indentation,
        traction_n=traction,
    )
    got = sensors.film_strains(mech, finger, pv)
    half, r = pv.length_m / 2.0, finger.pad_radius_m
    want = []
    for sign in (1.0, -1.0):
        centre = sign * pv.offset_m - ahead
        rise = contact.surface_slope(centre + half, indentation, r) - (
            contact.surface_slope(centre - half, indentation, r)
        )
        bending = -pv.neutral_axis_offset_m * rise / pv.length_m
        want.append(bending - sign * pv.shear_strain_per_n * traction)
    want = np.stack(want, axis=1)
    assert np.array_equal(got, want)
    assert (indentation == 0).any() and np.abs(want).max() > 0


@pytest.mark.parametrize(
    ("ufunc", "libm", "low", "high"),
    [
        (kernels.exp, math.exp, -40.0, 5.0),
        (kernels.log, math.log, 1e-9, 50.0),
        (kernels.arcsin, math.asin, -1.0, 1.0),
        (kernels.cbrt, math.cbrt, -10.0, 10.0),
    ],
)
def test_the_math_ufuncs_give_the_c_librarys_bits(ufunc, libm, low, high):
    """Each ufunc gives, value by value, what Python's ``math`` module (the C library)
    gives, on arrays of any shape and on scalars."""
    rng = np.random.default_rng(5)
    x = rng.uniform(low, high, (40, 25))
    want = np.array([libm(v) for v in x.ravel()]).reshape(x.shape)
    assert np.array_equal(ufunc(x), want)
    assert ufunc(float(x[0, 0])) == want[0, 0]


def test_the_power_ufunc_gives_the_c_librarys_bits():
    rng = np.random.default_rng(6)
    x, y = rng.uniform(0.0, 3.0, 2000), rng.uniform(-2.0, 3.0, 2000)
    want = np.array([math.pow(a, b) for a, b in zip(x, y, strict=True)])
    assert np.array_equal(kernels.power(x, y), want)
    assert np.array_equal(kernels.power(1.3, y), np.array([math.pow(1.3, b) for b in y]))


def _felt_layers_numpy(profiles, bank_of, cells, rough_weights, mark_weights, totals, dx):
    """The ridge-by-ridge numpy form of ``kernels.felt_layers``: each ridge's shifted copy
    of every bank's profiles (edge-padded, read by slicing), the layers' sums as
    ``weighted_rows`` over the bank each ridge reads in that layer, the slope by
    ``np.gradient``."""
    k, n = profiles.shape[1] - 1, profiles.shape[2]
    pad = int(max(abs(c) for c in cells)) + 2
    padded = np.pad(profiles, ((0, 0), (0, 0), (pad, pad)), mode="edge")
    shifted = np.empty((len(cells), profiles.shape[0], 1 + k, n))
    for c, out in zip(cells, shifted, strict=True):
        whole = math.floor(c)
        frac = c - whole
        lo = padded[:, :, pad + whole : pad + whole + n]
        hi = padded[:, :, pad + whole + 1 : pad + whole + 1 + n]
        out[:] = np.multiply(lo, 1.0 - frac) + np.multiply(hi, frac)
    heights = np.empty((len(totals), n))
    for j, layer in enumerate(heights):
        # A ridge outside the layer reads bank 0 with weight 0: adding zeros to a sum
        # started at +0.0 keeps its bits.
        read = np.stack(
            [shifted[r, max(b, 0)] for r, b in enumerate(bank_of[j])]
        )  # (ridges, 1 + k, n)
        rough_w = np.where(bank_of[j] < 0, 0.0, rough_weights[j])
        felt, marked = np.empty(n), np.empty(n)
        kernels.weighted_rows(rough_w, np.ascontiguousarray(read[:, 0]), felt)
        if k:
            mark_w = np.where(np.repeat(bank_of[j], k) < 0, 0.0, mark_weights[j])
            flat = np.ascontiguousarray(read[:, 1:]).reshape(-1, n)
            kernels.weighted_rows(mark_w, flat, marked)
            felt += marked
        layer[:] = felt / totals[j]
    return heights, np.gradient(heights, dx, axis=1)


def test_the_felt_layers_kernel_gives_the_ridge_by_ridge_bits():
    """``felt_layers`` reads every ridge's shift inside its loop over the grid and gives
    the bits of the shifted copies summed row by row: with and without marks, one bank or
    several (a ridge reading another width's bank in another layer, or none), ridges
    shifted either way and past the profiles' ends, zero weights (skipped: adding zeros
    to a sum started at +0.0 keeps its bits)."""
    rng = np.random.default_rng(8)
    cases = ((2, 9, 5, 700, 1), (0, 4, 3, 50, 2), (1, 1, 1, 12, 1), (3, 12, 5, 301, 4))
    for k, ridges, layers, n, banks in cases:
        profiles = rng.normal(0.0, 1e-6, (banks, 1 + k, n))
        cells = list(rng.uniform(-25.0, 25.0, ridges)) + [0.0, -3.0][: max(0, 2 - ridges)]
        ridges = len(cells)
        bank_of = rng.integers(0, banks, (layers, ridges))
        if ridges > 2:
            bank_of[0, 1] = -1  # a ridge outside the first layer's contact
        rough_weights = rng.uniform(0.0, 1e-3, (layers, ridges))
        rough_weights[0, 0] = 0.0
        rough_weights[:, -1] = 0.0  # a ridge outside every layer's contact
        mark_weights = rng.normal(0.0, 1e-3, (layers, ridges * k))
        mark_weights[-1, :k] = 0.0
        totals = rng.uniform(1e-3, 1e-2, layers)
        whole = np.array([math.floor(c) for c in cells], dtype=np.intp)
        frac = np.array([c - math.floor(c) for c in cells])
        heights, slopes = np.full((layers, n), np.nan), np.full((layers, n), np.nan)
        kernels.felt_layers(
            profiles,
            bank_of,
            whole,
            frac,
            rough_weights,
            mark_weights,
            totals,
            5e-6,
            heights,
            slopes,
        )
        want_h, want_s = _felt_layers_numpy(
            profiles, bank_of, cells, rough_weights, mark_weights, totals, 5e-6
        )
        assert np.array_equal(heights, want_h), (k, ridges)
        assert np.array_equal(slopes, want_s), (k, ridges)


def test_the_weighted_rows_and_the_taps_mean_sum_in_one_order():
    """``weighted_rows`` adds the rows in order and ``taps_mean`` (equal taps: a box, as
    a flat ridge averages; or any taps) its window's samples in order of their
    position, to the last bit of the same sums as numpy expressions; both agree with
    numpy's BLAS-backed products to rounding."""
    rng = np.random.default_rng(7)
    for r_count, n in ((1, 5), (3, 400), (12, 1001), (0, 7)):
        w, rows = rng.normal(size=r_count), rng.normal(size=(r_count, n))
        out = np.full(n, np.nan)
        kernels.weighted_rows(w, rows, out)
        want = np.zeros(n)
        for r in range(r_count):
            want = want + w[r] * rows[r]
        assert np.array_equal(out, want)
        np.testing.assert_allclose(out, w @ rows, rtol=0, atol=1e-12)
    for width in (1, 2, 3, 4, 7, 12):
        for n in (width, 30, 999):
            x = rng.normal(size=n)
            out = np.full(n, np.nan)
            kernels.taps_mean(x, np.full(width, 1.0 / width), out)
            half = (width - 1) // 2
            padded = np.pad(x, (width - 1 - half, half))
            want = np.zeros(n)
            for d in range(width):
                want = want + padded[d : d + n] * (1.0 / width)
            assert np.array_equal(out, want), (width, n)
            in_place = x.copy()
            kernels.taps_mean(in_place, np.full(width, 1.0 / width), in_place)
            assert np.array_equal(in_place, want)
            same = np.convolve(x, np.ones(width) / width, mode="same")
            np.testing.assert_allclose(out, same, rtol=0, atol=1e-12)
    for width in (1, 3, 6, 29):
        taps = rng.uniform(0.1, 1.0, width)
        taps /= taps.sum()
        x = rng.normal(size=200)
        out = np.full(x.size, np.nan)
        kernels.taps_mean(x, taps, out)
        half = (width - 1) // 2
        padded = np.pad(x, (width - 1 - half, half))
        want = np.zeros(x.size)
        for d in range(width):
            want = want + padded[d : d + x.size] * taps[d]
        assert np.array_equal(out, want), width
        same = np.convolve(x, taps[::-1], mode="same")
        np.testing.assert_allclose(out, same, rtol=0, atol=1e-12)


def test_the_compiled_friction_law_and_layer_position_give_their_numpy_forms_bits():
    rng = np.random.default_rng(8)
    b = 64
    slip = np.abs(rng.normal(0.0, 0.01, b))
    slip[:4] = 0.0
    normal = rng.uniform(-0.2, 2.5, b)
    normal[4] = 0.05
    kinetic, excess = rng.uniform(0.3, 1.0, b), rng.uniform(0.0, 0.5, b)
    v_stribeck, load_exp = rng.uniform(1e-3, 1e-2, b), rng.uniform(-0.3, 0.0, b)
    scale = rng.uniform(0.8, 1.2, b)
    vel_exp = np.where(np.arange(b) % 2, rng.uniform(-0.2, 0.2, b), 0.0)
    v_ref = np.full(b, 0.01)
    out = np.empty(b)
    kernels.friction_law(
        slip, normal, kinetic, excess, v_stribeck, load_exp, vel_exp, v_ref, scale, out
    )
    f = np.maximum(normal, 0.05)
    weak = kernels.exp(-np.square(slip / v_stribeck))
    rate = np.where(
        vel_exp != 0.0, kernels.power(np.maximum(slip, v_stribeck) / v_ref, vel_exp), 1.0
    )
    want = (kinetic * rate + excess * weak) * kernels.power(f, load_exp) * scale
    assert np.array_equal(out, want)
    # A rate-independent law gives the same bits as before the rate term existed.
    flat = np.empty(b)
    kernels.friction_law(
        slip, normal, kinetic, excess, v_stribeck, load_exp, 0.0 * vel_exp, v_ref, scale, flat
    )
    assert np.array_equal(flat, (kinetic + excess * weak) * kernels.power(f, load_exp) * scale)

    first = rng.uniform(0.3, 0.8, b)
    load = np.concatenate([[0.0, 1e-12, 100.0], rng.uniform(0.0, 4.0, b - 3)])
    ratio = synth.texture.LOAD_RATIO
    for layers in (2, 3, 7):
        j, u = synth.texture.layer_position(first, layers, load)
        pos = kernels.log(np.maximum(load, 1e-9) / first) * (1.0 / math.log(ratio))
        pos = np.minimum(np.maximum(pos, 0.0), layers - 1.0)
        want_j = np.minimum(pos.astype(np.intp), layers - 2)
        assert np.array_equal(j, want_j) and np.array_equal(u, pos - want_j)
        assert (j >= 0).all() and (j <= layers - 2).all() and (u >= 0).all() and (u <= 1).all()
    j, u = synth.texture.layer_position(first, 1, load)
    assert not j.any() and not u.any()


_DIGEST = """
import dataclasses, hashlib, types
import numpy as np
import synth
from shapes import SHAPE_NAMES
from synth import contact, texture
from synth.closed_loop import ClosedLoop
from synth.trial import TrialSpec

h = hashlib.sha256()
# The data path's array functions on inputs large enough for every vector kernel.
rng = np.random.default_rng(3)
n = 20000
load, slip = rng.uniform(0.0, 3.0, n), rng.uniform(0.0, 0.03, n)
first = rng.uniform(0.3, 0.8, n)
law = synth.materials.MATERIALS["wood"].friction
loop = types.SimpleNamespace(
    b=n, kinetic=first, static_excess=first * 0.4, v_stribeck=first * 0.01,
    load_exp=-first * 0.2, vel_exp=np.zeros(n), v_ref=np.full(n, 0.01),
    scale=1.0 + first * 0.1,
)
outline = synth.pieces.outline_pieces("moon")
for out in (
    *texture.layer_position(first, 5, load),
    ClosedLoop.friction(loop, slip, load),
    contact.friction_coefficient(law, slip, load, 1.1),
    contact.hertz_indentation_m(load, 0.008, 2e5, 0.49),
    contact.hertz_force_n(load * 1e-3, 0.008, 2e5, 0.49),
    contact.surface_deflection_m(slip - 0.015, load * 1e-3, 0.008),
    contact.surface_slope(slip - 0.015, load * 1e-3, 0.008),
    synth.pieces.touchable(outline, rng.uniform(-0.012, 0.012, (n, 2)), 0.0025),
):
    h.update(np.ascontiguousarray(out).tobytes())
config = synth.SynthConfig()
fixed = dataclasses.replace(config, finger=dataclasses.replace(config.finger, ridges_in_contact=3))
for finger in (config.finger, fixed.finger):
    for seed in range(4):
        surface = texture.loaded_surface(
            synth.materials.MATERIALS["resin"].texture, finger, 0.0, 0.03,
            np.random.default_rng(seed), force_n=1.0, mark_angle_rad=0.1,
        )
        h.update(surface.height_m.tobytes() + surface.slope.tobytes())
print(h.hexdigest())
# Whole trials: every shape and material, batches of six.
h = hashlib.sha256()
specs = [TrialSpec(s, m, seed=i) for s in SHAPE_NAMES for m in synth.MATERIAL_NAMES for i in (0, 1)]
for t in synth.simulate_batch(specs, config=config, threads=2):
    h.update(t.signals.tobytes())
for t in synth.simulate_batch(specs[:24], config=fixed, threads=1):
    h.update(t.signals.tobytes())
print(h.hexdigest())
# The feature pool of these signals.
from models.features import extract
signals = np.stack([t.signals for t in synth.simulate_batch(specs[::4], config=config)])
print(hashlib.sha256(extract(signals).tobytes()).hexdigest())
"""


def _numpy_vector_levels() -> list[str]:
    """numpy's x86 dispatch groups above its baseline that this CPU has; empty where
    numpy does not name them so (before numpy 2.x's ``X86_V3``/``X86_V4`` groups)."""
    try:
        from numpy._core._multiarray_umath import __cpu_features__
    except ImportError:  # numpy 1.x keeps the module under numpy.core
        from numpy.core._multiarray_umath import __cpu_features__
    return [f for f in ("X86_V4", "X86_V3") if __cpu_features__.get(f)]


@pytest.mark.slow
def test_the_simulated_signals_do_not_depend_on_the_cpus_vector_instructions():
    """The data path's array functions (the layer look-up, the friction laws, the contact
    mechanics, the piece choice, the felt surfaces), whole trials (every shape and
    material; a fixed ridge count) and their 386 features give the same bits with numpy's
    and OpenBLAS's best kernels for this CPU as with the ones a CPU without AVX-512 or
    AVX2 would run, and with OpenBLAS's generic x86 kernels."""
    levels = _numpy_vector_levels()
    if not levels:
        pytest.skip("no x86 dispatch group above numpy's baseline on this CPU and numpy")

    def digest(**env):
        run = subprocess.run(
            [sys.executable, "-c", _DIGEST],
            env={**os.environ, **env},
            capture_output=True,
            text=True,
            check=True,
        )
        return run.stdout.strip()

    here = digest()
    assert [len(d) for d in here.split()] == [64, 64, 64]
    assert digest(NPY_DISABLE_CPU_FEATURES=levels[0]) == here
    assert digest(NPY_DISABLE_CPU_FEATURES=" ".join(levels), OPENBLAS_CORETYPE="Nehalem") == here


def _viscoelastic_numpy(h, slope, ratios, decays, gains, arms, last):
    """``kernels.viscoelastic_felt`` as numpy steps, operation for operation."""
    for t in range(h.shape[1]):
        x = np.stack([h[:, t], slope[:, t]], axis=1)  # (b, 2)
        dx = x - last
        last[:] = x
        out = x.copy()
        for j in range(ratios.size):
            arms[:, j] = decays[j] * arms[:, j] + gains[j] * dx
            out = out + ratios[j] * arms[:, j]
        h[:, t], slope[:, t] = out[:, 0], out[:, 1]


def test_the_viscoelastic_skin_gives_its_recursions_bits():
    """The skin's Prony arms run period by period give the bits of the same recursion in
    numpy, their state carried across periods."""
    from synth.viscoelastic import SILICONE_PRONY, Viscoelastic

    rng = np.random.default_rng(5)
    filt = Viscoelastic(0.29e6, SILICONE_PRONY).sampled_arms(5e-4)
    h0, s0 = rng.normal(size=(3, 40)) * 1e-6, rng.normal(size=(3, 40)) * 0.01
    got_h, got_s, want_h, want_s = h0.copy(), s0.copy(), h0.copy(), s0.copy()
    arms_k, last_k = np.zeros((3, 3, 2)), np.stack([h0[:, 0], s0[:, 0]], axis=1)
    arms_n, last_n = arms_k.copy(), last_k.copy()
    for start in range(0, 40, 8):
        period = slice(start, start + 8)
        a, b = got_h[:, period].copy(), got_s[:, period].copy()
        kernels.viscoelastic_felt(a, b, *filt, arms_k, last_k)
        got_h[:, period], got_s[:, period] = a, b
        c, d = want_h[:, period].copy(), want_s[:, period].copy()
        _viscoelastic_numpy(c, d, *filt, arms_n, last_n)
        want_h[:, period], want_s[:, period] = c, d
    assert got_h.tobytes() == want_h.tobytes() and got_s.tobytes() == want_s.tobytes()
    assert not np.array_equal(got_h, h0)  # the arms answer the changes
