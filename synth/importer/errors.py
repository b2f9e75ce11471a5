"""The import's limits and its errors: each names the file and line at fault."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: Columns every labels table has: the recording file (relative to the recordings
#: folder), the class, and the trial's nominal force and speed set-points.
REQUIRED_COLUMNS: tuple[str, ...] = ("file", "shape", "material", "force_n", "speed_mm_s")
#: Optional columns: ``trial`` (trial number within its class and condition) and ``seed``
#: (an integer id of the trial) must be filled on every row when present;
#: ``sample_rate_hz`` and ``window_start_s`` may be left empty on some rows.
OPTIONAL_COLUMNS: tuple[str, ...] = ("trial", "seed", "sample_rate_hz", "window_start_s")
LABEL_COLUMNS: tuple[str, ...] = REQUIRED_COLUMNS + OPTIONAL_COLUMNS
#: Default name of the labels table inside the recordings folder.
LABELS_FILE = "labels.csv"
#: Optional column (CSV) or array (NPZ) of sample times in seconds.
TIME_COLUMN = "time_s"
RECORDING_SUFFIXES: tuple[str, ...] = (".csv", ".npz")

#: Highest sample rate accepted: twice the 500 kS/s per channel of the paper's DAQ
#: (NI USB-6346); a larger value is a unit mistake (e.g. samples per minute).
MAX_SAMPLE_RATE_HZ: float = 1e6
#: Lowest sample rate accepted: a 2 s window at 10 Hz holds 20 samples, too few to show
#: a slide; a smaller value is a unit mistake (e.g. kHz for Hz).
MIN_SAMPLE_RATE_HZ: float = 10.0
#: Longest recording accepted, in seconds at SAMPLE_RATE_HZ (checked before resampling):
#: an hour is far beyond one slide and its four channels stay near 100 MB in memory.
MAX_RECORDING_S: float = 3600.0
#: Largest magnitude of a sample: the store holds float32 volts.
MAX_SAMPLE_V: float = float(np.finfo(np.float32).max)
#: Two statements of one recording's sample rate (the labels table, the file, the time
#: column, --sample-rate) must agree this closely (relative): 0.5 % of the 2 s window is
#: 10 ms, 0.1 mm of sliding at 10 mm/s, a fifth of the 0.5 mm fingerprint ridge period.
RATE_TOLERANCE: float = 0.005
#: A step of the time column may differ from the mean step by this fraction: rounding of
#: printed times stays far below it, a dropped or repeated sample does not.
TIME_STEP_TOLERANCE: float = 0.1
#: Largest denominator of the resampling ratio 1000 / rate (resample_poly's up/down):
#: any rate written with five significant digits is resampled exactly.
MAX_RATIO_DENOMINATOR: int = 100_000

#: The strain gauges are smoothed over 50 ms before the contact phase is looked for:
#: longer than the PVDF-like vibration and noise, shorter than crossing a 16 mm outline
#: at the paper's 10 mm/s (1.6 s).
CONTACT_SMOOTH_S: float = 0.05
#: The first and last tenth of a recording give the strain gauges' rest level (the
#: finger off the specimen, before and after the slide).
REST_FRACTION: float = 0.1
#: A sample belongs to the contact phase when a strain gauge deviates from its rest level
#: by at least this fraction of its largest deviation: a twentieth keeps the light load of
#: a finger sliding on the plate, which can be several times smaller than the bending
#: while it rides onto the outline, while slow drift and ripple stay below it.
CONTACT_FRACTION: float = 0.05
#: ... and by at least this many times the robust standard deviation of its smoothed rest
#: level; a gauge whose largest deviation stays below that shows no contact at all.
CONTACT_SNR: float = 10.0
#: Rest noise is taken as at least one step of a 16-bit +-10 V DAQ such as the paper's
#: (20 V / 2**16): a quantised, otherwise constant rest level has no smaller change.
DAQ_STEP_V: float = 20.0 / 2**16

#: How the windows are cut, recorded in the provenance of every trial.
WINDOW_CONTACT = "contact"  # centred on the contact phase found in sg1/sg2
WINDOW_GIVEN = "given"  # from --window-start or the window_start_s column
WINDOW_WHOLE = "whole"  # the recording is exactly one window long


class RecordingError(ValueError):
    """Bad input recordings or labels. ``problems`` lists each one, naming the file and
    line at fault; ``str()`` shows the first three on one line."""

    def __init__(self, problems: Sequence[str]) -> None:
        self.problems = list(problems)
        if len(self.problems) == 1:
            text = self.problems[0]
        else:
            shown = "; ".join(self.problems[:3])
            more = len(self.problems) - 3
            text = f"{len(self.problems)} problems: {shown}" + (
                f"; and {more} more" if more > 0 else ""
            )
        super().__init__(text)


class RecordingWarning(UserWarning):
    """Something the import changed or left out that the user should know (resampling,
    recordings in the folder that the labels table does not list)."""


class Bad(Exception):
    """One problem with one recording (collected into a :class:`RecordingError`)."""
