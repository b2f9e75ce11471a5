"""Statistics shared by the methods and the benchmark."""

from __future__ import annotations

import numpy as np


def ci95(values: np.ndarray) -> float:
    """Half-width of the 95 % normal confidence interval of the mean of ``values``
    (per-episode accuracies): ``1.96 * std / sqrt(n)``, population std; NaN when empty."""
    a = np.asarray(values, dtype=np.float64)
    return float(1.96 * a.std() / np.sqrt(a.size)) if a.size else float("nan")
