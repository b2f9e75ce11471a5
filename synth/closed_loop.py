"""The robot controller and the surface's response, closed around the simulated state.

MuJoCo rolls a batch of trials forward one controller period at a time
(``Motion.control_period_s``, a few physics steps, in ``mujoco.rollout``'s C++ threads);
between periods this module reads each trial's simulated state from its sensors and sets
the next period's inputs from it:

- **force loop** (the robot's force mode): an integral controller on the normal load the
  wrist sensor reads (the force the z drive transmits, averaged over the period, plus the
  sensor's noise, ``Motion.wrist_force_noise_n``) moves the set point of the stiff z
  servo, which the arm interpolates over the control period; its gain gives the closed
  loop ``Motion.force_loop_bandwidth_hz`` on the series stiffness of servo, PDMS support
  and skin contact;
- **friction**: the skin's coefficient follows the material's :class:`FrictionLaw` at the
  simulated slip speed of the skin's bottom point and the simulated normal force;
- **texture**: the height and slope of the felt surface under the skin's contacting
  material (the skin's bottom point: it moves over the surface only when the skin
  slips, so a stuck pad feels a still surface), extrapolated over the period with its
  simulated slip velocity, and felt by the ridges inside the contact of the simulated
  normal load, set the specimen's pose: it rises to the height and turns by the slope
  under the contact, so the contact's normal tilts and MuJoCo's contact carries the
  texture's push (``-slope x normal load`` along the path, returned beside the height
  for the trial's truth) and moves the contact over the pad as a turned plane would.

Nothing here sees the planned path except the x/y servo set points themselves; every
texture and friction input comes from where the pad is and how it moves. Each trial's
inputs depend only on its own state (elementwise arithmetic over the batch), so a trial's
result does not depend on the batch it runs in.
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field

import mujoco
import numpy as np
from mujoco import _rollout

from shapes import SpecimenLike

from . import contact, kernels
from . import pieces as pieces_mod
from . import scene as scene_mod
from . import texture as texture_mod
from .config import SynthConfig
from .materials import FrictionLaw
from .texture import FeltSurface, LoadedSurface
from .viscoelastic import SILICONE_PRONY, Viscoelastic


@dataclass(frozen=True)
class LoopTrial:
    """One trial's inputs to the closed loop.

    x_ref, y_ref: ``(steps,)`` the robot's x/y path set points; force_n: the normal force
    set point; friction: the material's law and ``friction_scale`` this stroke's scatter
    factor; surface: the felt texture along the path direction ``direction`` (unit x/y
    vector), whose path coordinate is ``s = p . direction`` (a :class:`LoadedSurface` is
    read at the simulated normal load, a :class:`FeltSurface` is felt the same under any
    load); z_ref0: initial z set point; wrist_noise_n: the wrist force sensor's noise on
    each of its readings, at ``Motion.wrist_sensor_rate_hz`` from the first step (a
    control period reads the latest reading; empty: a noiseless sensor).
    """

    x_ref: np.ndarray
    y_ref: np.ndarray
    force_n: float
    friction: FrictionLaw
    friction_scale: float
    surface: FeltSurface | LoadedSurface
    direction: tuple[float, float]
    z_ref0: float
    wrist_noise_n: np.ndarray = field(default_factory=lambda: np.zeros(0))


def skin_stiffness_n_m(config: SynthConfig, force_n: float) -> float:
    """Tangent stiffness of the skin's Hertz contact at the load ``force_n``: the load
    grows as the indentation ``delta`` to the power 1.5, so ``1.5 F / delta``."""
    f = config.finger
    delta = float(
        contact.hertz_indentation_m(force_n, f.pad_radius_m, f.skin_modulus_pa, f.skin_poisson)
    )
    return 1.5 * force_n / delta


def series_stiffness_n_m(config: SynthConfig, force_n: float) -> float:
    """How much the normal load changes per metre the robot's z set point moves, at the
    load ``force_n``: the stiffness of the servo, the PDMS support and the skin's Hertz
    contact (:func:`skin_stiffness_n_m`) in series."""
    k_skin = skin_stiffness_n_m(config, force_n)
    return 1.0 / (
        1.0 / config.motion.servo_stiffness_n_m
        + 1.0 / config.finger.pdms_normal_stiffness_n_m
        + 1.0 / k_skin
    )


def force_loop_gain_m_per_n_s(config: SynthConfig, force_n: float) -> float:
    """Integral gain (m/s per N of force error) for the configured loop bandwidth.

    The loop moves the servo set point; the load changes by the series stiffness of the
    servo, the PDMS support and the skin (:func:`series_stiffness_n_m`), so a gain of
    ``2 pi f / k_series`` closes the loop at ``f``.
    """
    k_series = series_stiffness_n_m(config, force_n)
    return 2 * math.pi * config.motion.force_loop_bandwidth_hz / k_series


_timers_lock = threading.Lock()
_timers_users = 0
_timers_saved = None


@contextlib.contextmanager
def timers_off() -> Iterator[None]:
    """Run MuJoCo without its profiling timers: while any caller is inside, MuJoCo's
    ``mjcb_time`` callback is a clock that reads 0 (:func:`synth.kernels.no_time`).

    MuJoCo reads that clock at the start and end of every stage of every step to fill
    ``mjData.timer``; the steady clock MuJoCo's Python bindings install there is read
    dozens of times per step, a share of the physics' time worth saving where reading a
    clock is slow (a virtual machine's), and nothing in the package reads the timers.
    The callback is process-wide, so nested and concurrent callers (a generation's
    chunks on threads) share one switch; the last one out puts the previous callback
    back (none, if it was the bindings' own clock, which they install again with the
    next ``MjData``). The physics does not depend on the timers.
    """
    global _timers_users, _timers_saved
    with _timers_lock:
        if _timers_users == 0:
            _timers_saved = mujoco.get_mjcb_time()
            mujoco.set_mjcb_time(kernels.no_time.ctypes)
        _timers_users += 1
    try:
        yield
    finally:
        with _timers_lock:
            _timers_users -= 1
            if _timers_users == 0:
                mujoco.set_mjcb_time(_timers_saved)
                _timers_saved = None


#: Where each trial's MuJoCo clock starts (``_initial_states``), in seconds. MuJoCo resets
#: a trial whose state turns bad (NaN, or beyond ``mjMAXVAL``) and restarts its clock at
#: zero, so from any start above zero a reset shows as a clock that did not advance by a
#: period's steps, even a reset in the very first step. Nothing in the scene depends on
#: the clock's value.
CLOCK_START_S = 1.0


class ClosedLoop:
    """Runs a batch of same-shape trials (``models`` share one scene) to ``steps`` steps;
    returns sensordata ``(b, steps, nsensordata)`` and the surface's inputs ``(b, steps,
    2)``: the specimen's height and the texture's push on the skin along the path.
    """

    def __init__(
        self,
        models: Sequence[mujoco.MjModel],
        trials: Sequence[LoopTrial],
        config: SynthConfig,
        shape: SpecimenLike | None = None,
    ) -> None:
        self.models = list(models)
        self.trials = list(trials)
        self.config = config
        base = self.models[0]
        self.layout = scene_mod.control_layout(base)
        self.cols = scene_mod.sensor_columns()
        self.skin = mujoco.mj_name2id(base, mujoco.mjtObj.mjOBJ_GEOM, "skin")
        self.nq, self.nv = base.nq, base.nv
        b = len(self.trials)
        self.force = np.array([t.force_n for t in self.trials])
        self.gain = np.array([force_loop_gain_m_per_n_s(config, t.force_n) for t in self.trials])
        self.kinetic = np.array([t.friction.kinetic for t in self.trials])
        # Static minus kinetic coefficient: the velocity-weakening part of the law.
        self.static_excess = np.array([t.friction.static for t in self.trials]) - self.kinetic
        self.v_stribeck = np.array([t.friction.stribeck_velocity_m_s for t in self.trials])
        self.load_exp = np.array([t.friction.load_exponent for t in self.trials])
        self.vel_exp = np.array([t.friction.velocity_exponent for t in self.trials])
        self.v_ref = np.array([t.friction.reference_speed_m_s for t in self.trials])
        self.scale = np.array([t.friction_scale for t in self.trials])
        self.dir = np.array([t.direction for t in self.trials])  # (b, 2)
        self.texture = texture_mod.texture_table(
            [texture_mod.as_loaded(t.surface) for t in self.trials]
        )
        # A viscoelastic skin answers the texture through its Prony arms, as recursive
        # filters at the physics step (synth.kernels.viscoelastic_felt); an elastic one
        # takes it as the surface has it.
        self.skin_arms = None
        if config.finger.skin_texture_response == "viscoelastic":
            skin = Viscoelastic(config.finger.skin_modulus_pa, SILICONE_PRONY)
            self.skin_arms = skin.sampled_arms(config.motion.timestep_s)
        # Trials at other forces or speeds plan paths of other lengths; the batch runs as
        # long as its longest window needs, so shorter paths are extended (see _extend).
        n_ref = max(t.x_ref.size for t in self.trials)
        self.x_ref = np.stack([_extend(t.x_ref, n_ref) for t in self.trials])
        self.y_ref = np.stack([_extend(t.y_ref, n_ref) for t in self.trials])
        self.z_ref = np.array([t.z_ref0 for t in self.trials])
        # The wrist sensor's noise per reading; a batch-mate's longer path reads zeros
        # beyond a trial's own readings, after its window.
        n_read = max([t.wrist_noise_n.size for t in self.trials] + [1])
        self.wrist_noise = np.zeros((b, n_read))
        for i, t in enumerate(self.trials):
            self.wrist_noise[i, : t.wrist_noise_n.size] = t.wrist_noise_n
        self.b = b
        # A specimen of several convex pieces: one contact per region of its surface.
        self.pieces = (
            None
            if shape is None
            else pieces_mod.piece_contacts(shape, self.models, config.finger.pad_radius_m)
        )

    def friction(
        self, slip_speed: np.ndarray, normal_n: np.ndarray, out: np.ndarray | None = None
    ) -> np.ndarray:
        """Coefficient of each trial's law at its slip speed and normal load (into
        ``out`` ``(b,)`` if given)."""
        if out is None:
            out = np.empty(self.b)
        kernels.friction_law(
            slip_speed,
            normal_n,
            self.kinetic,
            self.static_excess,
            self.v_stribeck,
            self.load_exp,
            self.vel_exp,
            self.v_ref,
            self.scale,
            out,
        )
        return out

    def run(
        self,
        datas: Sequence[mujoco.MjData],
        initial_state: np.ndarray,
        steps: int,
        nthread: int,
        record_qpos: bool = False,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Roll the batch ``steps`` physics steps (a multiple of the update period) from
        ``initial_state`` ``(b, nstate)`` on ``datas`` (one per thread). With
        ``record_qpos`` the joint positions ``(b, steps, nq)`` are kept in ``qpos_``
        (for replaying a trial in a viewer). The run stops at the end of the first period
        in which MuJoCo resets a trial or counts a warning (the outputs' later steps are
        then undefined); ``unstable_`` holds the indices of the trials it reset and
        ``warned_`` the names of the warnings MuJoCo counted (of the last trial on each
        data). ``rollout_s_`` holds the wall seconds spent inside MuJoCo's rollout calls
        (the rest of the run's time is its set-up and the controller's and the surface's
        work between periods), for profiling. MuJoCo runs without its profiling timers
        (:func:`timers_off`)."""
        sens, surface = self.run_periods(datas, initial_state, steps, nthread, record_qpos)
        return trial_major(sens), surface

    @timers_off()
    def run_periods(
        self,
        datas: Sequence[mujoco.MjData],
        initial_state: np.ndarray,
        steps: int,
        nthread: int,
        record_qpos: bool = False,
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`run`, with the sensors as MuJoCo wrote them: period-major,
        ``(steps // k, b, k, nsensordata)`` for the update period of ``k`` steps
        (:func:`trial_major` turns them trial-major). The simulator's sensor chain reads
        them so: a trial-major copy written period by period would put each period's
        block on pages far apart, which the physics evicts from the caches in between."""
        cfg = self.config
        mot = cfg.motion
        dt, k = mot.timestep_s, mot.surface_steps
        if steps % k:
            raise ValueError(f"steps ({steps}) must be a multiple of the update period ({k})")
        nseg = steps // k
        control_every = mot.control_steps // k  # force-loop updates happen every n periods
        b, base = self.b, self.models[0]
        n_read = self.wrist_noise.shape[1]
        nstate, nsens = initial_state.shape[1], base.nsensordata
        lay, cols = self.layout, self.cols
        # Rollout writes each period's sensors straight into its contiguous block of a
        # period-major buffer; the specimen's heights (small) go trial-major.
        sens_out = np.empty((nseg, b, k, nsens))
        height_out = np.empty((b, nseg, k))
        push_out = np.empty((b, nseg, k))
        h = np.empty((b, k))
        control = np.zeros((b, k, lay["size"].stop))
        state_buf = np.empty((b, k, nstate))
        qpos_out = np.empty((b, nseg, k, self.nq)) if record_qpos else None
        # The x/y servo set points of every period, laid out as the control's columns.
        xy_seg = np.stack([self.x_ref[:, :steps], self.y_ref[:, :steps]], axis=-1)
        xy_seg = xy_seg.reshape(b, nseg, k, 2)
        state = np.array(initial_state, dtype=float, order="C")  # updated in place
        warm = np.zeros((b, self.nv))
        slope = np.empty((b, k))
        reset = np.zeros(b, dtype=bool)
        # Where each model keeps the skin's sliding coefficient (self.models keeps the
        # buffers alive), written before every period by kernels.store_at.
        item = base.geom_friction.itemsize
        mu_at = self.skin * base.geom_friction.shape[1] * item
        friction_at = np.array(
            [m.geom_friction.ctypes.data + mu_at for m in self.models], dtype=np.uint64
        )
        mu = np.empty(b)
        warnings = [d.warning.number for d in datas]  # live views of the warning counters
        no_warning = bytes(warnings[0].nbytes)
        # The sensors the next period responds to (kernels.next_state): contact found, its
        # force's z, the skin's x and its slip velocity's x (y follows each), the wrist's.
        found = cols["contact"].start
        state_cols = np.array(
            [
                found,
                found + 3,
                cols["skin_pos"].start,
                cols["slip_vel"].start,
                cols["drive_force"].start,
            ]
        )
        c_pad = slice(cols["pad_pos"].start, cols["pad_pos"].start + 2)
        mz = lay["mocap_pos"].start + 2  # the height, then the orientation's quaternion
        direction = self.dir
        ahead = np.arange(1, k + 1) * dt

        # Before the first period: the pad rests at the start, loaded by the set force. These
        # inputs are updated in place after every period (kernels.next_state).
        s_now = self.x_ref[:, 0] * direction[:, 0] + self.y_ref[:, 0] * direction[:, 1]
        v_now = np.zeros(b)
        slip_speed = np.zeros(b)
        normal = self.force.copy()
        wrist = self.force.copy()
        wrist_sum = np.zeros(b)
        if self.pieces is not None:
            self.pieces.update(np.stack([self.x_ref[:, 0], self.y_ref[:, 0]], axis=1))
        self.unstable_ = np.zeros(0, dtype=np.intp)
        self.warned_: tuple[str, ...] = ()
        self.rollout_s_ = 0.0
        # The z set point: where the force loop last moved it to (z_to), the value it
        # moved from (z_from) and this period's interpolated value (z_set).
        z_to = self.z_ref.copy()
        z_from = self.z_ref.copy()
        z_set = self.z_ref.copy()
        runner = _rollout.Rollout(nthread=nthread if nthread > 1 else 0)
        spec = int(scene_mod.CONTROL_SPEC)
        # The viscoelastic skin's Prony arms per trial (height, slope) and the step's input
        # they last saw.
        n_arms = 0 if self.skin_arms is None else self.skin_arms[0].size
        skin_state = np.zeros((b, n_arms, 2))
        skin_last = np.zeros((b, 2))
        for g in range(nseg):
            if g % control_every == 0 and g:
                # Force loop: integral action on the wrist sensor's reading of the load
                # over the last period (the true load plus the latest reading's noise).
                reading = min(int(g * k * dt * mot.wrist_sensor_rate_hz), n_read - 1)
                wrist = wrist_sum / (control_every * k) + self.wrist_noise[:, reading]
                wrist_sum[:] = 0.0
                z_from = z_set.copy()
                z_to += mot.control_period_s * self.gain * (wrist - self.force)
            # The arm's servo interpolates the force loop's set point over the control
            # period (a step every 8 ms would jolt the stiff z drive at 125 Hz).
            z_set[:] = z_from + (z_to - z_from) * ((g % control_every + 1) / control_every)
            # Friction from the simulated slip and load.
            kernels.store_at(friction_at, self.friction(slip_speed, normal, mu))
            # Texture under the contact, extrapolated over the period, as felt by the
            # ridges inside the contact the simulated load makes; the specimen's heights
            # go straight to the output.
            self.texture.felt_into(s_now, v_now, ahead, normal, h, slope)
            height_out[:, g] = h
            if self.skin_arms is not None:
                if g == 0:  # the arms start relaxed, at the first step's height and slope
                    skin_last[:, 0], skin_last[:, 1] = h[:, 0], slope[:, 0]
                kernels.viscoelastic_felt(h, slope, *self.skin_arms, skin_state, skin_last)
            kernels.controls(
                h,
                slope,
                normal,
                xy_seg[:, g],
                z_set,
                direction,
                s_now,
                v_now,
                ahead,
                mz,
                control,
                push_out[:, g],
            )
            sens = sens_out[g]
            t0 = time.perf_counter()
            runner.rollout(self.models, datas, k, spec, state, warm, control, state_buf, sens, None)
            self.rollout_s_ += time.perf_counter() - t0
            if qpos_out is not None:
                qpos_out[:, g] = state_buf[:, :, 1 : 1 + self.nq]
            # A trial went unstable: the caller reports it; the rest is not needed. The
            # rollout clears a data's warning counters before each trial it runs there, so
            # they tell of the last trial on each data only; a reset trial is found by its
            # clock (CLOCK_START_S), the other warnings by the counters. Otherwise the state
            # and the inputs the next period responds to are read from this one's end.
            was_reset = kernels.next_state(
                state_buf,
                dt,
                1 + self.nq,
                sens,
                direction,
                state_cols,
                state,
                warm,
                normal,
                s_now,
                v_now,
                slip_speed,
                wrist_sum,
                reset,
            )
            if was_reset or any(w.tobytes() != no_warning for w in warnings):
                self.unstable_ = np.flatnonzero(reset)
                self.warned_ = _warning_names(datas)
                break
            if self.pieces is not None:
                self.pieces.update(sens[:, k - 1, c_pad])
        if qpos_out is not None:
            self.qpos_ = qpos_out.reshape(b, steps, self.nq)
        surface = np.stack([height_out.reshape(b, steps), push_out.reshape(b, steps)], axis=-1)
        return sens_out, surface


def _warning_names(datas: Sequence[mujoco.MjData]) -> tuple[str, ...]:
    """Names of the MuJoCo warnings counted on any of ``datas``, in MuJoCo's order."""
    counted = {w for d in datas for w in range(len(d.warning)) if d.warning[w].number > 0}
    return tuple(mujoco.mjtWarning(w).name for w in sorted(counted))


def _extend(ref: np.ndarray, n: int) -> np.ndarray:
    """``ref`` continued to ``n`` set points at its final step, as a longer plan of the same
    slide would continue it. A trial's own window ends within its planned path, so the
    steps added here come after its window and do not change its data."""
    extra = n - ref.size
    if extra <= 0:
        return ref
    step = ref[-1] - ref[-2]
    return np.concatenate([ref, ref[-1] + step * np.arange(1, extra + 1)])


def trial_major(periods: np.ndarray) -> np.ndarray:
    """Period-major sensors ``(periods, b, k, ...)`` as one contiguous trial-major array
    ``(b, periods * k, ...)``."""
    t = np.moveaxis(periods, 1, 0)
    return np.ascontiguousarray(t).reshape(t.shape[0], t.shape[1] * t.shape[2], *t.shape[3:])
