"""Real recordings into a dataset store (``tactile-synth import``).

The input is a folder with one recording per trial, a CSV or NPZ file of the four
channels ``pvdf1, pvdf2, sg1, sg2`` in volts, and a table of labels (CSV) naming each
file's shape, material, normal force and sliding speed (docs/recordings.md has the
layout with an example). Each recording is checked, brought to the DAQ rate of the
simulator (:data:`synth.trial.SAMPLE_RATE_HZ`) with an anti-aliasing polyphase filter,
and cut to one 2 s window (:data:`synth.trial.N_SAMPLES`): centred on the contact phase
found in the strain-gauge channels, or from a given start. The windows go into the same
Zarr store the simulator writes (kind ``"imported"``, see :mod:`synth.store`), so
``load_dataset``, ``inspect``, ``diagnose`` and ``benchmark`` read it unchanged.

Every problem is reported with the file and line at fault. The store is built beside
``--out`` under the dataset's lock and renamed into place only once complete and
verified: a failed or interrupted import leaves nothing behind and any previous dataset
whole.

The package's modules, one job each: :mod:`.errors` (limits and errors), :mod:`.labels`
(the labels table), :mod:`.recording` (one recording read and checked), :mod:`.window`
(sample rate, resampling, the window) and :mod:`.build` (the import into a store).
"""

from __future__ import annotations

from .build import ImportSummary, import_recordings
from .errors import LABEL_COLUMNS, RecordingError, RecordingWarning
from .labels import LabelRow, read_labels
from .recording import Recording, read_recording
from .window import contact_phase

__all__ = [
    "LABEL_COLUMNS",
    "ImportSummary",
    "LabelRow",
    "Recording",
    "RecordingError",
    "RecordingWarning",
    "contact_phase",
    "import_recordings",
    "read_labels",
    "read_recording",
]
