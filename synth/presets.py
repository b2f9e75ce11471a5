"""What a dataset contains: the generation grid (``GenerationConfig``), the named presets,
and the canonical trial plan (order and per-trial seeds) that the store and the runner share.
"""

from __future__ import annotations

import dataclasses
import itertools
import re
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from shapes import SHAPE_NAMES
from tactile_synth.validation import check_choice, check_int, check_positive

from .config import SynthConfig
from .materials import MATERIAL_NAMES
from .trial import CLASS_NAMES, TrialSpec

#: The paper's nominal acquisition condition (Section III): 1 N normal force, 10 mm/s.
NOMINAL_FORCE_N: float = 1.0
NOMINAL_SPEED_MM_S: float = 10.0

#: Normal forces the simulated finger reproduces for every shape and material at the
#: presets' speeds (6-14 mm/s). Below 0.4 N the pad skips off the outlines' edges and
#: loses contact; above 3 N the front PVDF film saturates the +-10 V DAQ on the moon
#: and the finger sticks on some outlines. People exploring a surface press with about
#: 0.5-0.6 N (Smith et al., Exp. Brain Res. 2002), inside this range.
FORCE_RANGE_N: tuple[float, float] = (0.4, 3.0)
#: Sliding speeds the simulator accepts. Above 24 mm/s the slide a trial needs (the
#: approach, the outline and the 2 s window) runs off the 60 mm plate. At 0.1 mm/s the
#: 2 s window slides 0.2 mm, less than one fingerprint ridge, so nothing below it can be
#: felt as sliding.
SPEED_RANGE_MM_S: tuple[float, float] = (0.1, 24.0)
#: Physical range of a real fingertip's normal force and sliding speed, which imported
#: recordings must lie in: 10 N presses a fingertip pad flat against the bone, below
#: 0.01 N (one gram-force) a finger barely rests on the surface; people scan a surface at
#: about 80 mm/s (Smith et al.), and 500 mm/s is six times that.
PHYSICAL_FORCE_RANGE_N: tuple[float, float] = (0.01, 10.0)
PHYSICAL_SPEED_RANGE_MM_S: tuple[float, float] = (0.1, 500.0)
#: Most trials one dataset may hold. A store takes ~10 kB per trial on disk and its plan
#: ~40 bytes per trial in memory, and ``trial_index`` is int32: ten million trials is
#: ~100 GB and days of simulation, far beyond any use of this benchmark (the paper's
#: grid has 2,160). The machine's free disk space bounds it further (synth.generation).
MAX_TRIALS: int = 10_000_000
#: Most trials per chunk: one chunk is one task's signals in memory (32 kB per trial,
#: 128 MB at this size) and one file on disk.
MAX_CHUNK_TRIALS: int = 4096


def _names(arg: str, values: object, allowed: Sequence[str]) -> tuple[str, ...]:
    """Validated names in the canonical order of ``allowed`` (so the trial order is fixed)."""
    if isinstance(values, str) or not isinstance(values, Sequence) or not values:
        raise ValueError(f"{arg} must be a non-empty list of names from {', '.join(allowed)}")
    picked = [check_choice(arg, v, allowed) for v in values]
    if len(set(picked)) != len(picked):
        raise ValueError(f"{arg} lists a name twice; got {list(values)!r}")
    return tuple(n for n in allowed if n in picked)


def _numbers(arg: str, values: object, unit: str, bounds: tuple[float, float]) -> tuple[float, ...]:
    lo, hi = bounds
    if isinstance(values, str) or not isinstance(values, Sequence) or not values:
        raise ValueError(
            f"{arg} must be a non-empty list of numbers in {lo:g}..{hi:g} {unit}; got {values!r}"
        )
    out = tuple(check_positive(arg, v, unit=unit) for v in values)
    for v in out:
        if not lo <= v <= hi:
            raise ValueError(
                f"{arg} must lie in {lo:g}..{hi:g} {unit} (the range the simulator reproduces for "
                f"every shape and material; docs/datasets.md, Bounds); got {v:g}"
            )
    if len(set(out)) != len(out):
        raise ValueError(f"{arg} lists a value twice; got {list(values)!r}")
    return out


def check_forces(arg: str, values: object) -> tuple[float, ...]:
    """``values`` as floats if each is a normal force the simulator reproduces
    (:data:`FORCE_RANGE_N`); else ``ValueError`` naming ``arg``."""
    return _numbers(arg, values, "N", FORCE_RANGE_N)


def check_speeds(arg: str, values: object) -> tuple[float, ...]:
    """``values`` as floats if each is a sliding speed the simulator accepts
    (:data:`SPEED_RANGE_MM_S`); else ``ValueError`` naming ``arg``."""
    return _numbers(arg, values, "mm/s", SPEED_RANGE_MM_S)


_CONDITION = re.compile(r"force=([0-9.eE+-]+)N,speed=([0-9.eE+-]+)mm/s")


def condition_name(force_n: float, speed_mm_s: float) -> str:
    """The name of a force/speed condition in a store and in results.json,
    e.g. ``"force=1.4N,speed=6mm/s"``."""
    return f"force={force_n:g}N,speed={speed_mm_s:g}mm/s"


