"""Cross-shape generalisation (paper Section V-C, Fig. 5a).

The paper's 3 fixed folds (:data:`benchmark.splits.CROSS_SHAPE_FOLDS`) on a dataset of its
12 shapes, otherwise the folds of :func:`benchmark.splits.specimen_folds`: fit on the
training specimens (all materials), evaluate N-way-1-shot (N = 2..12, as far as the test
classes go) on the unseen specimens' classes. The engine adds records across folds
(``fold=None``) and AFOP-ML's selection per fold.
"""

from __future__ import annotations

from synth import Dataset

from ..budget import EpisodeBudget
from ..labels import CROSS_SHAPE
from ..splits import cross_shape_splits
from ..tasks import Protocol, Task
from .curves import check_splits, split_tasks


class CrossShape(Protocol):
    name = CROSS_SHAPE
    uses_reference = True

    def tasks(
        self, data: Dataset, perturbed: Dataset | None, *, seed: int, episodes: EpisodeBudget
    ) -> list[Task]:
        """One task per fold: fit on its training specimens, test on its unseen ones."""
        splits = cross_shape_splits(data)
        check_splits(self.name, data, splits)
        return split_tasks(self.name, data, splits, seed=seed, episodes=episodes)
