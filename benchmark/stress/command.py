"""``tactile-synth stress`` and ``tactile-synth benchmark stress``: the whole suite from a
nominal dataset (given, or generated from the paper or quick preset), its test sets
simulated on demand into ``DIR/data`` (resumable), every method fitted once and
evaluated, the records checkpointed, and ``results.json``, ``stress.md`` and the figures
written into ``DIR``."""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from models.registry import METHOD_NAMES
from synth import Dataset
from tactile_synth.validation import check_choice, check_int

from .. import checkpoints
from ..cells import Features
from ..methods import check_methods
from ..plan import QUICK_METHODS, log
from ..results import Record, write_results
from .families import FAMILY_NAMES, QUICK_FAMILIES, SEVERITIES, get, parse_severities
from .report import write_stress_report
from .suite import (
    CLEAN,
    check_values,
    clean_set_config,
    conditions,
    faulted,
    prepare_test_sets,
    stress_records,
)

#: The reference method the corruption errors are relative to, when the run has it.
DEFAULT_REFERENCE = "Direct-Prot-ML"
#: Episodes per method and condition: full suite and ``--quick``.
FULL_EPISODES = 200
QUICK_EPISODES = 100
#: Severities ``--quick`` runs.
QUICK_SEVERITIES: tuple[int, ...] = (3, 5)


def _settings(
    quick: bool,
    methods: Sequence[str] | None,
    families: Sequence[str] | None,
    severities: str | Sequence[int] | None,
    episodes: int | None,
    reference: str | None,
    way: int,
    shot: int,
) -> dict[str, Any]:
    """Every option checked, before anything is loaded or simulated."""
    chosen = check_methods(methods or (QUICK_METHODS if quick else METHOD_NAMES))
    fams = [get(f) for f in (families or (QUICK_FAMILIES if quick else FAMILY_NAMES))]
    names = [f.name for f in fams]
    if len(set(names)) != len(names):
        raise ValueError(f"--families names a family twice: {', '.join(names)}")
    sev = (
        parse_severities(severities)
        if severities is not None
        else (QUICK_SEVERITIES if quick else SEVERITIES)
    )
    eps = QUICK_EPISODES if quick else FULL_EPISODES
    if episodes is not None:
        eps = check_int("--episodes", episodes, minimum=1)
    ref = reference or (DEFAULT_REFERENCE if DEFAULT_REFERENCE in chosen else chosen[0])
    check_choice("--reference", ref, chosen)
    check_int("--way", way, minimum=2)
    check_int("--shot", shot, minimum=1)
    return {
        "methods": chosen,
        "families": fams,
        "severities": sev,
        "episodes": eps,
        "reference": ref,
        "way": way,
        "shot": shot,
    }


def _stored_config(path: Path) -> Any:
    """The nominal store's generation configuration (None for imported recordings)."""
    from synth import store

    meta = store.read_meta(path)
    return None if store.store_kind(meta) == store.KIND_IMPORTED else store.stored_config(path)


