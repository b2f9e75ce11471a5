"""A human-readable summary of a dataset store (``tactile-synth inspect``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import store


def _chunk_rows(k: int, c: int, n: int) -> slice:
    return slice(k * c, min((k + 1) * c, n))


def channel_stats(group, done: np.ndarray, chunk_trials: int) -> dict[str, np.ndarray]:
    """Per-channel mean, std, min, max, rms over the finished chunks, streamed chunk by chunk.

    Returns arrays of shape ``(4,)`` (float64) and ``trials`` (how many were summarised).
    """
    signals = group["signals"]
    n, n_ch = signals.shape[0], signals.shape[1]
    total = np.zeros(n_ch)
    total_sq = np.zeros(n_ch)
    lo = np.full(n_ch, np.inf)
    hi = np.full(n_ch, -np.inf)
    count = 0
    trials = 0
    for k in np.flatnonzero(done):
        x = np.asarray(signals[_chunk_rows(int(k), chunk_trials, n)], dtype=np.float64)
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


def summarize(path: str | Path) -> str:
    """The text ``tactile-synth inspect`` prints: provenance, completeness, trials per class
    and condition, and per-channel signal statistics."""
    path = Path(path)
    group, meta = store.open_store(path)
    done = store.done_mask(group)
    cfg = meta["config"]
    n, c = int(meta["n_trials"]), int(meta["chunk_trials"])
    finished = np.zeros(n, dtype=bool)
    for k in np.flatnonzero(done):
        finished[_chunk_rows(int(k), c, n)] = True
    complete = bool(done.all())
    lines = [
        f"dataset    {path}",
        f"format     {meta['format_version']} (tactile-synth {meta['package_version']}, "
        f"MuJoCo {meta['mujoco_version']}, zarr {meta['zarr_version']}), "
        f"created {meta['created_at']}",
        f"config     preset={cfg['preset']} seed={cfg['seed']} "
        f"{len(cfg['shapes'])} shapes x {len(cfg['materials'])} materials x "
        f"{len(meta['conditions'])} conditions x {cfg['trials_per_class']} trials "
        f"({n} trials, {meta['n_chunks']} chunks of {c})",
        f"complete   {'yes' if complete else 'NO'}: {int(done.sum())}/{done.size} chunks, "
        f"{int(finished.sum())}/{n} trials"
        + ("" if complete else f" (finish with: tactile-synth generate --resume --out {path})"),
        "",
        "trials per class and condition" + ("" if complete else " (finished/planned)"),
    ]
    label = np.asarray(group["label"][:])
    cond = np.asarray(group["condition"][:])
    heads = [_short(x) for x in meta["conditions"]]
    width = max(12, *(len(h) for h in heads))
    lines.append(f"  {'class':<22}" + "".join(f"{h:>{width}}" for h in heads))
    for cls in sorted(set(label.tolist())):
        cells = []
        for j in range(len(heads)):
            rows = (label == cls) & (cond == j)
            got, planned = int((rows & finished).sum()), int(rows.sum())
            cells.append(f"{got}" if complete else f"{got}/{planned}")
        lines.append(f"  {meta['classes'][cls]:<22}" + "".join(f"{x:>{width}}" for x in cells))
    stats = channel_stats(group, done, c)
    lines += [
        "",
        f"signal statistics per channel (volts, over {int(stats['trials'])} trials x "
        f"{group['signals'].shape[2]} samples at {meta['sample_rate_hz']} Hz)",
        f"  {'channel':<8}" + "".join(f"{h:>12}" for h in ("mean", "std", "min", "max", "rms")),
    ]
    for i, ch in enumerate(meta["channels"]):
        vals = [stats[key][i] for key in ("mean", "std", "min", "max", "rms")]
        lines.append(f"  {ch:<8}" + "".join(f"{v:>12.5g}" for v in vals))
    return "\n".join(lines)
