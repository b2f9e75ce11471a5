"""Simulate trials: plan each trial's path and surface, run the robot's closed loop in
MuJoCo's C++ threads (``mujoco.rollout``, one controller period at a time; see
:mod:`synth.closed_loop`), and turn the physics into the four DAQ channels.

A trial's timeline (physics step ``Motion.timestep_s``):

1. load: the finger rests on the plate, clear of the raised outline, pressed with the
   target force (``settle_s``);
2. slide: the robot accelerates to the target speed along the path (``ramp_s``) and holds
   it; the start point is placed so that the skin first touches the raised outline
   ``approach_s`` after the slide starts (longer where a fast slide would otherwise
   start its window before the robot is at speed);
3. window: 2 s of the DAQ's 1 kHz record from the contact phase, cut as a lab cuts it
   from the recorded signals (:func:`contact_phase_samples`): the front gauge's departure
   from its level on the plate marks the entry and the exit edge, and the window is
   centred between them (plus the extraction's jitter). Every speed is cut the same
   way: at 10 mm/s the window holds both edge crossings of a 16 mm outline, slower runs
   see less of the shape around its middle, faster ones the whole crossing. The path is
   planned so that the contact phase's middle falls :data:`WINDOW_MARGIN_S` before the
   simulated record's end at the latest, whatever the pad's lag.

All per-trial randomness derives from ``SeedSequence([trial seed, class key])`` (the key:
:func:`synth.trial.class_key`, the index into ``CLASS_NAMES`` for the paper's classes), spawned
into independent streams (path, material, sensors, texture, noise), so a trial is
bit-identical whatever batch, thread or process simulates it.
"""

from __future__ import annotations

import functools
import itertools
import math
import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import mujoco
import numpy as np
import shapely
from mujoco import _rollout

import shapes
from shapes import SPECIMEN, Specimen, SpecimenLike
from tactile_synth.threads import rollout_threads

from . import contact, kernels, sensors, texture
from . import scene as scene_mod
from .closed_loop import (
    CLOCK_START_S,
    ClosedLoop,
    LoopTrial,
    force_loop_gain_m_per_n_s,
    timers_off,
)
from .config import SynthConfig
from .trial import N_SAMPLES, SAMPLE_RATE_HZ, WINDOW_S, Trial, TrialSpec, class_key

#: Most trials per rollout batch (bounds memory: about 2 MB of state and sensors per
#: trial). Larger batches share the closed loop's per-period Python work among more
#: trials; a generation chunk (36 trials of one shape in the presets) is one batch.
CHUNK = 64


