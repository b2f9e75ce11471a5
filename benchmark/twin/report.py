"""A calibration's outputs: ``finger.toml`` (the posterior medians), ``calibration.json``
(every estimate, the simulations' counts and the summaries), ``report.md`` and its
figure of the recordings against the twin at the fitted values (per channel: the mean
spectrum and one trial of the same class and condition overlaid)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from synth.calibration.finger_file import write_finger
from synth.trial import CHANNELS, SAMPLE_RATE_HZ

if TYPE_CHECKING:
    from .result import Calibration

FIGURE = "recordings_vs_twin.png"


def _fmt(v: float) -> str:
    return f"{v:.4g}"


def write_outputs(
    result: Calibration,
    data: Any,
    *,
    recordings: str,
    trials_per_class: int,
    seed: int,
    figures: bool = True,
) -> list[Path]:
    out = result.out
    medians = {e.name: e.median for e in result.estimates}
    written = [
        write_finger(
            out / "finger.toml",
            medians,
            comments=(
                f"fitted by tactile-synth calibrate to {recordings}: posterior medians of "
                f"{result.n_simulations} simulations",
                'load with `tactile-synth generate --finger FILE` or `finger = "FILE"` in '
                "an experiment file",
            ),
        )
    ]
    record = {
        "recordings": recordings,
        "n_simulations": result.n_simulations,
        "n_failed": result.n_failed,
        "trials_per_class": trials_per_class,
        "seed": seed,
        "estimates": [e.as_dict() for e in result.estimates],
    }
    path = out / "calibration.json"
    path.write_text(json.dumps(record, indent=1) + "\n")
    written.append(path)
    figure, why = None, None
    if figures:
        import synth

        try:
            figure = _figure(result, data, trials_per_class=trials_per_class, seed=seed)
            written.append(figure)
        except synth.SimulationError as exc:  # the fit stands; only its picture is missing
            why = f"the twin at the posterior medians could not be simulated: {exc}"
    path = out / "report.md"
    path.write_text(markdown(result, recordings, trials_per_class, figure, why))
    written.append(path)
    return written


def markdown(
    result: Calibration,
    recordings: str,
    trials_per_class: int,
    figure: Path | None,
    no_figure: str | None = None,
) -> str:
    lines = [
        "# Calibration of the twin",
        "",
        f"Recordings: `{recordings}` ({len(result.world.classes)} classes, "
        f"{len(result.world.conditions)} class-condition pairs). {result.n_simulations} "
        f"simulations of {trials_per_class} trials per class and condition "
        f"({result.n_failed} failed in the physics and were left out), neural posterior "
        "estimation (sbi) over the summary statistics of `docs/calibrate.md`.",
        "",
        "| parameter | posterior median | 90 % interval | cited range | pinned down |",
        "|---|---|---|---|---|",
    ]
    for e in result.estimates:
        lines.append(
            f"| `{e.name}` | {_fmt(e.median)} | {_fmt(e.low)} .. {_fmt(e.high)} | "
            f"{_fmt(e.prior_low)} .. {_fmt(e.prior_high)} | {'no: flat' if e.flat else 'yes'} |"
        )
    flat = [e.name for e in result.estimates if e.flat]
    lines.append("")
    if flat:
        lines.append(
            "The recordings do not pin down "
            + ", ".join(f"`{n}`" for n in flat)
            + ": the posterior's 90 % interval covers most of the cited range, so the "
            "value in `finger.toml` is the middle of what the data allow, not a measurement."
        )
    else:
        lines.append("Every parameter's 90 % interval is narrower than its cited range.")
    lines += ["", "`finger.toml` holds the posterior medians."]
    if figure is not None:
        lines += [
            "",
            "## Recordings against the twin",
            "",
            "Per channel, the mean spectrum of the recordings and of the twin at the "
            "posterior medians (top), and one recorded trial overlaid with the twin's trial "
            "of the same class and condition (bottom).",
            "",
            f"![recordings vs twin]({figure.name})",
        ]
    elif no_figure:
        lines += ["", f"No figure: {no_figure}."]
    return "\n".join(lines) + "\n"


def _figure(result: Calibration, data: Any, *, trials_per_class: int, seed: int) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy.signal import welch

    from .world import simulate_signals

    values = [e.median for e in result.estimates]
    twin, specs = simulate_signals(
        result.world, result.parameters, values, trials_per_class=trials_per_class, seed=seed
    )
    rec = np.asarray(data.signals, dtype=float)
    f, p_rec = welch(rec, fs=SAMPLE_RATE_HZ, nperseg=256, axis=-1)
    _, p_twin = welch(twin.astype(float), fs=SAMPLE_RATE_HZ, nperseg=256, axis=-1)
    first = specs[0]
    cls = result.world.classes.index(f"{first.shape}/{first.material}")
    match = np.flatnonzero(
        (np.asarray(data.label) == cls)
        & np.isclose(data.force_n, first.force_n)
        & np.isclose(data.speed_mm_s, first.speed_mm_s)
    )
    row = int(match[0]) if match.size else 0
    t = np.arange(rec.shape[-1]) / SAMPLE_RATE_HZ
    fig, axes = plt.subplots(2, len(CHANNELS), figsize=(4 * len(CHANNELS), 6), squeeze=False)
    for c, name in enumerate(CHANNELS):
        ax = axes[0, c]
        ax.semilogy(f, p_rec[:, c].mean(axis=0), label="recordings")
        ax.semilogy(f, p_twin[:, c].mean(axis=0), label="twin")
        ax.set_title(f"{name}: mean spectrum")
        ax.set_xlabel("Hz")
        ax.set_ylabel("V$^2$/Hz")
        ax = axes[1, c]
        ax.plot(t, rec[row, c], lw=0.7, label="recording")
        ax.plot(t, twin[0, c], lw=0.7, alpha=0.8, label="twin")
        ax.set_title(f"{name}: {result.world.classes[cls]}")
        ax.set_xlabel("s")
        ax.set_ylabel("V")
    axes[0, 0].legend()
    axes[1, 0].legend()
    fig.tight_layout()
    path = result.out / FIGURE
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path
