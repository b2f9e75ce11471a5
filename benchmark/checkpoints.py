"""Resumable runs: each finished protocol's records in ``DIR/checkpoints/<protocol>.json``,
and each finished fit of the protocols still running in ``DIR/checkpoints/fits/``.

A checkpoint is ``{"key": ..., "records": [...]}``: the key is a SHA-256 of everything
that determines the records (dataset fingerprints, methods and their settings, the
package version, the source files of plug-in methods and protocols, episode budget,
seed, protocol) and of :data:`LAYOUT`, so a re-run with
the same inputs reuses them and any change recomputes.
Records are written and read through :mod:`benchmark.results` (schema version checked,
typed on load); a damaged or foreign file counts as no checkpoint.

A fit checkpoint (:class:`FitCheckpoints`) holds one method's results on one fit group
(:class:`benchmark.fit_groups.FitGroup`) under a key made of the keys of the protocols its
shares belong to, their tasks and the method: an interrupted run continues with the fits
that were not finished. Once every protocol of a run is checkpointed they are deleted.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from synth import Dataset

from .fits import FitResult
from .results import from_json, to_json

if TYPE_CHECKING:
    from .fit_groups import FitGroup

T = TypeVar("T")

#: Top-level packages of tactile-synth: the package version covers their classes' code.
OWN_PACKAGES = frozenset({"shapes", "synth", "models", "benchmark", "tactile_synth"})

#: Version of what a checkpoint's records hold (AFOP-ML's selection records with their
#: selected features, a dscan record per AFOP-ML fit, the reference curve on the
#: closed-set fit, the across-condition summaries of protocols testing force/speed
#: conditions per reading, the perturbation protocol's enrolment reading), part of the
#: key: raise it when that changes, so that a resumed run recomputes checkpoints that
#: lack what it reads.
LAYOUT: int = 4


def fingerprint(data: Dataset) -> str:
    """SHA-256 of a dataset's arrays (signals, labels, conditions, seeds): 16 hex chars."""
    h = hashlib.sha256()
    for arr in (data.signals, data.label, data.force_n, data.speed_mm_s, data.seed):
        a = np.ascontiguousarray(arr)
        h.update(str(a.dtype).encode() + str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()[:16]


def method_settings(
    methods: Sequence[str], options: Mapping[str, Mapping[str, Any]] | None = None
) -> dict[str, dict[str, Any]]:
    """What each method is built with: the public scalar attributes of a new instance
    built with its ``options`` (hyper-parameters, tuned defaults included), for the
    checkpoint key, so that a run after a retuning or a change to a plug-in's settings does
    not reuse results made with other ones. Values that are not JSON scalars are keyed by
    their ``repr``."""
    from models.registry import make_method

    options = options or {}
    out: dict[str, dict[str, Any]] = {}
    for name in methods:
        attrs = vars(make_method(name, seed=0, **options.get(name, {})))
        out[name] = {
            k: v if isinstance(v, (bool, int, float, str, type(None))) else repr(v)
            for k, v in sorted(attrs.items())
            if not k.startswith("_")
            and not k.endswith("_")  # fitted state (none yet)
            and isinstance(v, (bool, int, float, str, type(None), tuple))
        }
    return out


def option_files(options: Mapping[str, Mapping[str, Any]] | None) -> dict[str, str]:
    """``"METHOD:NAME"`` -> SHA-256 (16 hex chars) of the file a method option names (a
    weights file), for the checkpoint key: a run with another file's contents at the same
    path recomputes."""
    out = {}
    for method, params in (options or {}).items():
        for name, value in params.items():
            if isinstance(value, str) and value and os.path.isfile(value):
                digest = hashlib.sha256(Path(value).read_bytes()).hexdigest()[:16]
                out[f"{method}:{name}"] = digest
    return out


def source_hash(cls: type) -> str | None:
    """SHA-256 (16 hex chars) of the bytes of the file that defines ``cls``, for the
    checkpoint key of a plug-in method or protocol, so that a run after an edit to its
    code recomputes; None for tactile-synth's own classes (the package version in the key
    covers their code) and for a class without a source file."""
    module = sys.modules.get(cls.__module__)
    if cls.__module__.split(".")[0] in OWN_PACKAGES or module is None:
        return None
    path = getattr(module, "__file__", None)
    if path is None or not os.path.isfile(path):
        return None
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]


