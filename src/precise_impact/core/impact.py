"""The impact: eq. (2b) and its saltation matrix, written once for every model and precision.

``v+ = -R v-`` at ``x = x_w``; the saltation matrix ``[[-R, 0], [(acc+ + R acc-) / v-, -R]]``
maps perturbations across it (di Bernardo et al., *Piecewise-smooth Dynamical Systems*, 2008,
sec. 2.5).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from fractions import Fraction
from typing import Any

import mpmath

from precise_impact.core.flow import acceleration, steady_state
from precise_impact.core.params import I_A, I_ETA, I_XW
from precise_impact.errors import ParameterError

__all__ = [
    "reset_velocity",
    "grazing_depth",
    "saltation_matrix",
    "oscillator_saltation",
    "impact_at_start",
    "wall_acceleration",
    "pushes_into_wall",
    "release_time",
    "chatter_accumulation_time",
    "elastic_bounce_count",
    "elastic_bounce_text",
    "elastic_bounce_refusal",
    "short_elastic_flight",
    "ELASTIC_FLIGHT_FRACTION",
    "ELASTIC_FLOOR_FACTOR",
]


def reset_velocity(v_minus: Any, R: Any) -> Any:
    """Velocity after the impact, eq. (2b): ``v+ = -R v-``.

    Parameters
    ----------
    v_minus : number
        Velocity before the impact.
    R : number
        Restitution coefficient, ``0 <= R <= 1``.

    Returns
    -------
    number
        Velocity after the impact.

    See Also
    --------
    precise_impact.core.impact.impact_at_start : whether the initial state is an impact.
    precise_impact.core.impact.oscillator_saltation : the impact's saltation matrix.
    precise_impact.core.flow.acceleration : the flow between impacts.

    Examples
    --------
    >>> import precise_impact as pi
    >>> pi.reset_velocity(2.0, 0.8)
    -1.6
    """
    return -R * v_minus


def saltation_matrix(
    jac_reset: Sequence[Sequence[Any]],
    f_minus: Sequence[Any],
    f_plus: Sequence[Any],
    normal: Sequence[Any],
) -> list[list[Any]]:
    """General saltation matrix ``Dg + (f+ - Dg f-) n^T / (n^T f-)`` for any dimension.

    Works for any number type with ``+ - * /`` (float, numpy, mpmath, heyoka real).

    Parameters
    ----------
    jac_reset : sequence of sequences
        Jacobian ``Dg`` of the reset map.
    f_minus, f_plus : sequence
        Vector field just before and just after the impact.
    normal : sequence
        Normal ``n`` of the switching surface.

    Returns
    -------
    list of list
        The saltation matrix.

    Raises
    ------
    ZeroDivisionError
        A tangential impact (``n^T f- = 0``).

    See Also
    --------
    precise_impact.core.impact.oscillator_saltation : the matrix for the single oscillator.
    precise_impact.core.impact.reset_velocity : the reset map.
    precise_impact.analysis.orbits.newton.find_orbit
        Its Jacobian passes impacts through saltation matrices.

    References
    ----------
    .. [1] P. C. Müller, Chaos Solitons Fractals 5 (1995) 1671-1681.

    Examples
    --------
    >>> import precise_impact as pi
    >>> S = pi.saltation_matrix([[1, 0], [0, -0.5]], [1.0, -1.0], [-0.5, -1.0], [1, 0])
    >>> [[round(float(s), 6) for s in row] for row in S]
    [[-0.5, 0.0], [-1.5, -0.5]]
    """
    n = len(f_minus)
    dg_f = [sum(jac_reset[i][k] * f_minus[k] for k in range(n)) for i in range(n)]
    denom = sum(normal[k] * f_minus[k] for k in range(n))
    if denom == 0:
        raise ZeroDivisionError(
            "tangential (grazing) impact: n . f- = 0, saltation matrix undefined"
        )
    return [
        [jac_reset[i][j] + (f_plus[i] - dg_f[i]) * normal[j] / denom for j in range(n)]
        for i in range(n)
    ]


def oscillator_saltation(
    t: Any, v_minus: Any, eta: Any, zeta: Any, a: Any, x_w: Any, R: Any, cos
) -> list[list[Any]]:
    """Saltation matrix of the single oscillator's impact at ``(t, x_w, v_minus)``.

    Built from :func:`saltation_matrix` with the flow
    :func:`~precise_impact.core.flow.acceleration`, so the two are never out of step.  Its
    determinant is ``R^2``.

    Parameters
    ----------
    t : number
        Impact time.
    v_minus : number
        Velocity before the impact (``> 0`` for a transversal impact).
    eta, zeta, a, x_w, R : number
        System parameters (as in :class:`~precise_impact.Params`).
    cos : callable
        The cosine of the number type.

    Returns
    -------
    list of list
        The 2x2 matrix mapping a pre-impact state perturbation to the post-impact one.

    Raises
    ------
    ZeroDivisionError
        ``v_minus = 0`` (a tangential, grazing contact has no saltation matrix).

    See Also
    --------
    precise_impact.core.impact.saltation_matrix : the general formula.
    precise_impact.core.impact.reset_velocity : the reset map.
    precise_impact.analysis.orbits.newton.find_orbit : uses it for the orbit's multipliers.

    References
    ----------
    .. [1] P. C. Müller, Chaos Solitons Fractals 5 (1995) 1671-1681.
    .. [2] M. di Bernardo et al., Piecewise-smooth Dynamical Systems (2008), sec. 2.5.

    Examples
    --------
    >>> import math
    >>> from precise_impact import oscillator_saltation
    >>> S = oscillator_saltation(1.0, 0.7, 0.712, 0.05, 1.0, 2.0, 0.8, math.cos)
    >>> round(S[0][0] * S[1][1] - S[0][1] * S[1][0], 12)    # det S = R^2
    0.64
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

    Parameters
    ----------
    x0, v0 : number
        Initial state.
    x_w : number
        Wall position.
    R : number
        Restitution coefficient (part of the signature of every impact rule).

    Returns
    -------
    bool
        Whether the start is an impact.

    See Also
    --------
    precise_impact.core.impact.reset_velocity : the velocity after an impact.
    precise_impact.solvers.simulate.simulate : applies it to the initial state.
    precise_impact.core.params.Params : the initial state and wall.

    Examples
    --------
    >>> import precise_impact as pi
    >>> pi.impact_at_start(2.0, 0.5, 2.0, 0.8), pi.impact_at_start(1.0, 0.5, 2.0, 0.8)
    (True, False)
    """
    return x0 == x_w and v0 > 0


# --------------------------------------------------------------------------- sticking
# Eq. (2) has no rule for a mass *resting* on the wall.  The standard completion
# (Budd & Dux 1994; di Bernardo et al., *Piecewise-smooth Dynamical Systems*,
# 2008: the sticking region of an impacting system) keeps ``x = x_w``, ``v = 0``
# while the net force at the wall pushes into it, ``wall_acceleration > 0``, and
# releases the mass, with ``v = 0``, where that force changes sign.  The
# functions below evaluate that force and its zeros in closed form.


def wall_acceleration(t: Any, eta: Any, zeta: Any, a: Any, x_w: Any, cos) -> Any:
    """Acceleration of the mass at rest on the wall, ``x'' (x = x_w, v = 0) = a cos(eta t) - x_w``.

    Built from :func:`~precise_impact.core.flow.acceleration`; positive means the net force
    pushes the mass into the wall.  Generic in the number type like ``acceleration``.
    """
    return acceleration(t, x_w, 0 * x_w, eta, zeta, a, cos)


def _mpq(q: Any, ctx: Any) -> Any:
    q = Fraction(q)
    return ctx.mpf(q.numerator) / q.denominator


def _mp_time(t: Any, ctx: Any) -> Any:
    """An exact time (Fraction, int, or an mpmath number of any context) in ``ctx``."""
    return ctx.make_mpf(t._mpf_) if hasattr(t, "_mpf_") else _mpq(t, ctx)


def pushes_into_wall(t: Any, eta: Fraction, a: Fraction, x_w: Fraction, *, ctx: Any = None) -> bool:
    """True if a mass at rest on the wall at time ``t`` stays there (sticks).

    ``G(s) = a cos(eta s) - x_w`` is the wall force (:func:`wall_acceleration`).
    The mass sticks if ``G(t) > 0``; at an exact zero of ``G`` (possible only at
    ``t = 0`` or for ``a = x_w = 0``) the first non-zero derivative decides:
    ``G' > 0``, or ``G' = 0`` and ``G'' = -eta^2 x_w > 0``.  ``G == 0`` everywhere
    (``a = x_w = 0``: the mass rests at the spring's equilibrium, on the wall)
    counts as sticking: the mass stays where it is, for good.

    ``t`` is an exact number (Fraction, int, or an mpf); the parameters are exact rationals.
    Evaluated in the mpmath context ``ctx`` (callers add guard bits to its precision; a context
    of their own, :func:`~precise_impact.core.mpcontext.mp_context`, is thread-safe), or without
    it at mpmath's module-level working precision.
    """
    mp = mpmath.mp if ctx is None else ctx
    eta, a, x_w = Fraction(eta), Fraction(a), Fraction(x_w)
    if t == 0:
        g0 = a - x_w  # exact: cos(0) = 1
        if g0 != 0:
            return g0 > 0
        if a == 0 and x_w == 0:
            return True  # G == 0 everywhere: at rest for good
        return -eta * eta * x_w > 0  # G'(0) = 0, G''(0) = -a eta^2 = -eta^2 x_w
    th = _mpq(eta, mp) * _mp_time(t, mp)
    g = _mpq(a, mp) * mp.cos(th) - _mpq(x_w, mp)
    if g != 0:
        return g > 0
    g1 = -_mpq(a, mp) * _mpq(eta, mp) * mp.sin(th)
    if g1 != 0:
        return g1 > 0
    if a == 0 and x_w == 0:
        return True
    return -eta * eta * x_w > 0


def release_time(t: Any, eta: Fraction, a: Fraction, x_w: Fraction, *, ctx: Any = None) -> Any:
    """First time ``s > t`` at which the wall force ``G = a cos(eta s) - x_w`` turns negative.

    Closed form at the current mpmath precision (callers add guard bits for
    ``|eta t|``): with ``c = x_w / |a|`` and ``-1 < c < 1`` the zeros of ``G`` where
    ``G' = -a eta sin(eta s) < 0`` are ``eta s = phi + 2 pi k``,
    ``phi = acos(c)`` for ``a > 0`` and ``phi = acos(c) - pi`` for ``a < 0``
    (equivalently ``-acos(x_w / a)``); the smallest one with ``eta s > eta t`` is
    returned as an mpf.  Returns ``None`` if ``G`` never turns negative:
    ``a = 0`` (constant force) or ``c <= -1`` (``G >= 0`` everywhere, touching
    zero at most tangentially when ``c = -1``); also for ``c >= 1``, where ``G <= 0``
    everywhere and nothing can stick in the first place.  Evaluated in the mpmath context
    ``ctx`` as :func:`pushes_into_wall` (a number of ``ctx``).
    """
    mp = mpmath.mp if ctx is None else ctx
    eta, a, x_w = Fraction(eta), Fraction(a), Fraction(x_w)
    if a == 0:
        return None
    c = x_w / abs(a)
    if c <= -1 or c >= 1:
        return None
    two_pi = 2 * mp.pi
    phi = mp.acos(_mpq(c, mp))
    if a < 0:
        phi -= mp.pi
    th = _mpq(eta, mp) * _mp_time(t, mp)
    k = mp.floor((th - phi) / two_pi) + 1
    th_rel = phi + two_pi * k
    while th_rel <= th:  # guards the floor against rounding at an exact zero
        th_rel += two_pi
    return th_rel / _mpq(eta, mp)


def chatter_accumulation_time(t_n: Any, v_n: Any, R: Any, g: Any) -> Any:
    """Accumulation time of a chattering sequence in the constant-force limit.

    A mass hitting the wall at ``t_n`` with speed ``v_n > 0`` and restitution
    ``0 <= R < 1``, under a constant acceleration ``g > 0`` into the wall, flies
    ``2 R^k v_n / g`` between its k-th and (k+1)-th later impacts, so the impacts
    accumulate (Zeno) at ``t_n + 2 R v_n / (g (1 - R))`` (C. J. Budd, F. Dux,
    Phil. Trans. R. Soc. A 347 (1994) 365-389; for a slowly varying force this is
    the leading term, with a relative error O(flight time)).  Generic in the
    number type.
    """
    return t_n + 2 * R * v_n / (g * (1 - R))


# --------------------------------------------------------------------- grazing contacts
#: Safety factor of the default grazing depth.
GRAZING_SAFETY = 16


def grazing_depth_coefficient(precision) -> Fraction:
    """``16 u``, ``u = 2^-bits``: the default grazing depth is this times
    ``|x_w| + |a| + A_p (1 + eta |t|)``."""
    return Fraction(GRAZING_SAFETY, 2**precision.bits)


def steady_amplitude(params) -> float:
    """Steady-state amplitude ``A_p = |a| / sqrt((1 - eta^2)^2 + (2 zeta eta)^2)`` as a float.

    At the undamped resonance (``zeta = 0``, ``eta = 1``: no steady state) ``|a|``.
    """
    try:
        return math.sqrt(float(steady_state(params).amplitude_squared))
    except ParameterError:
        return float(abs(params.a))


class GrazingDepth:
    """Grazing depth ``delta(t) = coef (|x_w| + |a| + amp (1 + eta |t|))``, or a fixed value.

    The rounding-level distance beyond the wall below which an event is a tangential
    contact, not an impact (:func:`is_contact`).  ``pr`` is an integrator's parameter
    vector in :data:`~precise_impact.core.params.RUNTIME_PARAMS` order.
    """

    def __init__(self, coef: Any = 0.0, amp: Any = 0.0, fixed: Any = None) -> None:
        self.coef = coef
        self.amp = amp
        self.fixed = fixed

    def __call__(self, t: Any, pr: Any) -> Any:
        if self.fixed is not None:
            return self.fixed
        return grazing_depth(self.coef, self.amp, t, pr[I_XW], pr[I_A], pr[I_ETA])


def grazing_depth(coef: Any, amp: Any, t: Any, x_w: Any, a: Any, eta: Any) -> Any:
    """The grazing-depth formula ``coef (|x_w| + |a| + amp (1 + eta |t|))``, written once.

    :class:`GrazingDepth` evaluates it from an integrator's parameter vector; the SIMD
    batch Lyapunov code per lane.  ``coef`` is :func:`grazing_depth_coefficient` in the
    working precision, ``amp`` the steady-state amplitude (:func:`steady_amplitude`),
    ``t`` the local clock.
    """
    return coef * (abs(x_w) + abs(a) + amp * (1 + eta * abs(t)))


def is_contact(v_minus: Any, acc_minus: Any, depth: Any) -> bool:
    """True if an event at the wall is a tangential contact, not an impact.

    Either the mass is not moving into the wall (``v- <= 0``), or it is decelerating
    (``acc- < 0``) and would go beyond the wall by at most ``v-^2 / (2 |acc-|) <= depth``
    (a rounding-level excursion: resetting ``v`` there changes it by a rounding-level
    amount, and the saltation matrix ~ 1/v- would be meaningless).
    """
    return not v_minus > 0 or (acc_minus < 0 and v_minus * v_minus <= -2 * acc_minus * depth)


# --------------------------------------------------------------------------- R = 1 bounces
#: A flight ``2 v / g`` at most this fraction of ``1 / max(1, eta)`` is *short*: the start of
#: an ``R = 1`` bounce sequence under the wall force (:func:`short_elastic_flight`).
ELASTIC_FLIGHT_FRACTION = 0.1
#: The speed floor of a bounce, ``sqrt(ELASTIC_FLOOR_FACTOR eps scale g)``: below it heyoka's
#: event cooldown comes within a factor 100 of the flight (the mass is taken to be at rest).
ELASTIC_FLOOR_FACTOR = 500.0

#: What ends a predicted bounce sequence (:func:`elastic_bounce_count`).
BOUNCES_RUN_END, BOUNCES_RELEASE, BOUNCES_REST, BOUNCES_ENDLESS, BOUNCES_HORIZON = 0, 1, 2, 3, 4


def short_elastic_flight(v: float, g: float, eta: float) -> bool:
    """Is the flight after an impact at speed ``v`` under the wall force ``g > 0`` short
    (``2 v / g <= ELASTIC_FLIGHT_FRACTION / max(1, eta)``)?  Plain floats (numba too)."""
    return g > 0.0 and 2.0 * v / g * max(1.0, eta) <= ELASTIC_FLIGHT_FRACTION


def elastic_bounce_count(
    t: float, v: float, t_end: float, eta: float, zeta: float, a: float, x_w: float, eps: float
) -> tuple[float, int, float]:
    """Predicted impacts of an ``R = 1`` bounce sequence on the wall from the impact ``(t, v)``.

    With ``R = 1`` and short flights under the wall force ``g(s) = a cos(eta s) - x_w > 0``
    the bounce's action ``J = (2/3) v^3 / g`` is an adiabatic invariant of the flight
    between impacts, and linear damping makes it decay exactly like ``exp(-2 zeta s)``
    on average (``dJ/dt = -2 zeta J`` for any bounce shape).  So the impact speed is
    ``v(s) = (1.5 g(s) J(s))^(1/3)``, ``~ exp(-2 zeta s / 3)``: flights shrink, the impact
    rate ``g / (2 v)`` grows exponentially, but their sum diverges (not a Zeno
    sequence).  The impact count is the integral of that rate (steps of ``1/64`` of the
    shorter of the forcing period and ``2 pi``, at most 64 x 4096 of them) up to the first of:
    the force turning (release), the speed floor ``sqrt(ELASTIC_FLOOR_FACTOR eps scale g)``
    (rest: the mass is taken to be at rest), ``t_end``.

    Plain floats and ``math`` only, so the compiled engine runs the same code
    (:mod:`precise_impact.solvers.fast.lle`).

    Returns
    -------
    tuple
        ``(count, end, s)``: ``end`` one of ``BOUNCES_RUN_END``, ``BOUNCES_RELEASE``,
        ``BOUNCES_REST``, ``BOUNCES_ENDLESS`` (the count passed 1e18: ``count = inf``) or
        ``BOUNCES_HORIZON`` (none within the steps); ``s`` the time it ends
        (:func:`elastic_bounce_text` words it).
    """
    scale = max(1.0, abs(a), abs(x_w))
    g0 = a * math.cos(eta * t) - x_w
    J0 = 2.0 * v**3 / 3.0 / max(g0, 1e-300)
    h = min(2.0 * math.pi / max(1.0, eta) / 64.0, max(t_end - t, 1e-300))
    total = 0.0
    s = t
    for i in range(1, 64 * 4096 + 1):
        s = t + h * i
        g = a * math.cos(eta * s) - x_w
        if g <= 0.0:
            return total, BOUNCES_RELEASE, s
        vs = (1.5 * g * J0 * math.exp(-2.0 * zeta * (s - t))) ** (1.0 / 3.0)
        if vs < math.sqrt(ELASTIC_FLOOR_FACTOR * eps * scale * g):
            return total, BOUNCES_REST, s
        if s >= t_end:
            return total, BOUNCES_RUN_END, s
        total += g / (2.0 * vs) * h
        if total > 1e18:
            return math.inf, BOUNCES_ENDLESS, s
    return total, BOUNCES_HORIZON, s


def elastic_bounce_text(end: int, s: float) -> str:
    """What ends a predicted bounce sequence, in words (:func:`elastic_bounce_count`)."""
    if end == BOUNCES_RUN_END or end == BOUNCES_ENDLESS:
        return "the end of the run"
    if end == BOUNCES_RELEASE:
        return f"the release at t ~ {s:.6g}"
    if end == BOUNCES_REST:
        return f"rest on the wall at t ~ {s:.6g}"
    return f"t = {s:.6g}"


def elastic_bounce_refusal(t: float, count: float, end: int, s: float, max_impacts: int) -> str:
    """Why a Lyapunov run refuses an ``R = 1`` bounce sequence predicted at time ``t``
    (:func:`elastic_bounce_count`'s ``count, end, s``): it comes to rest on the wall (whose
    exponents the tangent methods do not resolve) or outruns the budget ``max_impacts``."""
    rest = end in (BOUNCES_REST, BOUNCES_ENDLESS)
    return (
        f"R = 1 with the net force into the wall from t = {t:.6g}: the mass bounces on the "
        "wall with speeds decaying like exp(-2 zeta t / 3) and ever shorter flights; reaching "
        f"{elastic_bounce_text(end, s)} takes ~{count:.2g} more impacts"
        + (
            ", and the Lyapunov exponents of an orbit at rest on the wall are not resolved"
            if rest
            else f", over the budget max_impacts = {max_impacts}"
        )
        + "; use R < 1 or a wall the force does not push into"
    )
