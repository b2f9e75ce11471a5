"""Evaluation protocols by name: the paper's four, installed plug-ins and ``module:Class``.

A protocol is a :class:`benchmark.engine.Protocol` subclass: a ``name`` and a ``tasks``
method that turns the datasets into :class:`benchmark.engine.Task` objects; the engine
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
from ..engine import Features, Protocol, run_protocol
from ..results import Record

_PROTOCOLS: dict[str, str] = {
    "closed-set": "benchmark.protocols.closed_set:ClosedSet",
    "cross-shape": "benchmark.protocols.cross_shape:CrossShape",
    "cross-material": "benchmark.protocols.cross_material:CrossMaterial",
    "perturbation": "benchmark.protocols.perturbation:Perturbation",
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
) -> list[Record]:
    """The records of one protocol (a name or an instance) on ``data`` (and
    ``perturbed``); ``features`` / ``perturbed_features``: optional precomputed
    386-feature pools of each. :func:`benchmark.engine.run_protocol` does the work."""
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
    )
