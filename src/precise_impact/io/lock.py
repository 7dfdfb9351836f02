"""One writer per output directory: an advisory lock file that cannot go stale.

An exclusive ``flock`` the kernel releases when the holder dies; a live holder is named.
Re-entrant within one thread (the CLI locks every ``--out`` directory and a sweep locks its own
again); another thread or process is refused.  A directory the lock itself created and that
holds nothing else when the lock is released is removed again (a refused run leaves no trace).
"""

from __future__ import annotations

import json
import os
import socket
import threading
import time
from pathlib import Path

from precise_impact.errors import ParameterError

try:  # POSIX
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None

__all__ = ["DirectoryLock", "LOCK_NAME"]

#: The lock file's name inside the locked directory.
LOCK_NAME = ".precise_impact.lock"


#: Locks held by this process: real path of the directory -> [holding thread id, depth].
_HELD: dict[str, list[int]] = {}
_HELD_GUARD = threading.Lock()


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True
    return True


class DirectoryLock:
    """Exclusive, non-blocking lock on a directory (a context manager).

    Parameters
    ----------
    directory : path-like
        The directory to lock; created if missing.
    name : str, default ``'out'``
        The parameter named in the refusal (the CLI flag the user gave).

    Attributes
    ----------
    stale : dict or None
        After :meth:`acquire`: the holder recorded in a lock file that was left behind
        by a process that no longer holds it (``None`` when the file was absent or clean).

    Raises
    ------
    ParameterError
        On :meth:`acquire` (or entering the ``with`` block): another live process holds
        the lock.
    """

    def __init__(self, directory: str | os.PathLike, name: str = "out"):
        self.directory = Path(directory)
        self.path = self.directory / LOCK_NAME
        self.name = name
        self.stale: dict | None = None
        self._fd: int | None = None
        self._key: str | None = None  # set while held (the outermost or a nested acquire)
        self._created = False

    def _holder(self) -> dict:
        try:
            return json.loads(self.path.read_text(encoding="utf-8") or "{}")
        except (OSError, ValueError):
            return {}

    def _refuse(self, holder: dict):
        who = (
            f"pid {holder.get('pid', '?')} on {holder.get('host', '?')} since "
            f"{holder.get('since', '?')}"
            if holder
            else "another process"
        )
        raise ParameterError(
            self.name,
            str(self.directory),
            f"a directory no other run is writing to (locked by {who}; wait for it to finish)",
        )

    def acquire(self) -> DirectoryLock:
        self._created = not self.directory.exists()
        self._make_directory()
        key = os.path.realpath(self.directory)
        with _HELD_GUARD:
            held = _HELD.get(key)
            if held is not None and held[0] == threading.get_ident():
                held[1] += 1  # nested in the same thread: the outer acquire holds the lock
                self._key, self._created = key, False
                return self
        me = {
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "since": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        }
        if fcntl is not None:
            while True:
                try:
                    fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o666)
                except FileNotFoundError:  # a releasing holder removed the directory it made
                    self._created = True
                    self._make_directory()
                    continue
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                except BlockingIOError:
                    os.close(fd)
                    self._refuse(self._holder())
                except BaseException:
                    os.close(fd)
                    raise
                try:  # the file may have been removed by a releasing holder meanwhile
                    same = os.stat(self.path).st_ino == os.fstat(fd).st_ino
                except FileNotFoundError:
                    same = False
                if same:
                    break
                os.close(fd)
            previous = self._holder()
            self.stale = previous or None  # a clean release empties the file
            os.ftruncate(fd, 0)
            os.pwrite(fd, json.dumps(me).encode(), 0)
            self._fd = fd
            self._hold(key)
            return self
        while True:  # pragma: no cover - Windows fallback
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o666)
            except FileExistsError:
                holder = self._holder()
                pid = holder.get("pid")
                if (
                    holder.get("host") == me["host"]
                    and isinstance(pid, int)
                    and not _pid_alive(pid)
                ):
                    self.stale = holder
                    self.path.unlink(missing_ok=True)
                    continue
                self._refuse(holder)
            os.write(fd, json.dumps(me).encode())
            self._fd = fd
            self._hold(key)
            return self

    def _make_directory(self) -> None:
        """The directory made if missing, also while racers make and remove it (``mkdir``'s
        ``exist_ok`` raises when the directory it found is removed before its own check)."""
        while True:
            try:
                self.directory.mkdir(parents=True, exist_ok=True)
                return
            except FileExistsError:
                if not self.directory.is_dir() and (
                    self.directory.exists() or self.directory.is_symlink()
                ):  # a file, or a dangling link: not a race
                    raise

    def _hold(self, key: str) -> None:
        self._key = key
        with _HELD_GUARD:
            _HELD[key] = [threading.get_ident(), 1]

    def release(self) -> None:
        key, self._key = self._key, None
        if key is not None:
            with _HELD_GUARD:
                held = _HELD.get(key)
                if held is not None and held[1] > 1:
                    held[1] -= 1
                    return  # an inner acquire: the outer one still holds the lock
                _HELD.pop(key, None)
        if self._fd is None:
            return
        fd, self._fd = self._fd, None
        try:
            if fcntl is not None:
                os.ftruncate(fd, 0)  # empty = released cleanly (not stale)
                if self._created:  # still holding the lock: nobody else is writing here
                    self._remove_if_only_lock()
                fcntl.flock(fd, fcntl.LOCK_UN)
            else:  # pragma: no cover
                self.path.unlink(missing_ok=True)
        finally:
            os.close(fd)

    def _remove_if_only_lock(self) -> None:
        """The directory this lock created, if nothing but the lock file was written to it."""
        try:
            if [e.name for e in os.scandir(self.directory)] == [LOCK_NAME]:
                self.path.unlink()
                self.directory.rmdir()
        except OSError:
            pass  # something appeared meanwhile, or no permission: leave it

    def __enter__(self) -> DirectoryLock:
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()
