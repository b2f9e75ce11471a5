"""The benchmark: few-shot episodes, the paper's four protocols, interpretability, the
report and ``tactile-synth run``.

A protocol (:class:`Protocol`) turns datasets into tasks (:class:`Task`: a fit
:class:`Pool`, a test pool and a grid of N-way K-shot :class:`Cell` objects with their
episode seeds); the engine (:func:`run_protocol`, :func:`run_tasks`) fits every method
once per task and evaluates every cell, in this process or in worker processes
(:class:`ProcessPool`); the records (:mod:`benchmark.results`) are read back with
:func:`read_results` and queried with :func:`select`.

What users call:

- a protocol by name: ``benchmark.protocols.run(name, data, methods=..., episodes=...)``,
  :func:`get_protocol`, :data:`PROTOCOL_NAMES`;
- the engine: :func:`run_protocol`, :func:`run_tasks`, :func:`run_task_sets`,
  :class:`EpisodeBudget`, :class:`Budget`, :class:`Features`, :class:`ProcessPool`;
- writing a protocol: :class:`Protocol`, :class:`Task`, :class:`Pool`, :class:`Cell`,
  :func:`child_seed`, :exc:`NotApplicable` (``docs/protocols.md``);
- results: :func:`select`, :func:`read_results`, :func:`write_results`;
- whole jobs, as the command line runs them: :func:`run_all` (``tactile-synth run``:
  generate the datasets, then everything), :func:`benchmark_all` (every protocol,
  interpretability, report and figures on given datasets), :func:`benchmark_protocol`
  (``tactile-synth benchmark PROTOCOL``), :func:`run_stress` (``tactile-synth stress``);
- a dataset's diagnosis: ``benchmark.diagnose.diagnose(data)`` (the subpackage
  :mod:`benchmark.diagnose`).

The subpackages and the names above are imported on first use, so ``import benchmark``
stays cheap.

Examples
--------
>>> import benchmark
>>> from tests.synthetic_data import make_dataset
>>> data = make_dataset(trials_per_class=6, n_samples=200, noise=0.2)
>>> records = benchmark.protocols.run("closed-set", data, methods=["Direct-Prot-ML"],
...                                   episodes=10, seed=0)
>>> [r["way"] for r in benchmark.select(records, "accuracy", shot=1)]
[5, 10, 12, 28, 36]
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

import tactile_synth.threads  # noqa: F401  (first: sizes thread pools before numpy/torch load)

if TYPE_CHECKING:
    from . import diagnose, protocols, stress
    from .budget import Budget, EpisodeBudget
    from .cells import Features
    from .engine import FitExecutor, run_protocol, run_task_sets, run_tasks
    from .protocols import PROTOCOL_NAMES, available_protocols
    from .protocols import get as get_protocol
    from .results import Record, read_results, select, write_results
    from .run import benchmark_all
    from .run import run as run_all
    from .single import benchmark_protocol
    from .splits import NotApplicable
    from .stress.command import run_stress
    from .tasks import Cell, Pool, Protocol, Task, child_seed
    from .workers import ProcessPool

#: Public name -> (module, its name there), imported on first use.
_EXPORTS: dict[str, tuple[str, str]] = {
    **{n: ("budget", n) for n in ("Budget", "EpisodeBudget")},
    "Features": ("cells", "Features"),
    **{n: ("engine", n) for n in ("FitExecutor", "run_protocol", "run_task_sets", "run_tasks")},
    "PROTOCOL_NAMES": ("protocols", "PROTOCOL_NAMES"),
    "available_protocols": ("protocols", "available_protocols"),
    "get_protocol": ("protocols", "get"),
    **{n: ("results", n) for n in ("Record", "read_results", "select", "write_results")},
    "benchmark_all": ("run", "benchmark_all"),
    "run_all": ("run", "run"),
    "benchmark_protocol": ("single", "benchmark_protocol"),
    "NotApplicable": ("splits", "NotApplicable"),
    "run_stress": ("stress.command", "run_stress"),
    **{n: ("tasks", n) for n in ("Cell", "Pool", "Protocol", "Task", "child_seed")},
    "ProcessPool": ("workers", "ProcessPool"),
}
#: Subpackages reachable as attributes before anything imported them.
_SUBPACKAGES: tuple[str, ...] = ("diagnose", "protocols", "stress")

__all__ = [
    "PROTOCOL_NAMES",
    "Budget",
    "Cell",
    "EpisodeBudget",
    "Features",
    "FitExecutor",
    "NotApplicable",
    "Pool",
    "ProcessPool",
    "Protocol",
    "Record",
    "Task",
    "available_protocols",
    "benchmark_all",
    "benchmark_protocol",
    "child_seed",
    "diagnose",
    "get_protocol",
    "protocols",
    "read_results",
    "run_all",
    "run_protocol",
    "run_stress",
    "run_task_sets",
    "run_tasks",
    "select",
    "stress",
    "write_results",
]


def __getattr__(name: str) -> Any:
    if name in _SUBPACKAGES:
        return importlib.import_module(f"{__name__}.{name}")
    if name not in _EXPORTS:
        raise AttributeError(f"module 'benchmark' has no attribute {name!r}")
    module, attr = _EXPORTS[name]
    value = getattr(importlib.import_module(f"{__name__}.{module}"), attr)
    globals()[name] = value  # later lookups skip this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
