"""Progress reporting on standard error: the one place long jobs talk while they run.

``progress=True`` reports, ``False`` is silent, ``None`` reports only on a terminal.
"""

from __future__ import annotations

import sys
import time

__all__ = ["say", "Progress", "wanted"]

#: Least seconds between two redraws on a terminal, and between two lines elsewhere.
TTY_INTERVAL = 0.2
LINE_INTERVAL = 5.0


def _isatty() -> bool:
    try:
        return bool(sys.stderr.isatty())
    except (AttributeError, ValueError):  # no stderr, or a closed one
        return False


def wanted(enabled: bool | None) -> bool:
    """Whether to report: ``enabled`` itself, or for ``None`` whether stderr is a terminal.

    Parameters
    ----------
    enabled : bool or None
        ``True`` / ``False``, or ``None`` for "only on a terminal".

    Returns
    -------
    bool
    """
    return _isatty() if enabled is None else bool(enabled)


def say(msg: str, enabled: bool | None = True) -> None:
    """Print ``msg`` as one line on stderr.

    Parameters
    ----------
    msg : str
        The line (without newline).
    enabled : bool or None, default ``True``
        ``False`` prints nothing; ``None`` prints only when stderr is a terminal.
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
    enabled : bool or None, default ``True``
        ``False`` prints nothing; ``None`` reports only when stderr is a terminal.
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
        self, total: int, label: str, enabled: bool | None = True, interval: float | None = None
    ) -> None:
        self.total, self.label = int(total), label
        self.enabled = wanted(enabled)
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
            return f"  {self.label} [{'#' * filled}{'.' * (width - filled)}] {done}/{self.total}  {now - self.start:.1f} s{tail}"
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
        """Report ``done`` items finished: shown if due, and always at the first call and at ``total``.

        Parameters
        ----------
        done : int
            Items finished so far.
        extra : str, default ``''``
            Appended to the line (a running estimate, a rate ...).
        """
        if not self.enabled:
            return
        now = time.perf_counter()
        final = done >= self.total
        if final or now - self._last >= self.interval:
            self._emit(done, extra, now, final)
        else:
            self._pending = (done, extra)

    def close(self) -> None:
        """Show the last count if it was throttled away, and end a line redrawn in place."""
        if not self.enabled:
            return
        if self._pending is not None:
            self._emit(*self._pending, time.perf_counter(), final=True)
        elif self._open:
            print(file=sys.stderr, flush=True)
            self._open = False
