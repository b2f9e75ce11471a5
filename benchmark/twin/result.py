"""What a calibration finds: each parameter's posterior summary and the whole result.

Kept apart from :mod:`benchmark.twin.calibrate` so that the report writer reads a
result without importing the engine that makes one.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np

from synth.calibration.parameters import Parameter

from .world import World


@dataclasses.dataclass(frozen=True)
class Estimate:
    """One parameter's posterior: median and the 5-95 % interval, physical units."""

    name: str
    median: float
    low: float
    high: float
    prior_low: float
    prior_high: float
    flat: bool

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclasses.dataclass
class Calibration:
    """What :func:`benchmark.twin.calibrate.calibrate` found and wrote."""

    out: Path
    parameters: list[Parameter]
    estimates: list[Estimate]
    samples: np.ndarray
    n_simulations: int
    n_failed: int
    world: World
    x_obs: np.ndarray
