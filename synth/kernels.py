"""Compiled steps of the simulator's per-period and per-sample arithmetic.

Between periods the closed loop (:mod:`synth.closed_loop`) reads every trial's state from
its sensors, looks up the texture under each contact, chooses the pieces a concave
outline's skin may touch and assembles the next period's controls: a few dozen small
array operations on arrays of the batch's size, about a thousand times per trial. As
numpy expressions each operation pays a call's fixed cost, which added up to 4-5 ms per
trial, about an eighth of the physics' time. The sensor chain (:func:`synth.recording._process`)
starts from a dozen full-length expressions that each write a temporary array. Numba (a
JIT compiler for numeric Python) runs each group as one loop instead.

Each function repeats a numpy expression of the package operation for operation, in the
same order and the same precision (float32 table values widened to float64 where numpy
widens them; no fused multiply-adds), so it gives the bits the numpy expression gives;
``tests/test_kernels.py`` checks each against its numpy form.

Exponentials, logarithms, powers, arcsines and cube roots come from the C library (the
ufuncs :data:`exp`, :data:`log`, :data:`power`, :data:`arcsin` and :data:`cbrt`, and
``math`` calls inside the kernels), never from numpy's own: numpy picks a vectorised
version of these by the CPU's instructions, and on a CPU with AVX-512 its versions differ
from the C library's in the last bit of some values, so the same seed would give other
bits there than on a CPU without it. The C library's functions do not follow numpy's
choice of kernels, and they are what numpy itself calls on a CPU without AVX-512.
Intel's vector math library (SVML), which numba would use where it is installed, is
turned off for the same reason. Sines and cosines come from the C library too (``math``
calls inside the kernels, numpy's own elsewhere): numpy's float64 versions are the C
library's.

``nogil``: a generation running two chunks on threads steps one chunk's loop while the
other's holds the interpreter. ``cache``: compiled once per machine, into the package's
``__pycache__`` (or numba's user cache where that is read-only).
"""

from __future__ import annotations

import math
import os

# Before numba's first import: its configuration reads the variable once.
os.environ.setdefault("NUMBA_DISABLE_INTEL_SVML", "1")

import numba
import numpy as np
from numba import types
from numba.extending import intrinsic

if numba.config.USING_SVML:  # numba was imported earlier with SVML enabled
    raise ImportError(
        "synth needs numba without Intel's SVML (its vector math changes the data's bits): "
        "set NUMBA_DISABLE_INTEL_SVML=1 before importing numba"
    )


@numba.cfunc("float64()", cache=True)
def no_time():
    """A clock that always reads 0, for MuJoCo's ``mjcb_time`` callback: MuJoCo's engine
    reads that clock at the start and end of every stage of a step to fill
    ``mjData.timer``, and MuJoCo's Python bindings install a steady clock there. Nothing
    in the package reads the timers; :func:`synth.closed_loop.timers_off` installs this
    one while it simulates."""
    return 0.0


@numba.vectorize(["float64(float64)"], cache=True, nopython=True)
def exp(x):
    """``e**x`` from the C library (a ufunc, for numpy's ``np.exp``)."""
    return math.exp(x)


@numba.vectorize(["float64(float64)"], cache=True, nopython=True)
def log(x):
    """The natural logarithm from the C library (a ufunc, for numpy's ``np.log``)."""
    return math.log(x)


@numba.vectorize(["float64(float64, float64)"], cache=True, nopython=True)
def power(x, y):
    """``x**y`` from the C library (a ufunc, for numpy's ``np.power``)."""
    return x**y


@numba.vectorize(["float64(float64)"], cache=True, nopython=True)
def arcsin(x):
    """The arcsine from the C library (a ufunc, for numpy's ``np.arcsin``)."""
    return math.asin(x)


@numba.vectorize(["float64(float64)"], cache=True, nopython=True)
def cbrt(x):
    """The cube root from the C library (a ufunc, for numpy's ``np.cbrt``)."""
    return np.cbrt(x)


