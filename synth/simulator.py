"""Simulate trials: plan each trial's open-loop controls, roll them out in MuJoCo's C++
threads (``mujoco.rollout``), and turn the physics into the four DAQ channels.

A trial's timeline (physics step ``Motion.timestep_s``):

1. load: the finger rests on the plate, pushed down with the target force (``settle_s``);
2. slide: the robot accelerates to the target speed along the path (``ramp_s``) and holds it;
3. window: 2 s of the DAQ's 1 kHz record, starting ``lead_s`` plus a random delay after
   the slide starts, placed so that its centre passes over the specimen's centre.

All per-trial randomness derives from ``SeedSequence([trial seed, class index])``, spawned
into independent streams (path, material, sensors, texture, noise), so a trial is
bit-identical whatever batch, thread or process simulates it.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import mujoco
import numpy as np
from mujoco import rollout

from shapes import SPECIMEN

from . import scene as scene_mod
from . import sensors, texture
from .config import SynthConfig
from .trial import N_SAMPLES, SAMPLE_RATE_HZ, WINDOW_S, Trial, TrialSpec, class_index

#: Trials per rollout call (bounds memory: ~1 MB of state and sensors per trial).
CHUNK = 32
#: Largest tolerated gap between the finger and its commanded path: beyond the elastic lag
#: of the PDMS and servo at an edge (a few mm), the finger is stuck.
MAX_TRACKING_ERROR_M = 8e-3
#: Longest tolerated contact gap. The skin may hop for a millisecond or two when stored
#: shear snaps free at an edge's crest; longer means the finger left the specimen.
MAX_CONTACT_GAP_S = 0.01


class SimulationError(RuntimeError):
    """The physics went wrong for a trial (MuJoCo warning, NaN, lost contact, stuck finger)."""


@dataclass(frozen=True)
class Plan:
    """One trial's drawn conditions and open-loop inputs."""

    spec: TrialSpec
    model: mujoco.MjModel
    initial_qpos: np.ndarray
    control: np.ndarray  # (steps, scene.CONTROL_SPEC size): drives, texture wrench, height
    texture_force: np.ndarray  # (steps, 2): texture's tangential force on the finger (x, y)
    specimen_z: np.ndarray  # (steps,): texture height the specimen is moved by
    x_ref: np.ndarray  # commanded path x at each step
    window_start: int  # physics step of the window's first DAQ sample
    gains: np.ndarray  # (4,) sensor gain scatter factors
    noise_seed: np.random.SeedSequence


def steps_per_sample(config: SynthConfig) -> int:
    return round(1.0 / (config.motion.timestep_s * SAMPLE_RATE_HZ))


def n_steps(config: SynthConfig) -> int:
    m = config.motion
    total = m.settle_s + m.lead_s + config.variability.window_jitter_s + WINDOW_S
    return round(total / m.timestep_s) + 2 * steps_per_sample(config)


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


