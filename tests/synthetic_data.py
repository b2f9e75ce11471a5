"""A tiny synthetic :class:`synth.Dataset` for tests of models and benchmark code.

Each class gets its own frequencies and amplitudes on the four channels, so with low
``noise`` the classes are separable by construction; ``shuffle_labels`` breaks the link
between signals and labels (chance-level control).
"""

from __future__ import annotations

import numpy as np

from shapes import SHAPE_NAMES
from synth import CLASS_NAMES, MATERIAL_NAMES, Dataset


def make_dataset(
    *,
    trials_per_class: int = 10,
    shapes: tuple[str, ...] = SHAPE_NAMES,
    materials: tuple[str, ...] = MATERIAL_NAMES,
    n_samples: int = 2000,
    noise: float = 0.3,
    shuffle_labels: bool = False,
    force_n: float = 1.0,
    speed_mm_s: float = 10.0,
    seed: int = 0,
) -> Dataset:
    rng = np.random.default_rng(seed)
    t = np.arange(n_samples) / 1000.0
    rows = []
    meta = []
    for s_i, shape in enumerate(shapes):
        for m_i, material in enumerate(materials):
            # Shape sets the slow (SG-like) pattern, material the fast (PVDF-like) one.
            f_slow = 0.5 + 0.35 * SHAPE_NAMES.index(shape)
            f_fast = 40.0 + 35.0 * MATERIAL_NAMES.index(material)
            for k in range(trials_per_class):
                phase = rng.uniform(0, 2 * np.pi)
                sig = np.stack(
                    [
                        0.5 * np.sin(2 * np.pi * f_fast * t + phase),
                        0.4 * np.sin(2 * np.pi * (f_fast * 1.3) * t + phase),
                        1.0 + 0.3 * s_i / len(shapes) + 0.2 * np.sin(2 * np.pi * f_slow * t),
                        0.5 + 0.1 * m_i + 0.2 * np.cos(2 * np.pi * f_slow * t),
                    ]
                )
                sig = sig + noise * rng.standard_normal(sig.shape)
                rows.append(sig.astype(np.float32))
                meta.append((shape, material, k))
    shape_arr = np.array([m[0] for m in meta])
    material_arr = np.array([m[1] for m in meta])
    label = np.array([CLASS_NAMES.index(f"{s}/{m}") for s, m, _ in meta], dtype=np.int64)
    if shuffle_labels:
        perm = rng.permutation(len(label))
        label, shape_arr, material_arr = label[perm], shape_arr[perm], material_arr[perm]
    n = len(rows)
    return Dataset(
        signals=np.stack(rows),
        shape=shape_arr,
        material=material_arr,
        label=label,
        force_n=np.full(n, force_n),
        speed_mm_s=np.full(n, speed_mm_s),
        seed=np.arange(n, dtype=np.int64),
        attrs={"source": "tests/synthetic_data.py", "seed": seed},
    )
