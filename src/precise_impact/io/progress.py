"""Progress reporting: the one place long jobs talk to the user.

Everything goes to standard error (standard output stays clean for ``--json``);
nothing is printed when ``enabled`` is false.  :func:`say` prints one line;
:class:`Progress` reports ``done/total`` at most every ``interval`` seconds, so a
tight loop can call :meth:`Progress.update` on every item.
"""

from __future__ import annotations

import sys
import time

__all__ = ["say", "Progress"]


def say(msg: str, enabled: bool = True) -> None:
    """Print ``msg`` as one line on stderr if ``enabled``."""
    if enabled:
        print(msg, file=sys.stderr, flush=True)


class Progress:
    """Throttled ``label: done/total`` lines on stderr.

    Parameters
    ----------
    total : int
        Number of items.
    label : str
        What is counted (printed before the count).
    enabled : bool, default ``True``
        ``False`` prints nothing.
    interval : float, default 1.0
        Least number of seconds between two lines (the last item is always reported).
    """

    def __init__(self, total: int, label: str, enabled: bool = True, interval: float = 1.0) -> None:
        self.total, self.label, self.enabled, self.interval = total, label, enabled, interval
        self.start = time.perf_counter()
        self._last = -float("inf")

    def update(self, done: int, extra: str = "") -> None:
        """Report ``done`` items finished (printed if due, or if ``done == total``)."""
        if not self.enabled:
            return
        now = time.perf_counter()
        if done < self.total and now - self._last < self.interval:
            return
        self._last = now
        tail = f" {extra}" if extra else ""
        say(f"  {self.label}: {done}/{self.total} ({now - self.start:.1f} s){tail}")