def plan(spec: TrialSpec, config: SynthConfig) -> Plan:
    """Draw the trial's variability and build its model, initial state and controls."""
    var, mot, finger = config.variability, config.motion, config.finger
    material = config.materials[spec.material]
    root = np.random.SeedSequence([spec.seed, class_index(spec.shape, spec.material)])
    path_ss, material_ss, sensor_ss, texture_ss, noise_ss = root.spawn(5)
    path = np.random.default_rng(path_ss)
    force = spec.force_n * _scatter(path, var.force_rel)
    speed = spec.speed_mm_s * 1e-3 * _scatter(path, var.speed_rel)
    y_offset = mot.path_y_m + path.uniform(-1, 1) * var.lateral_offset_m
    yaw = path.standard_normal() * var.yaw_rad
    x_center = mot.window_center_x_m + path.standard_normal() * var.start_x_m
    k = steps_per_sample(config)
    window_start_s = mot.settle_s + mot.lead_s + path.uniform(0, 1) * var.window_jitter_s
    window_start = k * round(window_start_s * SAMPLE_RATE_HZ)

    mat_rng = np.random.default_rng(material_ss)
    friction = material.friction * _scatter(mat_rng, var.friction_rel)
    timeconst = material.contact_timeconst_s * _scatter(mat_rng, var.stiffness_rel)
    gains = np.asarray(_scatter(np.random.default_rng(sensor_ss), var.gain_rel, size=4))

    steps = n_steps(config)
    t = np.arange(steps) * mot.timestep_s
    d = travel(t - mot.settle_s, speed, mot.ramp_s)
    t_mid = window_start * mot.timestep_s + WINDOW_S / 2
    d_mid = float(travel(t_mid - mot.settle_s, speed, mot.ramp_s))
    x_ref = x_center + (d - d_mid) * math.cos(yaw)
    y_ref = y_offset + (d - d_mid) * math.sin(yaw)
    _check_on_plate(spec, x_ref, y_ref, finger.pad_radius_m)

    heights, slope = texture.felt_profile(
        material.texture, finger, d * math.cos(yaw), np.random.default_rng(texture_ss)
    )
    sc = scene_mod.scene(spec.shape, config)
    layout = scene_mod.control_layout(sc.model)
    control = np.zeros((steps, layout["size"].stop))
    control[:, layout["ctrl"]] = np.stack([x_ref, y_ref, np.full(steps, -force)], axis=1)
    control[:, layout["mocap_pos"].start + 2] = heights
    # The felt slope's tangential force on the finger, along the path, opposing the climb,
    # applied at the skin's contact point (torque about the pad centre r x F, r = -R z).
    push = -(1 + friction**2) * slope * force
    wrench = np.zeros((steps, 6))
    wrench[:, 0] = push * math.cos(yaw)
    wrench[:, 1] = push * math.sin(yaw)
    wrench[:, 3] = finger.pad_radius_m * wrench[:, 1]
    wrench[:, 4] = -finger.pad_radius_m * wrench[:, 0]
    control[:, layout["pad_wrench"]] = wrench

    qpos = np.zeros(sc.model.nq)
    qi = sc.qpos_index
    preload = force / finger.pdms_normal_stiffness_n_m
    qpos[qi["robot_x"]] = x_ref[0]
    qpos[qi["robot_y"]] = y_ref[0]
    qpos[qi["robot_z"]] = heights[0] - preload  # pad on the surface, PDMS pre-compressed
    qpos[qi["pdms_z"]] = preload
    return Plan(
        spec=spec,
        model=sc.trial_model(material, friction, timeconst),
        initial_qpos=qpos,
        control=control,
        texture_force=wrench[:, :2].copy(),
        specimen_z=heights,
        x_ref=x_ref,
        window_start=window_start,
        gains=gains,
        noise_seed=noise_ss,
    )


def _check_on_plate(spec: TrialSpec, x_ref: np.ndarray, y_ref: np.ndarray, radius: float) -> None:
    x_lim = SPECIMEN.base_length_m / 2 - radius / 2
    y_lim = SPECIMEN.base_width_m / 2 - radius / 2
    if np.abs(x_ref).max() > x_lim or np.abs(y_ref).max() > y_lim:
        span_mm = (x_ref.max() - x_ref.min()) * 1e3
        raise ValueError(
            f"speed_mm_s={spec.speed_mm_s!r} makes the finger travel {span_mm:.0f} mm, beyond "
            f"the {SPECIMEN.base_length_m * 1e3:.0f} mm plate; use a speed of at most about "
            f"{(2 * x_lim) / (x_ref.max() - x_ref.min()) * spec.speed_mm_s:.0f} mm/s"
        )


def _describe(spec: TrialSpec) -> str:
    return (
        f"shape={spec.shape!r}, material={spec.material!r}, force_n={spec.force_n}, "
        f"speed_mm_s={spec.speed_mm_s}, seed={spec.seed}"
    )


def _initial_states(plans: Sequence[Plan]) -> np.ndarray:
    out = []
    for p in plans:
        data = mujoco.MjData(p.model)
        data.qpos[:] = p.initial_qpos
        mujoco.mj_setState(p.model, data, p.control[0], scene_mod.CONTROL_SPEC)
        state = np.empty(mujoco.mj_stateSize(p.model, scene_mod.STATE_SPEC))
        mujoco.mj_getState(p.model, data, state, scene_mod.STATE_SPEC)
        out.append(state)
    return np.stack(out)