@numba.njit(cache=True, nogil=True)
def friction_law(
    slip_speed, normal, kinetic, static_excess, v_stribeck, load_exp, vel_exp, v_ref, scale, out
):
    """Each trial's friction coefficient (:meth:`synth.closed_loop.ClosedLoop.friction`)
    into ``out``: ``(kinetic * r + static_excess * exp(-(slip_speed / v_stribeck)**2)) *
    max(normal, 0.05)**load_exp * scale``, with ``r = (max(slip_speed, v_stribeck) /
    v_ref)**vel_exp`` (exactly 1 where ``vel_exp`` is 0)."""
    for i in range(out.size):
        f = normal[i] if not normal[i] < 0.05 else 0.05  # NaN stays NaN, as np.maximum
        ratio = slip_speed[i] / v_stribeck[i]
        weak = math.exp(-(ratio * ratio))
        kin = kinetic[i]
        if vel_exp[i] != 0.0:
            v = slip_speed[i] if slip_speed[i] > v_stribeck[i] else v_stribeck[i]
            kin = kin * (v / v_ref[i]) ** vel_exp[i]
        out[i] = (kin + static_excess[i] * weak) * f ** load_exp[i] * scale[i]


@intrinsic
def _double_at(typingctx, address):
    """The integer ``address`` as a pointer to a float64."""
    pointer = types.CPointer(types.float64)

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], context.get_value_type(pointer))

    return pointer(types.uintp), codegen


@numba.njit(cache=True, nogil=True)
def store_at(addresses, values):
    """Write ``values[i]`` to the float64 at memory address ``addresses[i]`` (uint64).

    The closed loop sets the skin's friction coefficient in each trial's own model before
    every period: one element of a different MuJoCo buffer per trial, which numpy can
    only write one Python call at a time. The caller keeps the buffers alive."""
    for i in range(values.size):
        _double_at(addresses[i])[0] = values[i]


@numba.njit(cache=True, nogil=True)
def layer_position(first_load, layers, inv_log_ratio, load, j_out, u_out):
    """:func:`synth.texture.layer_position` for ``layers`` > 1 into ``j_out`` and
    ``u_out``: the position ``log(max(load, 1e-9) / first_load) * inv_log_ratio`` clamped
    to ``[0, layers - 1]``, its layer (at most ``layers - 2``) and the fraction above it."""
    top = layers - 1.0
    for i in range(load.size):
        x = load[i] if not load[i] < 1e-9 else 1e-9
        pos = math.log(x / first_load[i]) * inv_log_ratio
        pos = pos if not pos < 0.0 else 0.0
        pos = pos if not pos > top else top
        j = min(np.intp(pos), layers - 2)
        j_out[i] = j
        u_out[i] = pos - j


@numba.njit(cache=True, nogil=True)
def weighted_rows(weights, rows, out):
    """``out[n] = sum over r of weights[r] * rows[r, n]``, summed over ``r`` in order: the
    vector-matrix product ``weights @ rows`` with one summation order on every CPU (a
    BLAS product picks its order, and so its last bits, by the CPU)."""
    out[:] = 0.0
    for r in range(rows.shape[0]):
        w = weights[r]
        for n in range(out.size):
            out[n] += w * rows[r, n]


@numba.njit(cache=True, nogil=True, inline="never")
def _interpolate(row, g, f, out):
    """``out[i] = row[i] * g + row[i + 1] * f`` (separate arrays: a vectorised loop)."""
    for i in range(out.size):
        out[i] = row[i] * g + row[i + 1] * f


@numba.njit(cache=True, nogil=True, inline="never")
def _add_scaled(acc, w, x):
    """``acc += w * x`` (separate arrays: a vectorised loop)."""
    for i in range(acc.size):
        acc[i] += w * x[i]


