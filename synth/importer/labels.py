"""The labels table (``labels.csv``): one row per recording, checked cell by cell."""

from __future__ import annotations

import csv
import dataclasses
import math
from collections.abc import Sequence
from pathlib import Path

from tactile_synth.validation import check_choice, parse_number

from ..presets import (
    PHYSICAL_FORCE_RANGE_N,
    PHYSICAL_SPEED_RANGE_MM_S,
)
from ..trial import check_name
from .errors import (
    LABEL_COLUMNS,
    MAX_SAMPLE_RATE_HZ,
    MIN_SAMPLE_RATE_HZ,
    OPTIONAL_COLUMNS,
    RECORDING_SUFFIXES,
    REQUIRED_COLUMNS,
    Bad,
    RecordingError,
)


@dataclasses.dataclass(frozen=True)
class LabelRow:
    """One trial of the labels table: ``line`` (1-based, in the table), ``file`` as
    written and its ``path``; the optional values are ``None`` where not given."""

    line: int
    file: str
    path: Path
    shape: str
    material: str
    force_n: float
    speed_mm_s: float
    trial: int | None = None
    seed: int | None = None
    sample_rate_hz: float | None = None
    window_start_s: float | None = None


def _number(text: str, column: str) -> float:
    try:
        value = parse_number(text, float)
    except ValueError as exc:
        raise Bad(f"column {column}: {exc}") from None
    if not math.isfinite(value):
        raise Bad(f"column {column}: {text!r} is not a finite number")
    return value


def _integer(text: str, column: str, maximum: int) -> int:
    try:
        value = parse_number(text, int)
    except ValueError as exc:
        raise Bad(f"column {column}: {exc}") from None
    if not 0 <= value <= maximum:
        raise Bad(f"column {column} must be in 0..{maximum}; got {value}")
    return value


def _in_range(value: float, column: str, unit: str, bounds: tuple[float, float]) -> float:
    lo, hi = bounds
    if not lo <= value <= hi:
        raise Bad(
            f"column {column} must lie in {lo:g}..{hi:g} {unit} (the physical range of a "
            f"fingertip sliding over a surface); got {value:g}"
        )
    return value


def check_header(names: list[str], allowed: Sequence[str], where: str, raw: str) -> None:
    """Refuse a header with unknown, repeated or unnamed columns (``where``: file and line)."""
    if len(names) == 1 and any(sep in raw for sep in (";", "\t")):
        sep = ";" if ";" in raw else "tab"
        raise Bad(f"{where}: the columns are separated by {sep}; separate them with commas")
    for name in names:
        try:
            float(name)
        except ValueError:
            pass
        else:
            raise Bad(
                f"{where} holds numbers, not column names; the first line names the columns "
                f"({', '.join(allowed)})"
            )
        if not name:
            raise Bad(f"{where}: a column has no name")
        try:
            check_choice("column", name, allowed)
        except ValueError as exc:
            raise Bad(f"{where}: {exc}") from None
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise Bad(f"{where}: column {repeated[0]} appears twice")


def _read_text(path: Path, what: str) -> str:
    try:
        return path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise RecordingError(
            [f"{path}: {what} is not UTF-8 text (byte {exc.start} cannot be decoded)"]
        ) from None