def run_stress(
    out: str | Path,
    *,
    data: str | Path | None = None,
    quick: bool = False,
    methods: Sequence[str] | None = None,
    families: Sequence[str] | None = None,
    severities: str | Sequence[int] | None = None,
    episodes: int | None = None,
    reference: str | None = None,
    way: int = 5,
    shot: int = 1,
    seed: int = 0,
    workers: int | None = None,
    executor: Any = None,
    progress: bool = True,
    overwrite: bool = False,
    options: Any = None,
    stress_data: str | Path | None = None,
    simulator: Any = None,
) -> list[Record]:
    """The stress suite into ``out`` (``docs/stress.md``): the nominal dataset ``data`` (a
    store) or, without it, the paper preset (``quick``: the quick one) generated into
    ``out/data/nominal``; the test sets simulated into ``out/data/stress`` (resumable), or,
    with ``stress_data``, read from that directory's existing stores (``benchmark
    stress``: nothing is simulated); every method fitted once on the nominal closed-set
    training half, with its constructor ``options`` (``--method-option``). Returns the
    records it writes to ``out/results.json``. ``executor``: where the test sets are
    simulated (e.g. a Dask client's executor; default this process, or ``workers`` local
    processes). ``simulator`` replaces MuJoCo (tests only)."""
    from synth import load_dataset
    from synth.presets import preset
    from tactile_synth import atomic

    from ..guards import generate_for_run
    from ..outputs import OutputDir
    from ..run import default_workers

    check_int("seed", seed, minimum=0)
    opts = _settings(quick, methods, families, severities, episodes, reference, way, shot)
    out = Path(out)
    atomic.check_out_dir(out)
    if data is not None and not Path(data).is_dir():
        raise FileNotFoundError(f"--data {data} is not a dataset directory")
    if stress_data is not None and data is None:
        raise ValueError(
            "--stress-data needs --data (the nominal dataset its test sets derive from)"
        )
    if stress_data is not None and not Path(stress_data).is_dir():
        raise FileNotFoundError(f"--stress-data {stress_data} is not a directory")
    nominal_config = (
        _stored_config(Path(data))
        if data is not None
        else preset("quick" if quick else "paper").replace(seed=seed)
    )
    trials = _test_trials(nominal_config)
    base = None
    if nominal_config is not None:
        base = clean_set_config(nominal_config, trials_per_class=trials, seed=seed)
    check_values(opts["families"], opts["severities"], base)  # before any simulation
    fit_workers = default_workers() if workers is None else check_int("workers", workers, minimum=1)
    t0 = time.perf_counter()
    inputs = {"--data": data, "--stress-data": stress_data}
    with OutputDir(out, overwrite=overwrite, command="stress", inputs=inputs) as tmp:
        if data is None:
            path = out / "data" / "nominal"
            log(progress, f"generating the nominal dataset into {path} (resumable)")
            generate_for_run(
                nominal_config,
                path,
                progress=progress,
                workers=workers,
                simulator=simulator,
                executor=executor,
            )
            data = path
        nominal = load_dataset(data)
        root = out / "data" / "stress" if stress_data is None else Path(stress_data)
        test_sets, enrol = _test_sets(
            nominal,
            base,
            opts,
            root,
            progress,
            workers,
            simulator,
            seed,
            simulate=stress_data is None,
            executor=executor,
        )
        records = _evaluate(
            nominal, test_sets, enrol, opts, tmp, seed, fit_workers, progress, options
        )
        _write(records, opts, tmp, nominal, data, test_sets, seed)
    log(progress, f"stress suite done in {time.perf_counter() - t0:.0f} s")
    return records


