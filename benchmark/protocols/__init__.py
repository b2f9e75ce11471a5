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

import importlib
import importlib.metadata
import importlib.util
import inspect
import os
import sys
import zlib
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from synth import Dataset
from tactile_synth.validation import check_choice

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
    eps = importlib.metadata.entry_points(group=ENTRY_POINT_GROUP)
    return {ep.name: ep.value for ep in eps if ep.name not in _PROTOCOLS}


def available_protocols() -> tuple[str, ...]:
    """Built-in names, then installed plug-in names (sorted)."""
    return (*PROTOCOL_NAMES, *sorted(plugin_protocols()))


def _module(spec: str, module: str, arg: str):
    if not module.endswith(".py"):
        if os.getcwd() not in sys.path and importlib.util.find_spec(module.split(".")[0]) is None:
            sys.path.append(os.getcwd())  # searched last, as for methods: installed ones win
        try:
            return importlib.import_module(module)
        except ImportError as exc:
            raise ValueError(f"{arg}: {spec!r}: importing {module} failed: {exc}") from None
    path = Path(module)
    if not path.is_file():
        raise ValueError(f"{arg}: {spec!r}: file {path} does not exist")
    resolved = str(path.resolve())
    name = f"_tactile_synth_protocol_{path.stem}_{zlib.crc32(resolved.encode()):08x}"
    if name not in sys.modules:
        loader = importlib.util.spec_from_file_location(name, resolved)
        if loader is None or loader.loader is None:
            raise ValueError(f"{arg}: {spec!r}: cannot load {path} as a Python module")
        mod = importlib.util.module_from_spec(loader)
        sys.modules[name] = mod  # before executing: dataclasses look it up
        try:
            loader.loader.exec_module(mod)
        except BaseException:
            del sys.modules[name]
            raise
    return sys.modules[name]


def _load(spec: str, arg: str) -> type[Protocol]:
    module, sep, attr = spec.rpartition(":")
    if not sep or not module or not attr.isidentifier():
        raise ValueError(f"{arg}: {spec!r} is not module:Class")
    cls = getattr(_module(spec, module, arg), attr, None)
    if not (inspect.isclass(cls) and issubclass(cls, Protocol)) or inspect.isabstract(cls):
        raise ValueError(
            f"{arg}: {spec!r} is not a complete benchmark.engine.Protocol subclass "
            "(see docs/protocols.md)"
        )
    if not isinstance(getattr(cls, "name", None), str):
        raise ValueError(f"{arg}: {spec!r} must set the class attribute name (a string)")
    return cls


def get(name: str, *, arg: str = "protocol") -> Protocol:
    """A new instance of protocol ``name`` (built-in, plug-in or ``module:Class``);
    ``ValueError`` naming ``arg`` when it cannot be found or is no Protocol."""
    if not isinstance(name, str) or not name:
        raise ValueError(f"{arg} must be a protocol name or module:Class; got {name!r}")
    if name in _PROTOCOLS:
        module, cls = _PROTOCOLS[name].split(":")
        return getattr(importlib.import_module(module), cls)()
    plugins = plugin_protocols()
    if name in plugins:
        return _load(plugins[name], f"{arg} {name!r} (entry point {plugins[name]!r})")()
    if ":" in name:
        return _load(name, arg)()
    check_choice(arg, name, available_protocols())  # raises, with a close match
    raise AssertionError("unreachable")


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
