"""The impact: eq. (2b) and its saltation matrix, written once for every model and precision.

At ``x = x_w`` with ``v > 0`` the velocity is reset, ``v+ = -R v-`` (the position is
kept).  The reset is discontinuous, so a perturbation of the state just before the
impact is *not* mapped by the Jacobian of the reset alone: the perturbed orbit hits
the wall at a slightly different time.  The saltation matrix (Aizerman & Gantmakher
1958; Müller 1995; di Bernardo et al., *Piecewise-smooth Dynamical Systems*, 2008,
sec. 2.5) accounts for that:

``S = Dg + (f+ - Dg f-) n^T / (n^T f-)``

with ``g`` the reset map, ``Dg`` its Jacobian, ``f-``/``f+`` the vector fields just
before/after, and ``n`` the gradient of the event function ``h = x - x_w``.  For the
oscillator ``n = (1, 0)``, ``Dg = diag(1, -R)``, ``f = (v, acc)`` and

``S = [[-R, 0], [(acc+ + R acc-) / v-, -R]]``,  ``det S = R^2``.

(For the smooth flow (2a) ``acc+ + R acc- = (1 + R)(a cos(eta t) - x_w)``.)  Note the
``1/v-``: near grazing (``v- -> 0``) the saltation matrix blows up.
"""

from __future__ import annotations

from typing import Any, Sequence

from ._system import acceleration

__all__ = ["reset_velocity", "saltation_matrix", "oscillator_saltation", "impact_at_start"]


def reset_velocity(v_minus: Any, R: Any) -> Any:
    """Velocity after the impact, eq. (2b): ``v+ = -R v-``."""
    return -R * v_minus


def saltation_matrix(
    jac_reset: Sequence[Sequence[Any]],
    f_minus: Sequence[Any],
    f_plus: Sequence[Any],
    normal: Sequence[Any],
) -> list[list[Any]]:
    """General saltation matrix ``Dg + (f+ - Dg f-) n^T / (n^T f-)`` for any dimension.

    Works for any number type with ``+ - * /`` (float, numpy, mpmath, heyoka real).
    Raises ``ZeroDivisionError`` for a tangential impact (``n^T f- = 0``).
    """
    n = len(f_minus)
    dg_f = [sum(jac_reset[i][k] * f_minus[k] for k in range(n)) for i in range(n)]
    denom = sum(normal[k] * f_minus[k] for k in range(n))
    if denom == 0:
        raise ZeroDivisionError("tangential (grazing) impact: n . f- = 0, saltation matrix undefined")
    return [
        [jac_reset[i][j] + (f_plus[i] - dg_f[i]) * normal[j] / denom for j in range(n)] for i in range(n)
    ]


def oscillator_saltation(t: Any, v_minus: Any, eta: Any, zeta: Any, a: Any, x_w: Any, R: Any, cos) -> list[list[Any]]:
    """Saltation matrix of the single oscillator's impact at ``(t, x_w, v_minus)``.

    Built from :func:`saltation_matrix` with the flow :func:`~._system.acceleration`,
    so the two are never out of step.
    """
    v_plus = reset_velocity(v_minus, R)
    f_minus = [v_minus, acceleration(t, x_w, v_minus, eta, zeta, a, cos)]
    f_plus = [v_plus, acceleration(t, x_w, v_plus, eta, zeta, a, cos)]
    zero, one = 0 * R, 0 * R + 1
    jac = [[one, zero], [zero, -R]]
    return saltation_matrix(jac, f_minus, f_plus, [one, zero])


def impact_at_start(x0: Any, v0: Any, x_w: Any, R: Any) -> bool:
    """True if the initial state lies on the wall moving into it (``x0 = x_w``, ``v0 > 0``).

    Such a start is an impact at ``t0``; solvers apply :func:`reset_velocity` first.
    """
    return x0 == x_w and v0 > 0
