"""The packages' public API: every name ``models`` and ``benchmark`` export resolves to
the object its module defines, ``__all__`` lists exactly the exports, and importing the
packages stays cheap (``import models`` loads no torch, ``import benchmark`` neither torch
nor the simulator)."""

from __future__ import annotations

import importlib
import json
import subprocess
import sys
from pathlib import Path

import pytest

import benchmark
import models

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize(
    ("package", "expected"),
    [
        (models, {name: f"models.{module}" for name, module in models._EXPORTS.items()}),
        (
            benchmark,
            {name: f"benchmark.{module}" for name, (module, _) in benchmark._EXPORTS.items()},
        ),
    ],
)
def test_every_export_is_the_object_its_module_defines(package, expected):
    assert sorted(package.__all__) == sorted([*expected, *getattr(package, "_SUBPACKAGES", ())])
    for name, module in expected.items():
        attr = name if package is models else benchmark._EXPORTS[name][1]
        assert getattr(package, name) is getattr(importlib.import_module(module), attr), name
    assert set(package.__all__) <= set(dir(package))


def test_subpackages_are_attributes_and_unknown_names_raise():
    assert benchmark.protocols.run.__module__ == "benchmark.protocols"
    assert benchmark.diagnose.diagnose.__module__ == "benchmark.diagnose.analysis"
    with pytest.raises(AttributeError, match="no attribute 'nothing_here'"):
        _ = benchmark.nothing_here
    with pytest.raises(AttributeError, match="no attribute 'nothing_here'"):
        _ = models.nothing_here


def test_the_main_names_are_the_ones_users_call():
    assert models.make_method("Direct-Prot-ML").name == "Direct-Prot-ML"
    assert isinstance(models.make_method("Direct-Prot-ML"), models.FewShotMethod)
    assert models.METHOD_NAMES[0] == "AFOP-ML"
    assert benchmark.get_protocol("closed-set").name == "closed-set"
    assert issubclass(type(benchmark.get_protocol("perturbation")), benchmark.Protocol)


def _loaded_after(statement: str, modules: tuple[str, ...]) -> list[str]:
    code = (
        f"import json, sys; {statement}; "
        f"print(json.dumps(sorted(m for m in {modules!r} if m in sys.modules)))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True
    )
    return json.loads(out.stdout)


def test_importing_the_packages_stays_cheap():
    heavy = ("torch", "synth", "mujoco", "matplotlib", "sklearn")
    assert _loaded_after("import models", heavy) == []
    assert _loaded_after("import benchmark", heavy) == []
    # The registry's names need no method class: still no torch.
    assert _loaded_after("import models; models.METHOD_NAMES; models.make_method", heavy) == []
