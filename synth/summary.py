"""A human-readable summary of a dataset store (``tactile-synth inspect``), with every
finished chunk and per-trial array checked."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np

from . import store


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """``"1 class"``, ``"2 classes"``: ``n`` and the noun in the number it needs (``plural``
    defaults to ``noun + "s"``)."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"


def chunking(n_trials: int, chunk_trials: int) -> str:
    """How ``n_trials`` fill chunks of at most ``chunk_trials``, in the trials each chunk
    really holds: ``"60 chunks of 36"``, ``"1 chunk of 8"`` (8 trials, chunks of up to
    36), ``"3 chunks of 5, the last of 2"``."""
    n_chunks = -(-n_trials // chunk_trials)
    text = f"{counted(n_chunks, 'chunk')} of {min(chunk_trials, n_trials)}"
    last = n_trials - (n_chunks - 1) * chunk_trials
    if n_chunks > 1 and last != chunk_trials:
        text += f", the last of {last}"
    return text


def channel_stats(chunks: Iterable[np.ndarray], n_channels: int) -> dict[str, np.ndarray]:
    """Per-channel mean, std, min, max, rms over ``chunks`` (each ``(b, C, T)``), streamed
    chunk by chunk. Returns arrays of shape ``(C,)`` (float64) and ``trials`` (how many
    were summarised)."""
    total = np.zeros(n_channels)
    total_sq = np.zeros(n_channels)
    lo = np.full(n_channels, np.inf)
    hi = np.full(n_channels, -np.inf)
    count = 0
    trials = 0
    for chunk in chunks:
        x = np.asarray(chunk, dtype=np.float64)
        total += x.sum(axis=(0, 2))
        total_sq += np.square(x).sum(axis=(0, 2))
        lo = np.minimum(lo, x.min(axis=(0, 2)))
        hi = np.maximum(hi, x.max(axis=(0, 2)))
        count += x.shape[0] * x.shape[2]
        trials += x.shape[0]
    mean = total / max(count, 1)
    mean_sq = total_sq / max(count, 1)
    return {
        "mean": mean,
        "std": np.sqrt(np.maximum(mean_sq - mean**2, 0.0)),
        "min": lo,
        "max": hi,
        "rms": np.sqrt(mean_sq),
        "trials": np.array(trials),
    }


def _short(name: str) -> str:
    # "force=1.4N,speed=6mm/s" -> "1.4N 6mm/s": keeps the table narrow.
    return name.replace("force=", "").replace(",speed=", " ")


def inspect_store(path: str | Path) -> tuple[str, list[store.Problem]]:
    """The text ``tactile-synth inspect`` prints (provenance, completeness, integrity,
    trials per class and condition, per-channel signal statistics over the chunks that
    pass their checks) and the problems found."""
    path = Path(path)
    st = store.Store.open(path)
    meta = st.meta
    done, problems = st.status()
    problems += st.check_plan()
    n = st.n_trials
    good: list[int] = []

    def verified_chunks():
        for k in np.flatnonzero(done):
            data, bad = st.read_chunks([int(k)])  # one chunk at a time: memory stays flat
            problems.extend(bad)
            if data:
                good.append(int(k))
                yield data[int(k)]

    stats = channel_stats(verified_chunks(), len(meta["channels"]))
    finished = np.zeros(n, dtype=bool)  # marked done and verified
    for k in good:
        finished[st.rows(k)] = True
    marked = np.zeros(n, dtype=bool)
    for k in np.flatnonzero(done):
        marked[st.rows(int(k))] = True
    complete = bool(done.all())
    lines = [
        f"dataset    {path}",
        f"format     {meta['format_version']} (tactile-synth {meta['package_version']}, "
        + ("" if st.imported else f"MuJoCo {meta['mujoco_version']}, ")
        + f"zarr {meta['zarr_version']}), created {meta['created_at']}",
        *_origin_lines(st),
        f"complete   {'yes' if complete else 'NO'}: {int(done.sum())}/{done.size} chunks, "
        f"{int(marked.sum())}/{n} trials" + ("" if complete else f" ({st.finish_advice()})"),
    ]
    if problems:
        shown = "; ".join(str(p) for p in problems[:5])
        more = f"; and {len(problems) - 5} more" if len(problems) > 5 else ""
        how = "rebuild" if st.imported else "repair"
        lines.append(
            f"integrity  DAMAGED: {shown}{more} ({how} with: {store.repair_command(path)})"
        )
    else:
        lines.append("integrity  ok: every finished chunk and per-trial array passes its checks")
    lines += ["", "trials per class and condition" + ("" if complete else " (finished/planned)")]
    label, cond = st.plan.label, st.plan.condition
    heads = [_short(x) for x in meta["conditions"]]
    width = max(12, *(len(h) for h in heads))
    lines.append(f"  {'class':<22}" + "".join(f"{h:>{width}}" for h in heads))
    for cls in sorted(set(label.tolist())):
        cells = []
        for j in range(len(heads)):
            rows = (label == cls) & (cond == j)
            got, planned = int((rows & finished).sum()), int(rows.sum())
            cells.append(f"{got}" if complete and not problems else f"{got}/{planned}")
        lines.append(f"  {meta['classes'][cls]:<22}" + "".join(f"{x:>{width}}" for x in cells))
    lines += [
        "",
        f"signal statistics per channel (volts, over {int(stats['trials'])} trials x "
        f"{st.arrays['signals'].shape[2]} samples at {meta['sample_rate_hz']} Hz)",
        f"  {'channel':<8}" + "".join(f"{h:>12}" for h in ("mean", "std", "min", "max", "rms")),
    ]
    for i, ch in enumerate(meta["channels"]):
        vals = [stats[key][i] for key in ("mean", "std", "min", "max", "rms")]
        lines.append(f"  {ch:<8}" + "".join(f"{v:>12.5g}" for v in vals))
    return "\n".join(lines), problems


def _counts(values: list) -> str:
    """``"72 x a, 2 x b"``: how often each value occurs, most frequent first."""
    uniq, counts = np.unique(np.asarray(values, dtype=str), return_counts=True)
    order = np.argsort(-counts, kind="stable")
    return ", ".join(f"{counts[i]} x {uniq[i]}" for i in order)


def _origin_lines(st: store.Store) -> list[str]:
    """Where the data come from: the generation grid, or the import's sources."""
    meta, n = st.meta, st.n_trials
    chunks = f"({counted(n, 'trial')}, {chunking(n, st.chunk_trials)})"
    if not st.imported:
        cfg = st.config
        return [
            f"config     preset={cfg.preset} seed={cfg.seed} "
            f"{counted(len(cfg.shapes), 'shape')} x {counted(len(cfg.materials), 'material')} x "
            f"{counted(len(meta['conditions']), 'condition')} x "
            f"{counted(cfg.trials_per_class, 'trial')} {chunks}"
        ]
    prov = meta.get("import") or {}
    trials = prov.get("trials") or {}
    classes = len(set(st.plan.label.tolist()))
    lines = [
        f"imported   from {prov.get('recordings', '?')} (labels {prov.get('labels', '?')}): "
        f"{counted(len(st.shapes), 'shape')} x {counted(len(st.materials), 'material')}, "
        f"{counted(classes, 'class', 'classes')} x "
        f"{counted(len(meta['conditions']), 'condition')} {chunks}"
    ]
    if trials.get("sample_rate_hz"):
        rates = [f"{r:g} Hz" for r in trials["sample_rate_hz"]]
        lines.append(
            f"recordings {_counts(rates)} (resampled to {meta['sample_rate_hz']} Hz where "
            f"different); windows of {prov.get('window_s', 2):g} s: {_counts(trials['window'])}"
        )
    return lines


def summarize(path: str | Path) -> str:
    """The text ``tactile-synth inspect`` prints (see :func:`inspect_store`)."""
    return inspect_store(path)[0]
