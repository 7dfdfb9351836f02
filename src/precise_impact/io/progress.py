"""Progress reporting on standard error: the one place long jobs talk while they run.

``progress=True`` reports, ``False`` is silent, ``None`` reports only on a terminal, a callable
``progress(done, total)`` is called instead of printing (:data:`ProgressArg`); always on stderr.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import Any

from precise_impact.errors import ParameterError

__all__ = ["say", "Progress", "ProgressArg", "check_progress", "wanted"]

#: What every ``progress=`` argument takes: a bool, ``None`` (only on a terminal) or a
#: callable ``(done, total)``.
ProgressArg = bool | None | Callable[[int, int], Any]

#: Least seconds between two redraws on a terminal, and between two lines elsewhere.
TTY_INTERVAL = 0.2
LINE_INTERVAL = 5.0


def _isatty() -> bool:
    try:
        return bool(sys.stderr.isatty())
    except (AttributeError, ValueError):  # no stderr, or a closed one
        return False


def check_progress(progress: Any, name: str = "progress") -> ProgressArg:
    """``progress`` if it is a :data:`ProgressArg` (numpy bools as bool), else a
    :class:`ParameterError` naming ``name``."""
    if progress is None or callable(progress):
        return progress
    kind = type(progress)
    if isinstance(progress, bool) or (
        kind.__module__ == "numpy" and kind.__name__ in ("bool", "bool_")
    ):
        return bool(progress)
    raise ParameterError(name, progress, "True, False, None or a callable(done, total)")


def wanted(enabled: ProgressArg) -> bool:
    """Whether to print on stderr: ``enabled`` itself, for ``None`` whether stderr is a
    terminal, for a callable no (it is called instead).

    Parameters
    ----------
    enabled : bool, None or callable
        ``True`` / ``False``, ``None`` for "only on a terminal", or a callback.

    Returns
    -------
    bool
    """
    if enabled is None:
        return _isatty()
    return False if callable(enabled) else bool(enabled)


def say(msg: str, enabled: ProgressArg = True) -> None:
    """Print ``msg`` as one line on stderr.

    Parameters
    ----------
    msg : str
        The line (without newline).
    enabled : bool, None or callable, default ``True``
        ``False`` or a callable prints nothing; ``None`` prints only when stderr is a terminal.
    """
    if wanted(enabled):
        print(msg, file=sys.stderr, flush=True)


class Progress:
    """Throttled ``label [####....] done/total  elapsed`` reports on stderr.

    Parameters
    ----------
    total : int
        Number of items.
    label : str
        What is counted (printed before the count).
    enabled : bool, None or callable, default ``True``
        ``False`` prints nothing; ``None`` reports only when stderr is a terminal; a
        callable is called as ``enabled(done, total)`` at every :meth:`update` (no
        throttling, nothing printed).
    interval : float or None, default ``None``
        Least seconds between two reports; ``None``: :data:`TTY_INTERVAL` on a terminal
        (one line redrawn in place), :data:`LINE_INTERVAL` elsewhere (one line each).

    Notes
    -----
    Call :meth:`update` as often as convenient (every item of a tight loop costs one
    clock read); call :meth:`close` when a job may stop before ``total`` (resumed or
    partial runs) so the last count is shown and a redrawn line is ended.
    """

    def __init__(
        self, total: int, label: str, enabled: ProgressArg = True, interval: float | None = None
    ) -> None:
        self.total, self.label = int(total), label
        self.callback = enabled if callable(enabled) else None
        self.enabled = self.callback is not None or wanted(enabled)
        self.tty = _isatty()
        self.interval = (
            (TTY_INTERVAL if self.tty else LINE_INTERVAL) if interval is None else float(interval)
        )
        self.start = time.perf_counter()
        self._last = -float("inf")
        self._shown: int | None = None
        self._pending: tuple[int, str] | None = None
        self._open = False  # a redrawn line is on screen without its newline

    def _text(self, done: int, extra: str, now: float) -> str:
        tail = f"  {extra}" if extra else ""
        if self.tty:
            width = 30
            filled = int(width * done / self.total) if self.total > 0 else width
            bar = "#" * filled + "." * (width - filled)
            return f"  {self.label} [{bar}] {done}/{self.total}  {now - self.start:.1f} s{tail}"
        return f"  {self.label}: {done}/{self.total} ({now - self.start:.1f} s){tail}"

    def _emit(self, done: int, extra: str, now: float, final: bool) -> None:
        text = self._text(done, extra, now)
        if self.tty:
            print("\r" + text + "\033[K", end="\n" if final else "", file=sys.stderr, flush=True)
            self._open = not final
        else:
            print(text, file=sys.stderr, flush=True)
        self._last, self._shown, self._pending = now, done, None

    def update(self, done: int, extra: str = "") -> None:
        """Report ``done`` items finished: shown if due, always at the first call and at ``total``.

        Parameters
        ----------
        done : int
            Items finished so far.
        extra : str, default ``''``
            Appended to the line (a running estimate, a rate ...).
        """
        if not self.enabled:
            return
        if self.callback is not None:
            self.callback(done, self.total)
            return
        now = time.perf_counter()
        final = done >= self.total
        if final or now - self._last >= self.interval:
            self._emit(done, extra, now, final)
        else:
            self._pending = (done, extra)

    def close(self) -> None:
        """Show the last count if it was throttled away, and end a line redrawn in place."""
        if not self.enabled or self.callback is not None:
            return
        if self._pending is not None:
            self._emit(*self._pending, time.perf_counter(), final=True)
        elif self._open:
            print(file=sys.stderr, flush=True)
            self._open = False