def method_sources(methods: Sequence[str]) -> dict[str, str]:
    """Method name -> :func:`source_hash` of its class, for every plug-in method."""
    from models.registry import method_class

    hashes = {name: source_hash(method_class(name)) for name in methods}
    return {name: h for name, h in hashes.items() if h is not None}


def key(inputs: Mapping[str, Any]) -> str:
    """The checkpoint key of ``inputs`` (a JSON-serialisable mapping) under :data:`LAYOUT`."""
    payload = {"inputs": dict(inputs), "layout": LAYOUT}
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()


def _path(out: Path, protocol: str) -> Path:
    # A plug-in protocol's name may be a path or module:Class spec.
    return Path(out) / "checkpoints" / (re.sub(r"[^A-Za-z0-9._-]+", "_", protocol) + ".json")


def _read(path: Path, key: str, field: str, decode: Callable[[Any], T]) -> T | None:
    """``decode`` of the ``field`` of the checkpoint file ``path`` written under ``key``;
    None when there is none, it is damaged or foreign, or it was written under another
    key."""
    if not path.is_file():
        return None
    try:
        saved = json.loads(path.read_text())
        if not isinstance(saved, dict) or saved.get("key") != key:
            return None
        return decode(saved[field])
    except (json.JSONDecodeError, KeyError, TypeError, ValueError):
        return None


def _write(path: Path, key: str, field: str, value: Any) -> None:
    """Write ``{"key": key, field: value}`` to ``path``, atomically."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps({"key": key, field: value}))
    tmp.replace(path)


def load(out: Path, protocol: str, key: str) -> list | None:
    """The typed records saved for ``protocol`` under ``key``, or None."""
    return _read(_path(out, protocol), key, "records", from_json)


def save(out: Path, protocol: str, key: str, records: Sequence[Mapping[str, Any]]) -> None:
    """Save ``records`` of ``protocol`` under ``key``, atomically."""
    _write(_path(out, protocol), key, "records", to_json(records))


class FitCheckpoints:
    """Finished fits in ``out/checkpoints/fits/``, for :func:`benchmark.engine.run_task_sets`
    (``fit_cache``). ``set_keys[i]`` is the checkpoint key of the protocol of task set
    ``i``: a fit's key hashes those of the sets its group serves, the names and fit trials
    of their tasks, the methods of each share and the method fitted, so a fit is found
    again only by a run that asks for the very same fit."""

    def __init__(self, out: Path, set_keys: Sequence[str]) -> None:
        self.directory = Path(out) / "checkpoints" / "fits"
        self.set_keys = list(set_keys)

    def _key(self, group: FitGroup, name: str) -> str:
        shares = [
            {
                "set": self.set_keys[share.set_index],
                "tasks": [t.name for t in share.tasks],
                "fit": [
                    hashlib.sha256(np.ascontiguousarray(t.fit.index).tobytes()).hexdigest()[:16]
                    for t in share.tasks
                ],
                "methods": list(share.methods),
            }
            for share in group.shares
        ]
        return key({"fit": name, "shares": shares})

    def _path(self, fit_key: str) -> Path:
        return self.directory / f"{fit_key[:32]}.json"

    def load(self, group: FitGroup, name: str) -> FitResult | None:
        """The results saved for ``name`` on ``group``, or None (none, damaged, or saved
        under another key)."""
        fit_key = self._key(group, name)
        result = _read(self._path(fit_key), fit_key, "result", FitResult.from_obj)
        if result is None or len(result.shares) != len(group.shares):
            return None
        return result

    def save(self, group: FitGroup, name: str, result: FitResult) -> None:
        """Save ``result`` of ``name`` on ``group``, atomically."""
        fit_key = self._key(group, name)
        _write(self._path(fit_key), fit_key, "result", result.to_obj())

    def clear(self) -> None:
        """Delete every fit checkpoint (the protocols they served are checkpointed)."""
        shutil.rmtree(self.directory, ignore_errors=True)
