"""One example trial per class in a grid (``tactile-synth plot``)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
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
    """Draw one trial per class of the store at ``path`` (rows: shapes, columns:
    materials), as :func:`plot_example_grid`. Returns ``out``."""
    store.check_not_inside_a_store(out)
    if Path(out).suffix.lower() != ".png":  # matplotlib would add one or write another format
        raise ValueError(f"--out {out} must end in .png (plot writes a PNG)")
    st = store.Store.open(path)
    meta = st.meta
    done, problems = st.status()
    problems += st.check_plan()
    if problems:
        raise store.DatasetDamaged(st.path, problems)
    st.check_complete(done)  # an unfinished class would be a blank panel
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
    classes = meta["classes"]
    examples = {classes[cls]: chunks[i // c][i % c] for cls, i in rows.items()}  # (4, T) each
    titles = {
        classes[cls]: f"{meta['conditions'][int(st.plan.condition[i])]}, row {i}"
        for cls, i in rows.items()
    }
    return plot_example_grid(
        examples,
        out,
        shapes=st.shapes,
        materials=st.materials,
        channels=meta["channels"],
        sample_rate_hz=float(meta["sample_rate_hz"]),
        notes=titles,
        title=f"{Path(path).name}: one trial per class",
    )


def plot_example_grid(
    examples: Mapping[str, np.ndarray],
    out: str | Path,
    *,
    shapes: Sequence[str],
    materials: Sequence[str],
    channels: Sequence[str],
    sample_rate_hz: float,
    notes: Mapping[str, str] | None = None,
    title: str = "one trial per class",
) -> Path:
    """One example trial per class in a grid (rows: ``shapes``, columns: ``materials``).

    examples: ``"<shape>/<material>"`` -> ``(channels, T)`` signals (classes absent are
    left empty); each channel is standardised over all the plotted trials and drawn at
    its own offset, so amplitudes compare across classes. ``notes`` adds a class's panel
    title after its name (e.g. its condition and store row). Writes ``out`` (PNG).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if not examples:
        raise ValueError("examples must hold at least one class's trial")
    notes = notes or {}
    stack = np.stack([np.asarray(x, dtype=np.float64) for x in examples.values()])
    mean = stack.mean(axis=(0, 2))[:, None]
    std = stack.std(axis=(0, 2))[:, None] + 1e-12
    t = np.arange(stack.shape[2]) / sample_rate_hz
    fig, axes = plt.subplots(
        len(shapes),
        len(materials),
        figsize=(3.4 * len(materials) + 1, 1.6 * len(shapes) + 1),
        sharex=True,
        squeeze=False,
    )
    colors = ("tab:blue", "tab:orange", "tab:green", "tab:red")
    offsets = -4.0 * np.arange(len(channels))
    for r, shape in enumerate(shapes):
        for col, material in enumerate(materials):
            ax = axes[r, col]
            name = f"{shape}/{material}"
            if name in examples:
                z = (np.asarray(examples[name], dtype=np.float64) - mean) / std
                for j in range(len(channels)):
                    ax.plot(t, z[j] + offsets[j], lw=0.6, color=colors[j % len(colors)])
                note = f"  ({notes[name]})" if name in notes else ""
                ax.set_title(f"{name}{note}", fontsize=7)
            ax.set_ylim(offsets[-1] - 3.0, offsets[0] + 3.0)
            ax.set_yticks(offsets, channels if col == 0 else [""] * len(channels), fontsize=7)
            ax.tick_params(axis="x", labelsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("time in window (s)", fontsize=8)
    fig.suptitle(f"{title} (channels standardised over the plotted trials)", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.98))
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