@numba.njit(cache=True, nogil=True)
def felt_layers(
    profiles, bank_of, whole, frac, rough_weights, mark_weights, totals, dx, heights, slopes
):
    """A loaded surface's layers (:func:`synth.texture.loaded_surface`) in one call,
    without a shifted copy of every profile per ridge.

    ``profiles`` ``(banks, 1 + k, n)``: the roughness and the ``k`` periodic marks on the
    grid, each bank as one ridge width's average leaves them; ridge ``r`` in layer ``j``
    reads bank ``bank_of[j, r]`` (-1: the ridge is outside that layer's contact). Ridge
    ``r`` reads each profile ``whole[r] + frac[r]`` cells further on, by linear
    interpolation (``p[i] * (1 - frac) + p[i + 1] * frac``, the end values beyond the
    ends). Layer ``j``'s height is ``(sum over r of rough_weights[j, r] * roughness_r +
    sum over r, m of mark_weights[j, r * k + m] * mark_rm) / totals[j]``, each sum taken
    in that order and the second added to the first, and its slope
    ``np.gradient(height, dx)``: the bits of the ridge-by-ridge numpy form (shifted
    copies, :func:`weighted_rows`, ``np.gradient``), which ``tests/test_kernels.py``
    keeps as the reference."""
    banks = profiles.shape[0]
    n = profiles.shape[2]
    k = profiles.shape[1] - 1
    layers, ridges = rough_weights.shape
    # Row by row, so that the inner loops run over the grid (vectorised): a ridge's
    # shifted profile, then its weighted term added into every layer's sum that reads
    # that bank (each layer reads one bank per ridge, so its sums keep the ridges' order).
    acc_rough = np.zeros((layers, n))
    acc_marks = np.zeros((layers, n))
    shifted = np.empty(n)
    for r in range(ridges):
        d = whole[r]
        f = frac[r]
        g = 1.0 - f
        first = min(max(-d, 0), n)  # grid points whose two neighbours lie inside
        stop = max(min(n - 1 - d, n), first)
        for b in range(banks):
            used = False
            for j in range(layers):
                if bank_of[j, r] == b:
                    used = True
            if not used:
                continue
            for p in range(1 + k):
                row = profiles[b, p]
                for i in range(first):
                    lo = min(max(i + d, 0), n - 1)
                    hi = min(max(i + d + 1, 0), n - 1)
                    shifted[i] = row[lo] * g + row[hi] * f
                _interpolate(row[first + d : stop + d + 1], g, f, shifted[first:stop])
                for i in range(stop, n):
                    lo = min(max(i + d, 0), n - 1)
                    hi = min(max(i + d + 1, 0), n - 1)
                    shifted[i] = row[lo] * g + row[hi] * f
                sums = acc_rough if p == 0 else acc_marks
                for j in range(layers):
                    if bank_of[j, r] != b:
                        continue
                    w = rough_weights[j, r] if p == 0 else mark_weights[j, r * k + p - 1]
                    if w == 0.0:
                        # Adds zeros: a sum started at +0.0 keeps its bits (a ridge
                        # outside this layer's contact).
                        continue
                    _add_scaled(sums[j], w, shifted)
    for j in range(layers):
        total = totals[j]
        for i in range(n):
            felt = acc_rough[j, i] + acc_marks[j, i] if k > 0 else acc_rough[j, i]
            heights[j, i] = felt / total
    two_dx = 2.0 * dx
    for j in range(layers):
        slopes[j, 0] = (heights[j, 1] - heights[j, 0]) / dx
        for i in range(1, n - 1):
            slopes[j, i] = (heights[j, i + 1] - heights[j, i - 1]) / two_dx
        slopes[j, n - 1] = (heights[j, n - 1] - heights[j, n - 2]) / dx


@numba.njit(cache=True, nogil=True)
def taps_mean(x, taps, out):
    """The moving weighted mean of ``x`` with ``taps`` (summing to 1), aligned and
    zero-padded as ``np.convolve(x, taps[::-1], mode="same")``; each output sums its
    terms in one order on every CPU (numpy's convolution sums through the BLAS). ``out``
    may be ``x`` itself: the sums read a padded copy."""
    n = x.size
    width = taps.size
    half = (width - 1) // 2
    # Zero-padded, so that every output adds its window's samples from the first to the
    # last, tap by tap across all outputs (a loop the compiler vectorises); the padding's
    # zeros leave the sums' bits as they are.
    lead = width - 1 - half
    padded = np.zeros(n + width - 1)
    padded[lead : lead + n] = x
    out[:] = 0.0
    for d in range(width):
        tap = taps[d]
        for i in range(n):
            out[i] += padded[d + i] * tap


