"""results.json records, their file I/O (JSON, atomic, no pickle) and a query helper.

A results.json file is a plain JSON list of records (objects); ``record`` names the kind
(``accuracy``, ``selection``, ``tsne``, ``dscan``, ``meta_curve``, and the stress suite's
``stress``, ``stress_family``, ``stress_score``) and ``schema_version``
the layout (:data:`SCHEMA_VERSION`). Every field, its type, unit and null rules are
documented in ``docs/results.md``; :func:`read_results` refuses a file of another schema
version.

In memory each kind is a frozen dataclass (:class:`AccuracyRecord`, ...) that is also a
read-only mapping of its JSON fields, so code can write ``r.accuracy`` or
``r["accuracy"]`` and :func:`select` queries typed records and plain dicts alike.

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
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import MISSING, dataclass, fields
from pathlib import Path
from typing import Any, ClassVar, Protocol

import numpy as np

from tactile_synth.validation import check_choice

#: Layout version of the records, written into every record as ``schema_version`` and
#: checked by :func:`read_results`. Raise it when a field changes meaning, type or unit,
#: or is removed; adding a record kind or an optional field keeps it.
SCHEMA_VERSION: int = 2

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


class _Record(Mapping[str, Any]):
    """Base of the record dataclasses: typed attributes, and the read-only mapping view
    that results.json holds (``record`` and ``schema_version`` first, then the fields in
    declaration order), so ``r.accuracy`` and ``r["accuracy"]`` are the same value and
    ``dict(r)`` is the JSON object."""

    kind: ClassVar[str]

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The JSON field names of this kind, in file order."""
        return ("record", "schema_version", *(f.name for f in fields(cls)))  # type: ignore[arg-type]

    def __getitem__(self, key: str) -> Any:
        if key == "record":
            return self.kind
        if key == "schema_version":
            return SCHEMA_VERSION
        if key in self._field_names():
            return getattr(self, key)
        raise KeyError(key)

    @classmethod
    def _field_names(cls) -> frozenset[str]:
        return frozenset(f.name for f in fields(cls))  # type: ignore[arg-type]

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())

    def __len__(self) -> int:
        return len(self.names())

    def to_dict(self) -> dict[str, Any]:
        """The record as results.json holds it (non-finite floats become None)."""
        return _clean({k: self[k] for k in self.names()})

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> _Record:
        """The record of ``d`` (a results.json object of this kind); extra fields, which a
        later version of the same schema may add, are ignored, and an optional field
        (one with a default) that ``d`` lacks takes its default."""
        required = [f.name for f in fields(cls) if f.default is MISSING]  # type: ignore[arg-type]
        missing = [k for k in required if k not in d]
        if missing:
            names = ", ".join(sorted(missing))
            raise ValueError(f"a {cls.kind!r} record lacks the field(s) {names}")
        return cls(**{k: d[k] for k in cls._field_names() if k in d})


def _fold(value: Any) -> int | str | None:
    return value if value is None or isinstance(value, str) else int(value)


def _opt_float(value: float | None) -> float | None:
    return None if value is None else float(value)


@dataclass(frozen=True, eq=False)
class AccuracyRecord(_Record):
    """One (protocol, fold, condition, method, way, shot) cell: fields in docs/results.md."""

    kind: ClassVar[str] = "accuracy"
    protocol: str
    fold: int | str | None
    condition: str | None
    method: str
    way: int
    shot: int
    query: int
    episodes: int
    accuracy: float
    ci95: float
    pretrain_s: float
    adapt_ms_per_episode: float
    latency_ms_per_episode: float | None
    latency_with_features_ms_per_episode: float | None
    latency_episodes: int
    feature_dim: int | None


@dataclass(frozen=True, eq=False)
class SelectionRecord(_Record):
    """AFOP-ML's chosen D, the PVDF/SG shares of its top-D features and, optionally, the
    top-D features themselves (``selected``: indices into the 386-feature pool, best
    ranked first; None in files that do not hold them), per fit."""

    kind: ClassVar[str] = "selection"
    protocol: str
    fold: int | str | None
    D: int
    pvdf_share: float
    sg_share: float
    selected: list[int] | None = None


