"""Episode budgets: how many episodes each method gets per cell of a protocol's grid.

:class:`EpisodeBudget` is what one task carries (a default and per-method overrides);
:class:`Budget` is a whole run's, from which each protocol gets its own
(:meth:`Budget.for_task`). Every method named in a budget is validated like ``--methods``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from models import registry
from tactile_synth.validation import check_int


def _check_table(table: Mapping[str, int]) -> None:
    for m, n in table.items():
        registry.check_methods([m], arg="method")
        check_int(f"episodes for {m}", n, minimum=1)


@dataclass(frozen=True)
class EpisodeBudget:
    """Episodes per cell: ``per_method[m]`` for method ``m`` if given, else ``default``."""

    default: int = 500
    per_method: Mapping[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        check_int("episodes", self.default, minimum=1)
        _check_table(self.per_method)

    def of(self, method: str) -> int:
        """Episodes per cell of ``method``."""
        return int(self.per_method.get(method, self.default))


@dataclass(frozen=True)
class Budget:
    """Episodes per (protocol, method): ``default`` unless ``per_method`` names the method.

    ``generalisation_per_method`` overrides ``per_method`` for every protocol but
    closed-set (their 11 ways x several folds/conditions cost most).
    """

    default: int = 500
    per_method: Mapping[str, int] = field(default_factory=dict)
    generalisation_per_method: Mapping[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        check_int("episodes", self.default, minimum=1)
        _check_table(self.per_method)
        _check_table(self.generalisation_per_method)

    def for_protocol(self, protocol: str) -> dict[str, int]:
        """Method -> episodes override for ``protocol`` (methods absent use ``default``)."""
        out = dict(self.per_method)
        if protocol != "closed-set":
            out.update(self.generalisation_per_method)
        return out

    def for_task(self, protocol: str) -> EpisodeBudget:
        """The :class:`EpisodeBudget` of ``protocol``'s tasks."""
        return EpisodeBudget(self.default, self.for_protocol(protocol))

    def describe(self, methods: Sequence[str], protocols: Sequence[str]) -> str:
        """One line for the report: every protocol's episodes per method."""
        parts = []
        for protocol in protocols:
            table = self.for_task(protocol)
            eps = ", ".join(f"{m} {table.of(m)}" for m in methods)
            parts.append(f"{protocol}: {eps}")
        return "episodes per (fold/condition, way) — " + "; ".join(parts)

    def to_dict(self) -> dict[str, Any]:
        return {
            "default": self.default,
            "per_method": dict(sorted(self.per_method.items())),
            "generalisation_per_method": dict(sorted(self.generalisation_per_method.items())),
        }
