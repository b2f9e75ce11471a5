"""The twin's world and its simulations: the recordings' classes and conditions, the
simulator's configuration the calibrated parameters are set on, and one simulation of a
parameter vector turned into its summary vector (:mod:`benchmark.twin.summaries`).

The world takes from the recordings only what a lab knows of its experiment: the class
names (specimen and material) and each trial's force and speed. A simulated store's own
specimens come from its stored configuration (their outlines are geometry, not the
finger); materials and every other setting start from the simulator's defaults and the
material library, so that nothing the recordings were made with leaks into the twin.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

import synth
from synth.calibration.parameters import Parameter
from synth.calibration.settings import CalibrationError, with_value
from synth.trial import TrialSpec

from .summaries import summarize


@dataclasses.dataclass(frozen=True)
class World:
    """What the twin simulates: ``classes`` (``"<specimen>/<material>"``), the
    ``conditions`` ``(force_n, speed_mm_s)`` each class is recorded under, and ``base``,
    the simulator's configuration as a dict (``SynthConfig.to_dict()``)."""

    classes: tuple[str, ...]
    conditions: tuple[tuple[int, float, float], ...]  # (class index, force N, speed mm/s)
    base: Mapping[str, Any]

    @property
    def materials(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(c.split("/")[1] for c in self.classes))

    def config(self, parameters: Sequence[Parameter], values: Sequence[float]) -> synth.SynthConfig:
        """The base configuration with each parameter at its value."""
        config = synth.SynthConfig.from_dict(dict(self.base))
        for p, v in zip(parameters, values, strict=True):
            config = with_value(config, p.section, p.field, float(v))
        return config


def world_of(data: synth.Dataset, *, where: str = "--recordings") -> World:
    """The world of the recordings ``data``; a one-line refusal when the simulator does not
    know a class's specimen or material, or a trial lacks its force or speed."""
    from synth.material_data import library

    force = np.asarray(data.force_n, dtype=float)
    speed = np.asarray(data.speed_mm_s, dtype=float)
    if not (np.isfinite(force).all() and np.isfinite(speed).all()) or (force <= 0).any():
        raise CalibrationError(
            f"{where}: every trial needs its normal force and sliding speed (the twin "
            "simulates the same conditions); this store lacks them for some trials"
        )
    lib = library()
    specimens: dict[str, Any] = {}
    stored = (data.attrs.get("config") or {}).get("synth") or {}
    known_specimens = set(stored.get("specimens") or {})
    from shapes import SHAPE_NAMES

    materials = {}
    for name in data.classes:
        shape, material = name.split("/")
        if material not in lib:
            raise CalibrationError(
                f"{where}: class {name!r}: material {material!r} is not in the simulator's "
                "library (synth/material_library.toml); the twin cannot simulate it"
            )
        materials[material] = lib[material]
        if shape in known_specimens:
            specimens[shape] = stored["specimens"][shape]
        elif shape not in SHAPE_NAMES:
            raise CalibrationError(
                f"{where}: class {name!r}: specimen {shape!r} is neither a built-in shape "
                "nor a specimen of the store's configuration; the twin cannot simulate it"
            )
    base = synth.SynthConfig()
    base = dataclasses.replace(base, materials=materials)
    table = base.to_dict()
    table["specimens"] = specimens
    try:
        synth.SynthConfig.from_dict(dict(table))
    except ValueError as exc:
        raise CalibrationError(f"{where}: its specimens cannot be simulated: {exc}") from None
    label = np.asarray(data.label)
    seen = dict.fromkeys(
        (int(c), float(f), float(s)) for c, f, s in zip(label, force, speed, strict=True)
    )
    return World(tuple(data.classes), tuple(seen), table)


def simulate(
    world: World,
    parameters: Sequence[Parameter],
    values: Sequence[float],
    *,
    trials_per_class: int,
    seed: int,
    index: int,
    threads: int = 1,
) -> np.ndarray:
    """Simulation ``index`` of the calibration: ``trials_per_class`` trials of every class
    under each of its conditions, the parameters at ``values``, summarised; all NaN when
    the physics fails (a saturated input, an unstable step). Its trials' seeds follow
    from ``seed`` and ``index`` alone, so it is the same on any worker."""
    from synth.generation import mujoco_simulator

    config = world.config(parameters, values)
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), int(index)]))
    specs = []
    for cls, force, speed in world.conditions:
        shape, material = world.classes[cls].split("/")
        for s in rng.integers(0, 2**31 - 1, size=trials_per_class):
            specs.append(TrialSpec(shape, material, force, speed, int(s)))
    n = len(summary_size(world))
    try:
        signals = mujoco_simulator(specs, config.to_dict(), threads)
    except synth.SimulationError:
        return np.full(n, np.nan)
    label = np.array([world.classes.index(f"{s.shape}/{s.material}") for s in specs])
    material = np.array([s.material for s in specs])
    return summarize(signals, material, label, world.materials)


def summary_size(world: World) -> list[str]:
    from .summaries import summary_names

    return summary_names(world.materials)


def simulate_signals(
    world: World,
    parameters: Sequence[Parameter],
    values: Sequence[float],
    *,
    trials_per_class: int,
    seed: int,
    threads: int = 1,
) -> tuple[np.ndarray, list[TrialSpec]]:
    """The signals (and trials) of one simulation, for the report's figures."""
    from synth.generation import mujoco_simulator

    config = world.config(parameters, values)
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 2**20]))
    specs = []
    for cls, force, speed in world.conditions:
        shape, material = world.classes[cls].split("/")
        for s in rng.integers(0, 2**31 - 1, size=trials_per_class):
            specs.append(TrialSpec(shape, material, force, speed, int(s)))
    return mujoco_simulator(specs, config.to_dict(), threads), specs