def batches(n: int, size: int = CHUNK) -> list[slice]:
    """``n`` items cut into the fewest batches of at most ``size``, as equal as possible."""
    count = -(-n // size)
    bounds = [round(i * n / count) for i in range(count + 1)] if count else [0]
    return [slice(a, b) for a, b in itertools.pairwise(bounds)]


#: Simulated time past the planned window's end: room for the window that the recorded
#: signals place (:func:`contact_phase_samples`) to fall later than the planned one, as
#: the pad's lag behind its path and the threshold's position on the edges' rise move it.
WINDOW_MARGIN_S = 0.1
#: A lab's cut of the contact phase from the record (:func:`contact_phase_samples`): the
#: films' level on the plate is read over this stretch after the robot has reached speed
#: and its start transient has died out, before the skin can touch the outline; an edge
#: is where the films depart from that level by this fraction of their largest departure
#: in the record.
BASELINE_S = 0.03
EDGE_THRESHOLD = 0.05
#: Largest tolerated gap between the finger and its commanded path: beyond the elastic lag
#: of the PDMS and servo at an edge (a few mm), the finger is stuck.
MAX_TRACKING_ERROR_M = 8e-3
#: Longest tolerated contact gap. The skin may hop for a millisecond or two when stored
#: shear snaps free at an edge's crest, and for a few tens of milliseconds where a light,
#: fast stroke runs off a wall: the stiff PDMS support leaves the skin's indentation as
#: the only travel while the force loop lowers the arm (up to 34 ms measured at 0.6 N and
#: 14 mm/s, the perturbation grid's corner); longer means the finger left the specimen.
#: A specimen higher than the built-ins' 2 mm is allowed the time the force loop takes to
#: lower the arm by the extra height at its fastest, with no force read
#: (:func:`contact_gap_limit_s`).
MAX_CONTACT_GAP_S = 0.05
#: Resolution of the search for the first touch along the path.
TOUCH_STEP_M = 20e-6


class SimulationError(RuntimeError):
    """The physics went wrong for a trial (MuJoCo warning, NaN, lost contact, stuck finger)."""


class SaturatedTrialError(SimulationError):
    """A trial's signals leave the DAQ's range (:func:`synth.generation.simulate_trials`
    names the trial)."""


@dataclass(frozen=True)
class Plan:
    """One trial's drawn conditions, its model, initial state and closed-loop inputs."""

    spec: TrialSpec
    model: mujoco.MjModel
    initial_qpos: np.ndarray
    loop: LoopTrial
    touch_step: int  # physics step at which the commanded path first touches the outline
    window_start: int  # physics step of the planned window's first DAQ sample
    record_start: int  # physics step of the DAQ record's first sample (the slide's start)
    jitter_s: float  # the extraction's offset of the window's middle from the phase's
    steps: int  # physics steps the record needs (a whole number of controller periods)
    noise_seed: np.random.SeedSequence
    specimen: SpecimenLike  # the built-in shape's name or the configuration's Specimen
    max_gap_s: float = MAX_CONTACT_GAP_S  # longest tolerated contact gap (contact_gap_limit_s)

    @property
    def x_ref(self) -> np.ndarray:
        return self.loop.x_ref


def steps_per_sample(config: SynthConfig) -> int:
    return round(1.0 / (config.motion.timestep_s * SAMPLE_RATE_HZ))


def n_steps(
    config: SynthConfig, speed_mm_s: float, force_n: float, specimen: SpecimenLike | None = None
) -> int:
    """Most physics steps any trial at ``speed_mm_s`` and ``force_n`` (before their
    scatter) can need:
    up to the latest possible window end over every built-in outline, rounded up to a
    whole number of controller periods. Paths are planned this long; a batch runs only as
    many steps as its trials' windows need. A user's ``specimen`` longer along x than the
    built-ins' longest (18 mm), or higher than their 2 mm, gets the steps its own length
    and touch distance need; the built-ins' count is the same for every one of them."""
    m, var = config.motion, config.variability
    speed = speed_mm_s * 1e-3 * (1 - 3 * var.speed_rel)
    extent = shapes.dims.MAX_EXTENT_RATIO * SPECIMEN.outline_size_m
    height = SPECIMEN.height_m
    if isinstance(specimen, Specimen):
        extent = max(extent, specimen.x_extent_m)
        height = max(height, specimen.height_m)
    reach = touch_distance_m(config, force_n * (1 + 3 * var.force_rel), height)
    phase_m = extent + 2 * reach
    middle = max(m.approach_s + phase_m / (2 * speed), _earliest_middle_s(config))
    # The record runs to the later of the window's end and the exit edge's last touch
    # (the window is cut between the two edges the signals show), plus the margin.
    end = max(middle + WINDOW_S / 2 + var.window_jitter_s / 2, middle + phase_m / (2 * speed))
    total = m.settle_s + m.ramp_s + end + WINDOW_MARGIN_S
    steps = round(total / m.timestep_s) + 2 * steps_per_sample(config)
    return _whole_periods(steps, m.control_steps)


def travel(t_slide: np.ndarray, speed_m_s: float, ramp_s: float) -> np.ndarray:
    """Distance along the path after ``t_slide`` seconds of sliding (linear speed ramp)."""
    t = np.asarray(t_slide, dtype=float)
    return np.where(
        t <= 0,
        0.0,
        np.where(t < ramp_s, speed_m_s * t * t / (2 * ramp_s), speed_m_s * (t - ramp_s / 2)),
    )


def _scatter(rng: np.random.Generator, rel: float, size=None) -> np.ndarray | float:
    """1 + N(0, rel), clipped at 3 sigma (no negative gains or friction)."""
    return 1.0 + rel * np.clip(rng.standard_normal(size), -3, 3)


def touch_distance_m(config: SynthConfig, force_n: float, height_m: float | None = None) -> float:
    """Horizontal distance from the pad's axis to a raised edge of ``height_m`` (default:
    the built-ins' 2 mm) at which the skin (sunk into the plate by its Hertz indentation
    at ``force_n``) first touches the edge."""
    r = config.finger.pad_radius_m
    h = SPECIMEN.height_m if height_m is None else height_m
    f = config.finger
    sink = float(contact.hertz_indentation_m(force_n, r, f.skin_modulus_pa, f.skin_poisson))
    return math.sqrt(max(r * r - (r - h - sink) ** 2, 0.0))


def contact_phase_m(
    shape: SpecimenLike, y_offset_m: float, yaw_rad: float, reach_m: float
) -> tuple[float, float]:
    """Path coordinates ``(first, last)`` between which the pad's axis is within
    ``reach_m`` of the raised outline (the path is ``(d cos yaw, y_offset + d sin yaw)``):
    the skin's first touch of the entry edge and last touch of the exit edge, on a grid of
    ``TOUCH_STEP_M``.

    The distance to the outline changes by at most the step along the path, so a grid
    :data:`_COARSE` times coarser finds where the fine grid can come within reach; the
    fine grid is then searched only there (the same answer as searching all of it)."""
    poly = _outline(shape)
    half = SPECIMEN.base_length_m / 2
    d = np.arange(-half, half, TOUCH_STEP_M)
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)

    def near(idx: np.ndarray, limit: float) -> np.ndarray:
        pts = shapely.points(d[idx] * c, y_offset_m + d[idx] * s)
        return idx[shapely.distance(pts, poly) <= limit]

    coarse = near(np.arange(0, d.size, _COARSE), reach_m + _COARSE * TOUCH_STEP_M)

    def edge(candidates: np.ndarray, last: bool) -> int | None:
        for j in candidates:
            window = np.arange(max(j - _COARSE, 0), min(j + _COARSE + 1, d.size))
            hit = near(window, reach_m)
            if hit.size:
                return int(hit[-1] if last else hit[0])
        return None

    lo, hi = edge(coarse, last=False), edge(coarse[::-1], last=True)
    if lo is None or hi is None:
        raise ValueError(
            f"the path at y = {y_offset_m * 1e3:.2f} mm misses the "
            f"{shapes.specimen_name(shape)} outline"
        )
    return float(d[lo]), float(d[hi])


