"""Output directories of ``benchmark`` and ``run``: whose they are, and replacing them whole.

A directory this tool wrote holds a marker file, :data:`MARKER`. A non-empty ``--out``
without it belongs to someone else and is refused unless ``--overwrite``. The output set
(results.json, report.md, table1.md, figures) is written into a hidden sibling
(``.<name>.tactile-synth-new``) and put in place of the old one in one step at the end,
so no file of an earlier run (an old ``table1.md``) survives beside new results, and an
interrupted run leaves the previous outputs as they were. Two sub-directories are state
kept across runs, not outputs: ``data/`` (``run``'s resumable datasets) and
``checkpoints/`` (finished protocols; ``--overwrite`` starts them over); they move into
the new set at the swap. One process
at a time may write an output directory (a lock beside it).
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import shutil
from collections.abc import Mapping
from pathlib import Path
from types import TracebackType

from synth import store
from tactile_synth import atomic

#: The file that marks a directory as written by tactile-synth.
MARKER = ".tactile-synth-output"
#: Sub-directories that are state kept across runs, not part of the output set.
STATE = ("data", "checkpoints")


def _inside(path: Path, parent: Path) -> bool:
    return path == parent or parent in path.parents


class OutputDir:
    """``with OutputDir(out, overwrite=..., command=...) as tmp:`` write the output set
    into ``tmp``; on a clean exit it replaces ``out``'s output set at once (``out``'s
    ``data/`` and ``checkpoints/`` are kept; ``tmp/checkpoints`` already points at them).

    ``overwrite``: accept a non-empty ``out`` without the marker, and start over: the
    checkpoints of earlier runs are deleted (``data/`` is kept).

    ``inputs``: argument name -> path the command reads (datasets); one that the
    replacement would delete (symbolic links followed) is refused, naming its argument.
    ``out`` itself (for state such as ``run``'s datasets) exists and carries the marker
    from ``__enter__`` on.
    """

    def __init__(
        self,
        out: str | Path,
        *,
        overwrite: bool = False,
        command: str = "",
        inputs: Mapping[str, str | Path | None] | None = None,
    ) -> None:
        out = Path(out)
        self.given = out  # as typed, for messages
        self.out = out.resolve() if out.is_symlink() else out
        self.overwrite = overwrite
        self.command = command
        self.inputs = {arg: Path(p) for arg, p in (inputs or {}).items() if p is not None}
        self.tmp = atomic.sibling(self.out, "new")
        self._lock = atomic.PathLock(self.out)

    # -- checks ----------------------------------------------------------------------------
    def _check(self) -> None:
        out = self.out
        atomic.check_out_dir(out)
        store.check_not_inside_a_store(out, itself=True, advice="choose another DIR")
        root = out.resolve()
        kept = [root / s for s in STATE]
        for arg, given in self.inputs.items():
            p = given.resolve()
            if _inside(p, root) and not any(_inside(p, k) for k in kept):
                raise ValueError(
                    f"{arg} {given} lies inside --out {out}, whose contents are replaced; "
                    f"move the dataset to {root / 'data'} or outside {out}"
                )
        if out.is_dir() and any(out.iterdir()) and not (out / MARKER).is_file():
            if not self.overwrite:
                names = sorted(p.name for p in out.iterdir())
                shown = ", ".join(names[:3]) + (", ..." if len(names) > 3 else "")
                raise FileExistsError(
                    f"--out {out} is not empty ({shown}) and was not written by tactile-synth "
                    f"(no {MARKER} file); pass --overwrite to replace its contents, or choose "
                    f"a new or empty directory"
                )

    def _write_marker(self, where: Path) -> None:
        text = json.dumps(
            {
                "tool": "tactile-synth",
                "command": self.command,
                "written_at": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
            }
        )
        tmp = where / f"{MARKER}.tmp"
        tmp.write_text(text + "\n")
        tmp.replace(where / MARKER)

    # -- the context -----------------------------------------------------------------------
    def __enter__(self) -> Path:
        atomic.check_dir_path(self.out)
        # The directories this command creates (out and any missing parents), deepest
        # first: a command that fails before it has anything to keep removes them again.
        self._made = [p for p in (self.out, *self.out.absolute().parents) if not p.exists()]
        self._was_empty = self.out.is_dir() and not any(self.out.iterdir())
        try:
            self._lock.acquire()
        except atomic.LockedError as exc:
            who = f"process {exc.pid}" if exc.pid is not None else "another process"
            raise ValueError(
                f"--out {self.out} is being written by {who} (another tactile-synth "
                f"benchmark or run); wait for it to finish or choose another directory"
            ) from None
        except OSError as exc:
            raise self._not_writable(exc) from None
        try:
            self._recover()
            self._check()
            # Every check passed. out holds the state (and the marker, so an interrupted
            # run is recognised as ours); the new output set starts empty beside it.
            self.out.mkdir(parents=True, exist_ok=True)
            self._write_marker(self.out)
            if self.overwrite:
                self._drop_checkpoints()
            (self.out / "checkpoints").mkdir(exist_ok=True)
            self.tmp.mkdir()
            os.symlink(os.path.abspath(self.out / "checkpoints"), self.tmp / "checkpoints")
        except OSError as exc:
            self._lock.release()
            self._remove_made()
            raise self._not_writable(exc) from None
        except BaseException:
            self._lock.release()
            self._remove_made()
            raise
        return self.tmp

    def _not_writable(self, exc: OSError) -> Exception:
        """A read-only, forbidden or unusable ``--out`` is the user's input: a one-line
        ``ValueError`` naming ``--out`` as given, not the hidden file that failed; other
        errors (a full disk) pass unchanged."""
        return atomic.not_writable(exc, self.given, "choose another directory")

    def _drop_checkpoints(self) -> None:
        """``overwrite`` starts over: every protocol is computed again, none is taken
        from the checkpoints of the results being replaced."""
        path = self.out / "checkpoints"
        if path.is_symlink() or path.is_file():
            path.unlink()
        elif path.is_dir():
            shutil.rmtree(path)

    def _recover(self) -> None:
        """Undo what a killed process left: finish or roll back its swap, move kept state
        back from an output set that never went in place, and drop that set."""
        atomic.recover(self.out, complete=(self.tmp / MARKER).is_file())
        if not self.tmp.exists():
            return
        for name in STATE:
            src = self.tmp / name
            if src.is_dir() and not src.is_symlink() and not (self.out / name).exists():
                self.out.mkdir(parents=True, exist_ok=True)
                os.rename(src, self.out / name)
        shutil.rmtree(self.tmp)

    def _commit(self) -> None:
        for name in STATE:
            link = self.tmp / name
            if link.is_symlink():
                link.unlink()
            elif link.exists():
                raise FileExistsError(f"{link} was written as an output; {name}/ is kept state")
            if (self.out / name).exists():
                os.rename(self.out / name, link)
        self._write_marker(self.tmp)
        atomic.replace_dir(self.tmp, self.out)

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        try:
            if exc_type is None:
                self._commit()
            else:
                self._recover()  # the unfinished output set goes; the old one stays
                self._drop_if_empty()
        finally:
            self._lock.release()
        if exc_type is not None:
            self._remove_made()

    def _drop_if_empty(self) -> None:
        """Remove what ``__enter__`` put into an ``out`` this command created or found
        empty, if the command failed before it had anything to keep (no dataset, no
        checkpoint): a failed check leaves ``--out`` as it found it."""
        created = bool(self._made) and self._made[0] == self.out
        if not (created or self._was_empty) or not self.out.is_dir():
            return
        names = {p.name for p in self.out.iterdir()}
        checkpoints = self.out / "checkpoints"
        if names <= {MARKER, "checkpoints"} and not (
            checkpoints.is_dir() and any(checkpoints.iterdir())
        ):
            (self.out / MARKER).unlink(missing_ok=True)
            if checkpoints.is_dir():
                checkpoints.rmdir()

    def _remove_made(self) -> None:
        """Remove the directories of :attr:`_made` that are empty, deepest first."""
        for path in self._made:
            try:
                path.rmdir()
            except OSError:
                return  # not empty (kept state, or another process's files): keep it
