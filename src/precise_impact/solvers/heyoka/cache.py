"""The one cache of compiled heyoka integrators.

An integrator is mutable state, so every caller gets its own deep copy of a compiled template
(no recompilation); the concurrency rules are in ``docs/design.rst``.
"""

from __future__ import annotations

import copy
import threading
from collections.abc import Callable, Hashable
from typing import Any

__all__ = ["IntegratorCache"]


class IntegratorCache:
    """Compile once per key, hand out private copies.

    Parameters
    ----------
    name : str
        What the cache holds (used in ``repr`` only).

    Notes
    -----
    :meth:`get` compiles under a lock (two threads asking for the same key compile
    it once) and returns a deep copy made from the never-integrated template, so the
    caller may reset time, state, parameters and callbacks freely.  The templates
    themselves are never returned.
    """

    def __init__(self, name: str) -> None:
        self.name = name
        self._templates: dict[Hashable, Any] = {}
        self._lock = threading.Lock()

    def get(self, key: Hashable, compile: Callable[[], Any]) -> Any:
        """A private copy of the integrator for ``key``, compiled by ``compile()`` on first use.

        Parameters
        ----------
        key : hashable
            Everything the compiled code depends on (precision, tolerance, mode, form ...).
        compile : callable
            Builds the integrator; called at most once per key and process.

        Returns
        -------
        heyoka.taylor_adaptive or heyoka.taylor_adaptive_batch
            An integrator owned by the caller.
        """
        with self._lock:
            template = self._templates.get(key)
            if template is None:
                template = compile()
                self._templates[key] = template
            # Copy under the lock: the template is only ever read, but heyoka makes
            # no promise about concurrent copies of one object.
            return copy.deepcopy(template)

    def clear(self) -> None:
        """Drop every compiled template (the next :meth:`get` of each key compiles again)."""
        with self._lock:
            self._templates.clear()

    def __len__(self) -> int:
        with self._lock:
            return len(self._templates)

    def __repr__(self) -> str:
        return f"IntegratorCache({self.name!r}, {len(self)} compiled)"