@numba.njit(cache=True, nogil=True)
def layered_felt(
    points, origins, row_start, layer, last, inv_grid, j, u, s_now, v_now, ahead, h_out, slope_out
):
    """:class:`synth.texture.LayeredTable`'s look-up at the path coordinates
    ``s_now[i] + v_now[i] * ahead[t]`` under the loads whose layer position is ``(j, u)``
    (:func:`synth.texture.layer_position`), into ``h_out`` and ``slope_out`` ``(b, k)``.
    ``points``: the table's ``(height, slope)`` pairs, float32."""
    b, k = h_out.shape
    for i in range(b):
        base = row_start[i] + j[i] * layer
        for t in range(k):
            pos = _clamped((s_now[i] + v_now[i] * ahead[t] - origins[i]) * inv_grid, last)
            i0 = np.intp(pos)
            w = pos - i0
            p = base + i0
            q = p + layer  # the same point in the layer above
            h_below = np.float64(points[p, 0]) + np.float64(points[p + 1, 0] - points[p, 0]) * w
            s_below = np.float64(points[p, 1]) + np.float64(points[p + 1, 1] - points[p, 1]) * w
            h_above = np.float64(points[q, 0]) + np.float64(points[q + 1, 0] - points[q, 0]) * w
            s_above = np.float64(points[q, 1]) + np.float64(points[q + 1, 1] - points[q, 1]) * w
            h_out[i, t] = h_below + (h_above - h_below) * u[i]
            slope_out[i, t] = s_below + (s_above - s_below) * u[i]


@numba.njit(cache=True, nogil=True)
def table_felt(cells, origins, row_start, last, inv_grid, s_now, v_now, ahead, h_out, slope_out):
    """:class:`synth.texture.TextureTable`'s look-up at the path coordinates
    ``s_now[i] + v_now[i] * ahead[t]``, into ``h_out`` and ``slope_out`` ``(b, k)``.
    ``cells``: per grid cell its height, the height's rise, its slope, the slope's rise."""
    b, k = h_out.shape
    for i in range(b):
        for t in range(k):
            pos = _clamped((s_now[i] + v_now[i] * ahead[t] - origins[i]) * inv_grid, last)
            i0 = np.intp(pos)
            w = pos - i0
            c = row_start[i] + i0
            h_out[i, t] = cells[c, 0] + cells[c, 1] * w
            slope_out[i, t] = cells[c, 2] + cells[c, 3] * w


@numba.njit(inline="always")
def _clamped(pos, last):
    """``pos`` within ``[0, last]``; NaN raises (as numpy would index outside the table
    with it)."""
    if pos != pos:
        raise FloatingPointError("NaN path coordinate in the texture look-up")
    return min(max(pos, 0.0), last)


@numba.njit(cache=True, nogil=True)
def viscoelastic_felt(h, slope, ratios, decays, gains, arms, last):
    """The texture's height ``h`` and slope ``slope`` ``(b, k)`` over a period, as a
    viscoelastic skin answers them, in place: each Prony arm ``j`` of each trial carries
    its state (``arms[i, j, 0]`` for the height, ``[i, j, 1]`` for the slope), updated
    every step by ``y = decays[j] y + gains[j] (x - x_prev)`` (``x_prev`` in ``last[i]``,
    the previous step's input), and the answer is ``x + sum_j ratios[j] y_j``
    (:meth:`synth.viscoelastic.Viscoelastic.sampled_arms`)."""
    b, k = h.shape
    n = ratios.shape[0]
    for i in range(b):
        for t in range(k):
            xh = h[i, t]
            xs = slope[i, t]
            dh = xh - last[i, 0]
            ds = xs - last[i, 1]
            last[i, 0] = xh
            last[i, 1] = xs
            for j in range(n):
                arms[i, j, 0] = decays[j] * arms[i, j, 0] + gains[j] * dh
                arms[i, j, 1] = decays[j] * arms[i, j, 1] + gains[j] * ds
                xh = xh + ratios[j] * arms[i, j, 0]
                xs = xs + ratios[j] * arms[i, j, 1]
            h[i, t] = xh
            slope[i, t] = xs


