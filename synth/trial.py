"""One simulated trial: what to simulate (``TrialSpec``) and what comes out (``Trial``)."""

from __future__ import annotations

import zlib
from dataclasses import dataclass, field

import numpy as np

from shapes import SHAPE_NAMES
from shapes.specimen import NAME_PATTERN, NAME_RULE
from tactile_synth.validation import check_choice, check_int, check_positive

from .materials import MATERIAL_NAMES

#: The paper's tactile channels 1-4: two PVDF films (dynamic), two strain gauges (static).
CHANNELS: tuple[str, ...] = ("pvdf1", "pvdf2", "sg1", "sg2")
#: Acquisition rate of the virtual DAQ, as the paper's NI USB-6346 recording.
SAMPLE_RATE_HZ: int = 1000
#: Length of the analysed window taken from the contact phase.
WINDOW_S: float = 2.0
#: Samples per trial window.
N_SAMPLES: int = round(SAMPLE_RATE_HZ * WINDOW_S)

#: The 36 class names ``"<shape>/<material>"``, shape-major in the paper's order.
CLASS_NAMES: tuple[str, ...] = tuple(f"{s}/{m}" for s in SHAPE_NAMES for m in MATERIAL_NAMES)


_PAPER_INDEX = {name: i for i, name in enumerate(CLASS_NAMES)}


def class_index(shape: str, material: str) -> int:
    """Index of ``"<shape>/<material>"`` in :data:`CLASS_NAMES` (the paper's classes)."""
    check_choice("shape", shape, SHAPE_NAMES)
    check_choice("material", material, MATERIAL_NAMES)
    return CLASS_NAMES.index(f"{shape}/{material}")


def check_name(arg: str, name: object) -> str:
    """``name`` if it can be one part of a class name ``"<specimen>/<material>"`` (lower-case
    letters, digits, ``_`` and ``-``, at most 64); else ``ValueError`` naming ``arg``."""
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        raise ValueError(f"{arg} must hold only {NAME_RULE}; got {name!r}")
    return name


def class_key(name: str) -> int:
    """The number a class's name gives every trial seed of the class
    (:func:`synth.presets.trial_seed`, the simulator's root ``SeedSequence``): the index
    into :data:`CLASS_NAMES` for the paper's 36 classes, so their trials keep their
    randomness in any grid, and for any other ``"<specimen>/<material>"`` its CRC-32 with
    the top bit set (``zlib.crc32(name) | 0x80000000``: a fixed 32-bit number that never
    equals a paper index). Two other classes may share a key (a 1 in 2**31 chance per
    pair): their trials then draw the same random numbers, each on its own specimen and
    material."""
    index = _PAPER_INDEX.get(name)
    if index is not None:
        return index
    return zlib.crc32(name.encode("utf-8")) | 0x80000000


@dataclass(frozen=True)
class TrialSpec:
    """Everything that determines one trial. ``seed`` is the trial's own seed: all
    per-trial variability (path offset, yaw, jitter, scatter, noise) derives from it,
    so ``simulate(**spec)`` reproduces a dataset row bit for bit."""

    shape: str  # a built-in shape or a specimen of the simulator's configuration
    material: str  # a material of the simulator's configuration
    force_n: float = 1.0
    speed_mm_s: float = 10.0
    seed: int = 0

    def __post_init__(self) -> None:
        # Any names: the simulator resolves them against its configuration (a built-in
        # shape or one of its specimens; one of its materials).
        check_name("shape", self.shape)
        check_name("material", self.material)
        check_positive("force_n", self.force_n, unit="N")
        check_positive("speed_mm_s", self.speed_mm_s, unit="mm/s")
        check_int("seed", self.seed, minimum=0)


@dataclass(frozen=True)
class Trial:
    """Result of one trial.

    signals: float32 ``(4, N_SAMPLES)`` volts at the DAQ, channel order :data:`CHANNELS`.
    truth: ground truth on the same 1 kHz clock and window, at least
        ``normal_force_n``, ``tangential_force_n``, ``finger_x_m`` (each ``(N_SAMPLES,)``).
    """

    spec: TrialSpec
    signals: np.ndarray
    truth: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def class_name(self) -> str:
        """``"<shape>/<material>"``."""
        return f"{self.spec.shape}/{self.spec.material}"

    @property
    def label(self) -> int:
        """Index of the trial's class in :data:`CLASS_NAMES` (the paper's classes only; a
        dataset's labels index its own ``classes``)."""
        return class_index(self.spec.shape, self.spec.material)
