"""One example trial per class in a grid (``tactile-synth plot``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import store


def example_rows(label: np.ndarray, condition: np.ndarray, finished: np.ndarray) -> dict[int, int]:
    """``class index -> row`` of each class's first finished trial, preferring condition 0."""
    rows: dict[int, int] = {}
    order = np.lexsort((np.arange(label.size), condition))  # condition 0 first, then store order
    for i in order:
        if finished[i] and int(label[i]) not in rows:
            rows[int(label[i])] = int(i)
    return rows


def plot_examples(path: str | Path, out: str | Path) -> Path:
    """Draw one trial per class (rows: shapes, columns: materials); each channel is
    standardised over the plotted trials and drawn at its own offset. Returns ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    st = store.Store.open(path)
    meta = st.meta
    done, problems = st.status()
    problems += st.check_plan()
    if problems:
        raise store.DatasetDamaged(st.path, problems)
    n, c = st.n_trials, st.chunk_trials
    finished = np.zeros(n, dtype=bool)
    for k in np.flatnonzero(done):
        finished[st.rows(int(k))] = True
    if not finished.any():
        raise ValueError(f"{path} holds no finished trial yet; generate it first")
    rows = example_rows(st.plan.label, st.plan.condition, finished)
    chunks, problems = st.read_chunks(sorted({i // c for i in rows.values()}))
    if problems:
        raise store.DatasetDamaged(st.path, problems)
    examples = {cls: chunks[i // c][i % c] for cls, i in rows.items()}  # (4, T) each
    stack = np.stack(list(examples.values()))
    mean = stack.mean(axis=(0, 2))[:, None]
    std = stack.std(axis=(0, 2))[:, None] + 1e-12
    classes, channels = meta["classes"], meta["channels"]
    shapes_, materials = st.shapes, st.materials
    t = np.arange(stack.shape[2]) / float(meta["sample_rate_hz"])
    fig, axes = plt.subplots(
        len(shapes_),
        len(materials),
        figsize=(3.4 * len(materials) + 1, 1.6 * len(shapes_) + 1),
        sharex=True,
        squeeze=False,
    )
    colors = ("tab:blue", "tab:orange", "tab:green", "tab:red")
    offsets = -4.0 * np.arange(len(channels))
    for r, shape in enumerate(shapes_):
        for col, material in enumerate(materials):
            ax = axes[r, col]
            cls = classes.index(f"{shape}/{material}")
            if cls in examples:
                z = (examples[cls] - mean) / std
                for j in range(len(channels)):
                    ax.plot(t, z[j] + offsets[j], lw=0.6, color=colors[j % len(colors)])
                i = rows[cls]
                cond = meta["conditions"][int(st.plan.condition[i])]
                ax.set_title(f"{shape}/{material}  ({cond}, row {i})", fontsize=7)
            ax.set_ylim(offsets[-1] - 3.0, offsets[0] + 3.0)
            ax.set_yticks(offsets, channels if col == 0 else [""] * len(channels), fontsize=7)
            ax.tick_params(axis="x", labelsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("time in window (s)", fontsize=8)
    fig.suptitle(
        f"{Path(path).name}: one trial per class (channels standardised over the plotted trials)",
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0, 1, 0.98))
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
