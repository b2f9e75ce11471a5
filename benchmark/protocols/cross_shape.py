"""Cross-shape generalisation (paper Section V-C, Fig. 5a).

3 fixed folds (:data:`benchmark.splits.CROSS_SHAPE_FOLDS`): fit on the 8 training shapes
(all materials), evaluate N-way-1-shot (N = 2..12) on the 4 unseen shapes' 12 classes.
The engine adds records across folds (``fold=None``) and AFOP-ML's selection per fold.
"""

from __future__ import annotations

from shapes import SHAPE_NAMES
from synth import Dataset

from ..budget import EpisodeBudget
from ..engine import Protocol, Task
from ..splits import cross_shape_splits
from .curves import check_splits, held, split_tasks


class CrossShape(Protocol):
    name = "cross-shape"
    uses_reference = True

    def tasks(
        self, data: Dataset, perturbed: Dataset | None, *, seed: int, episodes: EpisodeBudget
    ) -> list[Task]:
        """One task per fold: fit on its 8 shapes, test on its 4 unseen shapes."""
        splits = cross_shape_splits(data)
        check_splits(self.name, splits, "shapes", held(data.shape, SHAPE_NAMES), "all 12 shapes")
        return split_tasks(self.name, data, splits, seed=seed, episodes=episodes)
