"""What a dataset contains: the generation grid (``GenerationConfig``), the named presets,
and the canonical trial plan (order and per-trial seeds) that the store and the runner share.
"""

from __future__ import annotations

import dataclasses
import itertools
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from shapes import SHAPE_NAMES
from shapes.validation import check_choice, check_int, check_positive

from .materials import MATERIAL_NAMES
from .trial import CLASS_NAMES, TrialSpec

#: The paper's nominal acquisition condition (Section III): 1 N normal force, 10 mm/s.
NOMINAL_FORCE_N: float = 1.0
NOMINAL_SPEED_MM_S: float = 10.0


def _names(arg: str, values: object, allowed: Sequence[str]) -> tuple[str, ...]:
    """Validated names in the canonical order of ``allowed`` (so the trial order is fixed)."""
    if isinstance(values, str) or not isinstance(values, Sequence) or not values:
        raise ValueError(f"{arg} must be a non-empty list of names from {', '.join(allowed)}")
    picked = [check_choice(arg, v, allowed) for v in values]
    if len(set(picked)) != len(picked):
        raise ValueError(f"{arg} lists a name twice; got {list(values)!r}")
    return tuple(n for n in allowed if n in picked)


def _numbers(arg: str, values: object, unit: str) -> tuple[float, ...]:
    if isinstance(values, str) or not isinstance(values, Sequence) or not values:
        raise ValueError(f"{arg} must be a non-empty list of numbers > 0 {unit}; got {values!r}")
    out = tuple(check_positive(arg, v, unit=unit) for v in values)
    if len(set(out)) != len(out):
        raise ValueError(f"{arg} lists a value twice; got {list(values)!r}")
    return out


def condition_name(force_n: float, speed_mm_s: float) -> str:
    """``"force=1.4N,speed=6mm/s"`` (the results.json condition naming)."""
    return f"force={force_n:g}N,speed={speed_mm_s:g}mm/s"


@dataclass(frozen=True)
class GenerationConfig:
    """A dataset's full recipe. Saved in the store, so ``from_dict(store attrs)`` regenerates it.

    Trials are the grid classes (``shapes`` x ``materials``) x conditions
    (``forces_n`` x ``speeds_mm_s``, minus the nominal one if ``include_nominal`` is false)
    x ``trials_per_class``. ``synth`` is the simulator configuration
    (``SynthConfig.to_dict()``; ``None`` means the simulator's defaults, resolved and saved
    when the dataset is created). ``chunk_trials`` trials form one storage chunk and one task.
    """

    preset: str = "custom"
    shapes: tuple[str, ...] = SHAPE_NAMES
    materials: tuple[str, ...] = MATERIAL_NAMES
    trials_per_class: int = 60
    forces_n: tuple[float, ...] = (NOMINAL_FORCE_N,)
    speeds_mm_s: tuple[float, ...] = (NOMINAL_SPEED_MM_S,)
    include_nominal: bool = True
    seed: int = 0
    chunk_trials: int = 36
    synth: Mapping[str, Any] | None = field(default=None, compare=True)

    def __post_init__(self) -> None:
        if not isinstance(self.preset, str) or not self.preset:
            raise ValueError(f"preset must be a non-empty name; got {self.preset!r}")
        object.__setattr__(self, "shapes", _names("shapes", self.shapes, SHAPE_NAMES))
        object.__setattr__(self, "materials", _names("materials", self.materials, MATERIAL_NAMES))
        check_int("trials_per_class", self.trials_per_class, minimum=1)
        object.__setattr__(self, "forces_n", _numbers("forces_n", self.forces_n, "N"))
        object.__setattr__(self, "speeds_mm_s", _numbers("speeds_mm_s", self.speeds_mm_s, "mm/s"))
        if not isinstance(self.include_nominal, bool):
            raise ValueError(f"include_nominal must be true or false; got {self.include_nominal!r}")
        check_int("seed", self.seed, minimum=0)
        check_int("chunk_trials", self.chunk_trials, minimum=1)
        if self.synth is not None and not isinstance(self.synth, Mapping):
            raise ValueError(f"synth must be a table of simulator settings; got {self.synth!r}")
        if not self.conditions:
            raise ValueError(
                "the force/speed grid is empty: it holds only the nominal condition and "
                "include_nominal is false; add forces or speeds"
            )

    # -- the grid ------------------------------------------------------------------------
    @property
    def conditions(self) -> tuple[tuple[float, float], ...]:
        """``(force_n, speed_mm_s)`` pairs, force-major."""
        pairs = itertools.product(self.forces_n, self.speeds_mm_s)
        return tuple(
            (f, s)
            for f, s in pairs
            if self.include_nominal or (f, s) != (NOMINAL_FORCE_N, NOMINAL_SPEED_MM_S)
        )

    @property
    def class_indices(self) -> tuple[int, ...]:
        """Indices into :data:`CLASS_NAMES` of the grid's classes (shape-major)."""
        return tuple(CLASS_NAMES.index(f"{s}/{m}") for s in self.shapes for m in self.materials)

    @property
    def n_trials(self) -> int:
        return len(self.conditions) * len(self.class_indices) * self.trials_per_class

    @property
    def n_chunks(self) -> int:
        return -(-self.n_trials // self.chunk_trials)

    def replace(self, **changes: Any) -> GenerationConfig:
        return dataclasses.replace(self, **changes)

    # -- serialisation -------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """JSON/TOML-friendly dict (lists, floats, ints, strings)."""
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, tuple):
                value = list(value)
            elif isinstance(value, Mapping):
                value = dict(value)
            out[f.name] = value
        if out["synth"] is None:
            del out["synth"]
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> GenerationConfig:
        """Inverse of :meth:`to_dict`; unknown keys are an error naming the valid ones."""
        if not isinstance(data, Mapping):
            raise ValueError(f"a generation config must be a table; got {type(data).__name__}")
        known = [f.name for f in dataclasses.fields(cls)]
        for key in data:
            check_choice("generation config key", key, known)
        kwargs = {
            k: tuple(v) if isinstance(v, list) else v for k, v in data.items() if k != "synth"
        }
        if "synth" in data:
            kwargs["synth"] = dict(data["synth"])
        return cls(**kwargs)


