"""Filesystem steps that writers share so that they never collide or leave half-done work.

- :class:`PathLock`: an exclusive, non-blocking ``flock`` on a lock file *beside* a path
  (``<parent>/.<name>.tactile-synth-lock``). It sits beside the path rather than inside
  it because the path itself is replaced by a rename when a new version is ready, and
  the lock must cover the path, its replacement and the moment of the swap. The holder
  writes its pid into the file, so a second writer can say who holds it. The kernel
  drops the lock when the holder exits, however it exits, so a lock is never stale.
- :func:`replace_dir`: put a finished directory in place of another (two renames in one
  directory, the old one deleted last); :func:`recover` completes a replacement a killed
  process left half-way, so the path always ends up holding one whole version.
- :func:`check_out_dir`, :func:`check_dir_path`, :func:`not_writable`: an output path
  refused in one line naming its argument before anything is written;
  :func:`check_not_inside_a_store`: an output that would land inside a dataset store
  (a Zarr group) refused likewise.

Every package's commands write through these, so the module sits in the package every
other one may import, and imports only the standard library.
"""

from __future__ import annotations

import errno
import fcntl
import os
import shutil
from pathlib import Path

SUFFIX = ".tactile-synth"


class LockedError(RuntimeError):
    """Another process holds the lock. ``path``: the locked path; ``pid``: the holder's
    pid (``None`` if it could not be read)."""

    def __init__(self, path: Path, pid: int | None) -> None:
        self.path = path
        self.pid = pid
        who = f"process {pid}" if pid is not None else "another process"
        super().__init__(f"{path} is locked by {who}")


def sibling(path: str | Path, role: str) -> Path:
    """``<parent>/.<name>.tactile-synth-<role>``: a hidden name beside ``path`` (same
    directory, so a rename between them is atomic)."""
    p = Path(os.path.abspath(path))
    if not p.name:
        raise ValueError(f"{path} has no name to create anything beside it; choose a sub-path")
    return p.parent / f".{p.name}{SUFFIX}-{role}"


def check_out_dir(path: str | Path, arg: str = "--out", advice: str = "choose a directory") -> None:
    """One-line errors naming ``arg`` when ``path`` cannot be an output directory:
    ``FileExistsError`` if a file stands at ``path`` (the message ends with ``advice``),
    ``NotADirectoryError`` if a file stands where one of its parents must be."""
    if Path(path).exists() and not Path(path).is_dir():
        raise FileExistsError(f"{arg} {path} is a file; {advice}")
    check_dir_path(path, arg)


def check_dir_path(path: str | Path, arg: str = "--out") -> None:
    """``NotADirectoryError`` naming ``arg`` if a file stands where ``path`` or one of its
    parent directories must be."""
    p = Path(os.path.abspath(path))
    for parent in p.parents:
        if parent.exists():
            if not parent.is_dir():
                raise NotADirectoryError(f"{arg} {path}: {parent} is a file, not a directory")
            return


#: errno values that say an output place is read-only or forbidden, not that the work
#: failed (a full disk is not among them).
NOT_WRITABLE_ERRNOS: tuple[int, ...] = (errno.EROFS, errno.EACCES, errno.EPERM)


def not_writable(
    exc: OSError,
    given: str | Path,
    advice: str,
    errnos: tuple[int, ...] = NOT_WRITABLE_ERRNOS,
) -> Exception:
    """The error to raise for ``exc``, met while writing the ``--out`` the user gave as
    ``given``: for one of ``errnos`` the place is the user's input, so a one-line
    ``ValueError`` naming ``--out`` as given (ending with ``advice``), not the hidden file
    that failed; otherwise ``exc`` itself."""
    if exc.errno not in errnos:
        return exc
    return ValueError(f"--out {given} cannot be written ({exc.strerror}); {advice}")