def _roll(plans: Sequence[Plan], datas: list[mujoco.MjData]) -> np.ndarray:
    """Roll out a chunk of same-shape plans; returns sensordata ``(b, steps, nsensordata)``."""
    models = [p.model for p in plans]
    control = np.stack([p.control for p in plans])
    for d in datas:
        mujoco.mj_resetData(models[0], d)
    _, sens = rollout.rollout(
        models,
        datas,
        _initial_states(plans),
        control,
        control_spec=scene_mod.CONTROL_SPEC,
        nstep=control.shape[1],
    )
    warned = [w for d in datas for w in range(len(d.warning)) if d.warning[w].number > 0]
    if warned:
        if len(plans) > 1:  # find the culprit trial(s) one by one
            for p in plans:
                _roll([p], datas[:1])
        names = ", ".join(mujoco.mjtWarning(w).name for w in sorted(set(warned)))
        raise SimulationError(f"MuJoCo warning {names} while simulating {_describe(plans[0].spec)}")
    return sens


def _process(plans: Sequence[Plan], sens: np.ndarray, config: SynthConfig) -> list[Trial]:
    cols = scene_mod.sensor_columns()
    k = steps_per_sample(config)
    fs = SAMPLE_RATE_HZ * k
    contact = sens[..., cols["contact"]]
    pad_pos = sens[..., cols["pad_pos"]]
    # Net force on the specimen: the simulated contacts plus the texture's tangential
    # force (the finger's reaction to the felt slope), while in contact.
    in_contact = (contact[..., 0] > 0)[..., None]
    force = contact[..., 1:4].copy()
    force[..., :2] -= np.stack([p.texture_force for p in plans]) * in_contact
    mech = sensors.Mechanics(
        mount_force=sens[..., cols["mount_force"]],
        mount_torque=sens[..., cols["mount_torque"]],
        pad_acc_z=sens[..., cols["pad_acc"]][..., 2],
        contact_force=force,
        contact_x_rel=np.where(contact[..., 0] > 0, contact[..., 7] - pad_pos[..., 0], 0.0),
    )
    strain = sensors.gauge_strains(mech, config.finger, config.strain_gauge)
    sg = sensors.bridge_volts(strain, config.strain_gauge, fs)
    pvdf = sensors.pvdf_volts(sensors.film_loads(mech, config.finger), config.pvdf, fs)
    gains = np.stack([p.gains for p in plans])[:, :, None]
    analog = sensors.antialias(np.concatenate([pvdf, sg], axis=1) * gains, config.acquisition, fs)

    idx = np.stack([p.window_start + k * np.arange(N_SAMPLES) for p in plans])
    rows = np.arange(len(plans))[:, None]
    sampled = analog[rows[:, :, None], np.arange(4)[None, :, None], idx[:, None, :]]
    volts = sensors.digitise(
        sampled,
        config.acquisition,
        SAMPLE_RATE_HZ,
        [np.random.default_rng(p.noise_seed) for p in plans],
        dc_coupled=np.array([0.0, 0.0, 1.0, 1.0]),  # PVDF AC-coupled, strain gauges DC
    )
    trials = []
    for i, p in enumerate(plans):
        at = idx[i]
        f = force[i, at]
        truth = {
            "time_s": at * config.motion.timestep_s,
            "normal_force_n": -f[:, 2],
            "tangential_force_n": np.hypot(f[:, 0], f[:, 1]),
            "friction_force_x_n": f[:, 0],
            "lateral_force_n": f[:, 1],
            "finger_x_m": pad_pos[i, at, 0],
            "finger_y_m": pad_pos[i, at, 1],
            "finger_z_m": pad_pos[i, at, 2] - config.finger.pad_radius_m,
            "commanded_x_m": p.x_ref[at],
            "contacts": contact[i, at, 0],
            "specimen_z_m": p.specimen_z[at],
        }
        _check_trial(p, truth, sens[i])
        truth = {name: np.ascontiguousarray(v) for name, v in truth.items()}
        trials.append(Trial(spec=p.spec, signals=volts[i].astype(np.float32), truth=truth))
    return trials


