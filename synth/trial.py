"""One simulated trial: what to simulate (``TrialSpec``) and what comes out (``Trial``)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from shapes import SHAPE_NAMES
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


def class_index(shape: str, material: str) -> int:
    """Index of ``"<shape>/<material>"`` in :data:`CLASS_NAMES`."""
    check_choice("shape", shape, SHAPE_NAMES)
    check_choice("material", material, MATERIAL_NAMES)
    return CLASS_NAMES.index(f"{shape}/{material}")


@dataclass(frozen=True)
class TrialSpec:
    """Everything that determines one trial. ``seed`` is the trial's own seed: all
    per-trial variability (path offset, yaw, jitter, scatter, noise) derives from it,
    so ``simulate(**spec)`` reproduces a dataset row bit for bit."""

    shape: str
    material: str
    force_n: float = 1.0
    speed_mm_s: float = 10.0
    seed: int = 0

    def __post_init__(self) -> None:
        check_choice("shape", self.shape, SHAPE_NAMES)
        check_choice("material", self.material, MATERIAL_NAMES)
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
    def label(self) -> int:
        return class_index(self.spec.shape, self.spec.material)
