"""Loading a store into a :class:`synth.Dataset`, every chunk and per-trial array checked."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..dataset import Dataset
from ..trial import CHANNELS, CLASS_NAMES, N_SAMPLES
from .errors import DatasetError, DatasetIncomplete
from .meta import DatasetDamaged
from .reader import Store


def load_dataset(path: str | Path, *, allow_incomplete: bool = False) -> Dataset:
    """Read a store into a :class:`Dataset` (signals float32 ``(n, 4, T)``), checking
    every chunk it reads and the per-trial arrays (:class:`DatasetDamaged` if any fails).

    An incomplete store (an interrupted generation) raises ``DatasetError`` unless
    ``allow_incomplete``, in which case only the finished chunks' trials are returned.
    """
    store = Store.open(path)
    path = store.path
    done, problems = store.status()
    if not done.all() and not allow_incomplete and not problems:
        raise DatasetIncomplete(
            f"dataset {path} is incomplete ({int(done.sum())}/{done.size} chunks done)",
            store.finish_advice(),
            "load it with allow_incomplete=True",
        )
    problems += store.check_plan()
    chunks, chunk_problems, whole = store._read_chunks(np.flatnonzero(done))
    problems += chunk_problems
    if problems:
        raise DatasetDamaged(path, problems)
    classes = tuple(store.meta["classes"])
    if classes != CLASS_NAMES:
        raise DatasetError(f"dataset {path} lists classes that differ from synth.CLASS_NAMES")
    rows = np.zeros(store.n_trials, dtype=bool)
    for k in chunks:
        rows[store.rows(k)] = True
    if whole is not None:
        signals = whole  # every chunk read at once and verified: no copy
    else:
        signals = (
            np.concatenate([chunks[k] for k in sorted(chunks)])
            if chunks
            else np.zeros((0, len(CHANNELS), N_SAMPLES), np.float32)
        )
    trials = store.plan
    label = trials.label[rows]
    names = np.array(classes)[label.astype(np.intp)]
    attrs = dict(store.meta)
    attrs["complete"] = bool(done.all())
    return Dataset(
        signals=signals,
        shape=np.array([s.split("/")[0] for s in names], dtype=str),
        material=np.array([s.split("/")[1] for s in names], dtype=str),
        label=label.astype(np.int64),
        force_n=trials.force_n[rows],
        speed_mm_s=trials.speed_mm_s[rows],
        seed=trials.seed[rows],
        classes=classes,
        attrs=attrs,
    )