@numba.njit(cache=True, nogil=True)
def controls(h, slope, normal, xy, z_ref, direction, s_now, v_now, ahead, mz, control, push_out):
    """A period's controls ``(b, k, ncontrol)``: the x/y servo set points ``xy`` ``(b, k,
    2)``, the z set point ``z_ref`` and the specimen's pose, which puts the felt surface
    under the skin's contacting point (path coordinate ``s_now + v_now * ahead``) at height
    ``h`` and slope ``slope`` along the path ``direction``: the specimen turns by
    ``atan(slope)`` about the horizontal axis across the path (quaternion in columns
    ``mz + 1 .. mz + 4``) and rises to ``h - slope * s`` (column ``mz``), so that the turned
    plane passes through height ``h`` at ``s``. Into ``push_out`` ``(b, k)``: the share of
    the normal load the turned plane tips along the path, ``-slope * normal``.

    The half-angle's cosine and sine come from square roots alone (``cos a = 1 / sqrt(1 +
    slope^2)``, ``cos(a/2) = sqrt((1 + cos a) / 2)``, ``sin(a/2) = slope cos a / (2
    cos(a/2))``): IEEE square roots give the same bits on every CPU."""
    b, k = h.shape
    for i in range(b):
        for t in range(k):
            m = slope[i, t]
            push_out[i, t] = m * -normal[i]
            s = s_now[i] + v_now[i] * ahead[t]
            cos_a = 1.0 / math.sqrt(1.0 + m * m)
            c2 = math.sqrt((1.0 + cos_a) / 2.0)
            s2 = m * cos_a / (2.0 * c2)
            control[i, t, 0] = xy[i, t, 0]
            control[i, t, 1] = xy[i, t, 1]
            control[i, t, 2] = z_ref[i]
            control[i, t, mz] = h[i, t] - m * s
            control[i, t, mz + 1] = c2
            control[i, t, mz + 2] = s2 * direction[i, 1]
            control[i, t, mz + 3] = -(s2 * direction[i, 0])
            control[i, t, mz + 4] = 0.0


@numba.njit(cache=True, nogil=True)
def next_state(
    state_buf,
    dt,
    qvel,
    sens,
    direction,
    cols,
    state,
    warm,
    normal,
    s_now,
    v_now,
    slip_speed,
    wrist_sum,
    reset,
):
    """After a period of ``k`` steps: each trial's ``reset`` flag (its clock, column 0 of
    the state, advanced by less than ``k - 0.5`` steps ``dt``: MuJoCo restarted it); if
    none was reset, the state to continue from (the period's last, into ``state``), the
    warm start ``warm`` (the last step's change of the velocities at columns ``qvel,
    qvel + nv``, per second) and, from the last step's sensors ``sens`` ``(b, k, n)``, the
    inputs the next period responds to: the contact's ``normal`` load (0 without a
    contact), the skin's path coordinate ``s_now`` and slip velocity along the path
    ``v_now``, its slip speed, and the wrist force summed over the period, subtracted
    from ``wrist_sum``. ``cols``: the sensors' columns (contact found, contact force z,
    skin x, slip x, wrist). Returns whether a trial was reset (the state is then left
    as it was)."""
    b, k = sens.shape[0], sens.shape[1]
    margin = (k - 0.5) * dt
    was_reset = False
    for i in range(b):
        reset[i] = state_buf[i, k - 1, 0] < state[i, 0] + margin
        was_reset = was_reset or reset[i]
    if was_reset:
        return True
    c_found, c_fz, c_skin, c_slip, c_wrist = cols[0], cols[1], cols[2], cols[3], cols[4]
    for i in range(b):
        state[i, :] = state_buf[i, k - 1, :]
        for c in range(warm.shape[1]):
            warm[i, c] = (state_buf[i, k - 1, qvel + c] - state_buf[i, k - 2, qvel + c]) / dt
        last = sens[i, k - 1]
        normal[i] = -last[c_fz] if last[c_found] > 0 else 0.0
        dx, dy = direction[i, 0], direction[i, 1]
        s_now[i] = last[c_skin] * dx + last[c_skin + 1] * dy
        slip_x, slip_y = last[c_slip], last[c_slip + 1]
        v_now[i] = slip_x * dx + slip_y * dy
        slip_speed[i] = np.hypot(slip_x, slip_y)
        wrist = sens[i, 0, c_wrist]
        for t in range(1, k):
            wrist += sens[i, t, c_wrist]
        wrist_sum[i] -= wrist
    return False


