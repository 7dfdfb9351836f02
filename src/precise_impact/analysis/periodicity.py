"""Periods of stroboscopic sequences: the one home of period detection."""

from __future__ import annotations

import numpy as np

__all__ = ["detect_period"]


def detect_period(xs: np.ndarray, vs: np.ndarray, max_period: int = 32, rtol: float = 1e-6) -> int:
    """Smallest period ``p <= max_period`` of a stroboscopic sequence, else 0.

    Parameters
    ----------
    xs, vs : numpy.ndarray
        Stroboscopic samples of ``x`` and ``v`` (float64), one per forcing period.
    max_period : int, default 32
        Largest period tried.
    rtol : float, default 1e-6
        Every one of the last ``2 max_period`` samples must repeat after ``p`` periods
        to ``rtol * (1 + |x|)``.

    Returns
    -------
    int
        The period; 0 means no period up to ``max_period`` (chaotic, quasi-periodic,
        or still transient).

    See Also
    --------
    precise_impact.analysis.orbits.branch.brute_force_diagram
        Stroboscopic samples along a parameter.
    precise_impact.analysis.orbits.newton.find_orbit : the periodic orbit itself.
    precise_impact.solvers.simulate.simulate : a trajectory's stroboscopic samples.

    Examples
    --------
    >>> import numpy as np
    >>> from precise_impact import detect_period
    >>> xs = np.tile([0.1, 0.7, -0.4], 40)
    >>> detect_period(xs, xs)
    3
    """
    n = len(xs)
    w = min(n, 2 * max_period)
    for p in range(1, max_period + 1):
        if n < w + p:
            break
        a = slice(n - w, n)
        b = slice(n - w - p, n - p)
        tol = rtol * (1 + np.abs(xs[a]) + np.abs(vs[a]))
        if np.all(np.abs(xs[a] - xs[b]) <= tol) and np.all(np.abs(vs[a] - vs[b]) <= tol):
            return p
    return 0