def _check_trial(p: Plan, truth: dict[str, np.ndarray], sens: np.ndarray) -> None:
    if not np.all(np.isfinite(sens)):
        raise SimulationError(f"non-finite physics (NaN/inf) while simulating {_describe(p.spec)}")
    gap, where = _longest_run(truth["contacts"] < 1)
    if gap / SAMPLE_RATE_HZ > MAX_CONTACT_GAP_S:
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


def simulate_batch(
    specs: Sequence[TrialSpec],
    *,
    config: SynthConfig | None = None,
    threads: int | None = None,
    progress: bool = False,
) -> list[Trial]:
    """Simulate many trials through ``mujoco.rollout``; results in the order of ``specs``.

    ``threads``: rollout threads (default: all cores). Results do not depend on it.
    """
    config = _check_config(config)
    specs = list(specs)
    for i, s in enumerate(specs):
        if not isinstance(s, TrialSpec):
            raise ValueError(f"specs[{i}] must be a TrialSpec; got {type(s).__name__}")
    if threads is None:
        threads = os.cpu_count() or 1
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        raise ValueError(f"threads must be an integer >= 1; got {threads!r}")
    by_shape: dict[str, list[int]] = {}
    for i, s in enumerate(specs):
        by_shape.setdefault(s.shape, []).append(i)
    results: list[Trial | None] = [None] * len(specs)
    chunks = [
        members[start : start + CHUNK]
        for members in by_shape.values()
        for start in range(0, len(members), CHUNK)
    ]
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(specs), unit="trial", desc="simulate")
    datas: dict[str, list[mujoco.MjData]] = {}

    def roll(chunk: list[int]) -> tuple[list[Plan], np.ndarray]:
        shape = specs[chunk[0]].shape
        if shape not in datas:
            base = scene_mod.scene(shape, config).model
            datas[shape] = [mujoco.MjData(base) for _ in range(threads)]
        plans = [plan(specs[i], config) for i in chunk]
        return plans, _roll(plans, datas[shape][: len(chunk)])

    # Pipeline: MuJoCo rolls the next chunk out in its C++ threads (GIL released) while
    # this thread turns the previous chunk's physics into signals.
    pool = ThreadPoolExecutor(max_workers=1)
    pending = None
    try:
        pending = pool.submit(roll, chunks[0]) if chunks else None
        for n, chunk in enumerate(chunks):
            plans, sens = pending.result()
            pending = pool.submit(roll, chunks[n + 1]) if n + 1 < len(chunks) else None
            for i, trial in zip(chunk, _process(plans, sens, config), strict=True):
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
    """Physics only, for speed references: the bare ``mujoco.rollout`` of ``specs``' scenes.

    Controls are planned first (not timed); then the same rollouts as :func:`simulate_batch`
    run without the sensor chain, checks or storage. Returns the rollout wall seconds.
    """
    config = _check_config(config)
    threads = threads or os.cpu_count() or 1
    by_shape: dict[str, list[Plan]] = {}
    for s in specs:
        by_shape.setdefault(s.shape, []).append(plan(s, config))
    wall = 0.0
    for group in by_shape.values():
        datas = [mujoco.MjData(group[0].model) for _ in range(threads)]
        t0 = time.perf_counter()
        for start in range(0, len(group), CHUNK):
            _roll(group[start : start + CHUNK], datas)
        wall += time.perf_counter() - t0
    return wall


def simulate(
    shape: str,
    material: str,
    *,
    force_n: float = 1.0,
    speed_mm_s: float = 10.0,
    seed: int = 0,
    config: SynthConfig | None = None,
) -> Trial:
    """Simulate one trial: ``Trial.signals`` float32 ``(4, 2000)`` plus ground truth."""
    spec = TrialSpec(shape, material, force_n=force_n, speed_mm_s=speed_mm_s, seed=seed)
    return simulate_batch([spec], config=config, threads=1)[0]
