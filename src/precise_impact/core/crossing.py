"""The safeguarded Newton iteration on the closed form, written once for the Python arithmetics.

A crossing (the wall, or a maximum ``v = 0``) is the root of an increasing function on a
bracket: Newton when the step stays inside and halves the bracket, bisection otherwise.  Used by
:mod:`precise_impact.solvers.closed_form` and :mod:`precise_impact.analysis.orbits.shooting`;
numba copy: :func:`precise_impact.solvers.fast.crossing.refine_crossing`.
Reference: Press et al., *Numerical Recipes*, 3rd ed. (2007), sec. 9.4 (``rtsafe``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

__all__ = ["safeguarded_newton"]


def safeguarded_newton(
    fn: Callable[[Any], tuple[Any, Any]],
    lo: Any,
    hi: Any,
    f_lo: Any,
    df_lo: Any,
    tol: Any,
    max_iter: int,
) -> tuple[Any, tuple[Any, Any]]:
    """The root of an increasing ``f`` in ``[lo, hi]`` by Newton safeguarded by bisection.

    Parameters
    ----------
    fn : callable
        ``fn(t) -> (f(t), f'(t))`` in the working number type.
    lo, hi : number
        The bracket, ``f(lo) <= 0 < f(hi)`` up to rounding.
    f_lo, df_lo : number
        ``f(lo)`` and ``f'(lo)`` (already known to the caller); the first iterate is the
        Newton step from ``lo`` when ``f'(lo) > 0``, else the midpoint.
    tol : number
        Absolute tolerance: a Newton step or a bracket at most this long ends the iteration.
    max_iter : int
        Iterations at most (each evaluates ``fn`` once).

    Returns
    -------
    t : number
        The root: ``lo`` if ``f(lo) >= 0``; an exact zero; the last Newton iterate once its
        step is within ``tol`` (and inside the bracket); else the midpoint of the final
        bracket.
    (f, df) : tuple
        ``fn(t)`` (``(f_lo, df_lo)`` when ``t = lo``).
    """
    if f_lo >= 0:
        return lo, (f_lo, df_lo)
    t = lo - f_lo / df_lo if df_lo > 0 else (lo + hi) / 2
    for _ in range(max_iter):
        if not (lo < t < hi):
            t = (lo + hi) / 2
            if not (lo < t < hi):
                break
        f, df = fn(t)
        if f == 0:
            return t, (f, df)
        if f > 0:
            hi = t
        else:
            lo = t
        if df > 0:
            step = -f / df
            t_new = t + step
            if abs(step) <= tol and lo <= t_new <= hi:
                return t_new, fn(t_new)
            # Newton must shrink the bracket fast; otherwise bisect.
            if lo < t_new < hi and abs(step) < (hi - lo) / 2:
                t = t_new
                continue
        t = (lo + hi) / 2
        if hi - lo <= tol:
            break
    t = (lo + hi) / 2
    return t, fn(t)
