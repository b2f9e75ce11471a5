"""The paper's evaluation protocols by name.

Each protocol module exposes ``run(data, *, perturbed, methods, episodes, seed, progress)
-> list[dict]`` returning results.json records (fields in ``docs/results.md``). Modules
are imported on first use.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable

from shapes.validation import check_choice

_PROTOCOLS: dict[str, str] = {
    "closed-set": "benchmark.protocols.closed_set",
    "cross-shape": "benchmark.protocols.cross_shape",
    "cross-material": "benchmark.protocols.cross_material",
    "perturbation": "benchmark.protocols.perturbation",
}

PROTOCOL_NAMES: tuple[str, ...] = tuple(_PROTOCOLS)


def protocol_runner(name: str) -> Callable[..., list[dict]]:
    """The ``run`` function of protocol ``name`` (one of :data:`PROTOCOL_NAMES`)."""
    check_choice("protocol", name, PROTOCOL_NAMES)
    return importlib.import_module(_PROTOCOLS[name]).run
