"""Cross-material generalisation (paper Section V-C, Fig. 5b), leave-one-material-in.

For each material: fit on its 12 classes (all shapes), evaluate N-way-1-shot (N = 2..12)
on the other two materials' 24 classes; ``fold`` is the training material. The engine
adds records across splits (``fold=None``) and AFOP-ML's selection per split.
"""

from __future__ import annotations

from synth import MATERIAL_NAMES, Dataset

from ..budget import EpisodeBudget
from ..engine import Protocol, Task
from ..splits import cross_material_splits
from .curves import check_splits, held, split_tasks


class CrossMaterial(Protocol):
    name = "cross-material"
    uses_reference = True

    def tasks(
        self, data: Dataset, perturbed: Dataset | None, *, seed: int, episodes: EpisodeBudget
    ) -> list[Task]:
        """One task per training material: fit on it, test on the other two."""
        splits = cross_material_splits(data)
        check_splits(
            self.name, splits, "materials", held(data.material, MATERIAL_NAMES), "all 3 materials"
        )
        return split_tasks(self.name, data, splits, seed=seed, episodes=episodes)
