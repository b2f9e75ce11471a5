"""The task types every protocol builds and the engine runs: the bottom layer of
``benchmark``.

A protocol (:class:`Protocol`) is only a generator of :class:`Task` objects from the
datasets. A task carries everything the engine (:mod:`benchmark.engine`) needs: the
trials methods are fitted on and the trials episodes are drawn from (:class:`Pool`), its
grid of N-way K-shot cells (:class:`Cell`, each with its own episode seed), its episode
budget, its fit seed and the labels its records carry (protocol, fold, condition).

Seeds derive from the run's seed and names (:func:`child_seed`), never from the methods,
so the same episodes serve every method. Cell rule: queries per class are
:data:`N_QUERY`, fewer when the N-th most populous test class is small
(:func:`n_query_for`).

Enrolment: a task may carry a separate ``support`` pool (:attr:`Task.support`). Its
episodes then draw their support examples from that pool and their queries from the
test pool, classes matched by name across the two datasets: a class is enrolled in one
setting and recognised in another.

Examples
--------
A protocol that fits on the first half of every class's trials and tests 2-way 1-shot
on the rest:

>>> import numpy as np
>>> from benchmark.budget import EpisodeBudget
>>> from benchmark.tasks import Cell, Pool, Protocol, Task, child_seed
>>> class Halves(Protocol):
...     name = "halves"
...     def tasks(self, data, perturbed, *, seed, episodes):
...         first = np.flatnonzero(np.arange(len(data)) % 2 == 0)
...         rest = np.flatnonzero(np.arange(len(data)) % 2 == 1)
...         cell = Cell(way=2, shot=1, seed=child_seed(seed, self.name, 2))
...         yield Task(protocol=self.name, fold=None, condition=None,
...                    fit=Pool(data, first), test=Pool(data, rest), grid=(cell,),
...                    episodes=episodes, fit_seed=child_seed(seed, self.name, "fit"))
>>> from tests.synthetic_data import make_dataset
>>> data = make_dataset(trials_per_class=4, n_samples=64)
>>> (task,) = Halves().tasks(data, None, seed=0, episodes=EpisodeBudget(3))
>>> task.fit.index.size, task.test.labels.size
(72, 72)
"""

from __future__ import annotations

import zlib
from abc import ABC, abstractmethod
from collections.abc import Hashable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from .budget import EpisodeBudget

if TYPE_CHECKING:
    from synth import Dataset

__all__ = ["N_QUERY", "Cell", "Pool", "Protocol", "Task", "child_seed", "n_query_for"]

#: Queries per class per episode (upper bound; lowered when a test pool is too small).
#: The paper does not state it; 5 keeps 36-way-5-shot episodes inside the 30 test trials
#: per class of the paper preset.
N_QUERY: int = 5


def child_seed(seed: int, *keys: int | str) -> int:
    """A 32-bit seed derived from ``seed`` and ``keys`` (strings hashed with CRC32).

    Parameters
    ----------
    seed : int
        The run's seed.
    *keys : int or str
        Names of what the seed is for (protocol, fold, way, ``"fit"``...).

    Examples
    --------
    >>> child_seed(0, "closed-set", "fit") == child_seed(0, "closed-set", "fit")
    True
    >>> child_seed(0, "closed-set", 5) == child_seed(0, "closed-set", 6)
    False
    """
    words = [seed] + [k if isinstance(k, int) else zlib.crc32(str(k).encode()) for k in keys]
    return int(np.random.SeedSequence(words).generate_state(1)[0])


def n_query_for(labels: np.ndarray, n_way: int, k_shot: int = 1) -> int:
    """Queries per class: :data:`N_QUERY`, fewer if the N-th most populous class of the
    pool has fewer than ``k_shot + N_QUERY`` trials. 0 means N-way is impossible.

    Examples
    --------
    >>> n_query_for(np.repeat([0, 1, 2], 4), n_way=2, k_shot=1)
    3
    >>> n_query_for(np.repeat([0, 1], 4), n_way=3)
    0
    """
    counts = np.sort(np.unique(labels, return_counts=True)[1])[::-1]
    if counts.size < n_way:
        return 0
    return int(max(0, min(N_QUERY, counts[n_way - 1] - k_shot)))


@dataclass(frozen=True)
class Pool:
    """Trials ``index`` of dataset ``data``.

    Parameters
    ----------
    data : synth.Dataset
        The dataset the trials belong to.
    index : numpy.ndarray
        Non-empty 1-D integer indices of the trials into ``data`` (stored as ``intp``).

    Attributes
    ----------
    labels : numpy.ndarray
        The class ids ``(n,)`` of the pool's trials.

    Examples
    --------
    >>> from tests.synthetic_data import make_dataset
    >>> data = make_dataset(trials_per_class=2, n_samples=64)
    >>> Pool(data, np.array([0, 1, 2])).labels.tolist()
    [0, 0, 1]
    """

    data: Dataset
    index: np.ndarray

    def __post_init__(self) -> None:
        idx = np.asarray(self.index)
        if idx.ndim != 1 or idx.size == 0 or not np.issubdtype(idx.dtype, np.integer):
            raise ValueError(f"a pool needs a non-empty 1-D integer index; got {idx.shape}")
        object.__setattr__(self, "index", idx.astype(np.intp, copy=False))

    @property
    def labels(self) -> np.ndarray:
        return self.data.label[self.index]


