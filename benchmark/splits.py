"""Train/test splits of the generalisation protocols (paper Section V-A, settings 2 and 3).

Cross-shape: the 12 shapes fall into 3 fixed folds of 4 test shapes; a fold trains on the
other 8 shapes (all three materials) and tests on its 4 unseen shapes. The folds are fixed
(not drawn at random) so every run, seed and method sees the same geometry split, and were
chosen deliberately so that each fold's test set is a mix of geometric families and each
fold's training set still holds every family:

========  =========================================  =====================================
fold      test shapes                                why
========  =========================================  =====================================
0         circle, moon, square, triangle             2 curved (1 convex, 1 concave), 1 quad,
                                                     the only 3-gon
1         ellipse, hexagon, pentagram, rhombus       1 curved, 1 regular n-gon, the concave
                                                     star, 1 quad
2         semicircle, pentagon, parallelogram,       1 curved with a straight edge, 1
          trapezoid                                  regular n-gon, 2 quads
========  =========================================  =====================================

Curved outlines (circle, ellipse, semicircle, moon) are spread 2/1/1 and the four
quadrilaterals 1/1/2, the two concave outlines (moon, pentagram) sit in different folds,
and each test shape keeps a geometric relative in training (circle/ellipse,
moon/semicircle, square/rhombus, pentagon/hexagon), as in a real study where one wants to
know whether *related* geometry transfers, not whether a wholly new family does.

Any other set of specimens (a subset of the paper's, or a lab's own) is split by a rule
(:func:`specimen_folds`): ``k = min(3, n)`` folds, the ``i``-th specimen in the
dataset's order testing in fold ``i mod k``; a dataset needs at least 2 specimens.

Cross-material: "leave-one-material-in": train on the classes of one material, test on
the classes of the others (the paper: train on 12 classes, test on 24); a dataset needs
at least 2 materials.

Closed-set (and the perturbation protocol's fit): a seeded 50:50 split of every class
(:func:`split_halves`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from shapes import SHAPE_NAMES, is_curved
from synth import Dataset
from synth.presets import condition_name, parse_condition
from tactile_synth.validation import check_choice, check_int

__all__ = [
    "CROSS_SHAPE_FOLDS",
    "CURVED_SHAPES",
    "NotApplicable",
    "Split",
    "condition_name",
    "cross_material_split",
    "cross_material_splits",
    "cross_shape_split",
    "cross_shape_splits",
    "cross_shape_test_shapes",
    "parse_condition",
    "specimen_folds",
    "split_halves",
]

#: Test shapes of each cross-shape fold (see the module docstring for the rationale).
CROSS_SHAPE_FOLDS: tuple[tuple[str, ...], ...] = (
    ("circle", "moon", "square", "triangle"),
    ("ellipse", "hexagon", "pentagram", "rhombus"),
    ("semicircle", "pentagon", "parallelogram", "trapezoid"),
)

#: The outlines with curved sides, as :func:`shapes.is_curved` defines them.
CURVED_SHAPES: frozenset[str] = frozenset(s for s in SHAPE_NAMES if is_curved(s))


class NotApplicable(ValueError):
    """A protocol cannot apply to a dataset (too few specimens or materials): the message
    says what it needs and what the dataset holds. ``benchmark all`` and ``run`` skip
    such a protocol and say why in the report; ``benchmark PROTOCOL`` fails with it."""


@dataclass(frozen=True)
class Split:
    """Boolean masks over one dataset's trials: ``train`` ``(n,)`` and ``test`` ``(n,)``.

    ``fold`` is the fold number (cross-shape) or the training material (cross-material);
    ``train_values`` / ``test_values`` the shapes or materials on each side.
    """

    fold: int | str
    train: np.ndarray
    test: np.ndarray
    train_values: tuple[str, ...]
    test_values: tuple[str, ...]

    def __post_init__(self) -> None:
        if self.train.shape != self.test.shape or self.train.dtype != bool:
            raise ValueError("train and test must be boolean masks of the same shape")
        if np.any(self.train & self.test):
            raise ValueError("train and test masks overlap")


def cross_shape_test_shapes(fold: int) -> tuple[str, ...]:
    """The 4 unseen test shapes of the paper's cross-shape ``fold`` (0, 1 or 2)."""
    check_int("fold", fold, minimum=0)
    if fold >= len(CROSS_SHAPE_FOLDS):
        raise ValueError(f"fold must be in 0..{len(CROSS_SHAPE_FOLDS) - 1}; got {fold}")
    return CROSS_SHAPE_FOLDS[fold]


