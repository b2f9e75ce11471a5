"""Loading a store into a :class:`synth.Dataset`, every chunk and per-trial array checked."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..dataset import Dataset
from ..trial import CHANNELS, N_SAMPLES
from .errors import DatasetIncomplete
from .meta import DatasetDamaged
from .reader import Store


def load_dataset(path: str | Path, *, allow_incomplete: bool = False) -> Dataset:
    """Read a store into a :class:`Dataset`, checking every chunk it reads against its
    checksum and the per-trial arrays against the stored configuration.

    Parameters
    ----------
    path : str or pathlib.Path
        A dataset store written by ``tactile-synth generate`` (:func:`synth.generate`) or
        ``tactile-synth import``.
    allow_incomplete : bool, default False
        Return the finished chunks' trials of an interrupted generation instead of
        raising :class:`DatasetIncomplete`.

    Returns
    -------
    Dataset
        ``signals`` float32 ``(n, 4, 2000)`` and the aligned per-trial arrays; ``label``
        indexes ``classes``, the store's own class list (``"<specimen>/<material>"``);
        ``attrs`` holds the provenance (versions, configuration, creation time).

    Raises
    ------
    DatasetDamaged
        A chunk or per-trial array fails its check (the message names the file and the
        repair command).
    DatasetError
        Not a dataset, another format version, or incomplete (one line saying what to run).

    Examples
    --------
    >>> import tempfile, synth
    >>> grid = synth.PRESETS["quick"].replace(
    ...     shapes=("circle", "square"), materials=("wood",), trials_per_class=2
    ... )
    >>> path = synth.generate(grid, tempfile.mkdtemp() + "/ds", progress=False)
    >>> data = synth.load_dataset(path)
    >>> data.signals.shape, data.class_names
    ((4, 4, 2000), ('circle/wood', 'square/wood'))
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
    classes = store.classes  # checked by Store.open; the labels by check_plan
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
