"""Turn a batch's simulated physics into trials: the virtual PVDF films, strain gauges
and DAQ read the mechanics, the window is cut from the record where its signals place
the contact phase (:func:`contact_phase_samples`, as a lab cuts it), and a trial whose
physics went wrong (non-finite values, lost contact, stuck finger) is refused with a
:class:`SimulationError` naming it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from . import kernels, sensors
from . import scene as scene_mod
from .config import SynthConfig
from .planning import Plan, steps_per_sample
from .trial import N_SAMPLES, SAMPLE_RATE_HZ, Trial, TrialSpec

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


class SimulationError(RuntimeError):
    """The physics went wrong for a trial (MuJoCo warning, NaN, lost contact, stuck finger)."""


class SaturatedTrialError(SimulationError):
    """A trial's signals leave the DAQ's range (:func:`synth.generation.simulate_trials`
    names the trial)."""


def _describe(spec: TrialSpec) -> str:
    return (
        f"shape={spec.shape!r}, material={spec.material!r}, force_n={spec.force_n}, "
        f"speed_mm_s={spec.speed_mm_s}, seed={spec.seed}"
    )


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
    # The skin's traction is the contact's whole tangential force: its friction and, on
    # the texture's tilted plane, the normal force's share along the path (the texture's
    # push). The films read it, as the mount does through the pad.
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
