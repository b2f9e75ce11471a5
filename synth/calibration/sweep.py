"""The sweep's bookkeeping: the candidates it measures (each swept parameter over its
cited range, the others at the base configuration's values), a candidate's metrics over
its dataset seeds, and its tables (``calibration.json`` and ``calibration.md``, rewritten
after every candidate so that an interrupted sweep keeps its rows and ``--resume`` reuses
them). Measuring a configuration is :func:`benchmark.calibration.measured`'s.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Collection, Iterator, Mapping
from pathlib import Path

import numpy as np

from ..config import SynthConfig
from .settings import SWEEP, CalibrationError, default_value, with_value

#: The metrics whose spread over dataset seeds the sweep reports beside their mean.
SPREAD_KEYS = (
    "pvdf_share_cross_shape",
    "pvdf_share_cross_material",
    "pvdf_share_gap",
    "pvdf_share_paper_d_gap",
)


def candidates(
    base: SynthConfig,
    only: Collection[str] | None = None,
    held: Mapping[tuple[str, str], float] | None = None,
) -> Iterator[tuple[str, str, float, str, bool, SynthConfig]]:
    """The sweep's candidates in :data:`synth.calibration.settings.SWEEP`'s order, as
    ``(section, field, value, why, is_default, config)``: every candidate value of each
    swept parameter (only those named ``SECTION.FIELD`` in ``only``, if given; none held
    in ``held``, which ``base`` already holds at their ``--base`` values), set on
    ``base``; ``is_default`` marks the value ``base`` has."""
    swept = swept_parameters(only, held)
    for section, field, values, why in SWEEP:
        if f"{section}.{field}" not in swept:
            continue
        default = default_value(base, section, field)
        for value in values:
            is_default = math.isclose(value, default, rel_tol=1e-9, abs_tol=1e-15)
            yield section, field, value, why, is_default, with_value(base, section, field, value)


def swept_parameters(
    only: Collection[str] | None = None, held: Mapping[tuple[str, str], float] | None = None
) -> list[str]:
    """The ``SECTION.FIELD`` names a sweep measures, in :data:`SWEEP`'s order: those in
    ``only`` (every one, if not given), less those ``held`` at a ``--base`` value."""
    return [
        f"{section}.{field}"
        for section, field, _, _ in SWEEP
        if (not only or f"{section}.{field}" in only) and not (held and (section, field) in held)
    ]


def over_seeds(per_seed: list[dict]) -> dict:
    """One candidate's metrics over its dataset seeds: every metric's mean, the share gaps
    (cross-shape minus cross-material PVDF share, of the selected features and of the
    first :data:`benchmark.calibration.PAPER_D` ranked ones), and for the
    :data:`SPREAD_KEYS` their standard deviation over the seeds (``*_sd``, 0 for one
    seed)."""
    rows = [
        {
            **r,
            "pvdf_share_gap": r["pvdf_share_cross_shape"] - r["pvdf_share_cross_material"],
            "pvdf_share_paper_d_gap": r["pvdf_share_paper_d_cross_shape"]
            - r["pvdf_share_paper_d_cross_material"],
        }
        for r in per_seed
    ]
    out = {k: float(np.mean([r[k] for r in rows])) for k in rows[0]}
    for k in SPREAD_KEYS:
        out[f"{k}_sd"] = float(np.std([r[k] for r in rows], ddof=1)) if len(rows) > 1 else 0.0
    return out


def format_metric(key: str, value: float) -> str:
    """A metric as the table shows it: feature counts to 1 decimal (a mean over seeds of
    medians; whole numbers without it), accuracies and shares to 3 decimals."""
    if key.startswith("d_"):
        return f"{value:.1f}".removesuffix(".0")
    return f"{value:.3f}"


def earlier_rows(out: Path | None, trials_per_class: int, seeds: int) -> list[dict]:
    """``--resume``: the rows of ``out/calibration.json`` that were measured with this
    sweep's trials per class and seeds, as they were written (none without the file)."""
    if out is None:
        raise CalibrationError("--resume needs --out DIR (the sweep whose rows it keeps)")
    path = out / "calibration.json"
    if not path.is_file():
        return []
    try:
        rows = json.loads(path.read_text())
        kept = [r for r in rows if (r["trials_per_class"], r["seeds"]) == (trials_per_class, seeds)]
        for r in kept:
            fields = ("parameter", "value", "default", "config_sha256", *r["metrics"])
            missing = [k for k in fields if k not in r]
            if missing:
                raise KeyError(missing[0])
    except (ValueError, KeyError, TypeError) as exc:
        raise CalibrationError(
            f"--resume: {path} is not a sweep table this script wrote ({type(exc).__name__}: "
            f"{exc}); choose another --out or remove it"
        ) from None
    return kept


