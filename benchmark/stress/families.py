"""The stress suite's families: one perturbation each, at graded severities.

A family is one thing that changes between the lab where a finger was enrolled and the
field where it works: a physical one changes the world the simulator slides the finger
through (:class:`PhysicalFamily`: it rewrites the generation configuration, and a test
set is simulated under it), a sensor one changes what the sensors and the DAQ record
(:class:`SensorFamily`: it transforms recorded windows after the DAQ, and is labelled
as a signal-level fault wherever it is reported).

Every family has five severities, values of one physical quantity in the family's
``unit`` (:attr:`StressFamily.levels`, severity 1 to 5), and the value at severity 0,
``nominal``, that leaves the world as it was: a physical family's configuration at
severity 0 is the nominal one, bit for bit, and a sensor family's transformation is
the identity. :meth:`StressFamily.check` refuses, in one line and before anything is
simulated, a value outside the physically valid range (a force <= 0, a path off the
plate).

A family is one class in one file. The shipped ones (:mod:`benchmark.stress.physical`,
:mod:`benchmark.stress.sensor`) use the same interface, and a user's family is named on
the command line as ``module:Class`` or ``path/to/file.py:Class``, or installed under the
entry-point group :data:`ENTRY_POINT_GROUP` (``docs/stress.md``).
"""

from __future__ import annotations

import itertools
from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from synth.presets import GenerationConfig
from tactile_synth import plugins

#: Severities every family has (0 is the nominal world).
SEVERITIES: tuple[int, ...] = (1, 2, 3, 4, 5)
#: Entry-point group through which installed distributions contribute families.
ENTRY_POINT_GROUP = "tactile_synth.stress_families"


class StressFamily(ABC):
    """One perturbation at five severities.

    Subclasses set the class attributes ``name`` (``[a-z0-9-]+``, the name on the command
    line and in results.json), ``summary`` (one line), ``unit`` (of ``levels``),
    ``levels`` (five values, severity 1 to 5, each further from ``nominal``) and
    ``nominal`` (the value at severity 0), and implement their kind's method.
    """

    name: ClassVar[str]
    kind: ClassVar[str]
    summary: ClassVar[str]
    unit: ClassVar[str]
    levels: ClassVar[tuple[float, ...]]
    nominal: ClassVar[float]

    def value(self, severity: int) -> float:
        """The perturbation's value at ``severity`` (0: ``nominal``)."""
        if (
            isinstance(severity, bool)
            or not isinstance(severity, int)
            or not (0 <= severity <= len(self.levels))
        ):
            raise ValueError(
                f"severity of {self.name} must be one of 0..{len(self.levels)}; got {severity!r}"
            )
        return float(self.nominal if severity == 0 else self.levels[severity - 1])

    def check(self, value: float, config: GenerationConfig | None) -> None:
        """Refuse a ``value`` that leaves the physically valid range for the experiment
        of ``config`` (None: an imported dataset), with a one-line ``ValueError`` naming
        the family, the value and the range. The default accepts every value."""
        return None

    def describe(self, severity: int) -> str:
        """``"yaw 4 deg"``: the family and its value at ``severity``."""
        return f"{self.name} {self.value(severity):g} {self.unit}".rstrip()


class PhysicalFamily(StressFamily):
    """A change of the simulated world: :meth:`configure` returns the generation
    configuration of the test set at a value (the nominal configuration itself at
    ``nominal``)."""

    kind = "physical"

    @abstractmethod
    def configure(self, config: GenerationConfig, value: float) -> GenerationConfig:
        """``config`` (the nominal test set's) with the perturbation at ``value``."""


class SensorFamily(StressFamily):
    """A fault of the sensors or the acquisition, applied to recorded windows after the
    DAQ: :meth:`apply` returns the faulted windows."""

    kind = "sensor"

    @abstractmethod
    def apply(self, signals: np.ndarray, value: float, seeds: np.ndarray) -> np.ndarray:
        """``signals`` float32 ``(n, 4, T)`` as the fault at ``value`` records them; a new
        array. ``seeds`` ``(n,)``: each trial's own seed, the only source of its draws."""