@dataclass(frozen=True, eq=False)
class TsneRecord(_Record):
    """The paper's Fig. 7 indicators of the closed-set top-D feature space
    (``nn1_shape_accuracy``, ``mix_sil``, ``dgi``, the DGI's neighbours ``dgi_k`` and its
    value under random material mixing ``dgi_random``) and of the 2-D t-SNE embedding
    (``embedding_*``); definitions in :mod:`benchmark.interpret` and docs/results.md."""

    kind: ClassVar[str] = "tsne"
    protocol: str
    fold: int | str | None
    D: int
    nn1_shape_accuracy: float
    mix_sil: float
    dgi: float
    dgi_k: int | None = None
    dgi_random: float | None = None
    embedding_nn1_shape_accuracy: float | None = None
    embedding_mix_sil: float | None = None
    embedding_dgi: float | None = None


@dataclass(frozen=True, eq=False)
class DscanRecord(_Record):
    """AFOP-ML's D-scan: validation accuracy (mean, 95 % CI half-width) per candidate D."""

    kind: ClassVar[str] = "dscan"
    protocol: str
    fold: int | str | None
    D: list[int]
    mean: list[float]
    ci95: list[float]


@dataclass(frozen=True, eq=False)
class MetaCurveRecord(_Record):
    """A meta-learner's validation curve during ``fit`` (held-out training classes).

    step: the outer (meta-training) step of each point; accuracy: the validation accuracy
    there; meta_gradient: how the method states its meta-gradient (MAML:
    ``"first-order"``), None when it does not say.
    """

    kind: ClassVar[str] = "meta_curve"
    protocol: str
    fold: int | str | None
    method: str
    step: list[int]
    accuracy: list[float]
    meta_gradient: str | None


@dataclass(frozen=True, eq=False)
class StressRecord(_Record):
    """One stress-suite cell: a method's accuracy on one reading of one family at one
    severity (``family`` null and ``severity`` 0: the clean test set). ``kind`` is
    ``physical`` or ``sensor``, ``value`` the perturbation in ``unit``; ``reading`` is
    ``enrolled-at-nominal`` or ``all-perturbed``. Timing fields as an accuracy record's."""

    kind: ClassVar[str] = "stress"
    protocol: str
    family: str | None
    family_kind: str | None
    severity: int
    value: float | None
    unit: str | None
    reading: str
    method: str
    way: int
    shot: int
    query: int
    episodes: int
    accuracy: float
    ci95: float
    pretrain_s: float
    adapt_ms_per_episode: float


@dataclass(frozen=True, eq=False)
class StressFamilyRecord(_Record):
    """A method's scores on one stress family under one reading (docs/stress.md):
    ``mean_drop`` (accuracy, fraction), ``ce`` and ``relative_ce`` against ``reference``
    (null where undefined)."""

    kind: ClassVar[str] = "stress_family"
    protocol: str
    family: str
    reading: str
    method: str
    mean_drop: float
    ce: float | None
    relative_ce: float | None
    reference: str


@dataclass(frozen=True, eq=False)
class StressScoreRecord(_Record):
    """A method's stress scores over the families under one reading: clean accuracy,
    the mean and the worst family mean drop (with its family), ``mce`` and
    ``relative_mce`` against ``reference`` (docs/stress.md)."""

    kind: ClassVar[str] = "stress_score"
    protocol: str
    reading: str
    method: str
    clean: float
    mean_drop: float
    worst_drop: float
    worst_family: str
    mce: float | None
    relative_mce: float | None
    reference: str


#: Record kind -> its dataclass.
RECORD_TYPES: dict[str, type[_Record]] = {
    t.kind: t
    for t in (
        AccuracyRecord,
        SelectionRecord,
        TsneRecord,
        DscanRecord,
        MetaCurveRecord,
        StressRecord,
        StressFamilyRecord,
        StressScoreRecord,
    )
}
#: The record kinds this version writes (``record`` field).
RECORD_KINDS: tuple[str, ...] = tuple(RECORD_TYPES)
Record = (
    AccuracyRecord
    | SelectionRecord
    | TsneRecord
    | DscanRecord
    | MetaCurveRecord
    | StressRecord
    | StressFamilyRecord
    | StressScoreRecord
)


