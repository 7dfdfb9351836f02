"""Atomic file writes: a reader never sees a half-written file.

Temporary file in the target directory, fsync, the umask's mode, one rename.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from precise_impact.errors import ParameterError
from precise_impact.io.lock import LOCK_NAME

__all__ = [
    "atomic_write",
    "sha256_file",
    "current_umask",
    "check_output_file",
    "check_output_dir",
]


def current_umask() -> int:
    """The process umask (read without changing it for longer than one call)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def atomic_write(
    path: str | os.PathLike, writer: Callable[[Any], Any], binary: bool = True
) -> None:
    """Write ``path`` through ``writer(fh)`` atomically.

    Parameters
    ----------
    path : path-like
        The target file; its directory is created if missing.
    writer : callable
        Called once with an open file object; writes the whole content.
    binary : bool, default ``True``
        Open the temporary file in binary (``'wb'``) or UTF-8 text (``'w'``) mode.

    Raises
    ------
    OSError
        Whatever the file system raises; the temporary file is removed and an
        existing target is left as it was.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.fchmod(fd, 0o666 & ~current_umask())
        with os.fdopen(fd, "wb") if binary else os.fdopen(fd, "w", encoding="utf-8") as fh:
            writer(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


def sha256_file(path: str | os.PathLike) -> str:
    """Hex SHA-256 of a file, read in 1 MiB chunks."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _nearest_existing(path: Path) -> Path:
    p = path
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def check_output_file(path: str | os.PathLike, force: bool = False, name: str = "out") -> Path:
    """Check, before any work, that ``path`` can be written as a new file.

    Refused with :class:`~precise_impact.errors.ParameterError` naming ``name``: a
    directory at ``path``, a file where a parent directory should be, a directory that
    cannot be written, and an existing file unless ``force``.
    """

    path = Path(path)
    if path.is_dir():
        raise ParameterError(name, str(path), "a file path, not a directory")
    if path.exists() and not force:
        raise ParameterError(
            name, str(path), "a path that does not exist yet (use --force to overwrite)"
        )
    base = _nearest_existing(path.parent)
    if not base.is_dir():
        raise ParameterError(name, str(path), f"a path under a directory ({base} is a file)")
    if not os.access(base, os.W_OK | os.X_OK):
        raise ParameterError(name, str(path), f"a writable location ({base} is not writable)")
    return path


def check_output_dir(path: str | os.PathLike, name: str = "out", force: bool = True) -> Path:
    """Check, before any work, that ``path`` is (or can be created as) a writable directory.

    With ``force=False`` an existing directory that holds anything is refused (the run
    would replace files of the same name in it): a new or empty directory, or ``--force``.
    """

    path = Path(path)
    if path.exists() and not path.is_dir():
        raise ParameterError(name, str(path), "a directory (this is an existing file)")
    if not force and path.is_dir():
        try:
            # the lock file of a finished run (io/lock.py) is not the user's content
            first = next((e for e in sorted(path.iterdir()) if e.name != LOCK_NAME), None)
        except OSError:
            first = None
        if first is not None:
            raise ParameterError(
                name,
                str(path),
                f"a new or empty directory (it holds {first.name}, which this run "
                "may replace): another --out, or --force to write into it",
            )
    base = _nearest_existing(path)
    if not base.is_dir():
        raise ParameterError(name, str(path), f"a directory path ({base} is a file)")
    if not os.access(base, os.W_OK | os.X_OK):
        raise ParameterError(name, str(path), f"a writable location ({base} is not writable)")
    return path
