"""The stress suite's test sets and its evaluation (``docs/stress.md``).

:func:`prepare_test_sets` simulates, into ``DIR/data/stress``, the clean test set and one
test set per physical family and severity (each a dataset store, resumable as ``run``'s
datasets are), after every requested value has passed its family's check.
:func:`stress_records` fits every method once on the nominal closed-set training half
and evaluates both readings of every family and severity with the protocol engine
(:mod:`benchmark.engine`), then scores them (:mod:`benchmark.stress.metrics`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from synth import Dataset
from synth.presets import GenerationConfig

from ..budget import EpisodeBudget
from ..cells import Features
from ..engine import run_task_sets
from ..protocols.closed_set import FIT_KEY, fit_seed
from ..results import (
    Record,
    StressFamilyRecord,
    StressRecord,
    StressScoreRecord,
)
from ..splits import split_halves
from ..tasks import Cell, Pool, Task, child_seed
from ..workers import ProcessPool
from .families import PhysicalFamily, SensorFamily, StressFamily
from .metrics import scores

PROTOCOL = "stress"
#: The two readings (``docs/stress.md``).
ENROLLED = "enrolled-at-nominal"
PERTURBED = "all-perturbed"
READINGS: tuple[str, ...] = (ENROLLED, PERTURBED)
#: The name of the clean test set's directory and condition.
CLEAN = "clean"


def clean_set_config(
    nominal: GenerationConfig, *, trials_per_class: int, seed: int
) -> GenerationConfig:
    """The clean test set's configuration: the nominal dataset's grid and simulator,
    ``trials_per_class`` fresh trials per class from a seed of its own (``seed`` derives
    it), seeds that do not depend on the condition (so a family's severities repeat the
    same strokes)."""
    if len(nominal.conditions) != 1:
        raise ValueError(
            "--data: the stress suite needs a nominal dataset of one force/speed condition; "
            f"it holds {len(nominal.conditions)}"
        )
    return nominal.replace(
        preset="stress",
        trials_per_class=trials_per_class,
        seed=child_seed(seed, PROTOCOL, "test sets") & 0x7FFFFFFF,
        seed_by_condition=False,
    )


@dataclass(frozen=True)
class Condition:
    """One test condition: the clean set (``family`` None) or a family at a severity."""

    family: StressFamily | None
    severity: int

    @property
    def key(self) -> str:
        """``"clean"`` or ``"<family>/<severity>"``: the condition's name and directory."""
        return CLEAN if self.family is None else f"{self.family.name}/{self.severity}"

    @property
    def value(self) -> float | None:
        return None if self.family is None else self.family.value(self.severity)


def conditions(families: Sequence[StressFamily], severities: Sequence[int]) -> list[Condition]:
    """The clean condition, then every family at every severity, in the given orders."""
    return [Condition(None, 0)] + [Condition(f, s) for f in families for s in severities]


def check_values(
    families: Sequence[StressFamily], severities: Sequence[int], base: GenerationConfig | None
) -> None:
    """Every family's check of every requested value, before anything is simulated; a
    physical family needs a simulated nominal dataset (``base`` not None)."""
    for fam in families:
        if isinstance(fam, PhysicalFamily) and base is None:
            raise ValueError(
                f"--families {fam.name}: a physical family is simulated from the nominal "
                "dataset's configuration, and --data holds imported recordings; choose "
                "sensor families"
            )
        for s in severities:
            value = fam.value(s)
            fam.check(value, base)
            if isinstance(fam, PhysicalFamily) and base is not None:
                _check_grid(fam, s, fam.configure(base, value))


def _check_grid(family: PhysicalFamily, severity: int, config: GenerationConfig) -> None:
    """Plan a trial of every specimen under ``config`` (the generator's own check), so a
    severity whose slides would leave the plate is refused before anything is simulated."""
    from synth.config import default_synth_config
    from synth.generation import validate_grid
    from synth.presets import GenerationConfig as _Config

    grid = config if config.synth is not None else config.replace(synth=default_synth_config())
    try:
        validate_grid(_Config.from_dict(grid.to_dict()))
    except ValueError as exc:
        raise ValueError(
            f"--families {family.name} severity {severity} ({family.describe(severity)}): {exc}"
        ) from None


def prepare_test_sets(
    base: GenerationConfig,
    families: Sequence[StressFamily],
    severities: Sequence[int],
    root: Path,
    *,
    progress: bool,
    workers: int | None,
    simulator: Any = None,
    log: Any = None,
    executor: Any = None,
) -> dict[str, Path]:
    """``{condition key: store}``: the clean test set and every physical family's test set
    at every severity, simulated into ``root`` (or completed there, or reused when
    complete) in this process, ``workers`` local processes or on ``executor`` (e.g. a Dask
    client's, :func:`synth.generate`); a configuration equal to the clean one reuses the
    clean store."""
    from ..guards import generate_for_run

    say = log or (lambda msg: None)
    paths: dict[str, Path] = {}
    todo: list[tuple[str, GenerationConfig]] = [(CLEAN, base)]
    for cond in conditions([f for f in families if isinstance(f, PhysicalFamily)], severities):
        if cond.family is not None:
            assert isinstance(cond.family, PhysicalFamily)
            todo.append((cond.key, cond.family.configure(base, cond.family.value(cond.severity))))
    for key, config in todo:
        if key != CLEAN and config == base:
            paths[key] = paths[CLEAN]
            continue
        path = root / key
        say(f"stress test set {key}: {config.n_trials} trials into {path} (resumable)")
        generate_for_run(
            config,
            path,
            progress=progress,
            workers=workers,
            simulator=simulator,
            executor=executor,
        )
        paths[key] = path
    return paths


