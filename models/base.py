"""The one interface every few-shot method implements (AFOP-ML and all baselines).

Life cycle, as in the paper: ``fit`` once on the source (training) classes, then
``predict_episodes`` adapts to each episode's support set and labels its queries.
Episodes are passed as index arrays into a pool of trials, so a method can batch
hundreds of episodes into one tensor problem and features are computed once per pool.

Query labels never reach a method: the evaluator keeps them. Support labels are
implicit in the layout: ``support[e, n, :]`` are the K examples of episode-class ``n``.
"""

from __future__ import annotations

import inspect
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import ClassVar, Self

import numpy as np

from tactile_synth.validation import check_int, check_non_negative, check_positive

#: The check :meth:`FewShotMethod._check_settings` runs for each kind of setting.
SETTING_KINDS: dict[str, Callable[[str, object], object]] = {
    "count": lambda arg, value: check_int(arg, value, minimum=1),
    "steps": lambda arg, value: check_int(arg, value, minimum=0),
    "rate": check_positive,
    "weight": check_non_negative,
}


class NotFittedError(RuntimeError):
    """``predict_episodes`` was called before ``fit``."""


@dataclass(frozen=True)
class DScanCurve:
    """The validation curve a feature-space size D was chosen on.

    Parameters
    ----------
    sizes : tuple of int
        The candidate sizes D.
    mean : tuple of float
        Mean validation accuracy of each candidate.
    ci95 : tuple of float
        Its 95 % confidence half-width.
    """

    sizes: tuple[int, ...]
    mean: tuple[float, ...]
    ci95: tuple[float, ...]


@dataclass(frozen=True)
class FitDetails:
    """What a fitted method exposes beyond its predictions (:meth:`FewShotMethod.fit_details`);
    the benchmark writes each part as a record of the fit (``docs/results.md``).

    Parameters
    ----------
    selected : tuple of int or None
        Indices into :data:`models.features.FEATURE_NAMES` of the features the method
        selected (AFOP-ML: its top-D features): a ``selection`` record with D = their
        number and their PVDF/SG shares (:func:`models.features.sensor_shares`). The
        record carries no method name: the report and the interpretability analysis read
        it as AFOP-ML's, so a run should hold one method that reports a selection.
    dscan : DScanCurve or None
        The validation curve D was chosen on: a ``dscan`` record.
    meta_curve : numpy.ndarray or None
        ``(n, 2)`` rows of (outer step, validation accuracy) of a meta-learner's
        meta-training: a ``meta_curve`` record.
    meta_gradient : str or None
        How the meta-gradient is computed (``"first-order"``), written beside the curve.

    Examples
    --------
    >>> FitDetails().selected is None
    True
    >>> FitDetails(selected=(3, 7)).selected
    (3, 7)
    """

    selected: tuple[int, ...] | None = None
    dscan: DScanCurve | None = None
    meta_curve: np.ndarray | None = None
    meta_gradient: str | None = None


def _check_index_array(arg: str, value: object, ndim: int, n_pool: int) -> np.ndarray:
    arr = np.asarray(value)
    if arr.ndim != ndim or not np.issubdtype(arr.dtype, np.integer):
        raise ValueError(
            f"{arg} must be an integer array with {ndim} dimensions; got "
            f"dtype {arr.dtype} and shape {arr.shape}"
        )
    if arr.size and (arr.min() < 0 or arr.max() >= n_pool):
        raise ValueError(
            f"{arg} indexes a pool of {n_pool} trials: values must lie in "
            f"0..{n_pool - 1}; got {arr.min()}..{arr.max()}"
        )
    return arr.astype(np.intp, copy=False)


def check_episodes(support: object, query: object, n_pool: int) -> tuple[np.ndarray, np.ndarray]:
    """Validate an episode batch: ``support`` ``(E, N, K)``, ``query`` ``(E, M)``.

    Rejects N < 2, K < 1, a trial used twice within one episode's support set, and a
    query that is also a support example of its episode.
    """
    s = _check_index_array("support", support, 3, n_pool)
    q = _check_index_array("query", query, 2, n_pool)
    e, n_way, k_shot = s.shape
    if n_way < 2:
        raise ValueError(f"support must hold N >= 2 classes per episode; got N={n_way}")
    if k_shot < 1:
        raise ValueError(f"support must hold K >= 1 examples per class; got K={k_shot}")
    if q.shape[0] != e:
        raise ValueError(f"query must have one row per episode ({e}); got {q.shape[0]}")
    flat = np.sort(s.reshape(e, -1), axis=1)
    if np.any(flat[:, 1:] == flat[:, :-1]):
        raise ValueError("support uses the same trial twice within one episode")
    if q.size and np.any((q[:, :, None] == s.reshape(e, 1, -1)).any(axis=2)):
        raise ValueError("query contains a trial that is also in its episode's support set")
    return s, q


