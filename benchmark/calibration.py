"""Measuring a configuration for the calibration (``scripts/calibrate.py`` sweep and
whatif): the paper grid generated with it, the leave-one-out diagnosis, and AFOP-ML's
feature selections fitted on the generalisation protocols' training splits alone (no test
accuracy enters), over dataset seeds; what those selections lean on (``picks``); and
AFOP-ML's closed-set row with its t-SNE indicators.

The configurations and the sweep's tables are the simulator's
(:mod:`synth.calibration`); these computations read models and the benchmark, so they
live here.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import numpy as np

import synth
from synth.calibration.sweep import over_seeds


def evaluate(config: synth.SynthConfig, trials_per_class: int, where: Path, seed: int = 0) -> dict:
    """The metrics the sweep chooses by, for ``config`` on the paper grid of
    ``trials_per_class`` trials per class generated from ``seed`` into ``where``: the
    diagnosis' strain-gauge shape accuracy (overall and the worst shape's), class and
    material accuracies, and :func:`selection_shares`."""
    from benchmark.diagnose import diagnose
    from synth.presets import preset

    grid = preset("paper").replace(
        trials_per_class=trials_per_class, synth=config.to_dict(), seed=seed
    )
    synth.generate(grid, where, overwrite=True, progress=False)
    data = synth.load_dataset(where)
    diag = diagnose(data).to_dict()
    acc = diag["accuracy"]
    per_shape = diag["per_shape"]["sg"]
    return {
        "sg_shape": acc["shape"]["sg"],
        "sg_worst_shape": min(v for v in per_shape.values() if v is not None),
        "class_all": acc["class"]["all"],
        "material_all": acc["material"]["all"],
        "material_sg": acc["material"]["sg"],
        "material_pvdf": acc["material"]["pvdf"],
        **selection_shares(data),
    }


#: The feature counts the paper's selections chose (medians): about 6 for cross-shape and
#: 12 for cross-material. Its PVDF shares (21 % and 50 %) are of those many features.
PAPER_D = {"cross_shape": 6, "cross_material": 12}


def training_fits(data: synth.Dataset, features: np.ndarray):
    """``(protocol, split, fitted AFOP-ML)`` for every cross-shape fold and cross-material
    split of ``data``, each fitted (seed 0) on its training split alone."""
    from benchmark.splits import cross_material_splits, cross_shape_splits
    from models.afop import AFOPML

    for protocol, splits in (
        ("cross_shape", cross_shape_splits(data)),
        ("cross_material", cross_material_splits(data)),
    ):
        for split in splits:
            fitted = AFOPML(seed=0).fit(
                data.signals[split.train], data.label[split.train], features=features[split.train]
            )
            yield protocol, split, fitted


def selection_shares(data: synth.Dataset) -> dict:
    """Mean PVDF share of AFOP-ML's top-D features over the cross-shape folds and over the
    cross-material splits, each fitted on its training split only; the median D each
    protocol's splits chose (the paper reports both: D about 6 and 12); and the mean PVDF
    share of the first :data:`PAPER_D` features of each split's NCA ranking, the share
    the paper's selection sizes would give (``pvdf_share_paper_d_*``)."""
    from benchmark.interpret import sensor_shares
    from models.features import FEATURE_NAMES, extract

    features = extract(data.signals)
    out = {}
    fits: dict[str, list] = {"cross_shape": [], "cross_material": []}
    for protocol, _split, fitted in training_fits(data, features):
        fits[protocol].append(fitted)
    for protocol, fitted_splits in fits.items():
        shares, sizes, at_paper_d = [], [], []
        for fitted in fitted_splits:
            shares.append(sensor_shares(fitted.selected_, FEATURE_NAMES)[0])
            sizes.append(len(fitted.selected_))
            top = fitted.ncfs_.ranking_[: PAPER_D[protocol]]
            at_paper_d.append(sensor_shares(top, FEATURE_NAMES)[0])
        out[f"pvdf_share_{protocol}"] = float(np.mean(shares))
        out[f"d_{protocol}"] = float(np.median(sizes))
        out[f"pvdf_share_paper_d_{protocol}"] = float(np.mean(at_paper_d))
    return out