def faulted(data: Dataset, family: SensorFamily, value: float) -> Dataset:
    """``data`` as ``family`` at ``value`` records it (signals transformed, the rest kept)."""
    signals = family.apply(np.asarray(data.signals), value, np.asarray(data.seed))
    return Dataset(
        signals=signals,
        shape=data.shape,
        material=data.material,
        label=data.label,
        force_n=data.force_n,
        speed_mm_s=data.speed_mm_s,
        seed=data.seed,
        classes=data.classes,
        attrs=dict(data.attrs),
    )


def stress_tasks(
    nominal: Dataset,
    test_sets: dict[str, Dataset],
    conds: Sequence[Condition],
    *,
    seed: int,
    way: int,
    shot: int,
    episodes: int,
    enrol: np.ndarray | None = None,
) -> list[Task]:
    """Two tasks per condition (one per reading), all sharing the closed-set fit of the
    nominal dataset; the same cell seed per reading for every condition, so a family's
    severities (and the clean set) see episodes drawn alike. The enrolled reading draws
    its support from the nominal trials ``enrol`` (default: the closed-set test half)."""
    train, test = split_halves(nominal.label, seed=seed)
    fit = Pool(nominal, train)
    enrol_pool = Pool(nominal, test if enrol is None else enrol)
    tasks = []
    for cond in conds:
        data = test_sets[cond.key]
        for reading in READINGS:
            tasks.append(
                Task(
                    protocol=PROTOCOL,
                    fold=None,
                    condition=f"{cond.key}|{reading}",
                    fit=fit,
                    test=Pool(data, np.arange(len(data))),
                    grid=(Cell(way, shot, child_seed(seed, PROTOCOL, reading, way, shot)),),
                    episodes=EpisodeBudget(episodes),
                    fit_seed=fit_seed(seed),
                    fit_key=FIT_KEY,
                    fit_records=False,
                    support=enrol_pool if reading == ENROLLED else None,
                )
            )
    return tasks


def stress_records(
    nominal: Dataset,
    test_sets: dict[str, Dataset],
    conds: Sequence[Condition],
    *,
    methods: Sequence[str],
    reference: str,
    seed: int,
    way: int,
    shot: int,
    episodes: int,
    workers: int = 1,
    progress: bool = False,
    features: Features | None = None,
    fit_cache: Any = None,
    enrol: np.ndarray | None = None,
    options: Any = None,
) -> list[Record]:
    """The stress records of ``methods``: accuracy per (condition, reading, method), then
    each method's family and overall scores against ``reference`` (``enrol``: see
    :func:`stress_tasks`)."""
    tasks = stress_tasks(
        nominal, test_sets, conds, seed=seed, way=way, shot=shot, episodes=episodes, enrol=enrol
    )
    done = run_task_sets(
        [tasks],
        methods,
        features=features or Features(),
        progress=progress,
        executor=ProcessPool(workers),
        fit_cache=fit_cache,
        options=options,
    ).sets[0]
    by_key = {c.key: c for c in conds}
    records: list[Record] = []
    for scored in done.scored:
        r = scored.record
        key, reading = r.condition.split("|")
        cond = by_key[key]
        fam = cond.family
        records.append(
            StressRecord(
                protocol=PROTOCOL,
                family=None if fam is None else fam.name,
                family_kind=None if fam is None else fam.kind,
                severity=cond.severity,
                value=cond.value,
                unit=None if fam is None else fam.unit,
                reading=reading,
                method=r.method,
                way=r.way,
                shot=r.shot,
                query=r.query,
                episodes=r.episodes,
                accuracy=r.accuracy,
                ci95=r.ci95,
                pretrain_s=r.pretrain_s,
                adapt_ms_per_episode=r.adapt_ms_per_episode,
            )
        )
    names = list(dict.fromkeys(c.family.name for c in conds if c.family is not None))
    fam_scores, method_scores = scores(records, reference=reference, families=names)
    records += [
        StressFamilyRecord(
            protocol=PROTOCOL,
            family=f.family,
            reading=f.reading,
            method=f.method,
            mean_drop=f.mean_drop,
            ce=f.ce,
            relative_ce=f.relative_ce,
            reference=reference,
        )
        for f in fam_scores
    ]
    records += [
        StressScoreRecord(
            protocol=PROTOCOL,
            reading=m.reading,
            method=m.method,
            clean=m.clean,
            mean_drop=m.mean_drop,
            worst_drop=m.worst_drop,
            worst_family=m.worst_family,
            mce=m.mce,
            relative_mce=m.relative_mce,
            reference=reference,
        )
        for m in method_scores
    ]
    return records
