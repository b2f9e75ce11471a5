"""results.json records, their file I/O (JSON, atomic, no pickle) and a query helper.

A results.json file is a plain JSON list of records (dicts); ``record`` names the kind
(``accuracy``, ``selection``, ``tsne``, ``dscan``) and ``schema_version`` the layout
(:data:`SCHEMA_VERSION`). Every field, its type, unit and null rules are documented in
``docs/results.md``; :func:`read_results` refuses a file of another schema version.

Timing fields of an accuracy record (wall clock, machine- and load-dependent; the only
fields allowed to differ between two runs with the same seed, see :data:`TIMING_FIELDS`):

- ``pretrain_s``: one ``fit`` on the training trials, seconds.
- ``adapt_ms_per_episode``: batched throughput. Wall time of one ``predict_episodes``
  call adapting all of the record's ``episodes`` together, features precomputed, divided
  by ``episodes``. Amortised over the batch: NOT the paper's per-episode time.
- ``latency_ms_per_episode``: single-episode latency, the paper's Table I "Adapt/episode"
  measure: mean wall time of adapting one episode at a time (its own support and query
  trials only), features precomputed, over ``latency_episodes`` episodes.
- ``latency_with_features_ms_per_episode``: the same, starting from raw signals (includes
  extracting the 386-feature pool of the episode's trials).
- ``latency_episodes``: how many episodes were timed one at a time (0: the latency fields
  are null; the protocols measure latency on the closed-set 5-way-5-shot column only).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from shapes.validation import check_choice

from .evaluate import EvalResult

#: Layout version of the records, written into every record as ``schema_version`` and
#: checked by :func:`read_results`. Raise it when a field changes meaning, type or unit,
#: or is removed; adding a record kind or an optional field keeps it.
SCHEMA_VERSION: int = 1
#: The record kinds this version writes (``record`` field).
RECORD_KINDS: tuple[str, ...] = ("accuracy", "selection", "tsne", "dscan")

ACCURACY_FIELDS: tuple[str, ...] = (
    "record",
    "schema_version",
    "protocol",
    "fold",
    "condition",
    "method",
    "way",
    "shot",
    "query",
    "episodes",
    "accuracy",
    "ci95",
    "pretrain_s",
    "adapt_ms_per_episode",
    "latency_ms_per_episode",
    "latency_with_features_ms_per_episode",
    "latency_episodes",
    "feature_dim",
)
#: Wall-clock fields (differ between runs with the same seed; everything else is equal).
TIMING_FIELDS: tuple[str, ...] = (
    "pretrain_s",
    "adapt_ms_per_episode",
    "latency_ms_per_episode",
    "latency_with_features_ms_per_episode",
)


def accuracy_record(
    *,
    protocol: str,
    fold: int | str | None,
    condition: str | None,
    method: str,
    way: int,
    shot: int,
    query: int,
    result: EvalResult,
    pretrain_s: float,
    feature_dim: int | None,
) -> dict[str, Any]:
    """One (protocol, fold, condition, method, way, shot) accuracy record."""
    return {
        "record": "accuracy",
        "schema_version": SCHEMA_VERSION,
        "protocol": protocol,
        "fold": fold,
        "condition": condition,
        "method": method,
        "way": int(way),
        "shot": int(shot),
        "query": int(query),
        "episodes": int(result.episodes),
        "accuracy": float(result.accuracy),
        "ci95": float(result.ci95),
        "pretrain_s": float(pretrain_s),
        "adapt_ms_per_episode": float(result.batch_ms_per_episode),
        "latency_ms_per_episode": _float_or_none(result.latency_ms_per_episode),
        "latency_with_features_ms_per_episode": _float_or_none(
            result.latency_with_features_ms_per_episode
        ),
        "latency_episodes": int(result.latency_episodes),
        "feature_dim": None if feature_dim is None else int(feature_dim),
    }


def _float_or_none(value: float | None) -> float | None:
    return None if value is None else float(value)


def selection_record(
    *, protocol: str, fold: int | str | None, D: int, pvdf_share: float, sg_share: float
) -> dict[str, Any]:
    """AFOP-ML's chosen D and the PVDF/SG shares of its top-D features."""
    return {
        "record": "selection",
        "schema_version": SCHEMA_VERSION,
        "protocol": protocol,
        "fold": fold,
        "D": int(D),
        "pvdf_share": float(pvdf_share),
        "sg_share": float(sg_share),
    }


