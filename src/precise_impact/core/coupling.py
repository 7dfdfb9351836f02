"""The master-slave coupling written once: slave equations, slave reset, error equation.

Generic in the number type, shared by the heyoka, compiled and certified engines of the pair
(:mod:`precise_impact.solvers.heyoka.coupled` derives the forms ``'first-order'``, ``'paper'``
and ``'reduced'``).  Between impacts ``e = y - x`` obeys ``e'' + c1 e' + c0 e = 0``
(:func:`error_coefficients`).  Reference: the paper's eqs. (10)-(15); Pecora & Carroll,
Phys. Rev. Lett. 64 (1990) 821.
"""

from __future__ import annotations

from collections.abc import Sequence
from fractions import Fraction
from typing import Any

from precise_impact.core.flow import acceleration
from precise_impact.core.impact import reset_velocity
from precise_impact.core.params import Params, decimal_str, exact
from precise_impact.errors import ParameterError

__all__ = [
    "COUPLED_FORMS",
    "FORM_IDS",
    "slave_rhs",
    "slave_position_rate",
    "slave_reset",
    "slave_velocity",
    "slave_derivative",
    "error_coefficients",
    "check_form",
    "check_k",
    "check_y0",
]

#: The slave equations offered.
COUPLED_FORMS = ("first-order", "paper", "reduced")

#: The forms by number (the compiled engine's ``form`` argument).
FORM_IDS = {"first-order": 0, "paper": 1, "reduced": 2}


def slave_rhs(
    form: str, t: Any, x: Any, v: Any, y: Any, w: Any, eta: Any, zeta: Any, a: Any, k: Any, cos
) -> tuple:
    """``(y', w')`` of the slave in ``form``'s own variables (generic number type).

    The uncoupled part is :func:`~precise_impact.core.flow.acceleration` evaluated first, the
    coupling added last, so that on the diagonal (coupling exactly 0) the slave's
    arithmetic is the master's, operation by operation.
    """
    acc = acceleration(t, y, w, eta, zeta, a, cos)
    if form == "first-order":
        return w + k * (x - y), acc + k * (v - w)
    if form == "paper":
        return w, acc + k * (1 + 2 * zeta) * (v - w) + 2 * k * (x - y)
    if form == "reduced":
        return w, acc + 2 * k * (v - w) + k * (2 * zeta + k) * (x - y)
    raise ParameterError("form", form, "one of " + ", ".join(COUPLED_FORMS))


def slave_position_rate(form: str, x: Any, y: Any, w: Any, k: Any) -> Any:
    """``dy/dt`` of the slave (``w + k (x - y)`` for 'first-order', ``w`` otherwise)."""
    if form == "first-order":
        return w + k * (x - y)
    return w


def slave_reset(form: str, x: Any, w_minus: Any, R: Any, k: Any, x_w: Any) -> Any:
    """Slave velocity variable after its impact at ``y = x_w`` (master at ``x``).

    'first-order' flips ``y2`` (12c), 'paper' flips ``y'`` (14b), both by
    :func:`~precise_impact.core.impact.reset_velocity`.  'reduced' converts to
    ``y2 = y' - k (x - x_w)``, flips ``y2`` with the same function and converts back, i.e.
    ``y'+ = -R y'- + (1 + R) k (x - x_w)``.
    """
    if form == "reduced":
        shift = k * (x - x_w)
        return reset_velocity(w_minus - shift, R) + shift
    return reset_velocity(w_minus, R)


def slave_velocity(form: str, k: Any, e: Any, yd: Any) -> Any:
    """The slave's velocity variable from ``e = y - x`` and ``y'`` (``y' + k e`` for
    'first-order', where ``y1' = y2 + k (x - y1)``; ``y'`` otherwise)."""
    return yd + k * e if form == "first-order" else yd


def slave_derivative(form: str, k: Any, e: Any, w: Any) -> Any:
    """``y'`` from ``e = y - x`` and the slave's velocity variable (inverse of
    :func:`slave_velocity`)."""
    return w - k * e if form == "first-order" else w


def error_coefficients(form: str, zeta: Any, k: Any) -> tuple[Any, Any]:
    """``(c1, c0)`` of ``e'' + c1 e' + c0 e = 0``, ``e = y - x`` (generic number type).

    Subtract eq. (11) from the slave's equation (for 'first-order' eliminate ``y2``):
    'first-order' and 'reduced' give ``c1 = 2 zeta + 2 k``, ``c0 = 1 + 2 zeta k + k^2``;
    'paper' gives ``c1 = 2 zeta + k (1 + 2 zeta)``, ``c0 = 1 + 2 k``.
    """
    if form == "paper":
        return 2 * zeta + k * (1 + 2 * zeta), 1 + 2 * k
    return 2 * zeta + 2 * k, 1 + 2 * zeta * k + k * k


def check_form(form: Any) -> str:
    """``form`` if it is one of :data:`COUPLED_FORMS`, else :class:`ParameterError`."""
    if not isinstance(form, str) or form not in COUPLED_FORMS:
        raise ParameterError("form", form, "one of " + ", ".join(repr(f) for f in COUPLED_FORMS))
    return form


def check_k(k: Any, name: str = "k") -> Fraction:
    """Exact coupling from a decimal string / Fraction / number; must be finite and >= 0."""
    q = exact(name, k)
    if q < 0:
        raise ParameterError(name, decimal_str(q), "coupling must be finite and >= 0")
    return q


def check_y0(y0: Any, params: Params) -> tuple[Fraction, Fraction] | None:
    """The slave's start ``(position, velocity variable)``, exact, position ``<= x_w``;
    ``None`` stays ``None``."""
    if y0 is None:
        return None
    if isinstance(y0, (str, bytes)) or not isinstance(y0, Sequence) or len(y0) != 2:
        raise ParameterError("y0", y0, "a pair (slave position, slave velocity variable) or None")
    yp, yv = exact("y0[0]", y0[0]), exact("y0[1]", y0[1])
    if yp > params.x_w:
        raise ParameterError(
            "y0[0]",
            decimal_str(yp),
            f"the slave must not start inside the wall: y0[0] <= x_w = {decimal_str(params.x_w)}",
        )
    return yp, yv
