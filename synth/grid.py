"""A dataset's grid (``GenerationConfig``: its classes, conditions, trials and seed) and
the canonical trial plan (order and per-trial seeds) that the store and the runner share.

The named presets and the experiment files that make grids are :mod:`synth.presets` and
:mod:`synth.experiment`.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from shapes import SHAPE_NAMES
from tactile_synth.validation import check_choice, check_int, check_positive

from .materials import MATERIAL_NAMES
from .trial import TrialSpec, class_key

#: The paper's nominal acquisition condition (Section III): 1 N normal force, 10 mm/s.
NOMINAL_FORCE_N: float = 1.0
NOMINAL_SPEED_MM_S: float = 10.0

#: Normal forces the simulated finger reproduces for every shape and material at the
#: presets' speeds (6-14 mm/s). Below 0.4 N the pad skips off the outlines' edges and
#: loses contact; above 3 N the front PVDF film saturates the +-10 V DAQ on the moon
#: and the finger sticks on some outlines. People exploring a surface press with about
#: 0.5-0.6 N (Smith et al., Exp. Brain Res. 2002), inside this range.
FORCE_RANGE_N: tuple[float, float] = (0.4, 3.0)
#: Sliding speeds the simulator accepts for every built-in shape. Faster, the slide a
#: trial needs (the approach, the outline and the 2 s window) runs off the 60 mm plate:
#: over the parallelogram from 22.7 mm/s, the last of the built-ins at 24 mm/s; 22 mm/s
#: leaves room for a trial's 3-sigma speed error (3 %). At 0.1 mm/s the 2 s window slides
#: 0.2 mm, less than one fingerprint ridge, so nothing below it can be felt as sliding.
SPEED_RANGE_MM_S: tuple[float, float] = (0.1, 22.0)
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


def _synth_names(synth: object) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The specimen and material names a grid may use with the simulator settings
    ``synth`` (a ``SynthConfig.to_dict()`` mapping, or None for the defaults): the
    built-ins then the settings' specimens, in their order; the settings' materials in
    their order (the paper's three by default). Only the names are read here; the
    settings themselves are checked where they are used."""
    specimens: tuple[str, ...] = SHAPE_NAMES
    materials: tuple[str, ...] = MATERIAL_NAMES
    if isinstance(synth, Mapping):
        extra = synth.get("specimens")
        if isinstance(extra, Mapping):
            specimens = (*SHAPE_NAMES, *(str(k) for k in extra if k not in SHAPE_NAMES))
        mats = synth.get("materials")
        if isinstance(mats, Mapping) and mats:
            materials = tuple(str(k) for k in mats)
    return specimens, materials


def in_range(value: float, bounds: tuple[float, float]) -> bool:
    """``lo <= value <= hi``, a bound matched to within rounding: a level computed as a
    factor of a nominal (``10 * 2.2`` is 22.000000000000004) lies on the bound it names."""
    lo, hi = bounds
    return (lo <= value or math.isclose(value, lo)) and (value <= hi or math.isclose(value, hi))


