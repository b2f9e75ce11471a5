"""Fit MuJoCo's soft-contact parameters of the skin to Hertz's law.

MuJoCo's contact is a regularised constraint: its penetration under a load depends on
``solref`` (time constant, damping ratio), ``solimp`` (the impedance rising with
penetration) and the effective mass of the bodies. :func:`measure_indentation` presses
the finger on the bare plate in the real scene (robot force loop, no sliding, no
texture) and reads the penetration; :func:`fit_skin_contact` holds the time constant at
the stiffest MuJoCo integrates stably (two physics steps) and the impedance linear in the
penetration, and chooses the impedance's lower bound and its width so that the
penetration follows ``synth.contact.hertz_indentation_m`` of the configured skin over the
loads the experiments use. ``scripts/calibrate.py skin`` runs the fit and prints the values that
``Finger.skin_solref`` / ``Finger.skin_solimp`` hold.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import mujoco
import numpy as np
from scipy import optimize

from . import contact
from . import scene as scene_mod
from .closed_loop import CLOCK_START_S, ClosedLoop, LoopTrial
from .config import SynthConfig
from .simulator import SimulationError
from .texture import FeltSurface

#: Loads the fit covers: the perturbation grid's 0.6-1.4 N with margin on both sides.
FIT_FORCES_N: tuple[float, ...] = (0.3, 0.6, 1.0, 1.4, 2.0)
#: Pressing time before the penetration is read (the force loop settles in ~0.1 s).
PRESS_S = 0.4
#: Where the fit starts, whatever the configured skin: the impedance rising from half of
#: its 0.95 maximum over 4 mm of penetration. A fixed start makes the fit a function of
#: the scene and the skin's modulus alone, so ``Finger``'s defaults can be checked
#: against it.
FIT_START = (0.5, 0.004)
#: The impedance rises linearly with penetration (solimp power 1, MuJoCo's lowest): with
#: the power free the fit ends there, so the power is held and the midpoint, which only
#: shapes a power above 1, plays no part.
FIT_POWER = 1.0


def measure_indentation(config: SynthConfig, forces_n: Sequence[float]) -> np.ndarray:
    """Steady penetration (m) of the skin into the bare plate at each load."""
    cfg = dataclasses.replace(config, motion=dataclasses.replace(config.motion, raised_shape=False))
    finger, mot = cfg.finger, cfg.motion
    sc = scene_mod.scene("square", cfg)
    k = mot.control_steps
    steps = -(-round(PRESS_S / mot.timestep_s) // k) * k
    flat = FeltSurface(origin_m=-0.03, height_m=np.zeros(8), slope=np.zeros(8))
    models, trials, states = [], [], []
    # The press does not slide, so the friction law hardly matters: the configuration's
    # first material's (resin's in the paper's set-up; an experiment may have no resin).
    law = next(iter(cfg.materials.values())).friction
    for f in forces_n:
        model = sc.trial_model(law.static)
        data = mujoco.MjData(model)
        preload = f / finger.pdms_normal_stiffness_n_m
        sink = float(
            contact.hertz_indentation_m(
                f, finger.pad_radius_m, finger.skin_modulus_pa, finger.skin_poisson
            )
        )
        z = -sink - preload
        data.qpos[sc.qpos_index["robot_x"]] = -0.02
        data.qpos[sc.qpos_index["robot_z"]] = z
        data.qpos[sc.qpos_index["pdms_z"]] = preload
        z_ref = z - f / mot.servo_stiffness_n_m
        lay = scene_mod.control_layout(model)
        control = scene_mod.rest_control(model)
        control[lay["ctrl"]] = (-0.02, 0.0, z_ref)
        mujoco.mj_setState(model, data, control, scene_mod.CONTROL_SPEC)
        data.time = CLOCK_START_S  # a reset shows in the clock (closed_loop.CLOCK_START_S)
        state = np.empty(mujoco.mj_stateSize(model, scene_mod.STATE_SPEC))
        mujoco.mj_getState(model, data, state, scene_mod.STATE_SPEC)
        models.append(model)
        states.append(state)
        trials.append(
            LoopTrial(
                x_ref=np.full(steps, -0.02),
                y_ref=np.zeros(steps),
                force_n=float(f),
                friction=law,
                friction_scale=1.0,
                surface=flat,
                direction=(1.0, 0.0),
                z_ref0=z_ref,
            )
        )
    loop = ClosedLoop(models, trials, cfg)
    datas = [mujoco.MjData(models[0])]
    sens, _ = loop.run(datas, np.stack(states), steps, 1)
    skin = f"the skin (solref {finger.skin_solref}, solimp {finger.skin_solimp})"
    if loop.unstable_.size:
        at = forces_n[int(loop.unstable_[0])]
        raise SimulationError(f"MuJoCo reset the unstable press of {skin} with {at:g} N")
    if loop.warned_:  # the last press's: the rollout clears the counters per trial
        warned = ", ".join(loop.warned_)
        raise SimulationError(f"MuJoCo warning {warned} pressing {skin} with {forces_n[-1]:g} N")
    depth = sens[:, -1, scene_mod.sensor_columns()["contact_depth"]]
    return np.maximum(-depth[:, 1], 0.0)


def fit_skin_contact(config: SynthConfig) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """``(skin_solref, skin_solimp)`` that make the simulated indentation follow Hertz's
    law of ``config.finger`` over :data:`FIT_FORCES_N` (least squares in log space,
    Nelder-Mead from :data:`FIT_START`; ``config``'s own skin_solref/solimp are not used)."""
    finger = config.finger
    forces = np.asarray(FIT_FORCES_N)
    target = contact.hertz_indentation_m(
        forces, finger.pad_radius_m, finger.skin_modulus_pa, finger.skin_poisson
    )
    dmax, midpoint = 0.95, 0.5
    # The stiffest contact MuJoCo integrates stably: a time constant of two physics steps
    # (shorter ones are clamped to it). With the time constant free the fit ends there.
    timeconst = 2 * config.motion.timestep_s

    def build(x: np.ndarray) -> SynthConfig:
        dmin_frac, width = x
        solref = (timeconst, 1.0)
        solimp = (float(dmin_frac * dmax), dmax, float(width), midpoint, FIT_POWER)
        return dataclasses.replace(
            config,
            finger=dataclasses.replace(finger, skin_solref=solref, skin_solimp=solimp),
        )

    def loss(x: np.ndarray) -> float:
        dmin_frac, width = x
        if not (0.05 <= dmin_frac <= 1.0 and 1e-4 <= width <= 2e-2):
            return 1e3
        got = measure_indentation(build(x), forces)
        return float(np.sum(np.log(np.maximum(got, 1e-7) / target) ** 2))

    res = optimize.minimize(
        loss,
        np.array(FIT_START),
        method="Nelder-Mead",
        options={"xatol": 1e-7, "fatol": 1e-7, "maxiter": 400},
    )
    fitted = build(res.x).finger
    return tuple(round(v, 6) for v in fitted.skin_solref), tuple(
        round(v, 6) for v in fitted.skin_solimp
    )


#: The finger's fields Hertz's law of the skin depends on: a configuration that changes
#: one needs the skin's contact refitted (:func:`with_fitted_skin`).
HERTZ_FIELDS = ("pad_radius_m", "skin_modulus_pa", "skin_poisson")


def with_fitted_skin(config: SynthConfig) -> SynthConfig:
    """``config`` with ``Finger.skin_solref``/``skin_solimp`` fitted to its skin's Hertz law
    (:func:`fit_skin_contact`, a few seconds)."""
    solref, solimp = fit_skin_contact(config)
    finger = dataclasses.replace(config.finger, skin_solref=solref, skin_solimp=solimp)
    return dataclasses.replace(config, finger=finger)
