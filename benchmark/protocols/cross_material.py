"""Cross-material generalisation (paper Section V-C, Fig. 5b), leave-one-material-in.

For each material of the dataset: fit on its classes (all shapes), evaluate N-way-1-shot
(N = 2..12) on the other materials' classes; ``fold`` is the training material. The
paper's dataset: fit on 12 classes, test on 24. The engine
adds records across splits (``fold=None``) and AFOP-ML's selection per split.
"""

from __future__ import annotations

from synth import Dataset

from ..budget import EpisodeBudget
from ..labels import CROSS_MATERIAL
from ..splits import cross_material_splits
from ..tasks import Protocol, Task
from .curves import check_splits, split_tasks


class CrossMaterial(Protocol):
    name = CROSS_MATERIAL
    uses_reference = True

    def tasks(
        self, data: Dataset, perturbed: Dataset | None, *, seed: int, episodes: EpisodeBudget
    ) -> list[Task]:
        """One task per training material: fit on it, test on the others."""
        splits = cross_material_splits(data)
        check_splits(self.name, data, splits)
        return split_tasks(self.name, data, splits, seed=seed, episodes=episodes)
