"""The one impact recorder of every heyoka event callback.

Reach a recorder through its integrator (``ta.t_events[i].callback``): heyoka deep-copies
callbacks (``docs/design.rst``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["ImpactRecorder"]


class ImpactRecorder:
    """Impact count, budget and (optionally) log of one event callback.

    Parameters
    ----------
    keep : bool, default ``True``
        Keep the log (``t``, ``v_before``, ``v_after`` and ``aux``); ``False`` counts
        only (the Lyapunov integrators: 10^7 impacts would otherwise cost ~1 GB).
    max_impacts : int, default ``10**6``
        Impact budget (see :meth:`reset`).

    Attributes
    ----------
    t, v_before, v_after : list
        Impact times and velocities before/after, in the order recorded (empty when
        ``keep`` is false).
    aux : list
        One more value per impact when the caller passes one (the coupled slave's
        impacts record the master's position there); otherwise empty.
    count : int
        Impacts recorded since :meth:`reset` (logged ones included).
    charged : int
        Events counted against the budget that are not impacts (:meth:`charge`).
    max_impacts : int
        The budget: :meth:`record` reports exhaustion once ``count + charged`` reaches it.
    exceeded : bool
        The budget ran out (the callback then asks heyoka to stop).

    Notes
    -----
    Subclass it (the callback *is* the recorder: ``ta.t_events[i].callback.count``)
    or hold one or more instances (a callback that applies two impacts at once).
    """

    def __init__(self, keep: bool = True, max_impacts: int = 10**6) -> None:
        self.keep = keep
        self.reset_log(max_impacts)

    def reset_log(self, max_impacts: int, keep: bool | None = None) -> None:
        """Forget every impact and set the budget.

        Parameters
        ----------
        max_impacts : int
            The new budget.
        keep : bool or None, default ``None``
            A new ``keep`` setting; ``None`` keeps the current one.
        """
        if keep is not None:
            self.keep = keep
        self.t: list = []
        self.v_before: list = []
        self.v_after: list = []
        self.aux: list = []
        self.count = 0
        self.charged = 0
        self.max_impacts = max_impacts
        self.exceeded = False

    def log(self, t: Any, v_before: Any = None, v_after: Any = None, aux: Any = None) -> None:
        """Record an impact without looking at the budget (e.g. an impact at the start time).

        Parameters
        ----------
        t : number
            Impact time.
        v_before, v_after : number or None, default ``None``
            Velocity just before and just after.
        aux : number or None, default ``None``
            An extra value kept in :attr:`aux` (not kept when ``None``).
        """
        self.count += 1
        if self.keep:
            self.t.append(t)
            self.v_before.append(v_before)
            self.v_after.append(v_after)
            if aux is not None:
                self.aux.append(aux)

    def record(self, t: Any, v_before: Any = None, v_after: Any = None, aux: Any = None) -> bool:
        """Record an impact and check the budget.

        Parameters
        ----------
        t, v_before, v_after, aux
            As in :meth:`log`.

        Returns
        -------
        bool
            ``True`` to let heyoka go on, ``False`` (and :attr:`exceeded` set) when the
            budget is exhausted: the callback's return value.
        """
        self.log(t, v_before, v_after, aux)
        return self.within_budget()

    def charge(self) -> bool:
        """Count an event that is not an impact against the budget.

        Returns
        -------
        bool
            As :meth:`record`.
        """
        self.charged += 1
        return self.within_budget()

    def within_budget(self) -> bool:
        """``False`` (and :attr:`exceeded` set) once ``count + charged`` reaches the budget.

        Returns
        -------
        bool
        """
        if self.count + self.charged >= self.max_impacts:
            self.exceeded = True
            return False
        return True

    def rows(self) -> list[tuple]:
        """The log as ``(t, v_before, v_after[, aux])`` tuples, in the order recorded.

        Returns
        -------
        list of tuple
        """
        if self.aux:
            return list(zip(self.t, self.v_before, self.v_after, self.aux, strict=True))
        return list(zip(self.t, self.v_before, self.v_after, strict=True))

    def arrays(self, precision: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The log as arrays of ``precision``'s type: ``(t, v_before, v_after)``.

        Parameters
        ----------
        precision : Precision
            Supplies :meth:`~precise_impact.core.precision.Precision.array`.

        Returns
        -------
        tuple of numpy.ndarray
        """
        return (
            precision.array(self.t),
            precision.array(self.v_before),
            precision.array(self.v_after),
        )