class CellScores(Protocol):
    """What an accuracy record is made of: the scores and timings of one cell's episodes
    (:class:`benchmark.evaluate.EvalResult` has them)."""

    episodes: int
    accuracy: float
    ci95: float
    batch_ms_per_episode: float
    latency_ms_per_episode: float | None
    latency_with_features_ms_per_episode: float | None
    latency_episodes: int


def accuracy_record(
    *,
    protocol: str,
    fold: int | str | None,
    condition: str | None,
    method: str,
    way: int,
    shot: int,
    query: int,
    result: CellScores,
    pretrain_s: float,
    feature_dim: int | None,
) -> AccuracyRecord:
    """One (protocol, fold, condition, method, way, shot) accuracy record of ``result``."""
    return AccuracyRecord(
        protocol=protocol,
        fold=_fold(fold),
        condition=condition,
        method=method,
        way=int(way),
        shot=int(shot),
        query=int(query),
        episodes=int(result.episodes),
        accuracy=float(result.accuracy),
        ci95=float(result.ci95),
        pretrain_s=float(pretrain_s),
        adapt_ms_per_episode=float(result.batch_ms_per_episode),
        latency_ms_per_episode=_opt_float(result.latency_ms_per_episode),
        latency_with_features_ms_per_episode=_opt_float(
            result.latency_with_features_ms_per_episode
        ),
        latency_episodes=int(result.latency_episodes),
        feature_dim=None if feature_dim is None else int(feature_dim),
    )


def selection_record(
    *,
    protocol: str,
    fold: int | str | None,
    D: int,
    pvdf_share: float,
    sg_share: float,
    selected: Sequence[int] | None = None,
) -> SelectionRecord:
    """AFOP-ML's chosen D, the PVDF/SG shares of its top-D features and the indices of
    those features (``selected``, ``D`` of them, when given)."""
    if selected is not None and len(selected) != int(D):
        raise ValueError(f"selected must hold D = {D} feature indices; got {len(selected)}")
    return SelectionRecord(
        protocol=protocol,
        fold=_fold(fold),
        D=int(D),
        pvdf_share=float(pvdf_share),
        sg_share=float(sg_share),
        selected=None if selected is None else [int(i) for i in selected],
    )


def tsne_record(
    *,
    protocol: str,
    D: int,
    nn1_shape_accuracy: float,
    mix_sil: float,
    dgi: float,
    dgi_k: int | None = None,
    dgi_random: float | None = None,
    embedding_nn1_shape_accuracy: float | None = None,
    embedding_mix_sil: float | None = None,
    embedding_dgi: float | None = None,
) -> TsneRecord:
    """The paper's indicators of the top-D feature space, and of the t-SNE embedding."""
    return TsneRecord(
        protocol=protocol,
        fold=None,
        D=int(D),
        nn1_shape_accuracy=float(nn1_shape_accuracy),
        mix_sil=float(mix_sil),
        dgi=float(dgi),
        dgi_k=None if dgi_k is None else int(dgi_k),
        dgi_random=_opt_float(dgi_random),
        embedding_nn1_shape_accuracy=_opt_float(embedding_nn1_shape_accuracy),
        embedding_mix_sil=_opt_float(embedding_mix_sil),
        embedding_dgi=_opt_float(embedding_dgi),
    )


def dscan_record(
    *,
    protocol: str,
    D: Sequence[int],
    mean: Sequence[float],
    ci95: Sequence[float],
    fold: int | str | None = None,
) -> DscanRecord:
    """AFOP-ML's D-scan: validation accuracy (mean and 95 % CI half-width) per candidate D."""
    if not len(D) == len(mean) == len(ci95):
        raise ValueError(
            f"D, mean and ci95 must have one entry per candidate; got {len(D)}, "
            f"{len(mean)} and {len(ci95)}"
        )
    return DscanRecord(
        protocol=protocol,
        fold=_fold(fold),
        D=[int(d) for d in D],
        mean=[float(x) for x in mean],
        ci95=[float(x) for x in ci95],
    )


