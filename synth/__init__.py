"""MuJoCo simulation of the tactile finger, its virtual sensor chain, and dataset I/O."""

import tactile_synth.threads  # noqa: F401  (first: sizes thread pools before numpy/torch load)

from .config import PVDF, Acquisition, Finger, Motion, StrainGauge, SynthConfig, Variability
from .dataset import Dataset
from .generation import generate
from .materials import MATERIAL_NAMES, MATERIALS, Material, Periodic, Texture
from .presets import PRESETS, GenerationConfig
from .simulator import SimulationError, simulate, simulate_batch
from .store import load_dataset
from .trial import CHANNELS, CLASS_NAMES, N_SAMPLES, SAMPLE_RATE_HZ, Trial, TrialSpec

__all__ = [
    "CHANNELS",
    "CLASS_NAMES",
    "MATERIALS",
    "MATERIAL_NAMES",
    "N_SAMPLES",
    "PRESETS",
    "PVDF",
    "SAMPLE_RATE_HZ",
    "Acquisition",
    "Dataset",
    "Finger",
    "GenerationConfig",
    "Material",
    "Motion",
    "Periodic",
    "SimulationError",
    "StrainGauge",
    "SynthConfig",
    "Texture",
    "Trial",
    "TrialSpec",
    "Variability",
    "generate",
    "load_dataset",
    "simulate",
    "simulate_batch",
]
