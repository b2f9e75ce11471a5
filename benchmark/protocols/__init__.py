"""Evaluation protocols by name: the paper's four, installed plug-ins and ``module:Class``.

A protocol is a :class:`benchmark.tasks.Protocol` subclass: a ``name`` and a ``tasks``
method that turns the datasets into :class:`benchmark.tasks.Task` objects; the engine
does the rest (``docs/protocols.md``). A protocol is named in one of three ways:

- a built-in name, :data:`PROTOCOL_NAMES`;
- the name of an entry point in the group :data:`ENTRY_POINT_GROUP` that an installed
  distribution declares (value ``"module:Class"``); a built-in name always wins;
- ``"module:Class"`` or ``"path/to/file.py:Class"``.

Modules are imported on first use.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from synth import Dataset
from tactile_synth import plugins

from ..budget import EpisodeBudget
from ..cells import Features
from ..engine import run_protocol
from ..labels import CLOSED_SET, CROSS_MATERIAL, CROSS_SHAPE, PERTURBATION
from ..results import Record
from ..tasks import Protocol
from ..workers import ProcessPool

_PROTOCOLS: dict[str, str] = {
    CLOSED_SET: "benchmark.protocols.closed_set:ClosedSet",
    CROSS_SHAPE: "benchmark.protocols.cross_shape:CrossShape",
    CROSS_MATERIAL: "benchmark.protocols.cross_material:CrossMaterial",
    PERTURBATION: "benchmark.protocols.perturbation:Perturbation",
}

#: The paper's protocols, in the order ``benchmark all`` runs them.
PROTOCOL_NAMES: tuple[str, ...] = tuple(_PROTOCOLS)
#: Entry-point group through which installed distributions contribute protocols.
ENTRY_POINT_GROUP = "tactile_synth.protocols"


def plugin_protocols() -> dict[str, str]:
    """Entry-point name -> ``"module:Class"`` of every installed plug-in protocol."""
    return plugins.entry_points(ENTRY_POINT_GROUP, _PROTOCOLS)


def available_protocols() -> tuple[str, ...]:
    """Built-in names, then installed plug-in names (sorted)."""
    return (*PROTOCOL_NAMES, *sorted(plugin_protocols()))


def protocol_class(name: str, *, arg: str = "protocol") -> type[Protocol]:
    """The class of protocol ``name`` (built-in, plug-in or ``module:Class``, see
    :func:`tactile_synth.plugins.resolve`); ``ValueError`` naming ``arg`` when it cannot
    be found or is no complete Protocol."""
    return plugins.resolve(
        name,
        builtins=_PROTOCOLS,
        group=ENTRY_POINT_GROUP,
        base=Protocol,
        kind="protocol",
        doc="docs/protocols.md",
        example="examples.leave_one_material_out:LeaveOneMaterialOut",
        arg=arg,
    )


def get(name: str, *, arg: str = "protocol") -> Protocol:
    """A new instance of protocol ``name`` (built-in, plug-in or ``module:Class``);
    ``ValueError`` naming ``arg`` when it cannot be found or is no Protocol."""
    return protocol_class(name, arg=arg)()


def run(
    protocol: str | Protocol,
    data: Dataset,
    *,
    perturbed: Dataset | None = None,
    methods: Sequence[str] = ("AFOP-ML",),
    episodes: int | EpisodeBudget = 500,
    seed: int = 0,
    progress: bool = False,
    features: np.ndarray | None = None,
    perturbed_features: np.ndarray | None = None,
    workers: int = 1,
) -> list[Record]:
    """The records of one protocol on ``data`` (and ``perturbed``).

    :func:`benchmark.engine.run_protocol` does the work.

    Parameters
    ----------
    protocol : str or benchmark.tasks.Protocol
        A built-in or plug-in protocol name, ``module:Class``, or an instance.
    data : synth.Dataset
        The nominal dataset.
    perturbed : synth.Dataset or None
        The perturbation dataset (the perturbation protocol needs it).
    methods : sequence of str, default ("AFOP-ML",)
        Method names, plug-in names or ``module:Class`` specs.
    episodes : int or benchmark.budget.EpisodeBudget, default 500
        Episodes per cell (per method).
    seed : int, default 0
        The run's seed: the same seed gives the same records.
    progress : bool, default False
        Show a progress bar on a terminal.
    features, perturbed_features : numpy.ndarray or None
        Precomputed 386-feature pools of ``data`` and ``perturbed``
        (:func:`models.features.extract`).
    workers : int, default 1
        Processes the fits run in (:class:`benchmark.workers.ProcessPool`; 1: this one).

    Returns
    -------
    list of records
        Accuracy records per cell, their summaries and the fits' records
        (:mod:`benchmark.results`).

    Examples
    --------
    >>> from benchmark.results import select
    >>> from tests.synthetic_data import make_dataset
    >>> data = make_dataset(trials_per_class=6, n_samples=200, noise=0.2)
    >>> records = run("closed-set", data, methods=["Direct-Prot-ML"], episodes=10)
    >>> row = select(records, "accuracy", way=5, shot=1)[0]
    >>> row["method"], row["episodes"], 0.0 <= row["accuracy"] <= 1.0
    ('Direct-Prot-ML', 10, True)
    """
    given = ((data, features), (perturbed, perturbed_features))
    known = [(d, f) for d, f in given if f is not None]
    return run_protocol(
        get(protocol) if isinstance(protocol, str) else protocol,
        data,
        perturbed,
        methods=methods,
        episodes=episodes,
        seed=seed,
        progress=progress,
        features=Features(known),
        executor=ProcessPool(workers),
    )
