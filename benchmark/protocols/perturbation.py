"""Force/speed perturbation (paper Section V-C, Fig. 5c) and the robustness heat maps.

Every method is fitted once on the nominal dataset's closed-set training half (the
closed-set protocol's split and fit seed, reused: the paper trains "at nominal force and
speed on the original training set"), then evaluated N-way-1-shot (N = 2..12) on the
perturbation dataset. The paper's "testing on multiple perturbed force-speed
combinations" allows more than one reading of where an episode's support and queries
come from; all three are run, side by side, none promoted:

- **within condition**: per force/speed combination
  (``condition="force=1.4N,speed=6mm/s"``), support and queries from that combination;
  the engine adds the across-condition summary ``condition="within-condition"`` (every
  combination's episodes together);
- **pooled**: all the perturbation dataset's trials as one test pool
  (``condition="pooled"``): an episode's support and queries may come from different
  combinations;
- **enrolled at nominal**: the deployment reading, a class enrolled at the nominal
  condition and recognised under perturbation: the support examples come from the
  nominal dataset's closed-set test half (trials no method was fitted on), the queries
  from one perturbed combination, classes matched by name
  (``condition="enrolled:force=1.4N,speed=6mm/s"``, the engine's enrolment tasks:
  :attr:`benchmark.tasks.Task.support`); the engine adds ``condition="enrolled"`` over
  every combination's episodes together.

The 5-way-1-shot per-combination records form the force x speed heat maps (within
condition, and enrolled at nominal). ``fold`` is null. One AFOP-ML selection record (the
nominal fit). Its tasks carry the closed-set task's fit key, so a command that runs both
protocols fits each method once for the two.

The "Force&Speed" D of this protocol (paper Fig. 6) is therefore the closed-set D: the fit
is the closed-set fit, and its D-scan sees only nominal training trials (drawing
validation episodes from the perturbed conditions would train on the test conditions).
The report says so next to the value.
"""

from __future__ import annotations

import numpy as np

from synth import Dataset

from ..budget import EpisodeBudget
from ..guards import check_perturbation_pair
from ..labels import ENROLLED, PERTURBATION, POOLED, READING_SEPARATOR, READINGS
from ..splits import condition_name, split_halves
from ..tasks import Pool, Protocol, Task, n_query_for
from .closed_set import FIT_KEY, fit_seed
from .curves import SHOT, WAYS, curve_grid

__all__ = ["ENROLLED", "POOLED", "READINGS", "Perturbation", "conditions"]

PROTOCOL = PERTURBATION


def conditions(perturbed: Dataset) -> list[tuple[float, float]]:
    """The (force_n, speed_mm_s) combinations present, sorted by force then speed."""
    pairs = {
        (float(f), float(s)) for f, s in zip(perturbed.force_n, perturbed.speed_mm_s, strict=True)
    }
    return sorted(pairs)


def _check_episodes_fit(perturbed: Dataset, tests: list[np.ndarray]) -> None:
    """Refuse a perturbation dataset from which no test pool can draw a single episode of
    the curve (its smallest cell: :data:`WAYS`'s first N classes with ``SHOT + 1`` trials
    each, one of them a query), naming --perturbed and what it holds; a run would
    otherwise write a report without perturbation results."""
    way, need = WAYS[0], SHOT + 1
    if any(n_query_for(perturbed.label[idx], way, SHOT) >= 1 for idx in tests):
        return
    most = max(int(np.unique(perturbed.label[idx], return_counts=True)[1].max()) for idx in tests)
    raise ValueError(
        f"--perturbed is too small for any perturbation episode: one needs at least {way} "
        f"classes with {need} trials per class in one force/speed condition (or {need} per "
        f"class over all conditions), and it holds {np.unique(perturbed.label).size} "
        f"class(es) with at most {most} trial(s) each"
    )


class Perturbation(Protocol):
    name = PROTOCOL
    needs_perturbed = True
    uses_reference = True

    def tasks(
        self, data: Dataset, perturbed: Dataset | None, *, seed: int, episodes: EpisodeBudget
    ) -> list[Task]:
        """One task per force/speed condition, the pooled one, then one enrolment task per
        condition; all share one fit."""
        if perturbed is None or len(perturbed) == 0:
            raise ValueError("the perturbation protocol needs a non-empty perturbed dataset")
        check_perturbation_pair(data, perturbed, seeds=False)
        train, nominal_test = split_halves(data.label, seed=seed)
        fit = Pool(data, train)
        tests = [
            (
                condition_name(f, s),
                np.flatnonzero((perturbed.force_n == f) & (perturbed.speed_mm_s == s)),
            )
            for f, s in conditions(perturbed)
        ]
        per_condition = list(tests)
        tests.append((POOLED, np.arange(len(perturbed))))
        _check_episodes_fit(perturbed, [idx for _, idx in tests])
        tasks = [
            Task(
                protocol=PROTOCOL,
                fold=None,
                condition=condition,
                fit=fit,
                test=Pool(perturbed, idx),
                grid=curve_grid(seed, PROTOCOL, i),
                episodes=episodes,
                fit_seed=fit_seed(seed),
                fit_key=FIT_KEY,
            )
            for i, (condition, idx) in enumerate(tests)
        ]
        enrolment = Pool(data, nominal_test)
        tasks += [
            Task(
                protocol=PROTOCOL,
                fold=None,
                condition=f"{ENROLLED}{READING_SEPARATOR}{condition}",
                fit=fit,
                test=Pool(perturbed, idx),
                grid=curve_grid(seed, PROTOCOL, len(tests) + i),
                episodes=episodes,
                fit_seed=fit_seed(seed),
                fit_key=FIT_KEY,
                support=enrolment,
            )
            for i, (condition, idx) in enumerate(per_condition)
        ]
        return tasks
