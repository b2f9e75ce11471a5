"""Export a dataset store to formats other tools read (``tactile-synth export``)."""

from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path

import numpy as np

from tactile_synth.validation import check_choice

from . import store
from .progress import Progress
from .progress import progress as show_progress

EXPORT_FORMATS: tuple[str, ...] = ("npz", "csv")


def _target(path: Path, out: str | Path | None, fmt: str, overwrite: bool) -> Path:
    """The file to write, checked (nothing is created here)."""
    target = Path(out) if out is not None else path.with_suffix(f".{fmt}")
    if target.is_dir():
        raise ValueError(f"--out {target} is a directory; give a file name")
    suffix = target.suffix.lower().lstrip(".")
    if suffix in EXPORT_FORMATS and suffix != fmt:
        # An .npz holding CSV text (or the reverse) would mislead every reader of it.
        raise ValueError(
            f"--out {target} ends in .{suffix} but --format is {fmt}; end it in .{fmt} or "
            f"pass --format {suffix}"
        )
    store.check_not_inside_a_store(target)  # a file there would sit among its arrays
    if target.exists() and not overwrite:
        raise FileExistsError(f"{target} exists; pass --overwrite to replace it or choose --out")
    return target


def export(
    path: str | Path,
    fmt: str,
    out: str | Path | None = None,
    *,
    overwrite: bool = False,
    progress: bool = True,
) -> Path:
    """Write the complete dataset at ``path`` as ``npz`` or ``csv``; returns the file written.

    npz: arrays ``signals (n, 4, T)`` float32, ``shape``, ``material`` (unicode),
    ``label``, ``condition``, ``trial_index``, ``force_n``, ``speed_mm_s``, ``seed``,
    ``classes``, ``channels`` and ``attrs_json`` (provenance as JSON text); readable with
    ``np.load(..., allow_pickle=False)``.
    csv: one row per (trial, channel): ``trial, shape, material, label, force_n,
    speed_mm_s, seed, channel`` then ``T`` sample columns ``t0..t{T-1}`` (volts).
    progress: report the trials written on stderr, one store chunk at a time
    (:func:`synth.progress.progress`: a bar on a terminal, plain lines elsewhere).
    """
    path = Path(path)
    check_choice("format", fmt, EXPORT_FORMATS)
    target = _target(path, out, fmt, overwrite)
    st = store.Store.open(path)
    done, problems = st.status()
    if not problems:  # load_dataset names the damage
        st.check_complete(done)
    data = store.load_dataset(path)  # checks every chunk
    meta = st.meta
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = target.with_name(target.name + ".partial")
    bar = show_progress(len(data), desc=f"export {fmt}", enabled=progress)
    # Written a store chunk of trials at a time: the progress moves as the file grows.
    blocks = [st.rows(k) for k in range(st.n_chunks)]
    try:
        if fmt == "npz":
            arrays = {
                "signals": data.signals,
                "shape": data.shape.astype(str),
                "material": data.material.astype(str),
                "label": data.label,
                "condition": st.plan.condition,
                "trial_index": st.plan.trial_index,
                "force_n": data.force_n,
                "speed_mm_s": data.speed_mm_s,
                "seed": data.seed,
                "classes": np.array(data.classes, dtype=str),
                "channels": np.array(meta["channels"], dtype=str),
                "attrs_json": np.array(json.dumps(meta, sort_keys=True)),
            }
            _write_npz(tmp, arrays, "signals", blocks, bar)
        else:
            _write_csv(tmp, data, meta["channels"], blocks, bar)
        os.replace(tmp, target)  # a reader never sees a half-written export
    finally:
        bar.close()
        tmp.unlink(missing_ok=True)
    return target


def _write_npz(
    tmp: Path, arrays: dict[str, np.ndarray], blocked: str, blocks: list[slice], bar: Progress
) -> None:
    """What ``np.savez_compressed(tmp, **arrays)`` writes, with the array ``blocked``
    written ``blocks`` of its rows at a time (``bar`` advanced by each block's rows)."""
    with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED, allowZip64=True) as zf:
        for name, values in arrays.items():
            with zf.open(f"{name}.npy", "w", force_zip64=True) as fh:
                if name != blocked:
                    np.lib.format.write_array(fh, values, allow_pickle=False)
                    continue
                values = np.ascontiguousarray(values)
                np.lib.format.write_array_header_1_0(
                    fh, np.lib.format.header_data_from_array_1_0(values)
                )
                for rows in blocks:
                    fh.write(values[rows].tobytes())
                    bar.update(rows.stop - rows.start)


def _write_csv(tmp: Path, data, channels: list[str], blocks: list[slice], bar: Progress) -> None:
    n_t = data.signals.shape[2]
    header = "trial,shape,material,label,force_n,speed_mm_s,seed,channel," + ",".join(
        f"t{i}" for i in range(n_t)
    )
    with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(header + "\n")
        for rows in blocks:
            for i in range(rows.start, rows.stop):
                meta = (
                    f"{i},{data.shape[i]},{data.material[i]},{int(data.label[i])},"
                    f"{float(data.force_n[i])!r},{float(data.speed_mm_s[i])!r},"
                    f"{int(data.seed[i])}"
                )
                for j, ch in enumerate(channels):
                    # float32 -> 9 significant digits round-trips exactly.
                    samples = ",".join(f"{v:.9g}" for v in data.signals[i, j].tolist())
                    fh.write(f"{meta},{ch},{samples}\n")
            bar.update(rows.stop - rows.start)
