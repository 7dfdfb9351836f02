"""The smooth flow of the impact oscillator, eq. (2a), written once.

``x' = v``, ``v' = a cos(eta t) - 2 zeta v - x``.  :func:`acceleration` is generic in
its number type: heyoka builds it from expressions, mpmath and numpy call it with
numbers, so every model and precision integrates the same formula.  The closed-form
steady state of the non-impacting oscillator and the grazing frequency live here too.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from fractions import Fraction
from typing import Any

import mpmath
from mpmath import libmp

from precise_impact.core.flight import steady_coefficients
from precise_impact.core.mpcontext import mp_context, mp_export
from precise_impact.core.params import as_params, check_count
from precise_impact.errors import ParameterError

__all__ = [
    "acceleration",
    "SteadyState",
    "steady_state",
    "grazing_frequencies",
    "tangent_decay_rate",
    "tangent_qr_interval",
]


def acceleration(
    t: Any, x: Any, v: Any, eta: Any, zeta: Any, a: Any, cos: Callable[[Any], Any]
) -> Any:
    """Right-hand side of ``v'`` in eq. (2a): ``a cos(eta t) - 2 zeta v - x``.

    Parameters
    ----------
    t, x, v : number
        Time and state.
    eta, zeta, a : number
        Forcing frequency, damping ratio, forcing amplitude.
    cos : callable
        The cosine of the number type (``math.cos``, ``mpmath.cos``, ``heyoka.cos`` ...).

    Returns
    -------
    number
        The acceleration, in the number type of the arguments.

    See Also
    --------
    precise_impact.core.impact.reset_velocity : the other half of eq. (2), at the wall.
    precise_impact.core.flow.steady_state : the smooth flow's steady state.
    precise_impact.solvers.simulate.simulate : the flow integrated.

    Examples
    --------
    >>> import precise_impact as pi
    >>> import math
    >>> pi.acceleration(0.0, 0.5, 0.0, 0.7, 0.05, 1.0, math.cos)
    0.5
    """
    return a * cos(eta * t) - 2 * zeta * v - x


@dataclasses.dataclass(frozen=True)
class SteadyState:
    """Non-impacting periodic response ``x_p(t) = P cos(eta t) + Q sin(eta t)``.

    ``P = a (1 - eta^2) / D``, ``Q = 2 zeta eta a / D``, ``D = (1 - eta^2)^2 + (2 zeta eta)^2``,
    exact rationals for rational parameters.  It is the unique periodic solution of
    (2a) when ``zeta > 0``; every solution that stops impacting converges to it as
    ``exp(-zeta t)``.

    See Also
    --------
    precise_impact.core.flow.steady_state : computes it.
    precise_impact.core.flow.grazing_frequencies : where its amplitude reaches the wall.
    """

    P: Fraction
    Q: Fraction
    eta: Fraction

    @property
    def amplitude_squared(self) -> Fraction:
        return self.P * self.P + self.Q * self.Q

    def at(self, t: Any, cos=mpmath.cos, sin=mpmath.sin) -> tuple[Any, Any]:
        """``(x_p(t), x_p'(t))`` evaluated with the given cos/sin.

        Parameters
        ----------
        t : number
            Time.
        cos, sin : callable, default ``mpmath.cos``, ``mpmath.sin``
            Functions of the number type wanted.

        Returns
        -------
        tuple
            Position and velocity of the steady state at ``t``.
        """
        eta = self.eta
        c, s = cos(eta * t), sin(eta * t)
        return self.P * c + self.Q * s, eta * (self.Q * c - self.P * s)


def tangent_decay_rate(zeta: Any) -> float:
    """Fastest decay rate of the smooth flow's tangent vectors, ``zeta + sqrt(max(zeta^2 - 1, 0))``.

    The tangent flow of ``x'' + 2 zeta x' + x = f(t)`` is ``exp(A t)`` with the eigenvalues
    ``-zeta +- sqrt(zeta^2 - 1)``: underdamped, every vector shrinks like ``exp(-zeta t)``;
    overdamped, the fast one like ``exp(-(zeta + sqrt(zeta^2 - 1)) t)`` and, measured against
    the slow one, also like ``exp(-2 sqrt(zeta^2 - 1) t)`` (the columns align), which is slower.

    Parameters
    ----------
    zeta : number
        Damping ratio, ``>= 0``.

    Returns
    -------
    float
        The rate (``0`` for ``zeta = 0``).
    """
    z = float(zeta)
    return z + math.sqrt(max(z * z - 1.0, 0.0))


#: How far (in e-folds) the tangent vectors may shrink between two re-orthonormalisations:
#: heyoka controls its error against the whole state's norm (``x, v`` included), so a
#: tangent entry ``e^-TANGENT_EFOLDS`` below ``(x, v)`` (~1) keeps ``16 - 8 / ln 10 ~ 12.5``
#: of float64's digits; below ``eps`` it would be noise (measured: a non-impacting orbit at
#: eta = 0.001, 8 periods between QRs, gave LLE -0.0045 instead of -zeta = -0.05).
TANGENT_EFOLDS = 8.0


def tangent_qr_interval(zeta: Any) -> float:
    """Longest time between two QRs of the tangent basis: ``TANGENT_EFOLDS / rate``.

    ``rate`` is :func:`tangent_decay_rate`; ``inf`` for ``zeta = 0`` (the flow only
    rotates).  Over this time the basis shrinks by at most ``e^-8`` and its two columns
    (overdamped) align by at most ``e^8``, so neither the integrator's error control nor
    the Gram-Schmidt step loses more than ~3.5 digits of the tangents.

    Parameters
    ----------
    zeta : number
        Damping ratio, ``>= 0``.

    Returns
    -------
    float
        The interval in time units.
    """
    rate = tangent_decay_rate(zeta)
    return TANGENT_EFOLDS / rate if rate > 0 else math.inf


def steady_state(params) -> SteadyState:
    """Closed-form steady state of the smooth (non-impacting) oscillator, exact.

    Parameters
    ----------
    params : Params
        System (``zeta``, ``a``, ``eta`` are used).

    Returns
    -------
    SteadyState
        ``P``, ``Q`` and ``eta`` as Fractions: ``x_p(t) = P cos(eta t) + Q sin(eta t)``.

    See Also
    --------
    precise_impact.core.flow.grazing_frequencies : where the steady amplitude reaches the wall.
    precise_impact.core.flow.SteadyState : the result's fields.
    precise_impact.solvers.simulate.simulate : the impacting motion.

    Examples
    --------
    >>> from precise_impact import Params, steady_state
    >>> ss = steady_state(Params.make(eta="0.70"))
    >>> ss.P, ss.eta * ss.Q
    (Fraction(102, 53), Fraction(49, 265))
    """
    params = as_params(params)
    eta, zeta, a = params.eta, params.zeta, params.a
    if (1 - eta**2) ** 2 + (2 * zeta * eta) ** 2 == 0:
        raise ParameterError(
            "zeta",
            "0",
            "zeta = 0 with eta = 1 is the undamped resonance: no bounded steady state; "
            "need zeta > 0",
        )
    P, Q = steady_coefficients(eta, zeta, a)
    return SteadyState(P=P, Q=Q, eta=eta)


def grazing_frequencies(params, dps: int = 30) -> list[mpmath.mpf]:
    """Forcing frequencies at which the steady-state amplitude equals ``|x_w|``.

    Solves ``(1 - u)^2 + 4 zeta^2 u = a^2 / x_w^2`` for ``u = eta^2`` (closed form).
    For the paper's parameters the lower root is eta ~ 0.71069: below it the
    non-impacting orbit stays clear of the wall.

    Parameters
    ----------
    params : Params
        System (``zeta``, ``a``, ``x_w`` are used).
    dps : int, default 30
        Decimal digits of the mpmath evaluation.

    Returns
    -------
    list of mpmath.mpf
        The positive roots ``eta`` in increasing order (empty if the amplitude never
        reaches the wall, or if ``x_w = 0``: the wall sits at the rest position, and every
        steady state crosses it).

    See Also
    --------
    precise_impact.core.flow.steady_state : the smooth oscillator's steady state.
    precise_impact.analysis.orbits.one_impact.one_impact_orbits
        The impacting orbits born at grazing.
    precise_impact.core.params.Params : the parameters.

    Examples
    --------
    >>> import precise_impact as pi
    >>> etas = pi.grazing_frequencies(pi.Params.make(), dps=15)
    >>> [round(float(e), 6) for e in etas]
    [0.710687, 1.218574]
    """
    params = as_params(params)
    dps = check_count(dps, "dps", 10_000, minimum=1)
    ctx = mp_context(libmp.dps_to_prec(dps))  # this thread's own, not mpmath's global precision
    z = ctx.mpf(params.zeta.numerator) / params.zeta.denominator
    a = ctx.mpf(params.a.numerator) / params.a.denominator
    xw = ctx.mpf(params.x_w.numerator) / params.x_w.denominator
    if xw == 0:  # the wall at the rest position: every steady state crosses it (or rests on it)
        return []
    b = 1 - 2 * z**2
    disc = b**2 - 1 + (a / xw) ** 2
    if disc < 0:
        return []
    roots = [b - ctx.sqrt(disc), b + ctx.sqrt(disc)]
    return sorted(mp_export(ctx.sqrt(u)) for u in roots if u > 0)
