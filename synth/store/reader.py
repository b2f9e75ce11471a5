"""An opened store (:class:`Store`): its metadata, configuration and arrays, with checked
reads of its chunks and per-trial arrays."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from ..presets import GenerationConfig, TrialPlan, plan
from ..trial import CHANNELS, N_SAMPLES
from .checksums import array_checksum, chunk_checksum
from .errors import DatasetError, DatasetIncomplete, Problem
from .layout import KIND_IMPORTED, PLAN_ARRAYS, PLAN_DTYPES, chunk_file
from .meta import (
    check_classes,
    check_format,
    check_imported_meta,
    config_of,
    read_meta,
    rebuild_advice,
    store_kind,
)


@dataclass
class Store:
    """An opened tactile-synth store: its metadata, configuration (``None`` for an
    imported store) and arrays, with checked reads. ``Store.open(path)`` raises one-line
    errors naming the file at fault."""

    path: Path
    group: Any
    meta: dict[str, Any]
    config: GenerationConfig | None
    arrays: dict[str, Any] = field(default_factory=dict)
    _checksums: tuple[np.ndarray, dict[int, str]] | None = field(default=None, repr=False)

    @classmethod
    def open(cls, path: str | Path, mode: str = "r") -> Store:
        import zarr

        path = Path(path)
        meta = read_meta(path)
        check_format(path, meta)
        if store_kind(meta) == KIND_IMPORTED:
            check_imported_meta(path, meta)
            config = None
        else:
            config = config_of(path, meta)
            check_classes(path, meta, config)
        try:
            group = zarr.open_group(path, mode=mode, zarr_format=3)
        except (ValueError, KeyError, TypeError) as exc:  # pragma: no cover - read above
            raise DatasetError(f"{path / 'zarr.json'} cannot be opened by zarr ({exc})") from None
        store = cls(path=path, group=group, meta=meta, config=config)
        store._open_arrays()
        return store

    def _open_arrays(self) -> None:
        import zarr

        n, c, k = self.n_trials, self.chunk_trials, self.n_chunks
        expected = {
            "signals": ((n, len(CHANNELS), N_SAMPLES), (c, len(CHANNELS), N_SAMPLES), "float32"),
            "checksum": ((k,), (1,), "uint32"),
            "done": ((k,), (1,), "uint8"),
        }
        for name, dtype in PLAN_DTYPES.items():
            expected[name] = ((n,), (max(n, 1),), dtype)
        for name, (shape, chunks, dtype) in expected.items():
            meta_file = self.path / name / "zarr.json"
            regenerate = rebuild_advice(self.path, self.meta)
            try:
                arr = self.group[name]
            except Exception as exc:  # zarr raises JSON, key and type errors on bad metadata
                if not meta_file.exists():
                    raise DatasetError(
                        f"dataset {self.path} has no {name} array ({meta_file} is missing)",
                        regenerate,
                    ) from None
                raise DatasetError(
                    f"{meta_file} is damaged ({type(exc).__name__}: {exc})", regenerate
                ) from None
            if not isinstance(arr, zarr.Array):
                raise DatasetError(
                    f"{meta_file} describes a group, not the dataset's {name} array",
                    regenerate,
                )
            if (arr.shape, arr.chunks, str(arr.dtype)) != (shape, chunks, dtype):
                raise DatasetError(
                    f"{meta_file} describes {arr.dtype} {arr.shape} in chunks {arr.chunks}, "
                    f"but the dataset's {'attributes' if self.imported else 'configuration'} "
                    f"need {dtype} {shape} in chunks {chunks}",
                    regenerate,
                )
            self.arrays[name] = arr

    # -- kind and geometry ---------------------------------------------------------------
    @property
    def kind(self) -> str:
        """``"simulated"`` or ``"imported"``."""
        return store_kind(self.meta)

    @property
    def imported(self) -> bool:
        return self.kind == KIND_IMPORTED

    @property
    def n_trials(self) -> int:
        return self.config.n_trials if self.config is not None else int(self.meta["n_trials"])

    @property
    def chunk_trials(self) -> int:
        if self.config is not None:
            return self.config.chunk_trials
        return int(self.meta["chunk_trials"])

    @property
    def n_chunks(self) -> int:
        return self.config.n_chunks if self.config is not None else int(self.meta["n_chunks"])

    @property
    def classes(self) -> tuple[str, ...]:
        """The dataset's class list: ``label`` indexes it."""
        return tuple(self.meta["classes"])

    @property
    def shapes(self) -> tuple[str, ...]:
        """The shapes (specimens) of the dataset's classes, in their order."""
        return self.config.shapes if self.config is not None else tuple(self.meta["shapes"])

    @property
    def materials(self) -> tuple[str, ...]:
        """The materials of the dataset's classes, in their order."""
        if self.config is not None:
            return self.config.materials
        return tuple(self.meta["materials"])

    def check_complete(self, done: np.ndarray) -> None:
        """``DatasetError`` saying how to finish the store unless every chunk is ``done``
        (for commands that need every trial: ``plot``, ``export``)."""
        if not done.all():
            raise DatasetIncomplete(
                f"dataset {self.path} is incomplete ({int(done.sum())}/{done.size} chunks done)",
                self.finish_advice(),
            )

    def finish_advice(self) -> str:
        """How to complete this store when chunks are not done."""
        if self.imported:
            return rebuild_advice(self.path, self.meta)
        return f"finish it with `tactile-synth generate --resume --out {self.path}`"

    @property
    def store_id(self) -> str | None:
        return self.meta.get("store_id")

    def rows(self, chunk: int) -> slice:
        c = self.chunk_trials
        return slice(chunk * c, min((chunk + 1) * c, self.n_trials))

    def file(self, name: str, chunk: int = 0) -> Path:
        return chunk_file(self.path, name, chunk)

    @cached_property
    def plan(self) -> TrialPlan:
        """The per-trial arrays: for a simulated store the plan of its configuration
        (regenerated, never read); for an imported one the stored arrays (checked by
        :meth:`check_plan`; one that cannot be read comes back as zeros, which fail it)."""
        if self.config is not None:
            return plan(self.config)
        values, _ = self._stored_trials
        return TrialPlan(**values, classes=self.classes)

    @cached_property
    def _stored_trials(self) -> tuple[dict[str, np.ndarray], dict[str, str]]:
        """An imported store's per-trial arrays and ``{name: error}`` for unreadable ones."""
        values, bad = {}, {}
        for name, dtype in PLAN_DTYPES.items():
            try:
                values[name] = np.asarray(self.arrays[name][:], dtype=dtype)
            except Exception as exc:
                values[name] = np.zeros(self.n_trials, dtype=dtype)
                bad[name] = _decode_error(exc)
        return values, bad

    # -- flags ---------------------------------------------------------------------------
    def _flags(self, name: str) -> tuple[np.ndarray, dict[int, str]]:
        """An array of per-chunk values and ``{chunk: error}`` for files that fail to decode."""
        arr = self.arrays[name]
        try:
            return np.asarray(arr[:]), {}
        except Exception:  # one damaged file fails the whole read: find which
            values = np.zeros(arr.shape, dtype=arr.dtype)
            bad: dict[int, str] = {}
            for k in range(arr.shape[0]):
                try:
                    values[k] = arr[k]
                except Exception as exc:
                    bad[k] = _decode_error(exc)
            return values, bad

    def status(self) -> tuple[np.ndarray, list[Problem]]:
        """``(done, problems)``: bool ``(n_chunks,)`` of chunks marked complete, and the
        chunks whose done-flag file is damaged (they count as not done)."""
        done, bad_done = self._flags("done")
        mask = done == 1
        problems = [
            Problem(f"chunk {k}'s done flag", self.file("done", k), why, chunk=k)
            for k, why in bad_done.items()
        ]
        return mask, problems

    def checksums(self) -> tuple[np.ndarray, dict[int, str]]:
        """Recorded per-chunk checksums and ``{chunk: error}`` for damaged checksum files
        (read once per opened store)."""
        if self._checksums is None:
            self._checksums = self._flags("checksum")
        return self._checksums

    # -- verified reads ------------------------------------------------------------------
    def expected_checksum(self, chunk: int, signals: np.ndarray) -> int:
        r, p = self.rows(chunk), self.plan
        return chunk_checksum(signals, p.label[r], p.force_n[r], p.speed_mm_s[r], p.seed[r])

    def _chunk_problem(self, chunk: int, why: str) -> Problem:
        r = self.rows(chunk)
        return Problem(
            f"chunk {chunk}",
            self.file("signals", chunk),
            why,
            chunk=chunk,
            trials=f"trials {r.start}-{r.stop - 1}",
        )

    def _check_chunk(self, chunk: int, data: np.ndarray, recorded: int) -> Problem | None:
        if self.expected_checksum(chunk, data) == recorded:
            return None
        if not self.file("signals", chunk).is_file():
            return self._chunk_problem(chunk, "is missing")
        if not self.file("checksum", chunk).is_file():
            return self._chunk_problem(chunk, f"has no checksum ({self.file('checksum', chunk)})")
        return self._chunk_problem(
            chunk,
            "fails its checksum (edited, or swapped with another chunk or dataset)",
        )

    def read_chunks(self, chunks: Iterable[int]) -> tuple[dict[int, np.ndarray], list[Problem]]:
        """Signals of ``chunks`` (``{chunk: (b, 4, T)}``), each checked against its recorded
        checksum and its trials' plan; chunks that fail are left out and listed."""
        out, problems, _ = self._read_chunks(chunks)
        return out, problems

    def _read_chunks(
        self, chunks: Iterable[int]
    ) -> tuple[dict[int, np.ndarray], list[Problem], np.ndarray | None]:
        chunks = [int(k) for k in chunks]
        recorded, bad_sums = self.checksums()
        out: dict[int, np.ndarray] = {}
        problems: list[Problem] = []
        signals = self.arrays["signals"]
        whole = None
        if chunks and chunks == list(range(self.n_chunks)):
            try:
                whole = np.asarray(signals[:])  # one read: zarr decodes chunks in parallel
            except Exception:
                whole = None  # a damaged file: fall back to chunk by chunk to name it
        for k in chunks:
            if k in bad_sums:
                problems.append(
                    self._chunk_problem(k, f"has a damaged checksum file: {bad_sums[k]}")
                )
                continue
            if whole is not None:
                data = whole[self.rows(k)]
            else:
                try:
                    data = np.asarray(signals[self.rows(k)])
                except Exception as exc:
                    problems.append(self._chunk_problem(k, f"cannot be read: {_decode_error(exc)}"))
                    continue
            problem = self._check_chunk(k, data, int(recorded[k]))
            if problem is None:
                out[k] = data
            else:
                problems.append(problem)
        return out, problems, whole

    def check_plan(self) -> list[Problem]:
        """The stored per-trial arrays that differ from the plan of the stored configuration
        (simulated) or from their recorded checksums (imported)."""
        if self.imported:
            return self._check_imported_trials()
        problems = []
        for name in PLAN_ARRAYS:
            file = self.file(name)
            try:
                stored = np.asarray(self.arrays[name][:])
            except Exception as exc:
                problems.append(Problem(name, file, f"cannot be read: {_decode_error(exc)}"))
                continue
            expected = getattr(self.plan, name)
            if not np.array_equal(stored, expected):
                if not file.is_file():
                    problems.append(Problem(name, file, "is missing"))
                    continue
                bad = np.flatnonzero(stored != expected)
                problems.append(
                    Problem(
                        name,
                        file,
                        f"differs from the dataset's configuration at {bad.size} trials "
                        f"(first: trial {int(bad[0])})",
                    )
                )
        return problems

    def _check_imported_trials(self) -> list[Problem]:
        values, bad = self._stored_trials
        sums = self.meta["array_checksums"]
        problems = []
        for name, dtype in PLAN_DTYPES.items():
            file = self.file(name)
            if name in bad:
                problems.append(Problem(name, file, f"cannot be read: {bad[name]}"))
            elif array_checksum(values[name], dtype) != int(sums[name]):
                why = (
                    "is missing"
                    if not file.is_file()
                    else "fails its checksum (edited, or copied from another dataset)"
                )
                problems.append(Problem(name, file, why))
            elif name == "label" and values[name].size:
                k = len(self.classes)
                bad = np.flatnonzero((values[name] < 0) | (values[name] >= k))
                if bad.size:
                    problems.append(
                        Problem(
                            name,
                            file,
                            f"holds labels outside the {k} classes at {bad.size} trials "
                            f"(first: trial {int(bad[0])})",
                        )
                    )
        return problems

    def verify(self) -> list[Problem]:
        """Every problem of the store: per-trial arrays, flags, and each finished chunk."""
        done, problems = self.status()
        problems += self.check_plan()
        _, chunk_problems = self.read_chunks(np.flatnonzero(done))
        return problems + chunk_problems


def _decode_error(exc: BaseException) -> str:
    text = str(exc).strip() or type(exc).__name__
    if "checksum" in text.lower():
        return "its stored CRC-32C does not match (truncated or corrupted)"
    if "blosc" in text.lower() or "decompress" in text.lower():
        return f"it does not decompress ({text}: truncated or corrupted)"
    return text.splitlines()[0]


def is_complete(path: str | Path) -> bool:
    """``path`` is a readable store whose every chunk is finished."""
    try:
        return bool(Store.open(path).status()[0].all())
    except (OSError, ValueError):
        return False
