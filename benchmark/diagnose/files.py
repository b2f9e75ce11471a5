"""Reading a store for the diagnosis and writing its files (``diagnose.md``, ``.json``,
``.npz``, figures): what the CLI runs."""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from synth import Dataset
from synth.store import check_not_inside_a_store
from tactile_synth.atomic import check_out_dir

from . import steady
from .analysis import diagnose
from .plots import plot_accuracy, plot_confusion, plot_pvdf_spectra, plot_sg_traces
from .result import CURVES_NAME, FIGURES, JSON_NAME, MARKDOWN_NAME, Diagnosis
from .text import markdown

#: Channel groups: key, human-readable name, sensor kept (None: all features).


def json_ready(value: Any) -> Any:
    """JSON-ready: non-finite floats become null, tuples lists."""
    if isinstance(value, float):
        return value if np.isfinite(value) else None
    if isinstance(value, dict):
        return {k: json_ready(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_ready(v) for v in value]
    return value


def _atomic_write(path: Path, write: Callable[[Path], None]) -> None:
    tmp = path.with_name(path.name + ".tmp")
    write(tmp)
    os.replace(tmp, path)


def write_curves(diag: Diagnosis, path: str | Path) -> Path:
    """``diagnose.npz``: spectra and traces as plain arrays (``np.load(allow_pickle=False)``)."""
    path = Path(path)
    arrays = {
        "psd_freq_hz": diag.spectra.freq_hz,
        "psd_v2_per_hz": diag.spectra.psd_v2_per_hz,
        "psd_conditions": np.array(diag.spectra.conditions, dtype=str),
        "psd_materials": np.array(diag.spectra.materials, dtype=str),
        "psd_channels": np.array(diag.spectra.channels, dtype=str),
        "trace_time_s": diag.sg_traces.time_s,
        "sg_mean_v": diag.sg_traces.mean_v,
        "sg_std_v": diag.sg_traces.std_v,
        "trace_conditions": np.array(diag.sg_traces.conditions, dtype=str),
        "trace_shapes": np.array(diag.sg_traces.shapes, dtype=str),
        "trace_channels": np.array(diag.sg_traces.channels, dtype=str),
    }

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, **arrays)

    _atomic_write(path, write)
    return path


def write_diagnosis(diag: Diagnosis, out: str | Path, *, figures: bool = True) -> list[Path]:
    """Write ``diagnose.md``, ``diagnose.json``, ``diagnose.npz`` and (``figures``) the PNG
    figures into directory ``out`` (created if needed); returns the paths written."""
    out = Path(out)
    check_out_dir(out)
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    names: dict[str, str] = {}
    if figures:
        plotters = {
            "accuracy": plot_accuracy,
            "confusion": plot_confusion,
            "pvdf_spectra": plot_pvdf_spectra,
            "sg_traces": plot_sg_traces,
        }
        for key, plot in plotters.items():
            written.append(plot(diag, out / FIGURES[key]))
            names[key] = FIGURES[key]
    text = json.dumps(json_ready(diag.to_dict()), indent=1) + "\n"
    _atomic_write(out / JSON_NAME, lambda p: p.write_text(text))
    written.append(out / JSON_NAME)
    written.append(write_curves(diag, out / CURVES_NAME))
    md = markdown(diag, names)
    _atomic_write(out / MARKDOWN_NAME, lambda p: p.write_text(md))
    written.append(out / MARKDOWN_NAME)
    return written


def run_diagnose(
    path: str | Path,
    *,
    out: str | Path | None = None,
    allow_incomplete: bool = False,
    progress: Callable[[str], None] | None = None,
    edge_gap_s: float = steady.EDGE_GAP_S,
) -> Diagnosis:
    """The CLI's work: load the store at ``path``, diagnose it (its steady stretches
    ``edge_gap_s`` from the walls), and write the files into ``out`` when given."""
    steady.check_edge_gap(edge_gap_s)  # before loading, so a bad value fails at once
    say = progress or (lambda msg: None)
    if out is not None:
        check_out_dir(out)  # before loading, so a bad --out fails at once
        # The report's files do not belong in a store.
        check_not_inside_a_store(out, itself=True, advice="choose another DIR")
    data = load_for_diagnosis(path, allow_incomplete=allow_incomplete, progress=say)
    diag = diagnose(data, source=str(path), progress=say, edge_gap_s=edge_gap_s)
    if out is not None:
        say(f"writing {Path(out) / MARKDOWN_NAME}, {JSON_NAME}, {CURVES_NAME} and figures")
        write_diagnosis(diag, out)
    return diag


# -- reading a store (files) -----------------------------------------------------------------------
def load_for_diagnosis(
    path: str | Path,
    *,
    allow_incomplete: bool = False,
    progress: Callable[[str], None] | None = None,
) -> Dataset:
    """The dataset at ``path``; an unfinished store is refused with a message naming both
    fixes (finish it, or diagnose its finished trials with ``--allow-incomplete``)."""
    from synth import load_dataset
    from synth.store import Store

    done, _ = Store.open(path).status()
    if not done.all() and not allow_incomplete:
        raise ValueError(
            f"dataset {path} is incomplete ({int(done.sum())}/{done.size} chunks done); "
            f"finish it with `tactile-synth generate --resume --out {path}` or add "
            f"--allow-incomplete to diagnose its finished trials"
        )
    if progress is not None:
        progress(f"reading {path}")
    data = load_dataset(path, allow_incomplete=allow_incomplete)
    if len(data) == 0:
        raise ValueError(
            f"dataset {path} has no finished trial yet; "
            f"finish it with `tactile-synth generate --resume --out {path}`"
        )
    return data
