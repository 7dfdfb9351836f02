"""One writer per output directory: an advisory lock file that cannot go stale.

An exclusive ``flock`` the kernel releases when the holder dies; a live holder is named.
"""

from __future__ import annotations

import json
import os
import socket
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
        self.directory.mkdir(parents=True, exist_ok=True)
        me = {
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "since": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        }
        if fcntl is not None:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o666)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                self._refuse(self._holder())
            except BaseException:
                os.close(fd)
                raise
            previous = self._holder()
            self.stale = previous or None  # a clean release empties the file
            os.ftruncate(fd, 0)
            os.pwrite(fd, json.dumps(me).encode(), 0)
            self._fd = fd
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
            return self

    def release(self) -> None:
        if self._fd is None:
            return
        fd, self._fd = self._fd, None
        try:
            if fcntl is not None:
                os.ftruncate(fd, 0)  # empty = released cleanly (not stale)
                fcntl.flock(fd, fcntl.LOCK_UN)
            else:  # pragma: no cover
                self.path.unlink(missing_ok=True)
        finally:
            os.close(fd)

    def __enter__(self) -> DirectoryLock:
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()
