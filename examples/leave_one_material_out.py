"""A complete user protocol: leave one material out.

For each material: fit every method on the other two materials' classes (all shapes),
then evaluate 1-shot 2..5-way episodes drawn only from the left-out material's 12
classes. ``fold`` is the left-out material; the engine adds the records pooled over the
folds (``fold: null``) and AFOP-ML's selection per fold. Run it with

    tactile-synth benchmark examples/leave_one_material_out.py:LeaveOneMaterialOut \\
        --data PATH --out DIR --methods AFOP-ML --episodes 100

(see docs/protocols.md).
"""

from __future__ import annotations

import numpy as np

from benchmark import Cell, EpisodeBudget, Pool, Protocol, Task, child_seed
from synth import Dataset


class LeaveOneMaterialOut(Protocol):
    name = "leave-one-material-out"

    def tasks(
        self, data: Dataset, perturbed: Dataset | None, *, seed: int, episodes: EpisodeBudget
    ) -> list[Task]:
        tasks = []
        for i, material in enumerate(data.materials):
            left_out = data.material == material
            if not left_out.any() or left_out.all():
                continue  # nothing to test on, or nothing to fit on
            tasks.append(
                Task(
                    protocol=self.name,
                    fold=material,
                    condition=None,
                    fit=Pool(data, np.flatnonzero(~left_out)),
                    test=Pool(data, np.flatnonzero(left_out)),
                    # Episode seeds depend on the run's seed, the protocol, task and cell
                    # only, so every method sees the same episodes.
                    grid=tuple(
                        Cell(way=n, shot=1, seed=child_seed(seed, self.name, i, n))
                        for n in (2, 3, 4, 5)
                    ),
                    episodes=episodes,
                    fit_seed=child_seed(seed, self.name, i, "fit"),
                )
            )
        return tasks