#: The named grids of issue #4. ``perturbation``: 3 forces x 3 speeds around nominal,
#: nominal excluded (8 conditions), 10 trials per class per condition.
PRESETS: dict[str, GenerationConfig] = {
    "quick": GenerationConfig(preset="quick", trials_per_class=4),
    "paper": GenerationConfig(preset="paper", trials_per_class=60),
    "perturbation": GenerationConfig(
        preset="perturbation",
        trials_per_class=10,
        forces_n=(0.6, 1.0, 1.4),
        speeds_mm_s=(6.0, 10.0, 14.0),
        include_nominal=False,
    ),
}


def preset(name: str) -> GenerationConfig:
    return PRESETS[check_choice("preset", name, tuple(PRESETS))]


def load_toml(path: str | Path) -> GenerationConfig:
    """A grid from a TOML file: an optional ``preset = "..."`` base plus any config keys."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"config file {path} does not exist")
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"config file {path} is not valid TOML: {exc}") from None
    base = preset(data["preset"]) if "preset" in data else GenerationConfig()
    merged = {**base.to_dict(), **data}
    return GenerationConfig.from_dict(merged)


# -- the canonical plan ------------------------------------------------------------------
def trial_seed(seed: int, class_idx: int, force_n: float, speed_mm_s: float, trial: int) -> int:
    """A trial's own seed, independent of batching, workers and of the rest of the grid.

    The condition enters by value (micro-newtons, micro-metres/s), so the same class,
    condition and trial index get the same seed whichever grid they belong to.
    """
    words = [seed, class_idx, round(force_n * 1e6), round(speed_mm_s * 1e3), trial]
    return int(np.random.SeedSequence(words).generate_state(1, dtype=np.uint32)[0])


@dataclass(frozen=True)
class TrialPlan:
    """Per-trial arrays in store order (condition, class, trial index); each ``(n,)``."""

    label: np.ndarray  # int16 index into CLASS_NAMES
    condition: np.ndarray  # int16 index into config.conditions
    trial_index: np.ndarray  # int32 index within (class, condition)
    force_n: np.ndarray  # float64
    speed_mm_s: np.ndarray  # float64
    seed: np.ndarray  # int64 (values fit in uint32)

    def __len__(self) -> int:
        return int(self.label.shape[0])

    def specs(self, start: int, stop: int) -> list[TrialSpec]:
        out = []
        for i in range(start, min(stop, len(self))):
            shape, material = CLASS_NAMES[int(self.label[i])].split("/")
            out.append(
                TrialSpec(
                    shape=shape,
                    material=material,
                    force_n=float(self.force_n[i]),
                    speed_mm_s=float(self.speed_mm_s[i]),
                    seed=int(self.seed[i]),
                )
            )
        return out


def plan(config: GenerationConfig) -> TrialPlan:
    rows = [
        (cls, c, k, f, s, trial_seed(config.seed, cls, f, s, k))
        for c, (f, s) in enumerate(config.conditions)
        for cls in config.class_indices
        for k in range(config.trials_per_class)
    ]
    cols = list(zip(*rows, strict=True))
    return TrialPlan(
        label=np.array(cols[0], dtype=np.int16),
        condition=np.array(cols[1], dtype=np.int16),
        trial_index=np.array(cols[2], dtype=np.int32),
        force_n=np.array(cols[3], dtype=np.float64),
        speed_mm_s=np.array(cols[4], dtype=np.float64),
        seed=np.array(cols[5], dtype=np.int64),
    )