class PathLock:
    """Exclusive lock on ``path`` (existing or not) for this process; use as a context
    manager. Raises :class:`LockedError` at once if another process (or another
    ``PathLock`` in this process) holds it."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.file = sibling(path, "lock")
        self._fd: int | None = None

    def acquire(self) -> PathLock:
        self.file.parent.mkdir(parents=True, exist_ok=True)
        while True:
            try:
                fd = os.open(self.file, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError as exc:  # name the path asked for, not only its lock file
                why = f"{exc.strerror} (cannot create the lock file beside it)"
                raise type(exc)(exc.errno, why, str(self.path)) from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                pid = _read_pid(fd)
                os.close(fd)
                if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                    raise LockedError(self.path, pid) from None
                raise
            # The previous holder deletes the file when it lets go; if it did so between
            # our open and our flock we hold a lock on a deleted file: start again.
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(self.file))
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        self._fd = fd
        return self

    def release(self) -> None:
        if self._fd is None:
            return
        try:
            self.file.unlink(missing_ok=True)  # while still holding it: see acquire
        finally:
            os.close(self._fd)
            self._fd = None

    def __enter__(self) -> PathLock:
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()


def _read_pid(fd: int) -> int | None:
    try:
        text = os.pread(fd, 64, 0).decode(errors="replace").strip()
        return int(text) if text else None
    except (OSError, ValueError):
        return None


def fsync_dir(path: Path) -> None:
    """Flush a directory's entries (renames, new files) to the disk."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def replace_dir(new: Path, target: Path) -> None:
    """Put the finished directory ``new`` at ``target``, replacing what is there.

    ``target`` is renamed to its ``old`` sibling, ``new`` to ``target``, and the old
    version deleted last; both renames stay in one directory. A process killed between
    the steps leaves a state :func:`recover` completes. Call it holding the lock.
    """
    old = sibling(target, "old")
    if old.exists():
        shutil.rmtree(old)
    if target.exists():
        os.rename(target, old)
    os.rename(new, target)
    fsync_dir(target.parent)
    if old.exists():
        shutil.rmtree(old)


def recover(target: Path, complete: bool) -> None:
    """Finish a :func:`replace_dir` that was killed half-way (call it holding the lock).

    complete: whether the ``new`` sibling holds a finished version. If ``target`` is
    missing but its ``old`` sibling exists, the swap stopped between its renames: the
    finished new version goes in place, else the old one goes back.
    """
    old = sibling(target, "old")
    if not old.exists():
        return
    if not target.exists():
        new = sibling(target, "new")
        os.rename(new if complete and new.exists() else old, target)
        fsync_dir(target.parent)
    if old.exists():
        shutil.rmtree(old)


# -- Zarr stores ------------------------------------------------------------------------
def is_store(path: Path) -> bool:
    """True if ``path`` is a Zarr group directory (a tactile-synth store or a half-created one)."""
    return (Path(path) / "zarr.json").is_file()


def enclosing_store(path: str | Path, *, itself: bool = False) -> Path | None:
    """The store that holds ``path`` below its root (one of its arrays, or anything
    further down), or with ``itself`` also the store that ``path`` is, if any: a dataset
    or a file written there would replace part of that store. An array's directory has
    its own ``zarr.json``, so the outermost one is the store."""
    p = Path(os.path.abspath(path))
    stores = [q for q in ((p,) if itself else ()) + tuple(p.parents) if is_store(q)]
    return stores[-1] if stores else None


def check_not_inside_a_store(
    out: str | Path, *, itself: bool = False, advice: str = "choose a path outside it"
) -> None:
    """A one-line ``ValueError`` naming ``--out`` (ending with ``advice``) if ``out`` lies
    inside another dataset store (or, with ``itself``, is one), where writing (or
    replacing with ``--overwrite``) would damage that store."""
    inside = enclosing_store(out, itself=itself)
    if inside is not None:
        raise ValueError(f"--out {out} lies inside the dataset {inside}; {advice}")
