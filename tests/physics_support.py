"""Configurations and helpers the simulator's physics tests share (test_physics,
test_films, test_surfaces)."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

import synth
from synth import simulator as sim
from synth.config import SynthConfig

NOMINAL = SynthConfig(variability=SynthConfig().variability.nominal())
FLAT = dataclasses.replace(NOMINAL, motion=dataclasses.replace(NOMINAL.motion, raised_shape=False))
#: A softer PDMS support (4 mm thick), on which a velocity-weakening law sticks and slips.
COMPLIANT = dataclasses.replace(
    FLAT, finger=dataclasses.replace(FLAT.finger, pdms_thickness_m=0.004)
)
#: The PVDF and strain-gauge channels of a trial's signals.
PVDF, SG = slice(0, 2), slice(2, 4)
#: Samples past the window's first 0.3 s, where the sliding is steady.
STEADY = slice(300, None)


def with_motion(base: SynthConfig, **motion) -> SynthConfig:
    """``base`` with these fields of its motion changed."""
    return dataclasses.replace(base, motion=dataclasses.replace(base.motion, **motion))


def with_material(config: SynthConfig, material: str, **changes) -> SynthConfig:
    """``config`` with these fields of one material changed."""
    return config.with_material(dataclasses.replace(config.materials[material], **changes))


def roll_plans(plans: list, config: SynthConfig) -> tuple[np.ndarray, list]:
    """Full-length sensordata ``(b, steps, n)`` and the windows' trials of ``plans``."""
    datas = [mujoco.MjData(plans[0].model)]
    sens, heights = sim._roll(plans, datas, config)
    return sens, sim._process(plans, sens, heights, config)


def flat_trial(material="wood", force_n=1.0, speed_mm_s=10.0, seed=0, config=FLAT):
    """One square trial, by default on the flat plate (no raised outline)."""
    return synth.simulate(
        "square", material, force_n=force_n, speed_mm_s=speed_mm_s, seed=seed, config=config
    )


def pvdf_rms(trial) -> float:
    """The films' RMS over the steady samples of a trial."""
    return float(np.sqrt(np.mean(trial.signals[PVDF, STEADY].astype(float) ** 2)))
