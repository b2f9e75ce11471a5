"""Z-scoring of the feature pool with statistics fitted on training trials only."""

from __future__ import annotations

from typing import Self

import numpy as np

from .base import NotFittedError


class FeatureScaler:
    """Per-feature z-score ``(x - mean_) / scale_``; constant features get scale 1.

    The paper z-scores per channel: every feature belongs to one channel, so scaling each
    feature with training-set statistics is that, feature by feature.
    """

    def fit(self, features: np.ndarray) -> Self:
        x = _check_2d("features", features)
        self.mean_ = x.mean(axis=0)
        std = x.std(axis=0)
        self.scale_ = np.where(std > 1e-12 * np.maximum(1.0, np.abs(self.mean_)), std, 1.0)
        return self

    def transform(self, features: np.ndarray) -> np.ndarray:
        if not hasattr(self, "mean_"):
            raise NotFittedError("FeatureScaler.transform called before fit")
        x = _check_2d("features", features)
        if x.shape[1] != self.mean_.size:
            raise ValueError(
                f"features must have {self.mean_.size} columns (as fitted); got {x.shape[1]}"
            )
        return ((x - self.mean_) / self.scale_).astype(np.float32)

    def fit_transform(self, features: np.ndarray) -> np.ndarray:
        return self.fit(features).transform(features)


def _check_2d(arg: str, value: object) -> np.ndarray:
    x = np.asarray(value, dtype=np.float64)
    if x.ndim != 2 or x.shape[0] < 1:
        raise ValueError(f"{arg} must be a 2-D array (n, d) with n >= 1; got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{arg} contains NaN or inf")
    return x
