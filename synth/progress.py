"""Progress of the long dataset commands (``generate``, ``import``, ``export``) on stderr.

On a terminal a tqdm bar redraws one line in place. Where stderr is not a terminal (a CI
log, ``2>log``) a redrawn bar would fill the log with carriage returns, so plain lines are
printed instead, ``[tactile-synth] DESC: DONE/TOTAL UNITs (P%) ...``: one each time the
work done passes another tenth of the total. The count of lines depends only on how the
work is split (a line is printed at most once per update), never on timing; a run of
one update prints one line.
"""

from __future__ import annotations

import math
import sys
import time
from typing import Any, Protocol

from .summary import counted

#: Line mode prints when the share of the work done reaches the next multiple of this
#: many percent (and at 100 %).
LINE_STEP_PERCENT = 10


class Progress(Protocol):
    """What the commands call: ``update(n)`` after ``n`` more units of work, ``close()``
    at the end (a tqdm bar has both)."""

    def update(self, n: int = 1) -> Any: ...

    def close(self) -> None: ...


class NoProgress:
    """Progress that prints nothing (``progress=False``)."""

    def update(self, n: int = 1) -> None:
        pass

    def close(self) -> None:
        pass


class LineProgress:
    """Plain progress lines on ``file`` (default stderr): one whenever the work done
    reaches the next :data:`LINE_STEP_PERCENT` step, with the time taken and left."""

    def __init__(
        self, total: int, *, desc: str, unit: str, initial: int = 0, file: Any = None
    ) -> None:
        self.total = int(total)
        self.n = int(initial)
        self.desc = desc
        self.unit = unit
        self.file = file
        self._initial = self.n
        self._start = time.perf_counter()
        self._next = self._step_after(self._percent())

    def _percent(self) -> int:
        return self.n * 100 // self.total if self.total > 0 else 100

    @staticmethod
    def _step_after(percent: int) -> int:
        return (percent // LINE_STEP_PERCENT + 1) * LINE_STEP_PERCENT

    def update(self, n: int = 1) -> None:
        self.n += int(n)
        percent = self._percent()
        if percent < min(self._next, 100):
            return
        self._next = self._step_after(percent)
        elapsed = time.perf_counter() - self._start
        line = (
            f"[tactile-synth] {self.desc}: {self.n}/{counted(self.total, self.unit)} "
            f"({percent}%) in {elapsed:.1f} s"
        )
        done_here = self.n - self._initial
        if self.n < self.total and done_here > 0:
            left = elapsed * (self.total - self.n) / done_here
            line += f", about {math.ceil(left)} s left"
        print(line, file=self.file or sys.stderr, flush=True)

    def close(self) -> None:
        pass


def progress(
    total: int,
    *,
    desc: str,
    unit: str = "trial",
    initial: int = 0,
    enabled: bool = True,
    **bar_options: Any,
) -> Progress:
    """Progress of ``total`` units (``initial`` of them already done) on stderr: a tqdm
    bar (``bar_options`` passed on) on a terminal, :class:`LineProgress` elsewhere,
    nothing unless ``enabled``."""
    if not enabled:
        return NoProgress()
    if sys.stderr.isatty():
        from tqdm import tqdm

        return tqdm(total=total, initial=initial, unit=unit, desc=desc, **bar_options)
    return LineProgress(total, desc=desc, unit=unit, initial=initial)