def read_labels(labels: str | Path, recordings: str | Path) -> list[LabelRow]:
    """The rows of the labels table ``labels``, every value checked; files are looked up
    in ``recordings``. Raises :class:`RecordingError` listing every bad line."""
    labels, recordings = Path(labels), Path(recordings)
    if not labels.is_file():
        raise FileNotFoundError(
            f"--labels {labels} does not exist (the table naming each recording's "
            f"{', '.join(REQUIRED_COLUMNS)})"
        )
    lines = _read_text(labels, "the labels table").splitlines()
    if not lines or not lines[0].strip():
        raise RecordingError(
            [f"{labels} line 1 is empty; it names the columns ({', '.join(REQUIRED_COLUMNS)})"]
        )
    reader = csv.reader(lines)
    header = [h.strip().lower() for h in next(reader)]
    try:
        check_header(header, LABEL_COLUMNS, f"{labels} line 1", lines[0])
    except Bad as exc:
        raise RecordingError([str(exc)]) from None
    missing = [c for c in REQUIRED_COLUMNS if c not in header]
    if missing:
        raise RecordingError(
            [
                f"{labels} line 1 has no column {', '.join(missing)} (a labels table has "
                f"{', '.join(REQUIRED_COLUMNS)}; optional: {', '.join(OPTIONAL_COLUMNS)})"
            ]
        )
    problems: list[str] = []
    rows: list[LabelRow] = []
    seen_files: dict[Path, int] = {}
    seen_trials: dict[tuple[str, float, float, int], int] = {}
    seen_seeds: dict[int, int] = {}
    for cells in reader:
        line = reader.line_num
        if not any(c.strip() for c in cells):
            continue  # a blank line
        where = f"{labels} line {line}"
        if len(cells) != len(header):
            problems.append(
                f"{where} has {len(cells)} cells; the header names {len(header)} columns "
                f"({', '.join(header)})"
            )
            continue
        values = {name: cell.strip() for name, cell in zip(header, cells, strict=True)}
        try:
            row = _label_row(values, line, recordings)
        except Bad as exc:
            problems.append(f"{where}: {exc}")
            continue
        key = row.path.resolve()
        if key in seen_files:
            problems.append(f"{where}: file {row.file} is listed again (first on line "
                            f"{seen_files[key]})")  # fmt: skip
            continue
        seen_files[key] = line
        if not row.path.is_file():
            problems.append(f"{where}: file {row.file} does not exist (looked for {row.path})")
        if row.trial is not None:
            tkey = (f"{row.shape}/{row.material}", row.force_n, row.speed_mm_s, row.trial)
            if tkey in seen_trials:
                problems.append(
                    f"{where}: trial {row.trial} of {row.shape}/{row.material} at "
                    f"{row.force_n:g} N, {row.speed_mm_s:g} mm/s is also on line "
                    f"{seen_trials[tkey]}"
                )
            seen_trials.setdefault(tkey, line)
        if row.seed is not None:
            if row.seed in seen_seeds:
                problems.append(f"{where}: seed {row.seed} is also on line {seen_seeds[row.seed]}")
            seen_seeds.setdefault(row.seed, line)
        rows.append(row)
    if not rows and not problems:
        problems.append(f"{labels} lists no recordings (only its header line)")
    if problems:
        raise RecordingError(problems)
    return rows


def _label_row(values: dict[str, str], line: int, recordings: Path) -> LabelRow:
    for column in (*REQUIRED_COLUMNS, "trial", "seed"):
        if column in values and not values[column]:
            raise Bad(f"column {column} is empty")
    file = values["file"]
    if Path(file).suffix.lower() not in RECORDING_SUFFIXES:
        raise Bad(f"file {file} is neither a .csv nor a .npz recording")
    try:
        # Any specimen and material: the paper's names or a lab's own.
        shape = check_name("column shape", values["shape"].lower())
        material = check_name("column material", values["material"].lower())
    except ValueError as exc:
        raise Bad(str(exc)) from None
    force = _in_range(_number(values["force_n"], "force_n"), "force_n", "N", PHYSICAL_FORCE_RANGE_N)
    speed = _in_range(
        _number(values["speed_mm_s"], "speed_mm_s"), "speed_mm_s", "mm/s", PHYSICAL_SPEED_RANGE_MM_S
    )
    trial = _integer(values["trial"], "trial", 2**31 - 1) if "trial" in values else None
    seed = _integer(values["seed"], "seed", 2**63 - 1) if "seed" in values else None
    rate = None
    if values.get("sample_rate_hz"):
        rate = check_rate(_number(values["sample_rate_hz"], "sample_rate_hz"), "sample_rate_hz")
    start = None
    if values.get("window_start_s"):
        start = _number(values["window_start_s"], "window_start_s")
        if start < 0:
            raise Bad(f"column window_start_s must be >= 0 s; got {start:g}")
    return LabelRow(
        line=line,
        file=file,
        path=recordings / file,
        shape=shape,
        material=material,
        force_n=force,
        speed_mm_s=speed,
        trial=trial,
        seed=seed,
        sample_rate_hz=rate,
        window_start_s=start,
    )


def check_rate(rate: float, what: str) -> float:
    if not math.isfinite(rate) or rate <= 0:
        raise Bad(f"{what} must be a finite number > 0 Hz; got {rate!r}")
    if rate > MAX_SAMPLE_RATE_HZ:
        raise Bad(f"{what} {rate:g} Hz is above {MAX_SAMPLE_RATE_HZ:g} Hz (is it in another unit?)")
    if rate < MIN_SAMPLE_RATE_HZ:
        raise Bad(f"{what} {rate:g} Hz is below {MIN_SAMPLE_RATE_HZ:g} Hz (is it in another unit?)")
    return rate
