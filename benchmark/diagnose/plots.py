"""The diagnosis's PNG figures."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .result import GROUPS, Diagnosis
from .text import fmt

#: Channel groups: key, human-readable name, sensor kept (None: all features).


def _condition_colours(conditions: Sequence[str]) -> list:
    import matplotlib.pyplot as plt

    cmap = plt.get_cmap("viridis")
    k = len(conditions)
    return [cmap(i / max(k - 1, 1)) for i in range(k)]


def plot_accuracy(diag: Diagnosis, path: str | Path) -> Path:
    """Bars: per-shape and per-material accuracy for each channel group."""
    import matplotlib.pyplot as plt

    from ..figures import save_figure

    panels = [
        (t, diag.per_shape if t == "shape" else diag.per_material)
        for t in ("shape", "material")
        if (diag.per_shape if t == "shape" else diag.per_material) is not None
    ]
    if not panels:
        panels = [("class", diag.per_class)]
    widths = [max(len(tab["all"]), 2) for _, tab in panels]
    fig, axes = plt.subplots(
        1,
        len(panels),
        figsize=(2.0 + 0.55 * sum(widths), 3.6),
        squeeze=False,
        gridspec_kw={"width_ratios": widths},
        layout="constrained",
    )
    colours = {"all": "tab:gray", "sg": "tab:blue", "pvdf": "tab:red"}
    for ax, (target, table) in zip(axes[0], panels, strict=True):
        keys = list(table["all"])
        x = np.arange(len(keys))
        for j, (g, name, _) in enumerate(GROUPS):
            vals = [np.nan if table[g][k] is None else table[g][k] for k in keys]
            ax.bar(x + (j - 1) * 0.27, vals, 0.27, color=colours[g], label=name)
        chance = diag.chance.get(target)
        if chance is not None:
            ax.axhline(chance, color="k", lw=0.8, ls=":", label="chance")
        ax.set_xticks(x, keys, rotation=45, ha="right", fontsize=8)
        ax.set_ylim(0, 1.02)
        ax.set_title(f"{target} accuracy per {target}", fontsize=10)
    axes[0, 0].set_ylabel("leave-one-out 1-NN accuracy")
    axes[0, -1].legend(fontsize=7, loc="lower right")
    return save_figure(fig, path)


def plot_confusion(diag: Diagnosis, path: str | Path) -> Path:
    """Row-normalised nearest-neighbour class confusion, one panel per channel group."""
    import matplotlib.pyplot as plt

    from ..figures import save_figure

    k = len(diag.classes)
    side = min(max(3.0, 0.16 * k + 1.5), 8.0)
    fig, axes = plt.subplots(1, 3, figsize=(3 * side, side + 0.6), layout="constrained")
    font = 8 if k <= 12 else 5
    for ax, (g, name, _) in zip(axes, GROUPS, strict=True):
        counts = diag.confusion[g].astype(np.float64)
        rates = counts / np.maximum(counts.sum(axis=1, keepdims=True), 1)
        im = ax.imshow(rates, vmin=0, vmax=1, cmap="Blues", interpolation="nearest")
        ax.set_xticks(range(k), diag.classes, rotation=90, fontsize=font)
        ax.set_yticks(range(k), diag.classes if g == "all" else [], fontsize=font)
        acc = diag.accuracy["class"]
        value = fmt(None if acc is None else acc[g])
        ax.set_title(f"{name}: class accuracy {value}", fontsize=9)
        ax.set_xlabel("class of the nearest neighbour", fontsize=8)
    axes[0].set_ylabel("class of the trial", fontsize=8)
    fig.colorbar(im, ax=axes, shrink=0.6, label="share of the class's trials")
    return save_figure(fig, path)


def plot_pvdf_spectra(diag: Diagnosis, path: str | Path) -> Path:
    """Mean PVDF power spectral density per material: one row per condition, one column
    per PVDF channel (log scale)."""
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullLocator

    from ..figures import material_colour, save_figure

    sp = diag.spectra
    rows = len(sp.conditions)
    fig, axes = plt.subplots(
        rows,
        len(sp.channels),
        figsize=(9, 2.6 * rows + 0.6),
        squeeze=False,
        sharex=True,
        sharey=True,
        layout="constrained",
    )
    f = sp.freq_hz
    for ci, cond in enumerate(sp.conditions):
        for k, ch in enumerate(sp.channels):
            ax = axes[ci, k]
            for mi, mat in enumerate(sp.materials):
                p = sp.psd_v2_per_hz[ci, mi, k]
                if np.all(np.isfinite(p)) and np.any(p[1:] > 0):
                    ax.semilogy(
                        f[1:],
                        p[1:],
                        color=material_colour(mat, diag.spectra.materials),
                        lw=1,
                        label=mat,
                    )
            # Minor log ticks on many panels cost more to draw than everything else.
            ax.yaxis.set_minor_locator(NullLocator())
            ax.set_title(f"{ch}, {cond}", fontsize=9)
            ax.grid(True, which="major", lw=0.3)
            if k == 0:
                ax.set_ylabel("PSD (V²/Hz)")
    for ax in axes[-1]:
        ax.set_xlabel("frequency (Hz)")
    axes[0, -1].legend(fontsize=8)
    return save_figure(fig, path)


def plot_sg_traces(diag: Diagnosis, path: str | Path) -> Path:
    """Mean strain-gauge traces per shape (one panel per shape): with one condition
    sg1/sg2 mean ± std; with several, each condition's means in its own colour."""
    import matplotlib.pyplot as plt

    from ..figures import save_figure

    tr = diag.sg_traces
    n_s = len(tr.shapes)
    cols = min(4, n_s)
    rows = -(-n_s // cols)
    fig, axes = plt.subplots(
        rows,
        cols,
        figsize=(3.2 * cols, 2.4 * rows + 0.8),
        squeeze=False,
        sharex=True,
        sharey=True,
        layout="constrained",
    )
    styles = ("-", "--")
    single = len(tr.conditions) == 1
    colours = ("tab:blue", "tab:cyan") if single else None
    cond_colours = _condition_colours(tr.conditions)
    for si, shape in enumerate(tr.shapes):
        ax = axes[si // cols, si % cols]
        for ci in range(len(tr.conditions)):
            for k, ch in enumerate(tr.channels):
                m = tr.mean_v[ci, si, k]
                if not np.all(np.isfinite(m)):
                    continue
                colour = colours[k] if single else cond_colours[ci]
                ax.plot(tr.time_s, m, color=colour, ls=styles[k % 2], lw=0.9, label=ch)
                if single:
                    s = tr.std_v[ci, si, k]
                    ax.fill_between(tr.time_s, m - s, m + s, color=colour, alpha=0.2, lw=0)
        ax.set_title(shape, fontsize=9)
    for j in range(n_s, rows * cols):
        axes[j // cols, j % cols].axis("off")
    for ax in axes[:, 0]:
        ax.set_ylabel("SG (V)")
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    if single:
        handles, labels = axes[0, 0].get_legend_handles_labels()
    else:
        from matplotlib.lines import Line2D

        # One entry per condition colour, and one per line style (channel).
        handles = [Line2D([], [], color=c, lw=1.5) for c in cond_colours]
        handles += [Line2D([], [], color="k", ls=styles[k], lw=0.9) for k in range(2)]
        labels = [*tr.conditions, *tr.channels]
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 5), fontsize=7)
    return save_figure(fig, path)
