"""The 1-shot N-way curves of the generalisation protocols (paper Section V-C, Fig. 5).

Every task's grid is 1-shot N-way for N = 2..12 (:data:`WAYS`); the episode seed of a
cell derives from ``(seed, protocol, task index, way)`` and a fit's seed from ``(seed,
protocol, task index, "fit")``, so the same episodes serve every method.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from synth import Dataset

from ..budget import EpisodeBudget
from ..engine import Cell, Pool, Task, child_seed
from ..splits import Split

#: The N of the paper's generalisation curves (Fig. 5): 2..12-way.
WAYS: tuple[int, ...] = tuple(range(2, 13))
SHOT: int = 1


def curve_grid(seed: int, protocol: str, task_index: int) -> tuple[Cell, ...]:
    """The 1-shot :data:`WAYS` cells of one task's curve."""
    return tuple(Cell(way, SHOT, child_seed(seed, protocol, task_index, way)) for way in WAYS)


def check_splits(
    protocol: str, splits: Sequence[Split], kind: str, have: Sequence[str], needs: str
) -> None:
    """Refuse, naming --data, a dataset in which a split has no training or no test trial
    (the engine cannot fit or test on nothing): the message names the ``kind`` (shapes,
    materials) that split needs, ``have`` (what the dataset holds) and ``needs`` (what the
    protocol needs)."""
    for s in splits:
        for side, mask, values in (
            ("trains", s.train, s.train_values),
            ("tests", s.test, s.test_values),
        ):
            if not mask.any():
                raise ValueError(
                    f"--data has no trial of the {kind} {', '.join(values)} that "
                    f"{protocol} split {s.fold} {side} on (--data holds "
                    f"{', '.join(have) or 'none'}); the {protocol} protocol needs {needs}"
                )


def split_tasks(
    protocol: str, data: Dataset, splits: Sequence[Split], *, seed: int, episodes: EpisodeBudget
) -> list[Task]:
    """One task per split of ``data``: fit on its training trials, a 1-shot curve on its
    test trials; ``fold`` is the split's fold (:func:`check_splits` first)."""
    return [
        Task(
            protocol=protocol,
            fold=s.fold,
            condition=None,
            fit=Pool(data, np.flatnonzero(s.train)),
            test=Pool(data, np.flatnonzero(s.test)),
            grid=curve_grid(seed, protocol, i),
            episodes=episodes,
            fit_seed=child_seed(seed, protocol, i, "fit"),
        )
        for i, s in enumerate(splits)
    ]