@numba.njit(cache=True, nogil=True)
def touchable(
    normals, offsets, starts, centre, seg_a, edges, edge_sq, previous, seg_piece, reach_m, out
):
    """:func:`synth.pieces.touchable`, into ``out`` ``(b, pieces)``: the first piece whose
    every edge holds the centre (the centre's excess over each edge's half-plane,
    ``x * normal_x + y * normal_y - offset``, is at most 0; the pieces' edges from
    ``starts``), else the owners of the outline segments ``(seg_a, edges, edge_sq,
    previous, seg_piece)`` whose nearest point is within ``reach_m`` at a segment's interior
    or at a vertex both sides end at."""
    b, m = centre.shape[0], normals.shape[0]
    n, s = starts.size, seg_a.shape[0]
    t = np.empty(s)
    for i in range(b):
        cx, cy = centre[i, 0], centre[i, 1]
        above = False
        for p in range(n):
            end = starts[p + 1] if p + 1 < n else m
            e = starts[p]
            worst = cx * normals[e, 0] + cy * normals[e, 1] - offsets[e]
            for e in range(starts[p] + 1, end):
                excess = cx * normals[e, 0] + cy * normals[e, 1] - offsets[e]
                if excess > worst:
                    worst = excess
            out[i, p] = worst <= 0.0 and not above
            above = above or worst <= 0.0
        if above:
            continue
        for j in range(s):
            t[j] = ((cx - seg_a[j, 0]) * edges[j, 0] + (cy - seg_a[j, 1]) * edges[j, 1]) / edge_sq[
                j
            ]
        for j in range(s):
            clamped = min(max(t[j], 0.0), 1.0)
            gap_x = cx - (seg_a[j, 0] + clamped * edges[j, 0])
            gap_y = cy - (seg_a[j, 1] + clamped * edges[j, 1])
            if np.hypot(gap_x, gap_y) < reach_m:
                interior = t[j] > 0.0 and t[j] < 1.0
                corner = t[j] <= 0.0 and t[previous[j]] >= 1.0
                if interior or corner:
                    out[i, seg_piece[j]] = True