#: Folds of the cross-shape protocol on a dataset of other specimens than the paper's 12.
MAX_SPECIMEN_FOLDS: int = 3


def specimen_folds(specimens: Sequence[str]) -> tuple[tuple[str, ...], ...]:
    """The cross-shape folds' test specimens for a dataset holding ``specimens`` (in the
    dataset's class order): the paper's hand-picked :data:`CROSS_SHAPE_FOLDS` when they
    are exactly the paper's 12 shapes; otherwise ``k = min(3, n)`` folds, specimen ``i``
    testing in fold ``i mod k`` (so the folds follow the order an experiment lists its
    specimens in, and each fold trains on every other specimen). ``ValueError`` for
    fewer than 2 specimens."""
    names = tuple(specimens)
    if len(names) < 2:
        raise NotApplicable(
            f"cross-shape needs >= 2 specimens (one to train on, one to test on); this "
            f"dataset has {len(names)}" + (f" ({names[0]})" if names else "")
        )
    if sorted(names) == sorted(SHAPE_NAMES):
        return CROSS_SHAPE_FOLDS
    k = min(MAX_SPECIMEN_FOLDS, len(names))
    return tuple(tuple(names[i] for i in range(f, len(names), k)) for f in range(k))


def cross_shape_split(data: Dataset, fold: int) -> Split:
    """Train on the specimens outside ``fold`` (all materials), test on the fold's
    specimens (:func:`specimen_folds` of the dataset's specimens)."""
    folds = specimen_folds(data.specimens)
    check_int("fold", fold, minimum=0)
    if fold >= len(folds):
        raise ValueError(f"fold must be in 0..{len(folds) - 1}; got {fold}")
    test_shapes = folds[fold]
    train_shapes = tuple(s for s in data.specimens if s not in test_shapes)
    test = np.isin(data.shape, test_shapes)
    train = np.isin(data.shape, train_shapes)
    return Split(fold, train, test, train_shapes, test_shapes)


def cross_material_split(data: Dataset, train_material: str) -> Split:
    """Train on ``train_material``'s classes, test on the other materials' classes."""
    materials = _materials(data)
    check_choice("train_material", train_material, materials)
    test_materials = tuple(m for m in materials if m != train_material)
    train = data.material == train_material
    test = np.isin(data.material, test_materials)
    return Split(train_material, train, test, (train_material,), test_materials)


def _materials(data: Dataset) -> tuple[str, ...]:
    materials = data.materials
    if len(materials) < 2:
        raise NotApplicable(
            f"cross-material needs >= 2 materials (one to train on, one to test on); this "
            f"dataset has {len(materials)}" + (f" ({materials[0]})" if materials else "")
        )
    return materials


def cross_shape_splits(data: Dataset) -> list[Split]:
    """Every cross-shape fold of the dataset (:func:`specimen_folds`)."""
    return [cross_shape_split(data, f) for f in range(len(specimen_folds(data.specimens)))]


def cross_material_splits(data: Dataset) -> list[Split]:
    """One leave-one-material-in split per material, in the dataset's order."""
    return [cross_material_split(data, m) for m in _materials(data)]


def split_halves(labels: np.ndarray, *, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Seeded 50:50 split per class: ``(train_idx, test_idx)`` sorted index arrays.

    A class with an odd count gives its extra trial to the test half; a class with one
    trial goes entirely to the test half.
    """
    y = np.asarray(labels)
    if y.ndim != 1 or y.size == 0:
        raise ValueError(f"labels must be a non-empty 1-D array; got shape {y.shape}")
    check_int("seed", seed, minimum=0)
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0xC105ED]))
    train: list[np.ndarray] = []
    test: list[np.ndarray] = []
    for c in np.unique(y):
        idx = rng.permutation(np.flatnonzero(y == c))
        half = idx.size // 2
        train.append(idx[:half])
        test.append(idx[half:])
    return np.sort(np.concatenate(train)), np.sort(np.concatenate(test))


def _check_folds() -> None:
    flat = [s for fold in CROSS_SHAPE_FOLDS for s in fold]
    if sorted(flat) != sorted(SHAPE_NAMES):
        raise AssertionError("CROSS_SHAPE_FOLDS must partition SHAPE_NAMES")


_check_folds()
