"""Closed-set protocol (paper Section V-A/B, Table I) and the closed-set reference curve.

The 36 classes are split 50:50 per class (seeded, :func:`benchmark.splits.split_halves`);
each method is fitted once on the training half; N-way K-shot episodes are drawn from the
test half only, for the paper's columns (1-shot 5/10/12/28/36-way, 3-shot 5/12/36,
5-shot 5/12/36). The same episodes (same seeds) serve every method. The 5-way-5-shot
column also times :data:`LATENCY_EPISODES` episodes one at a time (the paper's Table I
"Adapt/episode" measure); the other columns record only the batched throughput.

:class:`Reference` is the closed-set AFOP-ML 1-shot 2..12-way curve on the same halves
(``condition="reference"``), the dashed line the generalisation protocols are read
against (paper Fig. 5). Its task carries the closed-set fit key and fit seed, so a run
that has both evaluates the curve on the closed-set AFOP-ML fit itself.
"""

from __future__ import annotations

import numpy as np

from synth import Dataset

from ..budget import EpisodeBudget
from ..labels import CLOSED_SET, REFERENCE
from ..paper_reference import TABLE_ONE_COLUMNS
from ..splits import split_halves
from ..tasks import Cell, Pool, Protocol, Task, child_seed, n_query_for
from .curves import curve_grid

__all__ = ["TABLE_ONE_COLUMNS", "ClosedSet", "Reference", "columns_for", "split_halves"]

PROTOCOL = CLOSED_SET
#: Episodes of the 5-way-5-shot column also adapted one at a time.
LATENCY_EPISODES = 10


#: The fit key of the closed-set training half: the perturbation protocol's and the
#: reference curve's tasks carry it too, so a run fits each method once on that half and
#: tests every one of them on the fit.
FIT_KEY = "closed-set training half"


def fit_seed(seed: int) -> int:
    """The seed of every closed-set fit (the perturbation protocol reuses the fit)."""
    return child_seed(seed, PROTOCOL, "fit")


def columns_for(labels: np.ndarray) -> list[tuple[int, int, int]]:
    """The Table I columns ``(shot, way, query)`` this test pool can hold (query per class
    lowered when classes are small; columns needing more classes or trials are left out)."""
    out = []
    for shot, way in TABLE_ONE_COLUMNS:
        q = n_query_for(labels, way, shot)
        if q >= 1:
            out.append((shot, way, q))
    return out


class ClosedSet(Protocol):
    name = PROTOCOL

    def tasks(
        self, data: Dataset, perturbed: Dataset | None, *, seed: int, episodes: EpisodeBudget
    ) -> list[Task]:
        """One task: fit on the training half, the Table I columns on the test half."""
        train, test = split_halves(data.label, seed=seed)
        if not columns_for(data.label[test]):
            raise ValueError(
                "the dataset's test half is too small for any Table I column (needs >= 5 "
                "classes with >= 2 test trials each)"
            )
        grid = tuple(
            Cell(
                way,
                shot,
                child_seed(seed, PROTOCOL, way, shot),
                LATENCY_EPISODES if (shot, way) == (5, 5) else 0,
            )
            for shot, way in TABLE_ONE_COLUMNS
        )
        return [
            Task(
                protocol=PROTOCOL,
                fold=None,
                condition=None,
                fit=Pool(data, train),
                test=Pool(data, test),
                grid=grid,
                episodes=episodes,
                fit_seed=fit_seed(seed),
                fit_key=FIT_KEY,
            )
        ]


class Reference(Protocol):
    """AFOP-ML fitted on the closed-set training half with the closed-set fit seed (the
    closed-set fit, shared when the closed-set or perturbation protocol runs in the same
    queue of fits), 1-shot 2..12-way on the test half, ``episodes.default`` episodes per
    way whatever the requested methods; its share of the fit gives no selection record
    (the closed-set protocol's own share does)."""

    name = "closed-set reference"

    def tasks(
        self, data: Dataset, perturbed: Dataset | None, *, seed: int, episodes: EpisodeBudget
    ) -> list[Task]:
        train, test = split_halves(data.label, seed=seed)
        return [
            Task(
                protocol=PROTOCOL,
                fold=None,
                condition=REFERENCE,
                fit=Pool(data, train),
                test=Pool(data, test),
                grid=curve_grid(seed, PROTOCOL, 0),
                episodes=EpisodeBudget(episodes.default),
                fit_seed=fit_seed(seed),
                fit_key=FIT_KEY,
                methods=("AFOP-ML",),
                fit_records=False,
            )
        ]
