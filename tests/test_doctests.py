"""The Examples sections of the public API run as written (numpydoc docstrings)."""

from __future__ import annotations

import doctest
import importlib

import pytest

#: Modules whose docstring examples are part of the documentation users read.
MODULES = (
    "shapes.specimen",
    "synth.simulator",
    "synth.calibration.settings",
    "synth.generation",
    "synth.store.loader",
    "benchmark.diagnose.analysis",
    "models",
    "models.base",
    "models.registry",
    "models.features",
    "models.afop",
    "models.afo_mlp",
    "models.direct_prot",
    "models.maml",
    "models.cwt_resnet",
    "models.cnn",
    "models.bilstm",
    "benchmark",
    "benchmark.tasks",
    "benchmark.labels",
    "benchmark.results",
    "benchmark.cells",
    "benchmark.engine",
    "benchmark.workers",
    "benchmark.protocols",
)


@pytest.mark.slow
@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples_run(name):
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    tests = [t for t in finder.find(module, name) if t.examples]
    assert tests, f"{name} has no docstring examples"
    for test in tests:
        runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{result.failed} docstring example(s) of {name} failed"