def meta_curve_record(
    *,
    protocol: str,
    fold: int | str | None,
    method: str,
    curve: np.ndarray,
    meta_gradient: str | None,
) -> MetaCurveRecord:
    """The record of a fitted method's ``meta_curve_``: ``(n, 2)`` rows of (outer step,
    validation accuracy)."""
    c = np.asarray(curve, dtype=np.float64)
    if c.ndim != 2 or c.shape[1] != 2 or c.shape[0] < 1:
        raise ValueError(f"meta_curve_ must have shape (n >= 1, 2); got {c.shape}")
    return MetaCurveRecord(
        protocol=protocol,
        fold=_fold(fold),
        method=method,
        step=[int(s) for s in c[:, 0]],
        accuracy=[float(a) for a in c[:, 1]],
        meta_gradient=None if meta_gradient is None else str(meta_gradient),
    )


def from_dict(d: Mapping[str, Any]) -> Mapping[str, Any]:
    """The typed record of a results.json object; an object of a kind this version does
    not know stays a dict (readers skip what they do not know)."""
    kind = RECORD_TYPES.get(d.get("record"))  # type: ignore[arg-type]
    return dict(d) if kind is None else kind.from_dict(d)


def select(records: Iterable[Mapping[str, Any]], record: str, **match: Any) -> list[Any]:
    """The records of kind ``record`` whose fields equal every ``match`` value, in order.

    Works on typed records and on the plain dicts of a results.json alike.

    Parameters
    ----------
    records : iterable of mapping
        Records (:func:`read_results`, or what a run returns).
    record : str
        The kind: one of :data:`RECORD_KINDS` (``"accuracy"``, ``"selection"``...).
    **match
        Field values the records must have, e.g. ``protocol="cross-shape", fold=None``.
        A field a record lacks never matches (so ``fold=None`` does not match a record
        without ``fold``).

    Returns
    -------
    list
        The matching records, in their order.

    Examples
    --------
    >>> records = [
    ...     {"record": "accuracy", "protocol": "cross-shape", "fold": None, "way": 5},
    ...     {"record": "accuracy", "protocol": "cross-shape", "fold": 1, "way": 5},
    ...     {"record": "selection", "protocol": "cross-shape", "fold": None},
    ... ]
    >>> select(records, "accuracy", protocol="cross-shape", fold=None, way=5)
    [{'record': 'accuracy', 'protocol': 'cross-shape', 'fold': None, 'way': 5}]
    >>> len(select(records, "selection", way=5))
    0
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


def to_json(records: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """The JSON objects of ``records`` (typed or dicts): ``schema_version`` set (another
    version refused), non-finite floats as null."""
    return [_clean(_versioned(r)) for r in records]


def from_json(objects: Iterable[Mapping[str, Any]]) -> list[Mapping[str, Any]]:
    """Typed records of results.json objects (:func:`from_dict` each)."""
    return [from_dict(o) for o in objects]


def write_results(path: str | Path, records: Sequence[Mapping[str, Any]]) -> Path:
    """Write records as a JSON list, atomically (a reader never sees half a file); every
    record gets ``schema_version`` = :data:`SCHEMA_VERSION`, non-finite floats become null."""
    path = Path(path)
    payload = to_json(records)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(payload, indent=1) + "\n")
    os.replace(tmp, path)
    return path


def read_results(path: str | Path, *, typed: bool = False) -> list[Any]:
    """Load and check a results.json written by :func:`write_results`.

    Parameters
    ----------
    path : str or path-like
        The results.json file.
    typed : bool, default False
        Return the record dataclasses (:data:`RECORD_TYPES`; objects of kinds this
        version does not know stay dicts) instead of the plain JSON objects.

    Returns
    -------
    list
        The records, in file order.

    Raises
    ------
    FileNotFoundError, ValueError
        No such file; not a results.json list; a record of another schema version.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> record = selection_record(protocol="closed-set", fold=None, D=2, pvdf_share=0.5,
    ...                           sg_share=0.5, selected=[0, 200])
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = write_results(pathlib.Path(tmp) / "results.json", [record])
    ...     print(read_results(path, typed=True)[0].D, read_results(path)[0]["record"])
    2 selection
    """
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
    if not typed:
        return data
    try:
        return from_json(data)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{path}: {exc}") from None
