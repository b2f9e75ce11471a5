"""Plan a trial: draw its variability from its seed, place its path so that the skin
meets the raised outline where the record needs it, and build its MuJoCo model, initial
state and closed-loop inputs (:class:`Plan`), before anything is simulated.

It plans the load and the slide of the timeline :mod:`synth.simulator` describes: the
start point is placed so that the skin first touches the raised outline ``approach_s``
after the slide starts, and the path so that the contact phase's middle falls
:data:`WINDOW_MARGIN_S` before the simulated record's end at the latest, whatever the
pad's lag; :mod:`synth.recording` cuts the window from the recorded signals. Each trial's
randomness comes from its own seed streams (:mod:`synth.simulator`), so a plan is the
same whatever batch, thread or process makes it.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
import shapely

import shapes
from shapes import SPECIMEN, Specimen, SpecimenLike

from . import contact, texture
from . import scene as scene_mod
from .closed_loop import LoopTrial, force_loop_gain_m_per_n_s
from .config import SynthConfig
from .trial import N_SAMPLES, SAMPLE_RATE_HZ, WINDOW_S, TrialSpec, class_key

#: Simulated time past the planned window's end: room for the window that the recorded
#: signals place (:func:`synth.recording.contact_phase_samples`) to fall later than the
#: planned one, as the pad's lag behind its path and the threshold's position on the
#: edges' rise move it.
WINDOW_MARGIN_S = 0.1
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
            f"speed_mm_s={spec.speed_mm_s!r} makes the finger travel {span_mm:.0f} mm over "
            f"{spec.shape}, beyond the {2 * x_lim * 1e3:.0f} mm of the "
            f"{SPECIMEN.base_length_m * 1e3:.0f} mm plate the pad may cover; slide slower"
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


def _check_config(config: SynthConfig | None) -> SynthConfig:
    if config is None:
        return SynthConfig()
    if not isinstance(config, SynthConfig):
        raise ValueError(f"config must be a SynthConfig or None; got {type(config).__name__}")
    return config