def _numbers(arg: str, values: object, unit: str, bounds: tuple[float, float]) -> tuple[float, ...]:
    lo, hi = bounds
    if isinstance(values, str) or not isinstance(values, Sequence) or not values:
        raise ValueError(
            f"{arg} must be a non-empty list of numbers in {lo:g}..{hi:g} {unit}; got {values!r}"
        )
    out = tuple(check_positive(arg, v, unit=unit) for v in values)
    for v in out:
        if not in_range(v, bounds):
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

    Trials are the grid classes (``shapes`` x ``materials``, :attr:`classes`) x conditions
    (``forces_n`` x ``speeds_mm_s``, minus the nominal one if ``include_nominal`` is false)
    x ``trials_per_class``. ``synth`` is the simulator configuration
    (``SynthConfig.to_dict()``; ``None`` means the simulator's defaults, resolved and saved
    when the dataset is created). ``shapes`` names built-in shapes and the specimens of
    ``synth`` (its ``specimens``), ``materials`` the materials of ``synth`` (the paper's
    three by default); both are kept in a canonical order: the built-ins in the paper's
    order, then the specimens in ``synth``'s order; the materials in ``synth``'s order.
    ``chunk_trials`` trials form one storage chunk and one task.
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
        if self.synth is not None and not isinstance(self.synth, Mapping):
            raise ValueError(f"synth must be a table of simulator settings; got {self.synth!r}")
        specimens, materials = _synth_names(self.synth)
        object.__setattr__(self, "shapes", _names("shapes", self.shapes, specimens))
        object.__setattr__(self, "materials", _names("materials", self.materials, materials))
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
        if not self.conditions:
            raise ValueError(
                "the force/speed grid is empty: it holds only the nominal condition and "
                "include_nominal is false; add forces or speeds"
            )
        if self.n_trials > MAX_TRIALS:
            raise ValueError(
                f"trials_per_class={self.trials_per_class} gives {self.n_trials:,} trials "
                f"({len(self.classes)} classes x {len(self.conditions)} conditions x "
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
    def classes(self) -> tuple[str, ...]:
        """The dataset's classes, ``"<specimen>/<material>"``, specimen-major in the
        canonical order of ``shapes`` and ``materials``: a stored label indexes this list."""
        return tuple(f"{s}/{m}" for s in self.shapes for m in self.materials)

    @property
    def class_keys(self) -> tuple[int, ...]:
        """Each class's seed key (:func:`synth.trial.class_key`: the index into
        :data:`synth.CLASS_NAMES` for the paper's classes), in the order of :attr:`classes`."""
        return tuple(class_key(c) for c in self.classes)

    @property
    def n_trials(self) -> int:
        return len(self.conditions) * len(self.classes) * self.trials_per_class

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


# -- the canonical plan ------------------------------------------------------------------
def trial_seed(seed: int, class_idx: int, force_n: float, speed_mm_s: float, trial: int) -> int:
    """A trial's own seed, independent of batching, workers and of the rest of the grid.

    ``class_idx`` is the class's key (:func:`synth.trial.class_key`: its index into
    :data:`synth.CLASS_NAMES` for the paper's classes, a fixed 32-bit number for any
    other). The key and the condition enter by value (micro-newtons, micro-metres/s), so
    the same class, condition and trial index get the same seed whichever grid they
    belong to.
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
    """Per-trial arrays in store order (condition, class, trial index); each ``(n,)``.
    ``classes``: the names ``label`` indexes (:attr:`GenerationConfig.classes`)."""

    label: np.ndarray  # int16 index into classes
    condition: np.ndarray  # int16 index into config.conditions
    trial_index: np.ndarray  # int32 index within (class, condition)
    force_n: np.ndarray  # float64
    speed_mm_s: np.ndarray  # float64
    seed: np.ndarray  # int64 (values fit in uint32)
    classes: tuple[str, ...] = ()

    def __len__(self) -> int:
        return int(self.label.shape[0])

    def specs(self, start: int, stop: int) -> list[TrialSpec]:
        """The trials ``start:stop`` as :class:`TrialSpec` (their class named by
        ``classes``)."""
        if not self.classes:
            raise ValueError("the plan names no classes: its labels cannot be turned into specs")
        out = []
        for i in range(start, min(stop, len(self))):
            shape, material = self.classes[int(self.label[i])].split("/")
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
    n_cond, n_classes = len(conditions), len(config.classes)
    k = config.trials_per_class
    shape = (n_cond, n_classes, k)
    cond = np.broadcast_to(np.arange(n_cond, dtype=np.int16)[:, None, None], shape).ravel()
    local = np.arange(n_classes, dtype=np.int16)
    label = np.broadcast_to(local[None, :, None], shape).ravel()
    # A trial's seed takes its class's key, not its place in this grid: the paper's classes
    # keep their index into CLASS_NAMES, so their trials are the same in every grid.
    keys = np.asarray(config.class_keys, dtype=np.int64)[label]
    trial = np.broadcast_to(np.arange(k, dtype=np.int32)[None, None, :], shape).ravel()
    force = conditions[cond, 0]
    speed = conditions[cond, 1]
    if config.seed_by_condition:
        seeds = trial_seeds(config.seed, keys, force, speed, trial)
    else:
        nominal = np.ones(label.size)
        seeds = trial_seeds(
            config.seed, keys, NOMINAL_FORCE_N * nominal, NOMINAL_SPEED_MM_S * nominal, trial
        )
    return TrialPlan(
        label=label.copy(),
        condition=cond.copy(),
        trial_index=trial.copy(),
        force_n=force,
        speed_mm_s=speed,
        seed=seeds,
        classes=config.classes,
    )