def tsne_record(
    *, protocol: str, D: int, nn1_shape_accuracy: float, mix_sil: float, dgi: float
) -> dict[str, Any]:
    """The paper's t-SNE indicators of the top-D embedding."""
    return {
        "record": "tsne",
        "schema_version": SCHEMA_VERSION,
        "protocol": protocol,
        "fold": None,
        "D": int(D),
        "nn1_shape_accuracy": float(nn1_shape_accuracy),
        "mix_sil": float(mix_sil),
        "dgi": float(dgi),
    }


def dscan_record(
    *, protocol: str, D: Sequence[int], mean: Sequence[float], ci95: Sequence[float]
) -> dict[str, Any]:
    """AFOP-ML's D-scan: validation accuracy (mean and 95 % CI half-width) per candidate D."""
    if not len(D) == len(mean) == len(ci95):
        raise ValueError(
            f"D, mean and ci95 must have one entry per candidate; got {len(D)}, "
            f"{len(mean)} and {len(ci95)}"
        )
    return {
        "record": "dscan",
        "schema_version": SCHEMA_VERSION,
        "protocol": protocol,
        "fold": None,
        "D": [int(d) for d in D],
        "mean": [float(x) for x in mean],
        "ci95": [float(x) for x in ci95],
    }


def select(records: Iterable[dict], record: str, **match: Any) -> list[dict]:
    """The records of kind ``record`` whose fields equal every ``match`` value, in order.

    ``select(records, "accuracy", protocol="cross-shape", fold=None, way=5)``; a field a
    record lacks never matches (so ``fold=None`` does not match a record without ``fold``).
    """
    check_choice("record", record, RECORD_KINDS)
    return [
        r
        for r in records
        if r.get("record") == record and all(k in r and r[k] == v for k, v in match.items())
    ]


def _clean(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    return value


def _versioned(record: Mapping[str, Any]) -> dict[str, Any]:
    """``record`` with ``schema_version`` set (added when absent; another version refused)."""
    version = record.get("schema_version", SCHEMA_VERSION)
    if version != SCHEMA_VERSION:
        raise ValueError(
            f"records: a {record.get('record')!r} record has schema_version {version!r}; "
            f"this version of tactile-synth writes {SCHEMA_VERSION}"
        )
    out = dict(record)
    out["schema_version"] = SCHEMA_VERSION
    return out


def write_results(path: str | Path, records: Sequence[Mapping[str, Any]]) -> Path:
    """Write records as a JSON list, atomically (a reader never sees half a file); every
    record gets ``schema_version`` = :data:`SCHEMA_VERSION`, non-finite floats become null."""
    path = Path(path)
    payload = [_clean(_versioned(r)) for r in records]
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(payload, indent=1) + "\n")
    os.replace(tmp, path)
    return path


def read_results(path: str | Path) -> list[dict]:
    """Load and check a results.json written by :func:`write_results`."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"results file {path} does not exist")
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path} is not valid JSON: {exc}") from None
    if not isinstance(data, list) or not all(isinstance(r, dict) and "record" in r for r in data):
        raise ValueError(f"{path} is not a results.json list of records")
    for i, r in enumerate(data):
        # A record without the field predates schema versions; its layout is version 1.
        version = r.get("schema_version", 1)
        if version != SCHEMA_VERSION:
            raise ValueError(
                f"{path}: record {i} has schema_version {version!r}; this version of "
                f"tactile-synth reads schema_version {SCHEMA_VERSION} (see docs/results.md)"
            )
    return data
