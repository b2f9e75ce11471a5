"""Which fits a run needs: tasks that one fit of each method serves.

Within a set of tasks (one protocol's), consecutive tasks with the same ``fit_key``
share a fit (the perturbation protocol fits once and tests on every force/speed
condition); across sets, groups with the same ``fit_key``, fit seed and fit trials share
one too, each method fitted once for every set that asks for it (the perturbation
protocol tests the closed-set fit, the closed-set reference curve is the closed-set
AFOP-ML fit's). A method's fit seed is the task's, so results do not depend on the order
or subset of methods requested.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .methods import check_methods
from .tasks import Task


def fit_runs(tasks: Sequence[Task]) -> list[list[Task]]:
    """``tasks`` cut into runs of consecutive tasks that share one fit (the same non-None
    ``fit_key``; they must then have the same fit seed and methods)."""
    groups: list[list[Task]] = []
    for task in tasks:
        prev = groups[-1][0] if groups else None
        if prev is not None and task.fit_key is not None and task.fit_key == prev.fit_key:
            if task.fit_seed != prev.fit_seed or task.methods != prev.methods:
                raise ValueError(
                    f"tasks sharing fit_key {task.fit_key!r} differ in fit_seed or methods"
                )
            groups[-1].append(task)
        else:
            groups.append([task])
    return groups


@dataclass(frozen=True)
class Share:
    """The tasks of task set ``set_index`` that one fit serves, for each of ``methods``."""

    set_index: int
    tasks: tuple[Task, ...]
    methods: tuple[str, ...]


@dataclass(frozen=True)
class FitGroup:
    """Tasks, of one or several task sets, that one fit of each of ``methods`` serves
    (each share's tasks for the share's own methods, a subset of ``methods``)."""

    shares: tuple[Share, ...]
    methods: tuple[str, ...]

    @property
    def first(self) -> Task:
        return self.shares[0].tasks[0]

    def cells_of(self, name: str) -> int:
        """The cells the fit of method ``name`` is evaluated on."""
        return sum(
            len(t.grid) for share in self.shares if name in share.methods for t in share.tasks
        )


def same_fit(a: Task, b: Task) -> bool:
    """Whether tasks of different sets may share a fit: the same non-None ``fit_key`` and
    fit seed, and the very same fit trials."""
    return (
        a.fit_key is not None
        and a.fit_key == b.fit_key
        and a.fit_seed == b.fit_seed
        and a.fit.data is b.fit.data
        and np.array_equal(a.fit.index, b.fit.index)
    )


def plan_fits(
    task_sets: Sequence[Sequence[Task]], methods: Sequence[str]
) -> tuple[list[FitGroup], list[list[int]]]:
    """The fits that ``task_sets`` need: ``(groups, order)``, where ``order[i]`` lists the
    groups serving set ``i`` in that set's own order (sharing rules in the module
    docstring)."""
    methods = check_methods(methods)
    groups: list[FitGroup] = []
    order: list[list[int]] = []
    for i, tasks in enumerate(task_sets):
        order.append([])
        for members in fit_runs(tasks):
            head = members[0]
            chosen = methods if head.methods is None else check_methods(head.methods)
            share = Share(i, tuple(members), chosen)
            for g, group in enumerate(groups):
                if same_fit(group.first, head):
                    union = (*group.methods, *(m for m in chosen if m not in group.methods))
                    groups[g] = FitGroup((*group.shares, share), union)
                    order[i].append(g)
                    break
            else:
                groups.append(FitGroup((share,), chosen))
                order[i].append(len(groups) - 1)
    return groups, order
