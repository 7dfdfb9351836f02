"""Atomic file writes: a reader never sees a half-written file.

Temporary file in the target directory, fsync, the umask's mode, one rename.
"""

from __future__ import annotations

import fnmatch
import hashlib
import os
import tempfile
from collections.abc import Callable, Sequence
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
    cannot be written, an existing file unless ``force``, and a path the file system
    refuses to look at (a name too long, ...).
    """
    return _refuse_os_errors(_check_output_file, path, name, force)


def _check_output_file(path: str | os.PathLike, force: bool = False, name: str = "out") -> Path:
    """The checks of :func:`check_output_file`."""

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


def check_output_dir(
    path: str | os.PathLike,
    name: str = "out",
    force: bool = True,
    owned: Sequence[str] | None = None,
) -> Path:
    """Check, before any work, that ``path`` is (or can be created as) a writable directory.

    With ``force=False`` an existing directory is refused when it holds a file the run
    would replace: one whose name matches a glob pattern of ``owned`` (the files the
    command writes, e.g. ``("report.md", "fig*_phase_portraits.png")``), or, with
    ``owned=None``, anything at all.  So several commands share one ``--out`` directory
    and only a second run of the same command needs ``--force``.  A path the file system
    refuses to look at (a name too long, ...) is refused too.
    """

    def check(p: Any, force: bool, name: str) -> Path:
        return _check_output_dir(p, name=name, force=force, owned=owned)

    return _refuse_os_errors(check, path, name, force)


def _refuse_os_errors(check: Callable[..., Path], path: Any, name: str, force: bool) -> Path:
    """``check(path, force=force, name=name)``; an ``OSError`` from looking at ``path``
    (``ENAMETOOLONG``, ``ELOOP``, ...) becomes a :class:`ParameterError` naming ``name``
    (was: exit 4 as an I/O error "during the run", before any work had started)."""
    if not isinstance(path, (str, os.PathLike)):
        raise ParameterError(name, path, "a path (str or os.PathLike)")
    if isinstance(path, str) and not path:  # Path('') is '.': the working directory
        raise ParameterError(name, path, "a non-empty path")
    try:
        return check(path, force=force, name=name)
    except OSError as e:
        raise ParameterError(
            name, str(path), f"a path the file system accepts ({e.strerror or e})"
        ) from None


def _check_output_dir(
    path: str | os.PathLike,
    name: str = "out",
    force: bool = True,
    owned: Sequence[str] | None = None,
) -> Path:
    """The checks of :func:`check_output_dir`."""

    path = Path(path)
    if path.exists() and not path.is_dir():
        raise ParameterError(name, str(path), "a directory (this is an existing file)")
    if not force and path.is_dir():

        def replaced(entry: str) -> bool:
            if entry == LOCK_NAME:  # the lock file of a finished run (io/lock.py)
                return False
            return owned is None or any(fnmatch.fnmatchcase(entry, pat) for pat in owned)

        try:
            first = next((e for e in sorted(os.listdir(path)) if replaced(e)), None)
        except OSError:
            first = None
        if first is not None:
            what = (
                "a new or empty directory"
                if owned is None
                else "a directory without this command's files"
            )
            raise ParameterError(
                name,
                str(path),
                f"{what} (it holds {first}, which this run would replace): another --out, "
                "or --force to replace it",
            )
    base = _nearest_existing(path)
    if not base.is_dir():
        raise ParameterError(name, str(path), f"a directory path ({base} is a file)")
    if not os.access(base, os.W_OK | os.X_OK):
        raise ParameterError(name, str(path), f"a writable location ({base} is not writable)")
    return path
