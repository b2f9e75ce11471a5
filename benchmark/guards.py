"""Checks on the benchmark's inputs before any work starts: episode budgets the machine
can hold, a perturbation dataset that does not repeat the nominal one, and dataset
generation inside ``run`` with advice that names ``run``'s own options."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from synth import Dataset, store
from synth.generation import available_memory, generate
from synth.presets import NOMINAL_FORCE_N, NOMINAL_SPEED_MM_S
from tactile_synth.validation import check_int

#: Most episodes per (protocol, way, shot) cell. The 95 % CI half-width of a mean accuracy
#: is 1.96 * sd / sqrt(episodes) with sd <= 0.5, so at this count it is below 0.31
#: percentage points whatever the accuracy: more episodes cannot change a conclusion.
MAX_EPISODES: int = 100_000
#: Bytes per episode of the largest cell's index arrays: 36 ways x (5 shots + 5 queries)
#: trial indices (8 bytes) in support, query, labels and the shuffling temporaries.
_EPISODE_BYTES = 36 * 10 * 8 * 5


def check_episodes(episodes: object, *, arg: str = "--episodes") -> int:
    """``episodes`` if the machine can evaluate that many per cell; else ``ValueError``
    with the estimate."""
    episodes = check_int(arg, episodes, minimum=1)
    if episodes > MAX_EPISODES:
        raise ValueError(
            f"{arg} {episodes:,} is more than the {MAX_EPISODES:,} episodes per cell that can "
            f"matter (the 95 % CI is already below +-0.31 percentage points there) and needs "
            f"about {episodes * _EPISODE_BYTES / 1e9:,.1f} GB of episode indices per cell; "
            f"use at most {MAX_EPISODES:,} (the paper uses 500)"
        )
    need, have = episodes * _EPISODE_BYTES, available_memory()
    if need > have:
        raise ValueError(
            f"{arg} {episodes:,} needs about {need / 1e9:,.1f} GB of episode indices per cell "
            f"but {have / 1e9:,.1f} GB of memory is available; use fewer episodes"
        )
    return episodes


def _conditions(data: Dataset) -> set[tuple[float, float]]:
    return {(float(f), float(s)) for f, s in zip(data.force_n, data.speed_mm_s, strict=True)}


def _names(conditions: set[tuple[float, float]]) -> str:
    return ", ".join(f"{f:g} N/{s:g} mm/s" for f, s in sorted(conditions))


def check_nominal(data: Dataset, perturbed: Dataset | None = None) -> None:
    """Refuse a nominal dataset with no trial at the nominal condition (1 N, 10 mm/s): the
    perturbation protocol fits on it as trained "at nominal force and speed", and reads
    every condition of the perturbation dataset as a departure from it. Such a ``data``
    is most often the perturbation dataset given as --data (the two swapped)."""
    nominal = (NOMINAL_FORCE_N, NOMINAL_SPEED_MM_S)
    have = _conditions(data)
    if nominal in have:
        return
    swapped = perturbed is not None and nominal in _conditions(perturbed)
    raise ValueError(
        f"--data holds no trial at the nominal condition {_names({nominal})} that the "
        f"perturbation protocol fits on (it holds {_names(have)}); --data is the nominal "
        f"dataset and --perturbed the one at other forces and speeds"
        + ("; they look swapped" if swapped else "")
    )


def check_perturbation_pair(data: Dataset, perturbed: Dataset, *, seeds: bool = True) -> None:
    """Refuse a perturbation dataset whose trials could repeat the nominal dataset's: any
    force/speed condition in both, or (``seeds``) any class drawn with the same trial seed
    in both (the same specimen draws and sensor noise on both sides of the split); and a
    nominal dataset without the nominal condition (:func:`check_nominal`).

    ``seeds=False`` is for hand-made datasets that number their trials from 0 in each
    dataset (unit tests); the generator mixes the condition into every trial seed.
    """
    shared = _conditions(data) & _conditions(perturbed)
    if shared:
        names = _names(shared)
        raise ValueError(
            f"--perturbed shares the condition(s) {names} with --data: its trials would "
            f"test the methods on the condition they were trained on (is it the same "
            f"dataset?); use a perturbation dataset without those conditions, e.g. "
            f"`tactile-synth generate --preset perturbation`"
        )
    check_nominal(data, perturbed)
    if not seeds:
        return
    nominal = set(zip(data.label.tolist(), data.seed.tolist(), strict=True))
    both = [
        (c, s) for c, s in zip(perturbed.label.tolist(), perturbed.seed.tolist(), strict=True)
        if (c, s) in nominal
    ]  # fmt: skip
    if both:
        c, s = both[0]
        raise ValueError(
            f"--perturbed shares {len(both)} trial seed(s) with --data (e.g. class "
            f"{data.classes[c]} seed {s}): those trials repeat the nominal trials' specimen "
            f"draws and sensor noise; generate the two datasets with different --seed values"
        )


def generate_for_run(config: Any, path: Path, **kw: Any) -> Path:
    """``synth.generate(config, path, resume=True, **kw)`` with its refusals rephrased for
    ``run``, which keeps its datasets under ``DIR/data`` and has no --resume/--overwrite
    of its own."""
    try:
        return generate(config, path, resume=True, **kw)
    except (store.DatasetLocked, store.DatasetDamaged):
        raise  # their advice holds for run too (wait; `tactile-synth generate --repair`)
    except store.DatasetError as exc:
        raise store.DatasetError(
            exc.problem,
            f"`run` keeps its datasets in {path.parent}: delete {path} to have it generated "
            f"again, or choose another --out",
        ) from None
    except FileExistsError:
        raise FileExistsError(
            f"{path} exists and is not a tactile-synth dataset; `run` keeps its datasets in "
            f"{path.parent}: move it away or choose another --out"
        ) from None
