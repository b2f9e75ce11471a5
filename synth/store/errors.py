"""The errors a dataset store raises: each says what is wrong and what to run."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path


class DatasetError(ValueError):
    """A dataset problem the user must act on. ``problem`` says what is wrong, ``fix``
    what to run (as ``tactile-synth generate`` options); ``str()`` is both on one line."""

    def __init__(self, problem: str, fix: str = "") -> None:
        self.problem = problem
        self.fix = fix
        super().__init__(f"{problem}; {fix}" if fix else problem)


class DatasetLocked(DatasetError):
    """Another process is writing the dataset (``pid``: its process id, if known)."""

    def __init__(self, path: Path, pid: int | None) -> None:
        self.pid = pid
        who = f"process {pid}" if pid is not None else "another process"
        super().__init__(
            f"dataset {path} is being written by {who} (tactile-synth generate)",
            f"wait for it to finish or stop it{f' (kill {pid})' if pid else ''}, then retry",
        )


class DatasetIncomplete(DatasetError):
    """Not every chunk of the dataset is done. ``str()`` also offers the Python API's
    ``allow_incomplete=True``; ``cli_message`` is the same advice without it, for
    command-line users, who finish the store with ``fix`` instead."""

    def __init__(self, problem: str, fix: str, api_fix: str = "") -> None:
        self.cli_message = f"{problem}; {fix}"
        super().__init__(problem, f"{fix}, or {api_fix}" if api_fix else fix)
        self.fix = fix


@dataclass(frozen=True)
class Problem:
    """One damaged part of a store: ``what`` (e.g. ``"chunk 3"``, ``"label"``), the
    ``file`` holding it, ``why`` it fails, and for a chunk its index and trials."""

    what: str
    file: Path
    why: str
    chunk: int | None = None
    trials: str = ""

    def __str__(self) -> str:
        where = f"{self.trials}, file {self.file}" if self.trials else f"file {self.file}"
        return f"{self.what} ({where}) {self.why}"