def parse_condition(condition: str | None) -> tuple[float, float] | None:
    """``"force=1.4N,speed=6mm/s"`` -> ``(1.4, 6.0)``; ``None`` for other names."""
    m = _CONDITION.fullmatch(condition or "")
    return (float(m.group(1)), float(m.group(2))) if m else None


@dataclass(frozen=True)
class GenerationConfig:
    """A dataset's full recipe. Saved in the store, so ``from_dict(store attrs)`` regenerates it.

    Trials are the grid classes (``shapes`` x ``materials``) x conditions
    (``forces_n`` x ``speeds_mm_s``, minus the nominal one if ``include_nominal`` is false)
    x ``trials_per_class``. ``synth`` is the simulator configuration
    (``SynthConfig.to_dict()``; ``None`` means the simulator's defaults, resolved and saved
    when the dataset is created). ``chunk_trials`` trials form one storage chunk and one task.
    ``seed_by_condition``: whether a trial's seed depends on its force and speed (the
    default, :func:`trial_seed`); false gives trial ``k`` of a class the same seed under
    every condition, so a test set simulated at another force or speed repeats the same
    strokes (placement, surface stretch, noise draws) with only the condition changed,
    as the stress suite's severities need.
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
    seed_by_condition: bool = True

    def __post_init__(self) -> None:
        if not isinstance(self.preset, str) or not self.preset:
            raise ValueError(f"preset must be a non-empty name; got {self.preset!r}")
        object.__setattr__(self, "shapes", _names("shapes", self.shapes, SHAPE_NAMES))
        object.__setattr__(self, "materials", _names("materials", self.materials, MATERIAL_NAMES))
        check_int("trials_per_class", self.trials_per_class, minimum=1)
        forces = check_forces("forces_n", self.forces_n)
        speeds = check_speeds("speeds_mm_s", self.speeds_mm_s)
        object.__setattr__(self, "forces_n", forces)
        object.__setattr__(self, "speeds_mm_s", speeds)
        for flag in ("include_nominal", "seed_by_condition"):
            if not isinstance(getattr(self, flag), bool):
                raise ValueError(f"{flag} must be true or false; got {getattr(self, flag)!r}")
        check_int("seed", self.seed, minimum=0)
        check_int("chunk_trials", self.chunk_trials, minimum=1)
        if self.chunk_trials > MAX_CHUNK_TRIALS:
            raise ValueError(
                f"chunk_trials must be at most {MAX_CHUNK_TRIALS} (one chunk's signals are held "
                f"in memory: 32 kB per trial); got {self.chunk_trials}"
            )
        if self.synth is not None and not isinstance(self.synth, Mapping):
            raise ValueError(f"synth must be a table of simulator settings; got {self.synth!r}")
        if not self.conditions:
            raise ValueError(
                "the force/speed grid is empty: it holds only the nominal condition and "
                "include_nominal is false; add forces or speeds"
            )
        if self.n_trials > MAX_TRIALS:
            raise ValueError(
                f"trials_per_class={self.trials_per_class} gives {self.n_trials:,} trials "
                f"({len(self.class_indices)} classes x {len(self.conditions)} conditions x "
                f"{self.trials_per_class:,}), {self.n_trials * 32e3 / 1e12:,.1f} TB of signals; "
                f"a dataset holds at most {MAX_TRIALS:,} trials: lower trials_per_class"
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
        if out["seed_by_condition"]:
            del out["seed_by_condition"]  # the default: stores keep their earlier layout
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


#: The named grids. ``perturbation``: 3 forces x 3 speeds around nominal,
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
    """A grid from a TOML file: an optional ``preset = "..."`` base plus any config keys;
    a ``[synth.SECTION]`` table sets those simulator fields and keeps the other defaults."""
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"--config {path} is a directory; give a TOML file")
    if not path.is_file():
        raise FileNotFoundError(f"--config {path} does not exist")
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"--config {path} is not valid TOML: {exc}") from None
    if not data:
        # An empty file would silently stand for the whole paper grid.
        raise ValueError(
            f'--config {path} sets nothing; give the grid\'s keys (e.g. preset = "quick") '
            f"or use --preset"
        )
    base = preset(data["preset"]) if "preset" in data else GenerationConfig()
    merged = {**base.to_dict(), **data}
    if isinstance(data.get("synth"), Mapping):
        # A [synth.*] table sets only the fields it names; the rest keep the defaults.
        merged["synth"] = _overlay(SynthConfig().to_dict(), data["synth"])
        try:
            SynthConfig.from_dict(merged["synth"])
        except ValueError as exc:
            raise ValueError(f"--config {path}: [synth] {exc}") from None
    return GenerationConfig.from_dict(merged)


def _overlay(base: Mapping[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    """``base`` with ``over``'s values in place of its own, table by table (keys ``base``
    lacks are kept, for the configuration's own check to name)."""
    out = dict(base)
    for key, value in over.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = _overlay(out[key], value)
        else:
            out[key] = value
    return out