def _test_trials(config: Any) -> int:
    """Trials per class of each test set: the nominal test half's (a class's odd trial goes
    to the test half), at least 2 (one support example and one query)."""
    if config is None:
        return 0
    return max(2, -(-config.trials_per_class // 2))


def _test_sets(
    nominal: Dataset,
    base: Any,
    opts: dict[str, Any],
    root: Path,
    progress: bool,
    workers: int | None,
    simulator: Any,
    seed: int,
    *,
    simulate: bool = True,
    executor: Any = None,
) -> tuple[dict[str, Dataset], np.ndarray | None]:
    """Every condition's test set in memory (the simulated ones loaded, the sensor
    families' faulted from the clean set), and the nominal trials the enrolled reading
    draws its support from (None: the whole closed-set test half).

    Recordings cannot be simulated again: for an imported dataset the closed-set test
    half is split once more per class, one half to enrol from, the other as the clean
    test set, so that no recorded stroke is both a support example and (faulted) a
    query."""
    from synth import load_dataset

    from ..splits import split_halves
    from ..tasks import child_seed

    conds = conditions(opts["families"], opts["severities"])
    enrol = None
    if base is None:
        test = split_halves(nominal.label, seed=seed)[1]
        first, second = split_halves(nominal.label[test], seed=child_seed(seed, "stress"))
        enrol = test[first]
        sets = {CLEAN: nominal.subset(test[second])}
    elif simulate:
        paths = prepare_test_sets(
            base,
            opts["families"],
            opts["severities"],
            root,
            progress=progress,
            workers=workers,
            simulator=simulator,
            log=lambda msg: log(progress, msg),
            executor=executor,
        )
        sets = {key: load_dataset(p) for key, p in paths.items()}
    else:
        sets = {key: load_dataset(p) for key, p in existing_test_sets(base, opts, root).items()}
    for cond in conds:
        if cond.family is not None and cond.family.kind == "sensor":
            sets[cond.key] = faulted(sets[CLEAN], cond.family, cond.family.value(cond.severity))
    return sets, enrol


def existing_test_sets(base: Any, opts: dict[str, Any], root: Path) -> dict[str, Path]:
    """The stores of the clean and the physical test sets under ``root`` (``benchmark
    stress``), each checked to hold the configuration the suite would simulate; a missing
    or different one is a one-line error naming the command that makes it."""
    from synth import store

    wanted = {CLEAN: base}
    for cond in conditions(opts["families"], opts["severities"]):
        fam = cond.family
        if fam is not None and fam.kind == "physical":
            wanted[cond.key] = fam.configure(base, fam.value(cond.severity))
    paths = {}
    for key, config in wanted.items():
        path = root / CLEAN if key != CLEAN and config == base else root / key
        make = "make them with `tactile-synth stress --data ... --out DIR` (into DIR/data/stress)"
        if not store.is_store(path):
            raise FileNotFoundError(f"--stress-data {root}: no test set {key} at {path}; {make}")
        stored = store.stored_config(path)
        same_grid = stored.replace(synth=None) == config.replace(synth=None)
        if not same_grid or (config.synth is not None and stored.synth != config.synth):
            raise ValueError(
                f"--stress-data {root}: the test set at {path} was made for another nominal "
                f"dataset or seed; {make}"
            )
        paths[key] = path
    return paths


def _evaluate(
    nominal: Dataset,
    test_sets: dict[str, Dataset],
    enrol: np.ndarray | None,
    opts: dict[str, Any],
    tmp: Path,
    seed: int,
    workers: int,
    progress: bool,
    options: Any = None,
) -> list[Record]:
    """The stress records, from the checkpoint when the inputs are unchanged."""
    from synth.store import versions

    conds = conditions(opts["families"], opts["severities"])
    inputs = {
        "protocol": "stress",
        "data": checkpoints.fingerprint(nominal),
        "test_sets": {k: checkpoints.fingerprint(d) for k, d in sorted(test_sets.items())},
        "methods": list(opts["methods"]),
        "settings": checkpoints.method_settings(opts["methods"]),
        "families": [f.name for f in opts["families"]],
        "severities": list(opts["severities"]),
        "episodes": opts["episodes"],
        "cell": [opts["way"], opts["shot"]],
        "reference": opts["reference"],
        "options": {m: dict(sorted(o.items())) for m, o in sorted((options or {}).items())},
        "version": versions()["package_version"],
        "seed": seed,
    }
    key = checkpoints.key(inputs)
    cached = checkpoints.load(tmp, "stress", key)
    if cached is not None:
        log(progress, "stress: reusing checkpoint")
        return cached
    features = Features()
    log(progress, f"extracting the feature pools of {len(test_sets) + 1} datasets")
    for d in (nominal, *test_sets.values()):
        features.of(d)
    where = f" in {workers} worker processes" if workers > 1 else ""
    log(progress, f"stress: fitting and evaluating {', '.join(opts['methods'])}{where}")
    fits = checkpoints.FitCheckpoints(tmp, [key])
    records = stress_records(
        nominal,
        test_sets,
        conds,
        methods=opts["methods"],
        reference=opts["reference"],
        seed=seed,
        way=opts["way"],
        shot=opts["shot"],
        episodes=opts["episodes"],
        workers=workers,
        progress=progress,
        features=features,
        fit_cache=fits,
        enrol=enrol,
        options=options,
    )
    checkpoints.save(tmp, "stress", key, records)
    fits.clear()
    return records


def _write(
    records: list[Record],
    opts: dict[str, Any],
    tmp: Path,
    nominal: Dataset,
    data: Any,
    test_sets: dict[str, Dataset],
    seed: int,
) -> None:
    from ..report import dataset_summary

    write_results(tmp / "results.json", records)
    meta = {
        "data": dataset_summary(nominal, data),
        "test_sets": f"{len(test_sets)} of {len(test_sets[CLEAN])} trials each "
        f"({len(test_sets[CLEAN].class_names)} classes)",
        "cell": f"{opts['way']}-way {opts['shot']}-shot",
        "episodes": opts["episodes"],
        "seed": seed,
        "reference": opts["reference"],
    }
    write_stress_report(records, opts["families"], tmp, meta)
