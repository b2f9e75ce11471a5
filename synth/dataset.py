"""The in-memory dataset every consumer works with (``synth.load_dataset`` returns one)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .trial import CHANNELS, CLASS_NAMES


@dataclass(frozen=True)
class Dataset:
    """Aligned per-trial arrays.

    signals: float32 ``(n, 4, T)``; shape, material: str ``(n,)``; label: int ``(n,)``
    indexing ``classes``, the dataset's own class list (``"<specimen>/<material>"``,
    specimen-major, as its store records it: the paper's 36 :data:`synth.trial.CLASS_NAMES`
    for the paper presets, any set for a user's experiment; compare labels of two
    datasets by their names); force_n, speed_mm_s: float ``(n,)``; seed: int ``(n,)``;
    attrs: provenance (versions, full configuration, creation time).
    """

    signals: np.ndarray
    shape: np.ndarray
    material: np.ndarray
    label: np.ndarray
    force_n: np.ndarray
    speed_mm_s: np.ndarray
    seed: np.ndarray
    classes: tuple[str, ...] = CLASS_NAMES
    attrs: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.signals.ndim != 3 or self.signals.shape[1] != len(CHANNELS):
            raise ValueError(
                f"signals must have shape (n, {len(CHANNELS)}, T); got {self.signals.shape}"
            )
        n = self.signals.shape[0]
        for name in ("shape", "material", "label", "force_n", "speed_mm_s", "seed"):
            arr = getattr(self, name)
            if arr.shape != (n,):
                raise ValueError(f"{name} must have shape ({n},) like signals; got {arr.shape}")
        classes = self.classes
        if (
            not isinstance(classes, tuple)
            or not classes
            or any(not isinstance(c, str) or c.count("/") != 1 for c in classes)
            or len(set(classes)) != len(classes)
        ):
            raise ValueError(
                f'classes must be a non-empty tuple of unique "<specimen>/<material>" names; '
                f"got {classes!r}"
            )
        if n and (self.label.min() < 0 or self.label.max() >= len(self.classes)):
            raise ValueError(f"label must index classes (0..{len(self.classes) - 1})")

    def __len__(self) -> int:
        return int(self.signals.shape[0])

    @property
    def class_names(self) -> tuple[str, ...]:
        """The classes that have trials, in the order of ``classes``."""
        present = set(np.unique(self.label).tolist())
        return tuple(c for i, c in enumerate(self.classes) if i in present)

    @property
    def specimens(self) -> tuple[str, ...]:
        """The specimens (shapes) that have trials, in the order of ``classes``."""
        present = set(np.unique(self.shape).tolist())
        names = dict.fromkeys(c.split("/", 1)[0] for c in self.classes)
        return tuple(s for s in names if s in present)

    @property
    def materials(self) -> tuple[str, ...]:
        """The materials that have trials, in the order of ``classes``."""
        present = set(np.unique(self.material).tolist())
        names = dict.fromkeys(c.split("/", 1)[1] for c in self.classes)
        return tuple(m for m in names if m in present)

    def subset(self, mask_or_index: np.ndarray) -> Dataset:
        """The trials selected by a boolean mask or an index array (same attrs)."""
        idx = np.asarray(mask_or_index)
        take = (lambda a: a[idx]) if idx.dtype == bool else (lambda a: a[idx.astype(np.intp)])
        return Dataset(
            signals=take(self.signals),
            shape=take(self.shape),
            material=take(self.material),
            label=take(self.label),
            force_n=take(self.force_n),
            speed_mm_s=take(self.speed_mm_s),
            seed=take(self.seed),
            classes=self.classes,
            attrs=dict(self.attrs),
        )