@numba.njit(cache=True, nogil=True)
def mechanics(
    sens,
    pitch_col,
    pitch0,
    direction,
    cols,
    force,
    mount_force,
    mount_torque,
    contact_ahead,
    indentation,
    traction,
):
    """The mechanics the sensor chain reads, from the sensors ``sens``, period-major
    ``(periods, b, k, ...)`` (step ``t`` of trial ``i`` at ``[t // k, i, t % k]``; a
    trial-major ``(b, n, ...)`` array is ``sens[None]``), at columns ``cols`` (contact,
    pad position, contact depth, mount force, mount torque): the contact ``force`` ``(b,
    n, 3)`` (0 without a contact), the mount's force and torque turned from the rocking
    pad's frame into the phalanx's (by the pad's pitch, the sensors' column
    ``pitch_col``, less the finger's own pitch ``pitch0``), how far the contact centre
    lies ahead of the pad along the path ``direction`` ``(b, 2)``, the skin's indentation
    (the deepest penetration, 0 without one) and the traction along the path
    (:func:`synth.recording._process`'s mechanics)."""
    c_contact, c_pad, c_depth, c_force, c_torque = cols[0], cols[1], cols[2], cols[3], cols[4]
    periods, b, per = sens.shape[0], sens.shape[1], sens.shape[2]
    for i in range(b):
        dx, dy = direction[i, 0], direction[i, 1]
        for t in range(periods * per):
            row = sens[t // per, i, t % per]
            found = row[c_contact] > 0
            for a in range(3):
                force[i, t, a] = row[c_contact + 1 + a] if found else 0.0
            # An upright finger (pitch0 0) turns by the pad's rocking alone, bit for bit.
            angle = row[pitch_col] - pitch0 if pitch0 != 0.0 else row[pitch_col]
            c, s = math.cos(angle), math.sin(angle)
            x, y, z = row[c_force], row[c_force + 1], row[c_force + 2]
            mount_force[i, t, 0] = c * x + s * z
            mount_force[i, t, 1] = y
            mount_force[i, t, 2] = c * z - s * x
            x, y, z = row[c_torque], row[c_torque + 1], row[c_torque + 2]
            mount_torque[i, t, 0] = c * x + s * z
            mount_torque[i, t, 1] = y
            mount_torque[i, t, 2] = c * z - s * x
            if found:
                rel_x = row[c_contact + 7] - row[c_pad]
                rel_y = row[c_contact + 8] - row[c_pad + 1]
                contact_ahead[i, t] = rel_x * dx + rel_y * dy
            else:
                contact_ahead[i, t] = 0.0
            if row[c_depth] > 0:
                depth = -row[c_depth + 1]
                indentation[i, t] = depth if depth >= 0.0 else 0.0
            else:
                indentation[i, t] = 0.0
            traction[i, t] = -(force[i, t, 0] * dx + force[i, t, 1] * dy)


@numba.njit(inline="always")
def _surface_slope(x, delta, radius):
    """:func:`synth.contact.surface_slope` at one point, for ``delta >= 0``: the same
    operations in the same order."""
    if not delta > 0.0:
        return 0.0
    r = abs(x)
    a = math.sqrt(radius * delta)
    if r <= a:
        slope = -r / radius
    else:
        a_safe = a if a > 0.0 else 1.0
        rho = r / a_safe
        if rho < 1.0:
            rho = 1.0
        slope = (
            delta
            / (math.pi * a_safe)
            * (2.0 * math.sqrt(rho * rho - 1.0) / rho - 2.0 * rho * math.asin(1.0 / rho))
        )
    if x > 0.0:
        return slope
    if x < 0.0:
        return slope * -1.0
    return slope * 0.0


@numba.njit(cache=True, nogil=True)
def film_strains(
    ahead, indentation, traction, centres, half, radius, neg_offset, length, shears, out
):
    """:func:`synth.sensors.film_strains`' arithmetic: film ``f`` (centre ``centres[f]``
    from the pad's axis, shear factor ``shears[f]``) at every sample of ``ahead``,
    ``indentation`` and ``traction`` ``(b, n)``, into ``out`` ``(b, films, n)``: the
    slope's rise over the film, ``neg_offset * rise / length``, minus ``shears[f]`` times
    the traction."""
    b, n = ahead.shape
    for i in range(b):
        for f in range(centres.size):
            c0 = centres[f]
            shear = shears[f]
            for t in range(n):
                centre = c0 - ahead[i, t]
                delta = indentation[i, t]
                rise = _surface_slope(centre + half, delta, radius) - _surface_slope(
                    centre - half, delta, radius
                )
                out[i, f, t] = neg_offset * rise / length - shear * traction[i, t]


@numba.njit(cache=True, nogil=True)
def finite_trials(sens, out):
    """``out[i]``: every value of trial ``i`` in the period-major sensors ``sens``
    ``(periods, b, k, ...)`` is finite (``np.isfinite(sens[:, i]).all()``)."""
    periods, b = sens.shape[0], sens.shape[1]
    for i in range(b):
        out[i] = True
    for g in range(periods):
        for i in range(b):
            if out[i]:
                # x - x is 0 for a finite x and NaN for a NaN or an infinity: an "or"
                # over the block without a branch per value (a vectorised loop).
                block = sens[g, i].ravel()
                bad = False
                for j in range(block.size):
                    bad |= (block[j] - block[j]) != 0.0
                out[i] = not bad