def previous_measurements(rows: list[dict]) -> dict[str, dict]:
    """The metrics of :func:`earlier_rows`' ``rows`` by configuration (``{"failed": why}``
    for a configuration whose simulation failed: it fails again, bit for bit)."""
    return {
        r["config_sha256"]: (
            {"failed": r["failed"]} if r.get("failed") else {k: r[k] for k in r["metrics"]}
        )
        for r in rows
    }


def kept_rows(rows: list[dict], base_key: str, swept: Collection[str]) -> list[dict]:
    """The rows of an earlier table (:func:`earlier_rows`) that a resumed sweep writes
    beside its own: those of the parameters it does not sweep, provided the earlier
    sweep started from the same base (its ``(default)`` rows measured ``base_key``'s
    configuration); none otherwise, since they would describe another base."""
    if {r["config_sha256"] for r in rows if r["default"]} != {base_key}:
        return []
    return [r for r in rows if r["parameter"] not in swept]


def in_sweep_order(rows: list[dict]) -> list[dict]:
    """``rows`` ordered by their parameter's place in :data:`SWEEP` (a parameter's own
    rows keep their order)."""
    place = {f"{section}.{field}": i for i, (section, field, _, _) in enumerate(SWEEP)}
    return sorted(rows, key=lambda r: place.get(r["parameter"], len(place)))


def write_tables(out: Path, rows: list[dict], metrics: list[str], seeds: int) -> None:
    """``out/calibration.json`` (every row, with the names of its metrics) and
    ``calibration.md`` (the table), each replaced whole. A row whose simulation failed
    (``failed``: why) has no metrics; the table says why in its first metric's cell."""
    out.mkdir(parents=True, exist_ok=True)
    table = [{**r, "metrics": [] if r.get("failed") else metrics} for r in rows]
    keys = [k for k in metrics if not k.endswith("_sd")] or ["metrics"]
    lines = [
        "| parameter | value | post-gain | " + " | ".join(keys) + " |",
        "|---" * (len(keys) + 3) + "|",
    ]
    for r in rows:
        mark = " (default)" if r["default"] else ""
        if r.get("failed"):
            vals = " | ".join([f"not measured: {r['failed']}"] + [""] * (len(keys) - 1))
        else:
            vals = " | ".join(
                format_metric(k, r[k])
                + (f" ± {r[k + '_sd']:.3f}" if seeds > 1 and k in SPREAD_KEYS else "")
                for k in keys
            )
        gain = f"{r['post_gain']:g}" if r.get("post_gain") is not None else ""
        lines.append(f"| {r['parameter']} | {r['value']:g}{mark} | {gain} | {vals} |")
    for name, text in (
        ("calibration.json", json.dumps(table, indent=1) + "\n"),
        ("calibration.md", "\n".join(lines) + "\n"),
    ):
        tmp = out / f".{name}.partial"
        tmp.write_text(text)
        os.replace(tmp, out / name)


def sweep_row(
    parameter: str,
    value: float,
    why: str,
    is_default: bool,
    metrics: Mapping[str, float],
    trials_per_class: int,
    seeds: int,
    config_sha256: str,
    failed: str | None = None,
    post_gain: float | None = None,
) -> dict:
    """One row of the sweep's table: the candidate (``SECTION.FIELD`` and its value,
    whether it is the base's, why its range), its metrics (none, and ``failed`` saying
    why, when its simulation failed), and what they were measured with (the films'
    post-gain, trials per class, dataset seeds, the configuration's identity)."""
    return {
        "parameter": parameter,
        "value": value,
        "default": is_default,
        "why": why,
        **({} if post_gain is None else {"post_gain": post_gain}),
        **metrics,
        **({"failed": failed} if failed else {}),
        "trials_per_class": trials_per_class,
        "seeds": seeds,
        "config_sha256": config_sha256,
    }