#: Coarse grid of :func:`contact_phase_m`, in fine steps.
_COARSE = 25


@functools.lru_cache(maxsize=32)
def _outline(shape: SpecimenLike) -> shapely.Polygon:
    """The specimen outline of ``shape``, a built-in name or a ``Specimen`` (every trial's
    plan measures its path against it)."""
    poly = shapes.outline(shape)
    shapely.prepare(poly)
    return poly


def plan(spec: TrialSpec, config: SynthConfig) -> Plan:
    """Draw the trial's variability and build its model, initial state and loop inputs."""
    var, mot, finger = config.variability, config.motion, config.finger
    specimen = config.specimen(spec.shape)
    material = config.material(spec.material)
    height = specimen.height_m if isinstance(specimen, Specimen) else SPECIMEN.height_m
    root = np.random.SeedSequence([spec.seed, class_key(f"{spec.shape}/{spec.material}")])
    path_ss, material_ss, sensor_ss, texture_ss, noise_ss = root.spawn(5)
    path = np.random.default_rng(path_ss)
    force = spec.force_n * _scatter(path, var.force_rel)
    speed = spec.speed_mm_s * 1e-3 * _scatter(path, var.speed_rel)
    y_offset = mot.path_y_m + path.uniform(-1, 1) * var.lateral_offset_m
    yaw = path.standard_normal() * var.yaw_rad
    if mot.specimen_yaw_rad:  # the specimen turned in its fixture
        yaw += mot.specimen_yaw_rad
    jitter = path.uniform(-0.5, 0.5) * var.window_jitter_s
    friction_scale = float(_scatter(np.random.default_rng(material_ss), var.friction_rel))
    reach = touch_distance_m(config, force, height)
    d_in, d_out = contact_phase_m(specimen, y_offset, yaw, reach)
    half_phase_s = (d_out - d_in) / (2 * speed)
    approach = max(mot.approach_s, _earliest_middle_s(config) - half_phase_s)
    d_start = d_in - speed * (mot.ramp_s / 2 + approach)
    t_touch = mot.settle_s + mot.ramp_s + approach
    t_middle = t_touch + half_phase_s
    k = steps_per_sample(config)
    window_start = k * round((t_middle - WINDOW_S / 2 + jitter) * SAMPLE_RATE_HZ)

    # The record runs past the planned window's end and the exit edge's last touch.
    record_end = max(
        window_start + (N_SAMPLES + 1) * k, round((t_middle + half_phase_s) / mot.timestep_s)
    )
    t = np.arange(n_steps(config, spec.speed_mm_s, spec.force_n, specimen)) * mot.timestep_s
    d = d_start + travel(t - mot.settle_s, speed, mot.ramp_s)
    c, s = math.cos(yaw), math.sin(yaw)
    x_ref, y_ref = d * c, y_offset + d * s
    _check_on_plate(spec, x_ref, y_ref, finger.pad_radius_m)

    s_path = d + y_offset * s  # path coordinate p . direction along the commanded path
    sink = float(
        contact.hertz_indentation_m(
            force, finger.pad_radius_m, finger.skin_modulus_pa, finger.skin_poisson
        )
    )
    # The surface as felt at every contact radius the simulated load can make; the closed
    # loop reads the one of the load it simulates.
    surface = texture.loaded_surface(
        material.texture,
        finger,
        float(s_path[0]) - 2 * finger.pad_radius_m,
        float(s_path[-1]) + 2 * finger.pad_radius_m,
        np.random.default_rng(texture_ss),
        force_n=force,
        mark_angle_rad=yaw,  # the marks run along the specimen's y, the ridges along the robot's
    )
    sc = scene_mod.scene(specimen, config)
    qpos = np.zeros(sc.model.nq)
    qi = sc.qpos_index
    preload = force / finger.pdms_normal_stiffness_n_m
    h0 = surface.height_at(force, float(s_path[0]))  # under the resting pad
    qpos[qi["robot_x"]] = x_ref[0]
    qpos[qi["robot_y"]] = y_ref[0]
    qpos[qi["robot_z"]] = h0 - sink - preload  # skin indented, PDMS pre-compressed
    qpos[qi["pdms_z"]] = preload
    z_ref0 = qpos[qi["robot_z"]] - force / mot.servo_stiffness_n_m
    # The wrist sensor's noise on each of its readings over the whole path.
    readings = int(t[-1] * mot.wrist_sensor_rate_hz) + 1
    wrist_noise = np.random.default_rng(sensor_ss).standard_normal(readings)
    wrist_noise *= mot.wrist_force_noise_n
    mu0 = contact.friction_coefficient(material.friction, 0.0, force, friction_scale)
    loop = LoopTrial(
        x_ref=x_ref,
        y_ref=y_ref,
        force_n=force,
        friction=material.friction,
        friction_scale=friction_scale,
        surface=surface,
        direction=(c, s),
        z_ref0=z_ref0,
        wrist_noise_n=wrist_noise,
    )
    return Plan(
        spec=spec,
        model=sc.trial_model(float(mu0)),
        initial_qpos=qpos,
        loop=loop,
        touch_step=round(t_touch / mot.timestep_s),
        window_start=window_start,
        record_start=k * round(mot.settle_s * SAMPLE_RATE_HZ),
        jitter_s=float(jitter),
        steps=_whole_periods(
            record_end + round(WINDOW_MARGIN_S / mot.timestep_s), mot.control_steps
        ),
        noise_seed=noise_ss,
        specimen=specimen,
        max_gap_s=contact_gap_limit_s(config, force, height),
    )


