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
from ..splits import NotApplicable, Split
from ..tasks import Cell, Pool, Task, child_seed

#: The N of the paper's generalisation curves (Fig. 5): 2..12-way.
WAYS: tuple[int, ...] = tuple(range(2, 13))
SHOT: int = 1


def curve_grid(seed: int, protocol: str, task_index: int) -> tuple[Cell, ...]:
    """The 1-shot :data:`WAYS` cells of one task's curve."""
    return tuple(Cell(way, SHOT, child_seed(seed, protocol, task_index, way)) for way in WAYS)


def check_splits(protocol: str, data: Dataset, splits: Sequence[Split]) -> None:
    """Refuse, as not applicable to ``data``, splits a method cannot be fitted on or tested
    on: each side of every split needs trials of at least 2 classes (a fit learns to tell
    classes apart; the smallest episode is 2-way). The message says what the dataset
    holds."""
    for s in splits:
        for side, mask in (("trains", s.train), ("tests", s.test)):
            names = sorted({data.classes[i] for i in np.unique(data.label[mask])})
            if len(names) < 2:
                raise NotApplicable(
                    f"{protocol} needs >= 2 classes on each side of every split; split "
                    f"{s.fold} {side} on {len(names)} ({', '.join(names) or 'none'}) of this "
                    f"dataset's {len(data.specimens)} specimen(s) x {len(data.materials)} "
                    f"material(s)"
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
