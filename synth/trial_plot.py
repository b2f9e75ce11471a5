"""Plot one simulated trial: the four DAQ channels, ground-truth forces and finger path."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .trial import CHANNELS, SAMPLE_RATE_HZ, Trial

_LABELS = {
    "pvdf1": "PVDF 1 (front film)",
    "pvdf2": "PVDF 2 (rear film)",
    "sg1": "SG 1 (front face)",
    "sg2": "SG 2 (side face)",
}


def plot_trial(trial: Trial, out: str | Path) -> Path:
    """Write a PNG of ``trial`` to ``out``; returns the path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out)
    if out.suffix.lower() != ".png":
        raise ValueError(f"out must be a .png path; got {str(out)!r}")
    out.parent.mkdir(parents=True, exist_ok=True)
    t = np.arange(trial.signals.shape[1]) / SAMPLE_RATE_HZ
    truth = trial.truth
    fig, axes = plt.subplots(7, 1, figsize=(9, 12), sharex=True)
    for ax, name, sig in zip(axes[:4], CHANNELS, trial.signals, strict=True):
        ax.plot(t, sig, lw=0.7)
        ax.set_ylabel(f"{_LABELS[name]}\n(V)", fontsize=8)
    ax = axes[4]
    ax.plot(t, truth["normal_force_n"], label="normal", lw=0.8)
    ax.plot(t, truth["tangential_force_n"], label="tangential", lw=0.8)
    ax.plot(t, truth["lateral_force_n"], label="lateral (y)", lw=0.8)
    ax.set_ylabel("contact\nforce (N)", fontsize=8)
    ax.legend(fontsize=7, loc="upper right")
    ax = axes[5]
    ax.plot(t, truth["finger_x_m"] * 1e3, label="finger x", lw=0.8)
    ax.plot(t, truth["commanded_x_m"] * 1e3, "--", label="commanded x", lw=0.8)
    ax.set_ylabel("x (mm)", fontsize=8)
    ax.legend(fontsize=7, loc="upper left")
    ax = axes[6]
    ax.plot(t, truth["finger_z_m"] * 1e3, lw=0.8)
    ax.set_ylabel("skin bottom\nz (mm)", fontsize=8)
    ax.set_xlabel("time in window (s)")
    s = trial.spec
    fig.suptitle(
        f"{s.shape} / {s.material}: {s.force_n:g} N, {s.speed_mm_s:g} mm/s, seed {s.seed}",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
