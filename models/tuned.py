"""Hyper-parameters chosen on training-split validation data (``scripts/tune.py``).

Every hyper-parameter of the feature-based methods is either a value the paper states
(the head's 250 Adam steps at lr 1.5e-3 with entropy weight 0.10, the D-scan's 5-way-5-shot
validation episodes, the MLP's 64/32 widths) or a default of the cited algorithm (fscnca's
kernel width 1, initial weights 1), or it is read from ``tuned.json`` next to this module.
``scripts/tune.py`` writes that file together with its evidence (``docs/tuning.md``:
every candidate with its validation score and 95 % CI, and the rule that picked the
value) from the closed-set *training* half of a dataset only; rerunning it with the same
data and seed reproduces both files.
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path
from typing import Any

TUNED_FILE: Path = Path(__file__).with_name("tuned.json")


@cache
def _load(path: str) -> dict[str, Any]:
    data = json.loads(Path(path).read_text())
    if not isinstance(data, dict) or not isinstance(data.get("values"), dict):
        raise ValueError(f"{path} is not a tuned-hyper-parameter file (no 'values' table)")
    return data


def tuned_values(path: str | Path = TUNED_FILE) -> dict[str, dict[str, Any]]:
    """``{method: {parameter: value}}`` of ``tuned.json``."""
    return _load(str(path))["values"]


def tuned(method: str, name: str) -> Any:
    """The tuned value of ``method``'s parameter ``name``."""
    values = tuned_values()
    try:
        return values[method][name]
    except KeyError:
        raise KeyError(
            f"{TUNED_FILE.name} has no value for {method}.{name}; run scripts/tune.py"
        ) from None
