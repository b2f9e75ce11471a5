"""The whole study in one call: ``benchmark all`` (all four protocols + interpretability +
report) and ``run`` (generate the datasets from nothing, then ``benchmark all``).

Interruptions lose nothing already finished: each protocol's records are saved to
``DIR/checkpoints/<protocol>.json`` as soon as it completes, keyed by everything that
determines them (dataset fingerprints, methods, episode budgets, seed); a re-run with the
same inputs reuses them. ``run`` passes ``resume=True`` to the generator, so completed
datasets are reused and interrupted ones completed. The output directories are managed by
:mod:`benchmark.outputs` (refuse foreign files, replace the output set at once).
"""

from __future__ import annotations

import hashlib
import json
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from models.registry import METHOD_NAMES
from shapes.validation import check_int
from synth import Dataset
from tactile_synth.threads import describe as describe_threads

from . import figures
from .protocols.generalisation import check_methods, closed_set_reference, dataset_features
from .results import select
from .splits import CROSS_SHAPE_FOLDS

ALL_PROTOCOLS: tuple[str, ...] = ("closed-set", "cross-shape", "cross-material", "perturbation")


@dataclass(frozen=True)
class Budget:
    """Episodes per (protocol, method): ``default`` unless ``per_method`` names the method.

    ``generalisation_per_method`` overrides ``per_method`` for the three generalisation
    protocols (11 ways x several folds/conditions each, so they cost most).
    """

    default: int = 500
    per_method: Mapping[str, int] = field(default_factory=dict)
    generalisation_per_method: Mapping[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        check_int("episodes", self.default, minimum=1)
        for table in (self.per_method, self.generalisation_per_method):
            for m, n in table.items():
                check_methods([m])
                check_int(f"episodes for {m}", n, minimum=1)

    def for_protocol(self, protocol: str) -> dict[str, int]:
        """Method -> episodes override for ``protocol`` (methods absent use ``default``)."""
        out = dict(self.per_method)
        if protocol != "closed-set":
            out.update(self.generalisation_per_method)
        return out

    def describe(self, methods: Sequence[str]) -> str:
        parts = []
        for protocol in ALL_PROTOCOLS:
            table = self.for_protocol(protocol)
            eps = ", ".join(f"{m} {table.get(m, self.default)}" for m in methods)
            parts.append(f"{protocol}: {eps}")
        return "episodes per (fold/condition, way) — " + "; ".join(parts)

    def to_dict(self) -> dict[str, Any]:
        return {
            "default": self.default,
            "per_method": dict(sorted(self.per_method.items())),
            "generalisation_per_method": dict(sorted(self.generalisation_per_method.items())),
        }


def _log(progress: bool, msg: str) -> None:
    if progress:
        print(f"[tactile-synth] {msg}", file=sys.stderr, flush=True)


def fingerprint(data: Dataset) -> str:
    """SHA-256 of a dataset's arrays (signals, labels, conditions, seeds): 16 hex chars."""
    h = hashlib.sha256()
    for arr in (data.signals, data.label, data.force_n, data.speed_mm_s, data.seed):
        a = np.ascontiguousarray(arr)
        h.update(str(a.dtype).encode() + str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()[:16]


def _call_protocol(
    protocol: str, data: Dataset, perturbed: Dataset | None, **kw: Any
) -> list[dict]:
    from .protocols import protocol_runner

    runner = protocol_runner(protocol)
    if protocol == "closed-set":
        # The closed-set protocol has the plain contract signature (+ precomputed features).
        kw = {k: kw[k] for k in ("methods", "episodes", "seed", "progress", "features") if k in kw}
        return runner(data, perturbed=perturbed, **kw)
    return runner(data, perturbed=perturbed, reference=False, **kw)


def _checkpoint(out: Path, protocol: str, key: str) -> list[dict] | None:
    path = out / "checkpoints" / f"{protocol}.json"
    if not path.is_file():
        return None
    try:
        saved = json.loads(path.read_text())
    except json.JSONDecodeError:
        return None
    return saved["records"] if saved.get("key") == key else None


def _save_checkpoint(out: Path, protocol: str, key: str, records: list[dict]) -> None:
    path = out / "checkpoints" / f"{protocol}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps({"key": key, "records": records}))
    tmp.replace(path)


def dataset_summary(data: Dataset, path: str | Path | None) -> str:
    conds = sorted(
        {(float(f), float(s)) for f, s in zip(data.force_n, data.speed_mm_s, strict=True)}
    )
    n_cls = np.unique(data.label).size
    per_cls = np.unique(np.unique(data.label, return_counts=True)[1])
    cond = ", ".join(f"{f:g} N/{s:g} mm/s" for f, s in conds)
    where = f"`{path}`, " if path is not None else ""
    return (
        f"{where}{len(data)} trials, {n_cls} classes, {'/'.join(map(str, per_cls))} trials "
        f"per class, conditions: {cond}; fingerprint {fingerprint(data)}"
    )


def benchmark_all(
    data: Dataset,
    perturbed: Dataset,
    out: str | Path,
    *,
    methods: Sequence[str] = METHOD_NAMES,
    budget: Budget | None = None,
    seed: int = 0,
    progress: bool = True,
    data_path: str | Path | None = None,
    perturbed_path: str | Path | None = None,
) -> list[dict]:
    """All four protocols + interpretability on ``data`` (nominal) and ``perturbed``;
    writes ``out/results.json``, ``out/report.md`` and the PNG figures. Returns records."""
    from .report import write_report
    from .results import write_results

    methods = check_methods(methods)
    if "AFOP-ML" not in methods:
        raise ValueError("methods must include AFOP-ML (the report and Fig. 6/7 are about it)")
    check_int("seed", seed, minimum=0)
    budget = budget or Budget()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()

    _log(progress, "extracting the 386-feature pools")
    features = dataset_features(data)
    perturbed_features = dataset_features(perturbed)
    base_key = {
        "data": fingerprint(data),
        "perturbed": fingerprint(perturbed),
        "methods": list(methods),
        "seed": seed,
    }

    records: list[dict] = []
    timings: dict[str, float] = {}
    for protocol in ALL_PROTOCOLS:
        per_method = budget.for_protocol(protocol)
        key_dict = {
            **base_key,
            "protocol": protocol,
            "episodes": budget.default,
            "per_method": dict(sorted(per_method.items())),
        }
        key = hashlib.sha256(json.dumps(key_dict, sort_keys=True).encode()).hexdigest()
        cached = _checkpoint(out, protocol, key)
        if cached is not None:
            _log(progress, f"{protocol}: reusing checkpoint")
            records += cached
            continue
        _log(progress, f"{protocol}: running {', '.join(methods)}")
        t0 = time.perf_counter()
        if protocol == "closed-set":
            recs: list[dict] = []
            for m in methods:  # the contract's run takes one episode count
                recs += _call_protocol(
                    protocol,
                    data,
                    perturbed,
                    methods=[m],
                    episodes=per_method.get(m, budget.default),
                    seed=seed,
                    progress=progress,
                    features=features,
                )
        else:
            kw: dict[str, Any] = {"features": features}
            if protocol == "perturbation":
                kw["perturbed_features"] = perturbed_features
            recs = _call_protocol(
                protocol,
                data,
                perturbed,
                methods=methods,
                episodes=budget.default,
                seed=seed,
                progress=progress,
                method_episodes=per_method,
                **kw,
            )
        timings[protocol] = time.perf_counter() - t0
        _save_checkpoint(out, protocol, key, recs)
        records += recs

    _log(progress, "closed-set reference curve, D-scan and t-SNE (AFOP-ML)")
    extra, artefacts = interpretability(
        data, features, episodes=budget.default, seed=seed, progress=progress
    )
    if not select(records, "selection", protocol="closed-set"):
        records += select(extra, "selection")
    records += [r for r in extra if r["record"] != "selection"]

    write_results(out / "results.json", records)
    _log(progress, "drawing figures")
    figs = draw_figures(records, data, artefacts, out)
    meta = {
        "seed": seed,
        "data": dataset_summary(data, data_path),
        "perturbed": dataset_summary(perturbed, perturbed_path),
        "methods": list(methods),
        "episodes": budget.describe(methods),
        "threads": describe_threads(),
        "cross_shape_folds": [list(f) for f in CROSS_SHAPE_FOLDS],
        "figures": figs,
        "figure_notes": figure_notes(records, artefacts, budget, seed),
        "notes": [
            "CWT-ResNet-ML's ResNet was pretrained from scratch on each task's training "
            "classes only (no ImageNet weights: none may be downloaded, and none would "
            "have seen tactile scalograms).",
            "The perturbation protocol fits each method on the closed-set training half "
            "of the nominal dataset (same seeded 50:50 per-class split as closed-set).",
        ],
    }
    write_report(records, out, meta)
    _log(progress, f"done in {time.perf_counter() - t_start:.0f} s")
    return records


@dataclass(frozen=True)
class Artefacts:
    """In-memory results behind Fig. 7 and the D-scan figure (not in results.json rows).

    dscan: AFOP-ML's ``dscan_`` (``D``, ``mean``, ``ci95`` arrays) or None; chosen_d: its D;
    emb: ``(n, 2)`` t-SNE of the closed-set test half; shape, material: ``(n,)`` labels.
    """

    dscan: Mapping[str, Sequence[float]] | None
    chosen_d: int
    emb: np.ndarray
    shape: np.ndarray
    material: np.ndarray
    indicators: Mapping[str, float]
    reference_episodes: int


def interpretability(
    data: Dataset, features: np.ndarray, *, episodes: int, seed: int, progress: bool
) -> tuple[list[dict], Artefacts]:
    """Closed-set AFOP-ML fit: reference curve records, its selection record, a ``dscan``
    record, and the t-SNE of the closed-set test half in its top-D space + indicators."""
    from .interpret import tsne_embedding, tsne_indicators
    from .protocols.generalisation import selection_of
    from .results import dscan_record, tsne_record

    ref = closed_set_reference(
        data, episodes=episodes, seed=seed, progress=progress, features=features
    )
    model = ref.model
    records = list(ref.records)
    records.append(selection_of("closed-set", None, model))
    dscan = getattr(model, "dscan_", None)
    if dscan is not None:
        records.append(
            dscan_record(
                protocol="closed-set",
                D=np.asarray(dscan["D"]).tolist(),
                mean=np.asarray(dscan["mean"]).tolist(),
                ci95=np.asarray(dscan["ci95"]).tolist(),
            )
        )
    test = ref.test_idx
    top = features[test][:, np.asarray(model.selected_)]
    emb = tsne_embedding(top, seed=seed)
    ind = tsne_indicators(emb, data.shape[test], data.material[test])
    records.append(
        tsne_record(
            protocol="closed-set",
            D=int(model.D_),
            nn1_shape_accuracy=ind.nn1_shape_accuracy,
            mix_sil=ind.mix_sil,
            dgi=ind.dgi,
        )
    )
    art = Artefacts(
        dscan=dscan,
        chosen_d=int(model.D_),
        emb=emb,
        shape=np.asarray(data.shape[test]),
        material=np.asarray(data.material[test]),
        indicators={
            "nn1_shape_accuracy": ind.nn1_shape_accuracy,
            "mix_sil": ind.mix_sil,
            "dgi": ind.dgi,
        },
        reference_episodes=episodes,
    )
    return records, art


#: Figure key -> file name (fixed, so reports and READMEs can link them).
FIGURE_FILES: dict[str, str] = {
    "dscan": "dscan.png",
    "generalisation": "generalisation.png",
    "perturbation_heatmap": "perturbation_heatmap.png",
    "selection": "selection.png",
    "tsne": "tsne.png",
    "signals": "example_signals.png",
}


def draw_figures(
    records: Sequence[dict], data: Dataset, art: Artefacts, out: Path
) -> dict[str, str]:
    """Write every PNG into ``out``; returns figure key -> file name (relative)."""
    made: dict[str, str] = {}
    if art.dscan is not None:
        figures.dscan_curve(art.dscan, art.chosen_d, out / FIGURE_FILES["dscan"])
        made["dscan"] = FIGURE_FILES["dscan"]
    figures.generalisation_curves(records, out / FIGURE_FILES["generalisation"])
    made["generalisation"] = FIGURE_FILES["generalisation"]
    pert_methods = list(
        dict.fromkeys(r["method"] for r in select(records, "accuracy", protocol="perturbation"))
    )
    if pert_methods:
        figures.perturbation_heatmap(
            records, out / FIGURE_FILES["perturbation_heatmap"], methods=pert_methods
        )
        made["perturbation_heatmap"] = FIGURE_FILES["perturbation_heatmap"]
    figures.selection_bars(records, out / FIGURE_FILES["selection"])
    made["selection"] = FIGURE_FILES["selection"]
    figures.tsne_scatter(
        art.emb, art.shape, art.material, art.indicators, out / FIGURE_FILES["tsne"], d=art.chosen_d
    )
    made["tsne"] = FIGURE_FILES["tsne"]
    figures.example_signals(data, out / FIGURE_FILES["signals"])
    made["signals"] = FIGURE_FILES["signals"]
    return made


def _episodes_of(records: Sequence[dict], **match: Any) -> str:
    eps: dict[str, set[int]] = {}
    for r in select(records, "accuracy", **match):
        eps.setdefault(r["method"], set()).add(r["episodes"])
    return ", ".join(f"{m} {'/'.join(map(str, sorted(e)))}" for m, e in eps.items())


def figure_notes(
    records: Sequence[dict], art: Artefacts, budget: Budget, seed: int
) -> dict[str, str]:
    """One-paragraph summary of each figure: what it shows, numbers, episode counts."""

    def _one(records: Sequence[dict], **match: Any) -> dict | None:
        return next(iter(select(records, "accuracy", **match)), None)

    notes: dict[str, str] = {}
    if art.dscan is not None:
        d = np.asarray(art.dscan["D"])
        notes["dscan"] = (
            f"AFOP-ML validation accuracy vs number of top-ranked features D "
            f"({int(d.min())}..{int(d.max())}) on held-out episodes of the closed-set "
            f"training half, 95 % CI band; chosen D = {art.chosen_d}."
        )
    parts = []
    for protocol, cond in (
        ("cross-shape", None),
        ("cross-material", None),
        ("perturbation", "pooled"),
    ):
        a2 = _one(records, protocol=protocol, condition=cond, fold=None, method="AFOP-ML", way=2)
        a12 = _one(records, protocol=protocol, condition=cond, fold=None, method="AFOP-ML", way=12)
        if a2 and a12:
            parts.append(
                f"{protocol}: AFOP-ML {100 * a2['accuracy']:.1f} % (2-way) → "
                f"{100 * a12['accuracy']:.1f} % (12-way), episodes per way "
                f"[{_episodes_of(records, protocol=protocol, condition=cond, fold=None, way=5)}]"
            )
    notes["generalisation"] = (
        "1-shot accuracy vs N (2..12) with 95 % CI bands per method; the dashed black line is "
        f"closed-set AFOP-ML ({art.reference_episodes} episodes per way). " + "; ".join(parts) + "."
    )
    notes["perturbation_heatmap"] = (
        "5-way-1-shot accuracy per force x speed condition after fitting at the nominal "
        "1 N / 10 mm/s; episodes per cell: "
        f"[{_episodes_of(records, protocol='perturbation', way=5)}]."
    )
    sel = select(records, "selection")
    notes["selection"] = (
        "Median AFOP-ML D per task (bars) and PVDF / SG shares of the selected features "
        f"(lines); {len(sel)} fits (3 folds each for cross-shape and cross-material, 1 each "
        "for closed-set and perturbation)."
    )
    ind = art.indicators
    notes["tsne"] = (
        f"t-SNE of the {art.emb.shape[0]} closed-set test-half trials in AFOP-ML's "
        f"top-{art.chosen_d} feature space; markers = shape, colours = material. "
        f"1-NN = {ind['nn1_shape_accuracy']:.3f}, mix-sil = {ind['mix_sil']:.3f}, "
        f"DGI = {ind['dgi']:.3f} (t-SNE seed {seed})."
    )
    notes["signals"] = (
        "The first trial of each class, 4 channels each, every channel standardised over "
        "the plotted trials."
    )
    return notes


@dataclass(frozen=True)
class RunPlan:
    """What ``tactile-synth run`` generates and how many episodes it evaluates."""

    nominal: Any  # synth.presets.GenerationConfig or preset name
    perturbation: Any
    methods: tuple[str, ...]
    budget: Budget


def run_plan(quick: bool, *, seed: int = 0, methods: Sequence[str] | None = None) -> RunPlan:
    """The full (``paper`` + ``perturbation`` presets) or ``--quick`` plan; ``methods``
    replaces the plan's methods (default: all seven, :data:`QUICK_METHODS` when quick).

    Budgets (:func:`full_budget`): the same for every method, the paper's 500 episodes per
    closed-set column and 100 per generalisation point (11 ways x 3 folds or 9
    conditions each); every record carries its own ``episodes``.
    """
    from synth.presets import preset

    chosen = None if methods is None else check_methods(methods)

    if quick:
        nominal = preset("quick").replace(seed=seed)
        pert = preset("perturbation").replace(
            preset="perturbation-quick",
            trials_per_class=2,
            forces_n=(0.6, 1.4),
            speeds_mm_s=(6.0, 14.0),
            seed=seed,
        )
        return RunPlan(nominal, pert, chosen or QUICK_METHODS, QUICK_BUDGET)
    chosen = chosen or METHOD_NAMES
    return RunPlan(
        preset("paper").replace(seed=seed),
        preset("perturbation").replace(seed=seed),
        chosen,
        full_budget(chosen),
    )


def full_budget(methods: Sequence[str]) -> Budget:
    """Episode budgets of the full run, the same for every one of ``methods``: the paper's
    500 episodes per closed-set column and 100 per generalisation point (fold or condition
    x way)."""
    return Budget(default=500, generalisation_per_method=dict.fromkeys(methods, 100))


FULL_BUDGET = full_budget(METHOD_NAMES)
QUICK_METHODS: tuple[str, ...] = ("AFOP-ML", "AFO-MLP-ML", "Direct-Prot-ML")
QUICK_BUDGET = Budget(default=100)


def run(
    out: str | Path,
    *,
    quick: bool = False,
    seed: int = 0,
    progress: bool = True,
    workers: int | None = None,
    methods: Sequence[str] | None = None,
    simulator: Any = None,
    overwrite: bool = False,
    data: str | Path | None = None,
    perturbed: str | Path | None = None,
) -> list[dict]:
    """Generate the nominal and perturbation datasets into ``out/data`` (reusing or
    completing any already there) and run :func:`benchmark_all` into ``out`` with the
    plan's methods, or ``methods`` (names, plug-in names or ``module:Class``; must include
    AFOP-ML).

    ``data`` / ``perturbed``: existing dataset stores (generated or imported with
    ``tactile-synth import``) used instead of generating the nominal / perturbation
    dataset; the one not given is generated as usual.

    ``out`` is refused if it holds files this tool did not write, unless ``overwrite``;
    its output set is replaced at once at the end, its datasets and checkpoints kept
    (see :mod:`benchmark.outputs`). ``simulator`` replaces the MuJoCo simulator (tests
    only; see :func:`synth.generate`).
    """
    from synth import load_dataset

    from .guards import check_perturbation_pair, generate_for_run
    from .outputs import OutputDir

    check_int("seed", seed, minimum=0)
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise FileExistsError(f"--out {out} is a file; choose a directory")
    plan = run_plan(quick, seed=seed, methods=methods)
    if "AFOP-ML" not in plan.methods:
        raise ValueError("methods must include AFOP-ML (the report and Fig. 6/7 are about it)")
    given = {"nominal": data, "perturbation": perturbed}
    for path, arg in zip(given.values(), ("data", "perturbed"), strict=True):
        if path is not None and not Path(path).is_dir():
            raise FileNotFoundError(f"--{arg} {path} is not a dataset directory")
    with OutputDir(out, overwrite=overwrite, command="run") as target:
        paths = {}
        for name, config in (("nominal", plan.nominal), ("perturbation", plan.perturbation)):
            if given[name] is not None:
                _log(progress, f"{name} dataset: {given[name]} (given, not generated)")
                paths[name] = Path(given[name])
                continue
            path = out / "data" / name
            _log(progress, f"generating the {name} dataset into {path} (resumable)")
            t0 = time.perf_counter()
            generate_for_run(config, path, progress=progress, workers=workers, simulator=simulator)
            _log(progress, f"{name} dataset ready ({time.perf_counter() - t0:.0f} s)")
            paths[name] = path
        data = load_dataset(paths["nominal"])
        perturbed = load_dataset(paths["perturbation"])
        check_perturbation_pair(data, perturbed)
        return benchmark_all(
            data,
            perturbed,
            target,
            methods=plan.methods,
            budget=plan.budget,
            seed=seed,
            progress=progress,
            data_path=paths["nominal"],
            perturbed_path=paths["perturbation"],
        )
