"""Helpers several test modules share: a stand-in simulator for CLI tests, the loader of
the repository's scripts, and the JSON field set of a record kind."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = ROOT / "scripts"


def class_signals(specs, synth, threads) -> np.ndarray:
    """A stand-in simulator (tests of the CLI, not of physics): class-specific sines plus
    noise seeded per trial, float32 ``(n, 4, 2000)``."""
    from synth.trial import class_index

    t = np.arange(2000) / 1000.0
    rows = []
    for s in specs:
        c = class_index(s.shape, s.material)
        rng = np.random.default_rng(s.seed)
        sig = np.sin(2 * np.pi * (1 + c) * t + rng.uniform(0, 6.28, (4, 1)))
        rows.append((sig + 0.3 * rng.standard_normal((4, 2000))).astype(np.float32))
    return np.stack(rows)


def load_script(name: str) -> ModuleType:
    """``scripts/<name>.py`` as a module (the scripts are not a package). The caller puts
    ``scripts/`` on ``sys.path`` first when the script imports its shared helper."""
    spec = importlib.util.spec_from_file_location(f"{name}_script", SCRIPTS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def record_fields(kind: type) -> set[str]:
    """The JSON fields every record of ``kind`` (a benchmark.results record class) holds."""
    return set(kind.names())