def contact_gap_limit_s(config: SynthConfig, force_n: float, height_m: float) -> float:
    """Longest contact gap a trial at ``force_n`` on a specimen ``height_m`` high may show:
    :data:`MAX_CONTACT_GAP_S`, measured on the built-ins' 2 mm, plus, for a higher
    specimen, the time the force loop takes to lower the arm by the extra height when it
    reads no force (its fastest descent, ``gain x force_n``): a light stroke that runs
    off a higher wall falls for longer before the skin meets the plate again."""
    extra = max(height_m - SPECIMEN.height_m, 0.0)
    if extra == 0.0:
        return MAX_CONTACT_GAP_S
    return MAX_CONTACT_GAP_S + extra / (force_loop_gain_m_per_n_s(config, force_n) * force_n)


def _earliest_middle_s(config: SynthConfig) -> float:
    """Earliest window middle, from the moment the robot reaches speed: the window must not
    start within ``Motion.start_transient_s`` of that, whatever its jitter."""
    jitter = config.variability.window_jitter_s
    return config.motion.start_transient_s + WINDOW_S / 2 + jitter / 2


def _whole_periods(steps: int, period: int) -> int:
    return -(-steps // period) * period


def _check_on_plate(spec: TrialSpec, x_ref: np.ndarray, y_ref: np.ndarray, radius: float) -> None:
    x_lim = SPECIMEN.base_length_m / 2 - radius / 2
    y_lim = SPECIMEN.base_width_m / 2 - radius / 2
    if np.abs(y_ref).max() > y_lim:
        raise ValueError(
            f"the path of {spec.shape} runs {np.abs(y_ref).max() * 1e3:.1f} mm across the "
            f"plate's centre line, beyond the {SPECIMEN.base_width_m * 1e3:.0f} mm wide plate "
            f"(less the pad's half radius): turn or offset the path less"
        )
    if np.abs(x_ref).max() > x_lim:
        span_mm = (x_ref.max() - x_ref.min()) * 1e3
        raise ValueError(
            f"speed_mm_s={spec.speed_mm_s!r} makes the finger travel {span_mm:.0f} mm, beyond "
            f"the {SPECIMEN.base_length_m * 1e3:.0f} mm plate; use a speed of at most about "
            f"{(2 * x_lim) / (x_ref.max() - x_ref.min()) * spec.speed_mm_s:.0f} mm/s"
        )


def check_grid(
    shapes_: Sequence[str],
    conditions: Sequence[tuple[float, float]],
    material: str,
    config: SynthConfig | None = None,
) -> None:
    """Plan one trial of every shape at every ``(force_n, speed_mm_s)`` condition, so a
    grid whose slides would leave the plate is refused before anything is simulated
    (``ValueError`` naming the speed)."""
    config = _check_config(config)
    for force, speed in conditions:
        for shape in shapes_:
            plan(TrialSpec(shape, material, force_n=force, speed_mm_s=speed), config)


def _describe(spec: TrialSpec) -> str:
    return (
        f"shape={spec.shape!r}, material={spec.material!r}, force_n={spec.force_n}, "
        f"speed_mm_s={spec.speed_mm_s}, seed={spec.seed}"
    )


def _initial_states(plans: Sequence[Plan]) -> np.ndarray:
    out = []
    lay = scene_mod.control_layout(plans[0].model)
    data = mujoco.MjData(plans[0].model)  # the plans share one scene: one data, reset per plan
    for p in plans:
        mujoco.mj_resetData(p.model, data)
        data.time = CLOCK_START_S
        data.qpos[:] = p.initial_qpos
        control = np.zeros(lay["size"].stop)
        control[lay["ctrl"]] = (p.loop.x_ref[0], p.loop.y_ref[0], p.loop.z_ref0)
        mujoco.mj_setState(p.model, data, control, scene_mod.CONTROL_SPEC)
        state = np.empty(mujoco.mj_stateSize(p.model, scene_mod.STATE_SPEC))
        mujoco.mj_getState(p.model, data, state, scene_mod.STATE_SPEC)
        out.append(state)
    return np.stack(out)


def _roll(
    plans: Sequence[Plan], datas: list[mujoco.MjData], config: SynthConfig
) -> tuple[np.ndarray, np.ndarray]:
    """Run a chunk of same-shape plans' closed loops; returns sensordata
    ``(b, steps, nsensordata)`` and the surface's inputs ``(b, steps, 2)`` (the specimen's
    texture height and the texture's push on the skin)."""
    sens, surface, _ = _roll_loop(plans, datas, config)
    return sens, surface


def _roll_loop(
    plans: Sequence[Plan],
    datas: list[mujoco.MjData],
    config: SynthConfig,
    periods: bool = False,
) -> tuple[np.ndarray, np.ndarray, ClosedLoop]:
    """:func:`_roll`, also returning the loop that ran (its ``rollout_s_`` for profiling);
    with ``periods`` the sensors come period-major, as
    :meth:`synth.closed_loop.ClosedLoop.run_periods` returns them."""
    for d in datas:
        mujoco.mj_resetData(plans[0].model, d)
    loop = ClosedLoop(
        [p.model for p in plans], [p.loop for p in plans], config, shape=plans[0].specimen
    )
    steps = max(p.steps for p in plans)
    run = loop.run_periods if periods else loop.run
    sens, surface = run(datas, _initial_states(plans), steps, len(datas))
    _check_stable(loop, plans, datas, config)
    return sens, surface, loop


def _check_stable(
    loop: ClosedLoop, plans: Sequence[Plan], datas: list[mujoco.MjData], config: SynthConfig
) -> None:
    """Raise :class:`SimulationError` naming the trial of ``loop``'s run that MuJoCo reset
    or warned about, if any."""
    warned, unstable = loop.warned_, loop.unstable_
    if not warned and not unstable.size:
        return
    if len(plans) > 1:  # alone, a trial's warnings stay on its data: find the culprit
        for i in unstable if unstable.size else range(len(plans)):
            _roll([plans[i]], datas[:1], config)
    culprit = _describe(plans[unstable[0] if unstable.size else 0].spec)
    if not warned:
        raise SimulationError(f"MuJoCo reset the unstable simulation of {culprit}")
    raise SimulationError(f"MuJoCo warning {', '.join(warned)} while simulating {culprit}")


#: The sensors :func:`synth.kernels.mechanics` reads, in its order.
_MECHANICS_COLUMNS = ("contact", "pad_pos", "contact_depth", "mount_force", "mount_torque")


def contact_phase_samples(record: np.ndarray, baseline: slice) -> tuple[int, int] | None:
    """First and last sample of the contact phase in a trial's DAQ record ``(4, n)``, as a
    lab cuts it: the films ring hard when the skin meets or leaves an edge and stay
    within millivolts while it slides on a face. The films' larger magnitude, after its
    level over ``baseline`` (samples on the plate) is taken off, marks an edge where it
    reaches :data:`EDGE_THRESHOLD` of its largest value in the record after ``baseline``;
    the phase runs from the first such sample to the last. ``None`` if the films never
    depart from the plate's level."""
    films = np.abs(np.asarray(record[:2], dtype=float))
    level = films[:, baseline].max(axis=1, keepdims=True)
    departure = (films - level).max(axis=0)[baseline.stop :]
    peak = departure.max() if departure.size else 0.0
    if not peak > 0:
        return None
    above = np.flatnonzero(departure >= EDGE_THRESHOLD * peak) + baseline.stop
    return int(above[0]), int(above[-1])


def _process(
    plans: Sequence[Plan], sens: np.ndarray, surface: np.ndarray, config: SynthConfig
) -> list[Trial]:
    """The trials of a batch's physics: ``sens`` the sensors, trial-major ``(b, steps,
    nsensordata)`` or period-major ``(periods, b, k, nsensordata)`` as
    :meth:`synth.closed_loop.ClosedLoop.run_periods` returns them; ``surface`` ``(b,
    steps, 2)`` the specimen's height and the texture's push on the skin.

    Each trial's DAQ records from the slide's start to the end of its own simulated
    steps; the window is cut from that record where its signals place the contact phase
    (:func:`contact_phase_samples`)."""
    if sens.ndim == 3:  # trial-major: one period of all the steps
        sens = sens[None]
    cols = scene_mod.sensor_columns()
    k = steps_per_sample(config)
    fs = SAMPLE_RATE_HZ * k
    _, b, per, _ = sens.shape
    n = surface.shape[1]
    force = np.empty((b, n, 3))
    mech = sensors.Mechanics(
        mount_force=np.empty((b, n, 3)),
        mount_torque=np.empty((b, n, 3)),
        contact_ahead_m=np.empty((b, n)),
        indentation_m=np.empty((b, n)),
        traction_n=np.empty((b, n)),
    )
    # The mount's force sensor turns with the rocking pad; the gauges' phalanx does not.
    kernels.mechanics(
        sens,
        cols["pad_pitch"].start,
        config.finger.pitch_rad,
        np.array([p.loop.direction for p in plans]),
        np.array([cols[c].start for c in _MECHANICS_COLUMNS]),
        force,
        mech.mount_force,
        mech.mount_torque,
        mech.contact_ahead_m,
        mech.indentation_m,
        mech.traction_n,
    )
    # The skin's traction is the contact's friction plus the texture's push, which the
    # closed loop applies to the skin at the contact: the films read both, as the mount
    # does through the pad.
    mech.traction_n[...] += surface[:, :, 1]
    strain = sensors.gauge_strains(mech, config.finger, config.strain_gauge)
    sg = sensors.bridge_volts(strain, config.strain_gauge, fs)
    pvdf = sensors.pvdf_volts(
        sensors.film_strains(mech, config.finger, config.pvdf), config.pvdf, fs
    )
    analog = sensors.antialias(np.concatenate([pvdf, sg], axis=1), config.acquisition, fs)
    amp_noise = sensors.amplifier_noise_v(config)
    mot = config.motion
    base_first = round((mot.ramp_s + mot.start_transient_s) * SAMPLE_RATE_HZ)
    base = slice(base_first, base_first + round(BASELINE_S * SAMPLE_RATE_HZ))
    finite = np.empty(b, dtype=bool)
    kernels.finite_trials(sens, finite)
    # The sensors the trials' truth reads, at their samples: the pad's position, the
    # slip velocity's x and y, the contacts found.
    slip_x, found = cols["slip_vel"].start, cols["contact"].start
    read = np.r_[cols["pad_pos"], slip_x, slip_x + 1, found]
    flat = sens.reshape(-1, sens.shape[-1])
    trials = []
    for i, p in enumerate(plans):
        # The DAQ's record: from the slide's start to the trial's own last step.
        n_rec = (p.steps - p.record_start) // k - 1
        at_rec = p.record_start + k * np.arange(n_rec)
        record = sensors.digitise(
            analog[i : i + 1, :, at_rec],
            config.acquisition,
            SAMPLE_RATE_HZ,
            [np.random.default_rng(p.noise_seed)],
            dc_coupled=np.array([0.0, 0.0, 1.0, 1.0]),  # PVDF AC-coupled, strain gauges DC
            amplifier_noise_v=amp_noise,
        )[0]
        if not finite[i]:
            _check_trial(p, {}, False)
        if mot.raised_shape:
            phase = contact_phase_samples(record, base)
            if phase is None:
                raise SimulationError(
                    f"the gauges show no edge in the record while simulating {_describe(p.spec)}"
                )
            middle = (phase[0] + phase[1]) / 2 + p.jitter_s * SAMPLE_RATE_HZ
            first = round(middle - N_SAMPLES / 2)
        else:  # the bare plate (calibration runs): no edge to cut at, the planned window
            first = (p.window_start - p.record_start) // k
        first = min(max(first, base.stop), n_rec - N_SAMPLES)
        window = slice(first, first + N_SAMPLES)
        at = at_rec[window]
        f = force[i, at]
        # The rows of the samples' steps in the sensors seen as (periods * b * k, n).
        row = flat.take((at // per) * (b * per) + i * per + at % per, axis=0)[:, read]
        pad_pos = row[:, :3]
        slip = row[:, 3:5]
        truth = {
            "time_s": at * config.motion.timestep_s,
            "normal_force_n": -f[:, 2],
            "tangential_force_n": np.hypot(f[:, 0], f[:, 1]),
            "friction_force_x_n": f[:, 0],
            "lateral_force_n": f[:, 1],
            "texture_push_n": surface[i, at, 1],
            "finger_x_m": pad_pos[:, 0],
            "finger_y_m": pad_pos[:, 1],
            "finger_z_m": pad_pos[:, 2] - config.finger.pad_radius_m,
            "commanded_x_m": p.loop.x_ref[at],
            "slip_speed_m_s": np.hypot(slip[:, 0], slip[:, 1]),
            "indentation_m": mech.indentation_m[i, at],
            "contacts": row[:, 5],
            "specimen_z_m": surface[i, at, 0],
        }
        _check_trial(p, truth, bool(finite[i]))
        truth = {name: np.ascontiguousarray(v) for name, v in truth.items()}
        signals = record[:, window].astype(np.float32)
        trials.append(Trial(spec=p.spec, signals=signals, truth=truth))
    return trials


def _check_trial(p: Plan, truth: dict[str, np.ndarray], finite: bool) -> None:
    """Raise :class:`SimulationError` for a trial whose physics went wrong: a non-finite
    sensor value (``finite`` False), a contact lost for longer than
    ``p.max_gap_s`` in its window, or a finger stuck behind its path."""
    if not finite:
        raise SimulationError(f"non-finite physics (NaN/inf) while simulating {_describe(p.spec)}")
    gap, where = _longest_run(truth["contacts"] < 1)
    if gap / SAMPLE_RATE_HZ > p.max_gap_s:
        raise SimulationError(
            f"the finger lost contact with the specimen for {gap} ms from "
            f"t={truth['time_s'][where]:.3f} s while simulating {_describe(p.spec)}"
        )
    error = np.abs(truth["finger_x_m"] - truth["commanded_x_m"]).max()
    if error > MAX_TRACKING_ERROR_M:
        raise SimulationError(
            f"the finger lagged {error * 1e3:.1f} mm behind its path (stuck) while simulating "
            f"{_describe(p.spec)}"
        )


def _longest_run(mask: np.ndarray) -> tuple[int, int]:
    """Length and start index of the longest run of True in ``mask``."""
    padded = np.concatenate([[0], mask.astype(np.int8), [0]])
    edges = np.flatnonzero(np.diff(padded))
    if edges.size == 0:
        return 0, 0
    starts, ends = edges[::2], edges[1::2]
    best = int(np.argmax(ends - starts))
    return int(ends[best] - starts[best]), int(starts[best])


def _check_config(config: SynthConfig | None) -> SynthConfig:
    if config is None:
        return SynthConfig()
    if not isinstance(config, SynthConfig):
        raise ValueError(f"config must be a SynthConfig or None; got {type(config).__name__}")
    return config


def rollout_chunks(specs: Sequence[TrialSpec]) -> list[list[int]]:
    """Indices of ``specs`` in the rollout batches :func:`simulate_batch` runs: the trials
    of one shape and speed (a batch shares a scene and a path length), in their order,
    cut by :func:`batches`."""
    by_shape: dict[tuple[str, float], list[int]] = {}
    for i, s in enumerate(specs):
        by_shape.setdefault((s.shape, s.speed_mm_s), []).append(i)
    return [members[part] for members in by_shape.values() for part in batches(len(members))]


def simulate_batch(
    specs: Sequence[TrialSpec],
    *,
    config: SynthConfig | None = None,
    threads: int | None = None,
    progress: bool = False,
) -> list[Trial]:
    """Simulate many trials through ``mujoco.rollout``; results in the order of ``specs``.

    ``threads``: rollout threads (default: ``tactile_synth.threads.rollout_threads()``, this
    process's thread budget). Results do not depend on it.
    """
    config = _check_config(config)
    specs = list(specs)
    for i, s in enumerate(specs):
        if not isinstance(s, TrialSpec):
            raise ValueError(f"specs[{i}] must be a TrialSpec; got {type(s).__name__}")
    if threads is None:
        threads = rollout_threads()
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        raise ValueError(f"threads must be an integer >= 1; got {threads!r}")
    results: list[Trial | None] = [None] * len(specs)
    chunks = rollout_chunks(specs)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(specs), unit="trial", desc="simulate")
    datas: dict[str, list[mujoco.MjData]] = {}

    def roll(chunk: list[int]) -> tuple[list[Plan], tuple[np.ndarray, np.ndarray]]:
        shape = specs[chunk[0]].shape
        if shape not in datas:
            base = scene_mod.scene(config.specimen(shape), config).model
            datas[shape] = [mujoco.MjData(base) for _ in range(threads)]
        plans = [plan(specs[i], config) for i in chunk]
        sens, heights, _ = _roll_loop(plans, datas[shape][: len(chunk)], config, periods=True)
        return plans, (sens, heights)

    # Pipeline: MuJoCo rolls the next chunk out in its C++ threads (GIL released) while
    # this thread turns the previous chunk's physics into signals.
    pool = ThreadPoolExecutor(max_workers=1)
    pending = None
    try:
        pending = pool.submit(roll, chunks[0]) if chunks else None
        for n, chunk in enumerate(chunks):
            plans, (sens, heights) = pending.result()
            pending = pool.submit(roll, chunks[n + 1]) if n + 1 < len(chunks) else None
            for i, trial in zip(chunk, _process(plans, sens, heights, config), strict=True):
                results[i] = trial
            if bar is not None:
                bar.update(len(chunk))
    finally:
        if pending is not None:
            pending.cancel()
        pool.shutdown(wait=True)
        if bar is not None:
            bar.close()
    return results  # type: ignore[return-value]


def raw_rollout(
    specs: Sequence[TrialSpec], *, config: SynthConfig | None = None, threads: int | None = None
) -> float:
    """Physics only, for speed references: one open-loop call of MuJoCo's C++ rollout
    (the one under ``mujoco.rollout``) per rollout batch of ``specs`` (the trials of one
    shape and speed, cut as :func:`rollout_chunks` cuts them), with the path and the
    initial force set point but no controller, texture, sensor chain, checks or storage;
    its inputs and outputs are made and their memory touched before the call. Every
    batch runs to the longest plan among all of its shape's and speed's trials, where
    :func:`simulate_batch` stops each batch at its own longest plan; the plans' lengths
    differ by their placement's scatter, and a batch of tens of trials holds one near the
    longest, so the two step counts differ by little. Returns the rollout wall seconds
    (:func:`raw_rollout_times` also gives their CPU seconds).
    """
    return raw_rollout_times(specs, config=config, threads=threads)[0]


def raw_rollout_times(
    specs: Sequence[TrialSpec], *, config: SynthConfig | None = None, threads: int | None = None
) -> tuple[float, float]:
    """:func:`raw_rollout`'s wall seconds and the process's CPU seconds inside its
    rollout calls (every rollout thread's): the planning and set-up around the calls are
    in neither, so a comparison with an end-to-end run's CPU charges that run with its
    planning. Other threads of this process computing meanwhile would count too. MuJoCo
    runs without its profiling timers, as in the simulator
    (:func:`synth.closed_loop.timers_off`)."""
    config = _check_config(config)
    threads = threads or rollout_threads()
    by_shape: dict[tuple[str, float], list[Plan]] = {}
    for s in specs:
        by_shape.setdefault((s.shape, s.speed_mm_s), []).append(plan(s, config))
    with timers_off():  # as the simulator runs MuJoCo
        return _raw_rollout_times(by_shape, threads)


def _raw_rollout_times(
    by_shape: dict[tuple[str, float], list[Plan]], threads: int
) -> tuple[float, float]:
    # MuJoCo's C++ rollout as the closed loop calls it, one call per batch; the inputs and
    # the outputs are made and touched before the timed call, so that it times the
    # physics (the Python wrapper, mujoco.rollout.rollout, copies the controls and
    # allocates the outputs inside its call).
    runner = _rollout.Rollout(nthread=threads if threads > 1 else 0)
    spec = int(scene_mod.CONTROL_SPEC)
    wall = cpu = 0.0
    for group in by_shape.values():
        steps = max(p.steps for p in group)
        base = group[0].model
        datas = [mujoco.MjData(base) for _ in range(threads)]
        lay = scene_mod.control_layout(base)
        for part in batches(len(group)):
            chunk = group[part]
            control = np.zeros((len(chunk), steps, lay["size"].stop))
            for i, p in enumerate(chunk):
                control[i, :, 0] = p.loop.x_ref[:steps]
                control[i, :, 1] = p.loop.y_ref[:steps]
                control[i, :, 2] = p.loop.z_ref0
            state0 = _initial_states(chunk)
            warm = np.zeros((len(chunk), base.nv))
            state = np.empty((len(chunk), steps, state0.shape[1]))
            sens = np.empty((len(chunk), steps, base.nsensordata))
            state.fill(0.0)
            sens.fill(0.0)
            t0, c0 = time.perf_counter(), time.process_time()
            runner.rollout(
                [p.model for p in chunk],
                datas,
                steps,
                spec,
                state0,
                warm,
                control,
                state,
                sens,
                None,
            )
            wall += time.perf_counter() - t0
            cpu += time.process_time() - c0
    return wall, cpu


def replay(spec: TrialSpec, config: SynthConfig | None = None):
    """``(model, qpos (steps, nq), specimen heights (steps,))`` of one simulated trial, for
    replaying its motion in a viewer."""
    config = _check_config(config)
    p = plan(spec, config)
    loop = ClosedLoop([p.model], [p.loop], config, shape=p.specimen)
    datas = [mujoco.MjData(p.model)]
    _, surface = loop.run(datas, _initial_states([p]), p.steps, 1, record_qpos=True)
    _check_stable(loop, [p], datas, config)
    return p.model, loop.qpos_[0], surface[0, :, 0]


def simulate(
    shape: str,
    material: str,
    *,
    force_n: float = 1.0,
    speed_mm_s: float = 10.0,
    seed: int = 0,
    config: SynthConfig | None = None,
) -> Trial:
    """Simulate one trial: the finger slides across a specimen under the robot's force
    loop and the four channels are recorded through the virtual sensors and DAQ.

    Parameters
    ----------
    shape : str
        The specimen: one of ``shapes.SHAPE_NAMES`` or a specimen of ``config``
        (``SynthConfig.specimens``).
    material : str
        Its material: one of ``config``'s materials (the paper's ``synth.MATERIAL_NAMES``
        by default).
    force_n, speed_mm_s : float
        The robot's normal-force set point (N) and sliding speed (mm/s).
    seed : int
        The trial's own seed: all its randomness (placement, surface stretch, scatter,
        noise) derives from it, so the same arguments give the same bits.
    config : SynthConfig, optional
        The simulated experiment (default: the paper's, ``SynthConfig()``).

    Returns
    -------
    Trial
        ``signals`` float32 ``(4, 2000)``: 2 s at 1 kHz from the contact phase, channels
        ``pvdf1, pvdf2, sg1, sg2``, volts; ``truth``: the simulated forces and positions
        on the same clock.

    Examples
    --------
    >>> import synth
    >>> trial = synth.simulate("circle", "wood", seed=0)
    >>> trial.signals.shape, trial.signals.dtype
    ((4, 2000), dtype('float32'))
    >>> again = synth.simulate("circle", "wood", seed=0)
    >>> bool((again.signals == trial.signals).all())
    True
    """
    spec = TrialSpec(shape, material, force_n=force_n, speed_mm_s=speed_mm_s, seed=seed)
    return simulate_batch([spec], config=config, threads=1)[0]