def variance_shares(
    features: np.ndarray, shape: np.ndarray, material: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``(shape share, material share)`` of each feature's variance over the trials given,
    ``(n, f)`` features: the share between the shapes' means, and the share between the
    materials' means inside each shape (the shape-and-material classes' means around their
    shape's mean). The rest lies within the classes. A feature with no variance has 0 for
    both."""
    x = np.asarray(features, dtype=float)
    shape, material = np.asarray(shape), np.asarray(material)
    centred = x - x.mean(axis=0)
    total = np.square(centred).sum(axis=0)

    def between(groups: np.ndarray) -> np.ndarray:
        _, index = np.unique(groups, axis=0, return_inverse=True)
        index = index.ravel()
        counts = np.bincount(index)
        sums = np.zeros((counts.size, x.shape[1]))
        np.add.at(sums, index, centred)
        return (np.square(sums) / counts[:, None]).sum(axis=0)

    by_shape = between(shape)
    by_class = between(np.stack([shape, material], axis=1))
    with np.errstate(invalid="ignore", divide="ignore"):
        shape_share = np.where(total > 0, by_shape / total, 0.0)
        material_share = np.where(total > 0, (by_class - by_shape) / total, 0.0)
    return shape_share, np.maximum(material_share, 0.0)


#: Cuts of the NCA ranking at which ``picks`` gives the PVDF share of the features
#: before it, so that two protocols' shares can be compared at the same feature count.
PICKS_CUTS = (6, 12, 24, 48)


def selection_picks(data: synth.Dataset, top: int) -> list[dict]:
    """Per cross-shape fold and cross-material split of ``data`` (AFOP-ML fitted on the
    training split alone, as :func:`selection_shares` fits it): the first ``top`` features
    of the NCA ranking, each with its sensor, whether the D-scan selected it, and its
    :func:`variance_shares` on that training split; and, of the selected features of each
    sensor, how many carry more of their variance between materials than between shapes
    (``material_led``); and the PVDF share of the first k ranked features for each k of
    :data:`PICKS_CUTS` (``pvdf_share_first``)."""
    from benchmark.interpret import sensor_shares
    from models.features import FEATURE_NAMES, extract, sensor_of

    features = extract(data.signals)
    shape, material = np.asarray(data.shape), np.asarray(data.material)
    sensors = [sensor_of(name).lower() for name in FEATURE_NAMES]
    out = []
    for protocol, split, fitted in training_fits(data, features):
        train = split.train
        by_shape, by_material = variance_shares(features[train], shape[train], material[train])
        selected = {int(i) for i in fitted.selected_}
        ranked = [int(i) for i in fitted.ncfs_.ranking_]
        rows = [
            {
                "rank": r + 1,
                "feature": FEATURE_NAMES[i],
                "sensor": sensors[i],
                "selected": i in selected,
                "shape_share": float(by_shape[i]),
                "material_share": float(by_material[i]),
            }
            for r, i in enumerate(ranked[:top])
        ]
        counts = {}
        for sensor in ("pvdf", "sg"):
            mine = [i for i in selected if sensors[i] == sensor]
            led = sum(by_material[i] > by_shape[i] for i in mine)
            counts[sensor] = {"selected": len(mine), "material_led": int(led)}
        out.append(
            {
                "protocol": protocol,
                "fold": str(split.fold),
                "d": len(selected),
                "top": rows,
                **counts,
                "pvdf_share_first": {
                    k: sensor_shares(ranked[:k], FEATURE_NAMES)[0]
                    for k in PICKS_CUTS
                    if k <= len(ranked)
                },
            }
        )
    return out


def measured(
    config: synth.SynthConfig,
    trials_per_class: int,
    seeds: int,
    where: Path,
    keep: Path | None = None,
) -> dict:
    """:func:`evaluate` of ``config`` on dataset seeds 0..``seeds``-1, summarised by
    :func:`synth.calibration.sweep.over_seeds`; with ``keep``, the dataset of seed 0 is
    moved there."""
    per_seed = []
    for seed in range(seeds):
        per_seed.append(evaluate(config, trials_per_class, where, seed))
        if keep is not None and seed == 0:
            shutil.move(str(where), str(keep))
    return over_seeds(per_seed)


def config_key(config: synth.SynthConfig) -> str:
    """A measurement's identity: the SHA-256 of the canonical JSON of the configuration,
    the simulator's format version (what it simulates from a configuration) and the
    tuned hyper-parameters AFOP-ML's selection uses, so that ``--resume`` keeps no row
    measured by another simulator or another tuning."""
    from models.tuned import tuned_values
    from synth.store import FORMAT_VERSION

    identity = {"config": config.to_dict(), "format": FORMAT_VERSION, "tuned": tuned_values()}
    return hashlib.sha256(json.dumps(identity, sort_keys=True).encode()).hexdigest()


def closed_set_row(
    config: synth.SynthConfig, episodes: int, where: Path, dataset_seed: int = 0
) -> dict:
    """AFOP-ML's closed-set 1-shot accuracy per N-way (%, over ``episodes`` episodes) on
    the paper preset generated with ``config`` from ``dataset_seed``, and of the same fit,
    as a full run reports them: its D, the PVDF share of its selected features and the
    t-SNE indicators of the test half in them (1-NN shape accuracy, mix-sil, DGI). The
    episodes are drawn with seed 0, as the full run draws them."""
    from benchmark import protocols
    from benchmark.engine import Features
    from benchmark.interpret import analyse, sensor_shares
    from benchmark.results import select
    from models.features import FEATURE_NAMES, extract
    from synth.presets import preset

    recipe = preset("paper").replace(synth=config.to_dict(), seed=dataset_seed)
    synth.generate(recipe, where, overwrite=True)
    data = synth.load_dataset(where)
    pool = extract(data.signals)  # the fit and the t-SNE read the same pool
    records = protocols.run(
        "closed-set", data, methods=["AFOP-ML"], episodes=episodes, seed=0, features=pool
    )
    row = {
        f"closed_set_1shot_{r['way']}way": 100 * r["accuracy"]
        for r in select(records, "accuracy")
        if r["shot"] == 1
    }
    selection = select(records, "selection")[0]
    _, artefacts = analyse(
        data, records, features=Features([(data, pool)]), episodes=episodes, seed=0
    )
    return {
        **row,
        "closed_set_d": selection["D"],
        "closed_set_pvdf_share": sensor_shares(selection["selected"], FEATURE_NAMES)[0],
        **{f"tsne_{k}": v for k, v in artefacts.indicators.items()},
    }


def closed_set_spread(rows: list[dict]) -> dict[str, tuple[float, float]]:
    """Each figure of :func:`closed_set_row`'s ``rows`` (one per dataset seed, two or
    more) as ``(mean, standard deviation)`` over them (``ddof=1``): one paper-preset
    dataset is one draw of the trials' scatter, the mean says what the configuration
    gives, the spread how far one dataset strays from it."""
    out = {}
    for key in rows[0]:
        values = np.array([r[key] for r in rows], dtype=np.float64)
        out[key] = (float(values.mean()), float(values.std(ddof=1)))
    return out
