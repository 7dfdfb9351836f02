"""Background work of one view of one browser session: a new start supersedes the running one,
whose result is dropped; results reach the session's event loop from any thread."""

from __future__ import annotations

import concurrent.futures
import threading
from collections.abc import Callable
from typing import Any

__all__ = ["Cancelled", "Runner"]


class Cancelled(Exception):
    """Raised inside a computation whose cancel flag was set (a newer start, or Cancel)."""


class Runner:
    """Starts one view's computations on ``executor`` and hands their results to ``doc``'s
    event loop (see the module docstring).

    Parameters
    ----------
    executor : concurrent.futures.Executor
        The server's pool (shared by every session).
    schedule : callable
        ``schedule(callback)`` runs ``callback()`` on the session's event loop (a Bokeh
        document's ``add_next_tick_callback``; a test may call it at once).
    """

    def __init__(
        self, executor: concurrent.futures.Executor, schedule: Callable[[Callable], Any]
    ) -> None:
        self.executor, self.schedule = executor, schedule
        self.generation = 0
        self.flag = threading.Event()
        self.running = False

    def start(
        self,
        work: Callable[[threading.Event], Any],
        done: Callable[[Any], None],
        failed: Callable[[BaseException], None],
    ) -> None:
        """Run ``work(flag)`` in the pool; then ``done(result)`` or ``failed(error)`` on the
        session's loop, unless a newer start or :meth:`cancel` came first."""
        self.cancel()
        self.generation += 1
        generation, flag = self.generation, threading.Event()
        self.flag, self.running = flag, True
        future = self.executor.submit(work, flag)
        future.add_done_callback(lambda f: self._finished(f, generation, done, failed))

    def cancel(self) -> None:
        """Stop the running computation (its flag is set; its result will be dropped)."""
        self.flag.set()
        self.generation += 1
        self.running = False

    def _finished(self, future, generation, done, failed) -> None:
        if generation != self.generation or future.cancelled():
            return
        error = future.exception()
        if isinstance(error, Cancelled):
            return

        def deliver() -> None:
            if generation != self.generation:  # superseded while waiting for the loop
                return
            self.running = False
            if error is None:
                done(future.result())
            else:
                failed(error)

        self.schedule(deliver)
