"""The named presets and ``--config`` grid files; re-exports the grid (:mod:`synth.grid`:
``GenerationConfig``, the canonical trial plan and its seeds) under its historical name.

The presets are experiment files shipped in the package (``synth/experiments/*.toml``,
read by :mod:`synth.experiment`): ``quick`` (the paper's 36 classes, 4 trials each),
``paper`` (60 each, 2,160 trials) and ``perturbation`` (3 forces x 3 speeds around
nominal, the nominal one left out: 8 conditions, 10 trials per class in each).
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from pathlib import Path

from tactile_synth.validation import check_choice

from .config import SynthConfig
from .experiment import overlay, packaged
from .grid import (
    FORCE_RANGE_N,
    MAX_CHUNK_TRIALS,
    MAX_TRIALS,
    NOMINAL_FORCE_N,
    NOMINAL_SPEED_MM_S,
    PHYSICAL_FORCE_RANGE_N,
    PHYSICAL_SPEED_RANGE_MM_S,
    SPEED_RANGE_MM_S,
    GenerationConfig,
    TrialPlan,
    check_forces,
    check_speeds,
    condition_name,
    in_range,
    parse_condition,
    plan,
    trial_seed,
    trial_seeds,
)

__all__ = [
    "FORCE_RANGE_N",
    "MAX_CHUNK_TRIALS",
    "MAX_TRIALS",
    "NOMINAL_FORCE_N",
    "NOMINAL_SPEED_MM_S",
    "PHYSICAL_FORCE_RANGE_N",
    "PHYSICAL_SPEED_RANGE_MM_S",
    "PRESETS",
    "SPEED_RANGE_MM_S",
    "GenerationConfig",
    "TrialPlan",
    "check_forces",
    "check_speeds",
    "condition_name",
    "in_range",
    "load_toml",
    "parse_condition",
    "plan",
    "preset",
    "trial_seed",
    "trial_seeds",
]

#: The named grids, each loaded from its experiment file in ``synth/experiments``.
PRESETS: dict[str, GenerationConfig] = packaged()


def preset(name: str) -> GenerationConfig:
    return PRESETS[check_choice("preset", name, tuple(PRESETS))]


def load_toml(path: str | Path) -> GenerationConfig:
    """A grid from a TOML file: an optional ``preset = "..."`` base plus any config keys;
    a ``[synth.SECTION]`` table sets those simulator fields and keeps the other defaults."""
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"--config {path} is a directory; give a TOML file")
    if not path.is_file():
        raise FileNotFoundError(f"--config {path} does not exist")
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"--config {path} is not valid TOML: {exc}") from None
    if not data:
        # An empty file would silently stand for the whole paper grid.
        raise ValueError(
            f'--config {path} sets nothing; give the grid\'s keys (e.g. preset = "quick") '
            f"or use --preset"
        )
    base = preset(data["preset"]) if "preset" in data else GenerationConfig()
    merged = {**base.to_dict(), **data}
    if isinstance(data.get("synth"), Mapping):
        # A [synth.*] table sets only the fields it names; the rest keep the defaults.
        merged["synth"] = overlay(SynthConfig().to_dict(), data["synth"])
        try:
            SynthConfig.from_dict(merged["synth"])
        except ValueError as exc:
            raise ValueError(f"--config {path}: [synth] {exc}") from None
    return GenerationConfig.from_dict(merged)