class FewShotMethod(ABC):
    """The interface of every few-shot method: subclasses set ``name`` and implement
    ``_fit`` and ``_predict`` (``docs/methods.md``).

    Parameters are set only in ``__init__`` (keyword-only, each a setting a user may
    change with ``--method-option``); learned attributes end in ``_``. ``features``
    arguments are the raw (unscaled) 386-feature pool of :func:`models.features.extract`
    for the same trials, passed when the caller has already computed them; methods that
    need them compute them when ``None``.

    Parameters
    ----------
    seed : int, default 0
        Seeds everything random in the method: the same seed gives the same predictions.

    Attributes
    ----------
    name : str
        The method's name in results and on the command line (a class attribute).
    cost_hint : tuple of float
        Rough CPU seconds of one fit and of 1000 evaluated episodes (a class attribute:
        only orders the queue of fits).
    fitted_ : bool
        Whether :meth:`fit` has run.

    Examples
    --------
    A nearest-class-mean method on the channels' means:

    >>> import numpy as np
    >>> class NearestMean(FewShotMethod):
    ...     name = "nearest-mean"
    ...     def _fit(self, signals, labels, features):
    ...         pass  # nothing to learn from the training classes
    ...     def _predict(self, signals, support, query, features):
    ...         x = signals.mean(axis=2)
    ...         protos = x[support].mean(axis=2)  # (E, N, channels)
    ...         d = ((x[query][:, :, None] - protos[:, None]) ** 2).sum(-1)
    ...         return d.argmin(axis=2)
    >>> from tests.synthetic_data import make_dataset
    >>> data = make_dataset(trials_per_class=3, n_samples=200, noise=0.1)
    >>> from models.episodes import sample_episodes
    >>> batch = sample_episodes(data.label, n_way=5, k_shot=1, n_query=2, episodes=8, seed=0)
    >>> model = NearestMean(seed=0).fit(data.signals, data.label)
    >>> model.predict_episodes(data.signals, batch.support, batch.query).shape
    (8, 10)
    >>> model.fit_details()
    FitDetails(selected=None, dscan=None, meta_curve=None, meta_gradient=None)
    """

    name: ClassVar[str]
    #: Rough CPU seconds of one fit on the paper preset's closed-set training half, and of
    #: evaluating 1000 episodes (over a protocol's cells), on one core: only used to start
    #: the costliest fits first when fits run in several processes (no result depends on
    #: it).
    cost_hint: ClassVar[tuple[float, float]] = (1.0, 1.0)

    def __init__(self, *, seed: int = 0) -> None:
        method = getattr(self, "name", type(self).__name__)
        self.seed = check_int(f"{method}: seed", seed, minimum=0)
        self.fitted_ = False

    def _check_settings(self, **kinds: str) -> None:
        """Check the settings ``__init__`` stored, ``name=kind`` for each, at construction
        (a bad one would otherwise fail deep inside ``fit``, or silently train nothing):
        ``kind`` is a key of :data:`SETTING_KINDS`: ``count`` an integer >= 1, ``steps``
        an integer >= 0, ``rate`` a finite number > 0, ``weight`` a finite number >= 0. A
        setting whose default is None may stay None (the method then chooses it on
        training data, or reads it from the tuned values). Raises ValueError naming the
        method and the setting."""
        defaults = inspect.signature(type(self).__init__).parameters
        method = getattr(self, "name", type(self).__name__)
        for name, kind in kinds.items():
            value = getattr(self, name)
            if value is None and name in defaults and defaults[name].default is None:
                continue
            SETTING_KINDS[kind](f"{method}: {name}", value)

    def fit(
        self,
        signals: np.ndarray,
        labels: np.ndarray,
        *,
        features: np.ndarray | None = None,
        cells: Sequence[tuple[int, int]] | None = None,
    ) -> Self:
        """Offline training on the source classes.

        signals: float32 ``(n, 4, T)``; labels: int ``(n,)`` class ids; features: ``(n, 386)``;
        cells: the ``(way, shot)`` pairs the fitted method will be tested on, when the
        caller knows them (the benchmark passes its task's grid), else None. It tells only
        the protocol's design, no test data: a method that chooses settings per cell on
        validation episodes of the training split may validate only the cells these
        episodes take their settings from (:attr:`test_cells_` holds them, sorted).
        """
        signals = np.asarray(signals)
        labels = np.asarray(labels)
        if signals.ndim != 3:
            raise ValueError(f"signals must have shape (n, channels, T); got {signals.shape}")
        if labels.shape != (signals.shape[0],):
            raise ValueError(f"labels must have shape ({signals.shape[0]},); got {labels.shape}")
        if np.unique(labels).size < 2:
            raise ValueError("fit needs trials of at least 2 classes")
        if features is not None and np.asarray(features).shape[0] != signals.shape[0]:
            raise ValueError("features must have one row per trial of signals")
        self.test_cells_ = None if cells is None else _check_cells(cells)
        self._fit(signals, labels, features)
        self.fitted_ = True
        return self

    def predict_episodes(
        self,
        signals: np.ndarray,
        support: np.ndarray,
        query: np.ndarray,
        *,
        features: np.ndarray | None = None,
    ) -> np.ndarray:
        """Adapt to each episode's support set and label its queries.

        signals: ``(P, 4, T)`` the pool; support: int ``(E, N, K)``; query: int ``(E, M)``.
        Returns int ``(E, M)`` predictions in ``0..N-1`` (episode-class positions).
        """
        if not getattr(self, "fitted_", False):
            raise NotFittedError(f"{self.name}: call fit() before predict_episodes()")
        signals = np.asarray(signals)
        s, q = check_episodes(support, query, signals.shape[0])
        if features is not None and np.asarray(features).shape[0] != signals.shape[0]:
            raise ValueError("features must have one row per trial of signals")
        pred = np.asarray(self._predict(signals, s, q, features))
        if pred.shape != q.shape:
            raise RuntimeError(
                f"{self.name} returned predictions of shape {pred.shape}, expected {q.shape}"
            )
        return pred

    def fit_details(self) -> FitDetails:
        """What the fitted method exposes beyond its predictions, for the benchmark's
        records of each fit (:class:`FitDetails`); called after :meth:`fit`.

        The default reports a meta-training curve when the method has one: the
        ``meta_curve_`` attribute (``(n, 2)`` rows of outer step and validation
        accuracy) and the ``meta_gradient`` attribute beside it; nothing else. A method
        that selects features overrides it (AFOP-ML).
        """
        curve = getattr(self, "meta_curve_", None)
        if curve is None:
            return FitDetails()
        return FitDetails(meta_curve=curve, meta_gradient=getattr(self, "meta_gradient", None))

    @abstractmethod
    def _fit(self, signals: np.ndarray, labels: np.ndarray, features: np.ndarray | None) -> None:
        """Learn from the source classes (inputs already validated)."""

    @abstractmethod
    def _predict(
        self,
        signals: np.ndarray,
        support: np.ndarray,
        query: np.ndarray,
        features: np.ndarray | None,
    ) -> np.ndarray:
        """Return ``(E, M)`` predictions (inputs already validated)."""


def _check_cells(cells: Sequence[tuple[int, int]]) -> tuple[tuple[int, int], ...]:
    """``cells`` as sorted unique ``(way, shot)`` pairs of integers >= 1; ValueError naming
    ``cells`` otherwise."""
    out = set()
    for cell in cells:
        pair = tuple(cell) if isinstance(cell, (tuple, list)) else ()
        if len(pair) != 2 or not all(
            isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= 1 for v in pair
        ):
            raise ValueError(f"cells must hold (way, shot) pairs of integers >= 1; got {cell!r}")
        out.add((int(pair[0]), int(pair[1])))
    if not out:
        raise ValueError("cells must name at least one (way, shot) pair, or be None")
    return tuple(sorted(out))
