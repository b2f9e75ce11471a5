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

:mod:`synth.planning` plans the trials, :mod:`synth.recording` turns their physics into
signals and refuses a trial whose physics went wrong; this module runs the batches
through MuJoCo and keeps both modules' public names importable from here.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor

import mujoco
import numpy as np
from mujoco import _rollout

from tactile_synth.threads import rollout_threads

from . import scene as scene_mod
from .closed_loop import CLOCK_START_S, ClosedLoop, timers_off
from .config import SynthConfig
from .planning import (
    MAX_CONTACT_GAP_S,
    TOUCH_STEP_M,
    WINDOW_MARGIN_S,
    Plan,
    _check_config,
    check_grid,
    contact_gap_limit_s,
    contact_phase_m,
    n_steps,
    plan,
    steps_per_sample,
    touch_distance_m,
    travel,
)
from .recording import (
    BASELINE_S,
    EDGE_THRESHOLD,
    MAX_TRACKING_ERROR_M,
    SaturatedTrialError,
    SimulationError,
    _describe,
    _process,
    contact_phase_samples,
)
from .trial import Trial, TrialSpec

#: The simulator's names, with the planning's (:mod:`synth.planning`) and the recording's
#: (:mod:`synth.recording`) that users reach through this module.
__all__ = [
    "BASELINE_S",
    "CHUNK",
    "EDGE_THRESHOLD",
    "MAX_CONTACT_GAP_S",
    "MAX_TRACKING_ERROR_M",
    "TOUCH_STEP_M",
    "WINDOW_MARGIN_S",
    "Plan",
    "SaturatedTrialError",
    "SimulationError",
    "batches",
    "check_grid",
    "contact_gap_limit_s",
    "contact_phase_m",
    "contact_phase_samples",
    "n_steps",
    "plan",
    "raw_rollout",
    "raw_rollout_times",
    "replay",
    "rollout_chunks",
    "simulate",
    "simulate_batch",
    "steps_per_sample",
    "touch_distance_m",
    "travel",
]

#: Most trials per rollout batch (bounds memory: about 2 MB of state and sensors per
#: trial). Larger batches share the closed loop's per-period Python work among more
#: trials; a generation chunk (36 trials of one shape in the presets) is one batch.
CHUNK = 64


def batches(n: int, size: int = CHUNK) -> list[slice]:
    """``n`` items cut into the fewest batches of at most ``size``, as equal as possible."""
    count = -(-n // size)
    bounds = [round(i * n / count) for i in range(count + 1)] if count else [0]
    return [slice(a, b) for a, b in itertools.pairwise(bounds)]


def _initial_states(plans: Sequence[Plan]) -> np.ndarray:
    out = []
    lay = scene_mod.control_layout(plans[0].model)
    data = mujoco.MjData(plans[0].model)  # the plans share one scene: one data, reset per plan
    for p in plans:
        mujoco.mj_resetData(p.model, data)
        data.time = CLOCK_START_S
        data.qpos[:] = p.initial_qpos
        control = scene_mod.rest_control(p.model)
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
    # MuJoCo integrates the joint springs of the pad's mount explicitly: a step long
    # against their fastest mode diverges unless their damping holds it.
    diverged = not warned or "mjWARN_BADQACC" in warned
    hint = (
        f" (the integration diverged: a shorter simulator step than motion.timestep_s = "
        f"{config.motion.timestep_s * 1e3:g} ms, or more damping, may hold it)"
        if diverged
        else ""
    )
    if not warned:
        raise SimulationError(f"MuJoCo reset the unstable simulation of {culprit}{hint}")
    raise SimulationError(f"MuJoCo warning {', '.join(warned)} while simulating {culprit}{hint}")


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
        for part in batches(len(group)):
            chunk = group[part]
            control = np.tile(scene_mod.rest_control(base), (len(chunk), steps, 1))
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