@dataclass(frozen=True)
class Cell:
    """One N-way K-shot point of a task's grid.

    Parameters
    ----------
    way : int
        Classes per episode (N).
    shot : int
        Support examples per class (K).
    seed : int
        The seed its episodes are drawn with (the same for every method).
    latency_episodes : int, default 0
        The first this many episodes are also adapted one at a time (single-episode
        latency, see :mod:`benchmark.evaluate`).

    Examples
    --------
    >>> Cell(5, 1, seed=child_seed(0, "closed-set", 5, 1))  # doctest: +ELLIPSIS
    Cell(way=5, shot=1, seed=..., latency_episodes=0)
    """

    way: int
    shot: int
    seed: int
    latency_episodes: int = 0


@dataclass(frozen=True)
class Task:
    """One fit/test task of a protocol.

    Parameters
    ----------
    protocol, fold, condition : str; int, str or None; str or None
        The names its records carry.
    fit : Pool
        The trials the methods are fitted on.
    test : Pool
        The trials the episodes are drawn from (their queries, with ``support``).
    grid : tuple of Cell
        The cells evaluated.
    episodes : benchmark.budget.EpisodeBudget
        Episodes per cell (per method).
    fit_seed : int
        The seed each method is built with.
    fit_key : hashable or None, default None
        Consecutive tasks with the same non-None key share the first one's fit (and
        task sets of one run share fits with the same key, seed and trials).
    methods : tuple of str or None, default None
        The methods of this task whatever the run requests (None: the requested ones).
    fit_records : bool, default True
        Whether its fits give the records of what the method exposes
        (:meth:`models.base.FewShotMethod.fit_details`).
    support : Pool or None, default None
        The enrolment pool the episodes' support examples are drawn from (queries from
        ``test``, classes matched by name; None: support and queries both from ``test``).

    Attributes
    ----------
    name : str
        Fold or condition, for progress bars.

    Examples
    --------
    >>> from benchmark.budget import EpisodeBudget
    >>> from tests.synthetic_data import make_dataset
    >>> data = make_dataset(trials_per_class=4, n_samples=64)
    >>> half = np.arange(len(data)) % 2
    >>> task = Task(protocol="demo", fold=0, condition=None,
    ...             fit=Pool(data, np.flatnonzero(half == 0)),
    ...             test=Pool(data, np.flatnonzero(half == 1)),
    ...             grid=(Cell(2, 1, seed=1),), episodes=EpisodeBudget(10), fit_seed=7)
    >>> task.name
    '0'
    """

    protocol: str
    fold: int | str | None
    condition: str | None
    fit: Pool
    test: Pool
    grid: tuple[Cell, ...]
    episodes: EpisodeBudget
    fit_seed: int
    fit_key: Hashable | None = None
    methods: tuple[str, ...] | None = None
    fit_records: bool = True
    support: Pool | None = None

    @property
    def name(self) -> str:
        """Fold or condition, for progress bars."""
        return str(self.fold) if self.fold is not None else str(self.condition or "")


class Protocol(ABC):
    """An evaluation protocol: a name and a generator of tasks from the datasets.

    Subclasses set ``name`` and implement :meth:`tasks`; the engine fits, evaluates and
    writes the records (``docs/protocols.md``).

    Attributes
    ----------
    name : str
        The ``protocol`` field of its records and its name on the command line.
    needs_perturbed : bool
        Whether the perturbation dataset is required (default False).
    uses_reference : bool
        Whether its curves are read against the closed-set reference curve (``tactile-synth
        benchmark`` then runs that too; default False).

    Examples
    --------
    >>> class Nothing(Protocol):
    ...     name = "nothing"
    ...     def tasks(self, data, perturbed, *, seed, episodes):
    ...         return []
    >>> Nothing().name, Nothing.needs_perturbed
    ('nothing', False)
    """

    name: ClassVar[str]
    needs_perturbed: ClassVar[bool] = False
    uses_reference: ClassVar[bool] = False

    @abstractmethod
    def tasks(
        self, data: Dataset, perturbed: Dataset | None, *, seed: int, episodes: EpisodeBudget
    ) -> Iterable[Task]:
        """The protocol's tasks on nominal ``data`` (and ``perturbed``, when it needs it).

        Parameters
        ----------
        data : synth.Dataset
            The nominal dataset.
        perturbed : synth.Dataset or None
            The perturbation dataset, when the run has one.
        seed : int
            The run's seed (derive every seed from it with :func:`child_seed`).
        episodes : benchmark.budget.EpisodeBudget
            The episodes per cell its tasks carry.
        """