_FAMILIES: dict[str, str] = {
    "force": "benchmark.stress.physical:Force",
    "speed": "benchmark.stress.physical:Speed",
    "yaw": "benchmark.stress.physical:Yaw",
    "offset": "benchmark.stress.physical:Offset",
    "pitch": "benchmark.stress.physical:Pitch",
    "skin": "benchmark.stress.physical:SkinHardness",
    "friction": "benchmark.stress.physical:SurfaceFriction",
    "pvdf-noise": "benchmark.stress.sensor:PvdfNoise",
    "sg-noise": "benchmark.stress.sensor:SgNoise",
    "sg-offset": "benchmark.stress.sensor:SgOffset",
    "gain": "benchmark.stress.sensor:GainError",
    "dead-channel": "benchmark.stress.sensor:DeadChannel",
    "clipping": "benchmark.stress.sensor:Clipping",
    "dropped-samples": "benchmark.stress.sensor:DroppedSamples",
}

#: The shipped families, physical first, in the report's order.
FAMILY_NAMES: tuple[str, ...] = tuple(_FAMILIES)
#: The families ``--quick`` runs: two physical, two sensor.
QUICK_FAMILIES: tuple[str, ...] = ("yaw", "offset", "pvdf-noise", "dead-channel")


def family_class(name: str, *, arg: str = "--families") -> type[StressFamily]:
    """The class of family ``name`` (built-in, entry point or ``module:Class``)."""
    return plugins.resolve(
        name,
        builtins=_FAMILIES,
        group=ENTRY_POINT_GROUP,
        base=StressFamily,
        kind="stress family",
        doc="docs/stress.md",
        example="my_families.py:Humidity",
        arg=arg,
    )


def get(name: str, *, arg: str = "--families") -> StressFamily:
    """A new instance of family ``name``, its class attributes checked."""
    family = family_class(name, arg=arg)()
    _check_family(family, name, arg)
    return family


def _check_family(family: StressFamily, given: str, arg: str) -> None:
    where = f"{arg} {given}"
    if family.kind not in ("physical", "sensor"):
        raise ValueError(f"{where}: kind must be 'physical' or 'sensor'; got {family.kind!r}")
    levels = getattr(family, "levels", None)
    if (
        not isinstance(levels, tuple)
        or len(levels) != len(SEVERITIES)
        or not all(isinstance(v, int | float) and np.isfinite(v) for v in levels)
    ):
        raise ValueError(f"{where}: levels must be a tuple of {len(SEVERITIES)} finite numbers")
    nominal = getattr(family, "nominal", None)
    if not isinstance(nominal, int | float) or not np.isfinite(nominal):
        raise ValueError(f"{where}: nominal must be a finite number; got {nominal!r}")
    distance = [abs(v - nominal) for v in levels]
    if any(b <= a for a, b in itertools.pairwise(distance)) or distance[0] == 0:
        raise ValueError(f"{where}: levels must move away from nominal with each severity")
    for attr in ("summary", "unit"):
        if not isinstance(getattr(family, attr, None), str):
            raise ValueError(f"{where}: {attr} must be a string")


def parse_severities(text: str | Sequence[int], *, arg: str = "--severities") -> tuple[int, ...]:
    """``"1,3,5"`` (or a sequence) as sorted severities, each one of :data:`SEVERITIES`;
    a one-line ``ValueError`` naming ``arg`` and the valid ones otherwise."""
    items = text.split(",") if isinstance(text, str) else list(text)
    out = []
    for item in items:
        try:
            level = int(str(item).strip())
        except ValueError:
            level = None
        if level not in SEVERITIES:
            raise ValueError(
                f"{arg} takes severities from {', '.join(map(str, SEVERITIES))}; got {item!r}"
            )
        out.append(level)
    if not out:
        raise ValueError(f"{arg} must name at least one severity")
    return tuple(sorted(set(out)))
