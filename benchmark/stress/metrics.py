"""The stress suite's scores, computed from its accuracy records (``docs/stress.md``).

For a method ``m`` and a reading (enrolled at nominal, or all perturbed), with ``A0`` its
accuracy on the clean test set (severity 0) and ``A(f, s)`` its accuracy under family
``f`` at severity ``s``, accuracies as fractions:

- drop ``D(f, s) = A0 - A(f, s)``;
- a family's mean drop: the mean of ``D(f, s)`` over the severities run;
- over families: the mean of the families' mean drops, and the worst (largest) family
  mean drop with its family;
- corruption error, after ImageNet-C's (Hendrycks & Dietterich 2019): with error rates
  ``E = 1 - A``, ``CE(f) = sum_s E_m(f, s) / sum_s E_ref(f, s)`` against a named
  reference method, and ``mCE`` its mean over families; the relative version subtracts
  each method's clean error first, ``rCE(f) = sum_s (E_m(f, s) - E0_m) / sum_s (E_ref(f,
  s) - E0_ref)``, and ``rmCE`` its mean (a family that does not raise the reference's
  error leaves rCE undefined: null). Both are 1 for the reference itself; below 1 is more
  robust than the reference.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class FamilyScore:
    """One method's scores on one family under one reading."""

    method: str
    reading: str
    family: str
    mean_drop: float
    ce: float | None
    relative_ce: float | None


@dataclass(frozen=True)
class MethodScore:
    """One method's scores over the families under one reading."""

    method: str
    reading: str
    clean: float
    mean_drop: float
    worst_drop: float
    worst_family: str
    mce: float | None
    relative_mce: float | None
    reference: str


def _table(records: Iterable[Mapping[str, Any]]) -> dict[tuple[str, str], dict]:
    """``{(method, reading): {"clean": A0, (family, severity): A}}``."""
    out: dict[tuple[str, str], dict] = {}
    for r in records:
        cell = out.setdefault((r["method"], r["reading"]), {})
        if r["family"] is None:
            cell["clean"] = float(r["accuracy"])
        else:
            cell[(r["family"], int(r["severity"]))] = float(r["accuracy"])
    return out


def _ratio(num: float, den: float) -> float | None:
    return float(num / den) if den > 0 else None


def scores(
    records: Iterable[Mapping[str, Any]], *, reference: str, families: Sequence[str]
) -> tuple[list[FamilyScore], list[MethodScore]]:
    """The family and method scores of the stress accuracy records (``family`` None with
    ``severity`` 0 for the clean test set). ``reference`` must be among the methods;
    ``families`` gives the report's order."""
    table = _table(records)
    methods = list(dict.fromkeys(m for m, _ in table))
    readings = list(dict.fromkeys(r for _, r in table))
    if reference not in methods:
        raise ValueError(
            f"the reference method {reference!r} has no stress records (methods: "
            f"{', '.join(methods)})"
        )
    fam_out: list[FamilyScore] = []
    meth_out: list[MethodScore] = []
    for reading in readings:
        ref = table[(reference, reading)]
        for method in methods:
            cell = table.get((method, reading))
            if cell is None or "clean" not in cell:
                continue
            clean = cell["clean"]
            drops, ces, rces = {}, [], []
            for family in families:
                sev = sorted(s for f, s in (k for k in cell if k != "clean") if f == family)
                if not sev:
                    continue
                acc = np.array([cell[(family, s)] for s in sev])
                ref_acc = np.array([ref[(family, s)] for s in sev])
                drops[family] = float(np.mean(clean - acc))
                ce = _ratio(float(np.sum(1 - acc)), float(np.sum(1 - ref_acc)))
                rce = _ratio(
                    float(np.sum((1 - acc) - (1 - clean))),
                    float(np.sum((1 - ref_acc) - (1 - ref["clean"]))),
                )
                fam_out.append(FamilyScore(method, reading, family, drops[family], ce, rce))
                ces.append(ce)
                rces.append(rce)
            if not drops:
                continue
            worst = max(drops, key=lambda f: drops[f])
            meth_out.append(
                MethodScore(
                    method=method,
                    reading=reading,
                    clean=clean,
                    mean_drop=float(np.mean(list(drops.values()))),
                    worst_drop=drops[worst],
                    worst_family=worst,
                    mce=None if None in ces else float(np.mean(ces)),
                    relative_mce=None if None in rces else float(np.mean(rces)),
                    reference=reference,
                )
            )
    return fam_out, meth_out