# -- the canonical plan ------------------------------------------------------------------
def trial_seed(seed: int, class_idx: int, force_n: float, speed_mm_s: float, trial: int) -> int:
    """A trial's own seed, independent of batching, workers and of the rest of the grid.

    The condition enters by value (micro-newtons, micro-metres/s), so the same class,
    condition and trial index get the same seed whichever grid they belong to.
    """
    words = [seed, class_idx, round(force_n * 1e6), round(speed_mm_s * 1e3), trial]
    return int(np.random.SeedSequence(words).generate_state(1, dtype=np.uint32)[0])


# numpy's SeedSequence constants (O'Neill's seed_seq_fe with a pool of 4 words).
_INIT_A, _MULT_A = 0x43B0D7E5, 0x931E8875
_INIT_B, _MULT_B = 0x8B51F9DD, 0x58F38DED
_MIX_L, _MIX_R = 0xCA01F9DD, 0x4973F715
_POOL = 4
_M32 = 0xFFFFFFFF


def _seed_states(words: np.ndarray) -> np.ndarray:
    """``SeedSequence(row).generate_state(1, uint32)[0]`` for every row of ``words``
    (uint32 ``(n, w)``, w >= 4, each entry one 32-bit entropy word), all rows at once.

    The same arithmetic as numpy's SeedSequence, vectorised over rows: the per-trial
    Python call costs ~80 us, which made regenerating a plan (done on every load, to check
    the stored per-trial arrays) cost a sixth of reading the signals.
    """
    hash_const = _INIT_A

    def hashmix(value: np.ndarray) -> np.ndarray:
        nonlocal hash_const
        value = value ^ np.uint32(hash_const)
        hash_const = (hash_const * _MULT_A) & _M32
        value = value * np.uint32(hash_const)
        return value ^ (value >> np.uint32(16))

    def mix(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        r = np.uint32(_MIX_L) * x - np.uint32(_MIX_R) * y
        return r ^ (r >> np.uint32(16))

    words = np.asarray(words, dtype=np.uint32)
    pool = [hashmix(words[:, i]) for i in range(_POOL)]
    for src in range(_POOL):
        for dst in range(_POOL):
            if src != dst:
                pool[dst] = mix(pool[dst], hashmix(pool[src]))
    for src in range(_POOL, words.shape[1]):
        for dst in range(_POOL):
            pool[dst] = mix(pool[dst], hashmix(words[:, src]))
    out = pool[0] ^ np.uint32(_INIT_B)
    out = out * np.uint32((_INIT_B * _MULT_B) & _M32)
    return out ^ (out >> np.uint32(16))


def trial_seeds(
    seed: int,
    class_idx: np.ndarray,
    force_n: np.ndarray,
    speed_mm_s: np.ndarray,
    trial: np.ndarray,
) -> np.ndarray:
    """:func:`trial_seed` of many trials at once (int64 ``(n,)``, values in uint32)."""
    cols = [
        np.asarray(class_idx, dtype=np.int64),
        np.rint(np.asarray(force_n, dtype=np.float64) * 1e6),
        np.rint(np.asarray(speed_mm_s, dtype=np.float64) * 1e3),
        np.asarray(trial, dtype=np.int64),
    ]
    n = cols[0].size
    in_range = [c.size == 0 or (c.min() >= 0 and c.max() <= _M32) for c in cols]
    if not (0 <= seed <= _M32 and all(in_range)):
        # A value of 2**32 or more enters SeedSequence as several words: the scalar path.
        rows = zip(class_idx, force_n, speed_mm_s, trial, strict=True)
        seeds = [trial_seed(seed, int(c), float(f), float(s), int(k)) for c, f, s, k in rows]
        return np.array(seeds, dtype=np.int64).reshape(n)
    words = np.stack([np.full(n, seed, dtype=np.uint32), *(c.astype(np.uint32) for c in cols)], 1)
    return _seed_states(words).astype(np.int64)


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
    """The trials of ``config`` in store order: condition, then class, then trial index."""
    conditions = np.asarray(config.conditions, dtype=np.float64).reshape(-1, 2)
    n_cond, classes = len(conditions), np.asarray(config.class_indices, dtype=np.int16)
    k = config.trials_per_class
    shape = (n_cond, classes.size, k)
    cond = np.broadcast_to(np.arange(n_cond, dtype=np.int16)[:, None, None], shape).ravel()
    label = np.broadcast_to(classes[None, :, None], shape).ravel()
    trial = np.broadcast_to(np.arange(k, dtype=np.int32)[None, None, :], shape).ravel()
    force = conditions[cond, 0]
    speed = conditions[cond, 1]
    if config.seed_by_condition:
        seeds = trial_seeds(config.seed, label, force, speed, trial)
    else:
        nominal = np.ones(label.size)
        seeds = trial_seeds(
            config.seed, label, NOMINAL_FORCE_N * nominal, NOMINAL_SPEED_MM_S * nominal, trial
        )
    return TrialPlan(
        label=label.copy(),
        condition=cond.copy(),
        trial_index=trial.copy(),
        force_n=force,
        speed_mm_s=speed,
        seed=seeds,
    )
