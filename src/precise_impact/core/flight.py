"""The closed-form flight between impacts, written once for every arithmetic.

Steady state ``x_p = P cos(eta t) + Q sin(eta t)`` plus the damped flow ``Phi(tau)``, evaluated
through an ops namespace (:data:`FLOAT`, :class:`MpmathOps`, :data:`NUMPY`, :data:`ARB`); the
numba copies are pinned to it by tests.  Reference: the paper's eq. (2a); ``docs/numerics.rst``.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable
from fractions import Fraction
from typing import Any

import mpmath
import numpy as np
from mpmath import libmp

__all__ = [
    "FLOAT",
    "NUMPY",
    "ARB",
    "MPMATH",
    "FloatOps",
    "NumpyOps",
    "ArbOps",
    "MpmathOps",
    "steady_coefficients",
    "damped_frequency",
    "forced_response",
    "flow_matrix",
    "flow_and_decay",
    "homogeneous_start",
    "state_from_coefficients",
    "trig_coefficients",
    "Flight",
    "homogeneous_amplitudes",
    "second_derivative_bound",
]


# ------------------------------------------------------------------------------ arithmetics
class FloatOps:
    """Scalar float64 through :mod:`math` (correctly rounded conversions of exact rationals)."""

    name = "float64"
    # typed as any callable: the subclasses put numpy's, mpmath's or python-flint's here
    exp: Callable[..., Any] = staticmethod(math.exp)
    sqrt: Callable[..., Any] = staticmethod(math.sqrt)
    cos: Callable[..., Any] = staticmethod(math.cos)
    sin: Callable[..., Any] = staticmethod(math.sin)
    pi: Any = math.pi
    u = 2.0**-53  # unit roundoff

    @staticmethod
    def cos_sin(x: float) -> tuple[float, float]:
        return math.cos(x), math.sin(x)

    @staticmethod
    def num(q: Fraction) -> float:
        return float(q)  # correctly rounded

    @staticmethod
    def context():
        return contextlib.nullcontext()


class NumpyOps(FloatOps):
    """float64 arrays through numpy (element-wise; scalars work too)."""

    name = "numpy"
    exp = staticmethod(np.exp)
    sqrt = staticmethod(np.sqrt)
    cos = staticmethod(np.cos)
    sin = staticmethod(np.sin)

    @staticmethod
    def cos_sin(x: Any) -> tuple[Any, Any]:
        return np.cos(x), np.sin(x)


class MpmathOps:
    """mpmath at ``bits`` (or ``dps``) of precision, in an :class:`mpmath.MPContext` of its own.

    ``ctx.prec`` is this precision for good: numbers made by :meth:`num` (or ``ctx.mpf``) and
    the functions ``exp``, ``sqrt``, ``cos``, ``sin``, ``cos_sin``, ``pi`` compute at it whatever
    mpmath's process-global precision is, so concurrent threads at other precisions cannot
    change the results (mpmath's module-level ``mp``, which ``workprec``/``workdps`` set, is
    shared by every thread).  Nothing here changes ``ctx.prec``, so one instance may serve
    several threads; mpmath routines that raise and restore it (``eig``, ``lu_solve``) need a
    context of one computation or thread (:func:`precise_impact.core.mpcontext.mp_context`).
    """

    name = "mpmath"

    def __init__(self, dps: int | None = None, bits: int | None = None) -> None:
        if bits is not None:
            self.prec, self.dps = bits, libmp.prec_to_dps(bits)
        else:
            self.prec, self.dps = libmp.dps_to_prec(dps), dps
        self.ctx = ctx = mpmath.MPContext()
        ctx.prec = self.prec
        self.exp, self.sqrt, self.cos, self.sin = ctx.exp, ctx.sqrt, ctx.cos, ctx.sin
        self.cos_sin = ctx.cos_sin
        self.u = ctx.ldexp(ctx.mpf(1), -self.prec)

    @property
    def pi(self):
        return +self.ctx.pi

    def context(self):
        """Nothing to set (the context's precision is its own); kept for ops-generic code."""
        return contextlib.nullcontext()

    def num(self, q: Fraction) -> Any:
        q = Fraction(q)
        # one correct rounding of the exact rational at the working precision
        return self.ctx.make_mpf(libmp.from_rational(q.numerator, q.denominator, self.prec, "n"))

    def mpf(self, x: Any) -> Any:
        """``x`` as a number of this context: mpmath numbers of any context exactly, others
        rounded once to the working precision."""
        if hasattr(x, "_mpf_"):
            return self.ctx.make_mpf(x._mpf_)
        return self.ctx.mpf(x)


class _GlobalMpmathOps:
    """mpmath at whatever working precision the caller has set on the module-level context
    (``mpmath.workprec`` / ``workdps``): not safe in concurrent threads; kept for callers that
    evaluate the formulas on module-level ``mpmath.mpf`` numbers (:data:`MPMATH`)."""

    name = "mpmath"
    exp = staticmethod(mpmath.exp)
    sqrt = staticmethod(mpmath.sqrt)
    cos = staticmethod(mpmath.cos)
    sin = staticmethod(mpmath.sin)
    cos_sin = staticmethod(mpmath.cos_sin)

    @property
    def pi(self):
        return +mpmath.pi

    @staticmethod
    def context():
        return contextlib.nullcontext()


class ArbOps:
    """python-flint arb balls at python-flint's working precision (imported when first used)."""

    name = "arb"

    @staticmethod
    def exp(x: Any) -> Any:
        return x.exp()

    @staticmethod
    def sqrt(x: Any) -> Any:
        """The square root of a quantity known to be >= 0: a ball reaching below 0 (``y * y`` of a
        ball around 0 does) is enclosed as ``[0, sqrt(upper)]`` instead of NaN."""
        if x.lower() >= 0:
            return x.sqrt()
        import flint  # noqa: PLC0415 -- optional: loaded on first use

        return flint.arb(0).union(flint.arb(x.upper()).sqrt())

    @staticmethod
    def cos_sin(x: Any) -> tuple[Any, Any]:
        s, c = x.sin_cos()
        return c, s

    @staticmethod
    def num(q: Fraction) -> Any:
        import flint  # noqa: PLC0415 -- optional: loaded on first use

        q = Fraction(q)
        return flint.arb(q.numerator) / q.denominator


FLOAT, NUMPY, ARB = FloatOps(), NumpyOps(), ArbOps()

#: mpmath at whatever working precision the caller has set on the module-level context (for
#: formulas evaluated inside the caller's own ``mpmath.workprec`` / ``workdps`` block: not
#: thread-safe; the package's own mpmath work uses :class:`MpmathOps`).
MPMATH = _GlobalMpmathOps()


# ------------------------------------------------------------------------------ the formulas
def steady_coefficients(eta: Any, zeta: Any, a: Any) -> tuple[Any, Any]:
    """``(P, Q)`` of the steady state ``x_p = P cos(eta t) + Q sin(eta t)``.

    ``P = a (1 - eta^2) / D``, ``Q = 2 zeta eta a / D``, ``D = (1 - eta^2)^2 + (2 zeta eta)^2``:
    plain arithmetic, exact for Fractions (``D = 0`` only at ``zeta = 0, eta = 1``).
    """
    m, n = 1 - eta * eta, 2 * zeta * eta
    d = m * m + n * n
    return a * m / d, n * a / d


def damped_frequency(alpha: Any, ops: Any, c0: Any = 1) -> Any:
    """``sqrt(c0 - alpha^2)``, the frequency of ``y'' + 2 alpha y' + c0 y = 0`` (underdamped)."""
    return ops.sqrt(c0 - alpha * alpha)


def forced_response(t: Any, P: Any, Q: Any, eta: Any, ops: Any) -> tuple[Any, Any]:
    """``(x_p(t), x_p'(t))`` of the steady state."""
    c, s = ops.cos_sin(eta * t)
    return P * c + Q * s, eta * (Q * c - P * s)


def flow_matrix(tau: Any, alpha: Any, wd: Any, ops: Any, c0: Any = 1) -> tuple[Any, Any, Any, Any]:
    """The 2x2 flow ``Phi(tau)`` of ``y'' + 2 alpha y' + c0 y = 0`` in ``(y, y')``, row by row.

    ``wd = sqrt(c0 - alpha^2) > 0``.  With ``alpha = zeta``, ``c0 = 1`` it is the homogeneous
    flow of a flight and its tangent flow; ``det Phi = exp(-2 alpha tau)``.
    """
    return flow_and_decay(tau, alpha, wd, ops, c0)[0]


def flow_and_decay(tau: Any, alpha: Any, wd: Any, ops: Any, c0: Any = 1):
    """``(Phi(tau), exp(-alpha tau))``: :func:`flow_matrix` and its decay factor (one ``exp``)."""
    e = ops.exp(-alpha * tau)
    c, s = ops.cos_sin(wd * tau)
    sw = s / wd
    return (e * (c + alpha * sw), e * sw, -c0 * e * sw, e * (c - alpha * sw)), e


def trig_coefficients(y: Any, u: Any, alpha: Any, wd: Any, c0: Any = 1) -> tuple:
    """``(A, B, A1, B1)`` with ``y(tau) = e^(-alpha tau) (A cos(wd tau) + B sin(wd tau))`` and
    ``y'(tau) = e^(-alpha tau) (A1 cos + B1 sin)`` from the homogeneous start ``(y, u)``: the
    flight in amplitude form, cheaper to evaluate many times than :func:`flow_and_decay`."""
    return y, (u + alpha * y) / wd, u, -(alpha * u + c0 * y) / wd


def state_from_coefficients(
    t: Any, s: Any, coefficients: tuple, P: Any, Q: Any, eta: Any, zeta: Any, wd: Any, ops: Any
) -> tuple[Any, Any, Any]:
    """``(x(t), x'(t), exp(-zeta (t - s)))`` of a flight in amplitude form
    (:func:`trig_coefficients`): the closed form's hot loop (~20 evaluations a flight).
    :meth:`Flight.at` is the same state in flow form (:func:`flow_and_decay`)."""
    A, B, A1, B1 = coefficients
    cf, sf = ops.cos_sin(eta * t)
    tau = t - s
    e = ops.exp(-zeta * tau)
    c, sn = ops.cos_sin(wd * tau)
    return (
        P * cf + Q * sf + e * (A * c + B * sn),
        eta * (Q * cf - P * sf) + e * (A1 * c + B1 * sn),
        e,
    )


def homogeneous_start(s: Any, x: Any, v: Any, P: Any, Q: Any, eta: Any, ops: Any):
    """``(y, y')`` at ``s``: the state minus the steady state, the homogeneous part's start."""
    xp, vp = forced_response(s, P, Q, eta, ops)
    return x - xp, v - vp


def homogeneous_amplitudes(y: Any, u: Any, alpha: Any, wd: Any, ops: Any, c0: Any = 1):
    """``(A_y, A_u)`` with ``|y(tau)| <= A_y e^(-alpha tau)``, ``|y'(tau)| <= A_u e^(-alpha tau)``.

    ``y = e^(-alpha tau) (y0 cos + (u0 + alpha y0) / wd sin)`` and ``y'`` solves the same equation
    from ``(u0, -2 alpha u0 - c0 y0)``: each amplitude is the norm of its two coefficients (for
    ``c0 = 1`` both equal ``sqrt(A^2 + B^2)``, and so does every derivative's).
    """
    # products, not ** 2: python-flint's power of a ball around 0 is NaN (it goes through log)
    b, d = (u + alpha * y) / wd, (alpha * u + c0 * y) / wd
    return ops.sqrt(y * y + b * b), ops.sqrt(u * u + d * d)


def second_derivative_bound(ay: Any, au: Any, alpha: Any, c0: Any = 1) -> Any:
    """A bound of ``|y''| = |2 alpha y' + c0 y|`` for ``tau >= 0`` from the amplitudes."""
    return 2 * alpha * au + c0 * ay


class Flight:
    """The flight from ``(s, x_s, v_s)`` of ``x'' + 2 zeta x' + x = a cos(eta t)``, in ``ops``.

    ``P, Q, eta, zeta, wd`` are numbers of the arithmetic (converted once by the caller).
    """

    __slots__ = ("P", "Q", "eta", "zeta", "wd", "ops", "s", "y", "u", "_bound")

    def __init__(self, P, Q, eta, zeta, wd, ops, s, x, v) -> None:
        self.P, self.Q, self.eta, self.zeta, self.wd, self.ops = P, Q, eta, zeta, wd, ops
        self.s = s
        self.y, self.u = homogeneous_start(s, x, v, P, Q, eta, ops)
        self._bound = None

    def flow(self, t: Any) -> tuple[Any, Any, Any, Any]:
        """``Phi(t - s)``: the homogeneous and tangent flow of this flight."""
        return flow_matrix(t - self.s, self.zeta, self.wd, self.ops)

    def at(self, t: Any) -> tuple[Any, Any]:
        """``(x, v)`` at ``t``."""
        (p00, p01, p10, p11), _ = flow_and_decay(t - self.s, self.zeta, self.wd, self.ops)
        xp, vp = forced_response(t, self.P, self.Q, self.eta, self.ops)
        return xp + (p00 * self.y + p01 * self.u), vp + (p10 * self.y + p11 * self.u)

    def amplitude(self) -> Any:
        """``A`` with ``|y^(k)(tau)| <= A e^(-zeta tau)`` for every ``k`` (``c0 = 1``)."""
        return homogeneous_amplitudes(self.y, self.u, self.zeta, self.wd, self.ops)[0]

    def acceleration_bound(self) -> Any:
        """A bound of ``|x''|`` on the flight (``tau >= 0``): ``|y''| + eta^2 sqrt(P^2 + Q^2)``.

        Exact arithmetic would make it a bound; a rounded arithmetic's caller inflates it (balls:
        take the upper end)."""
        if self._bound is None:
            ay, au = homogeneous_amplitudes(self.y, self.u, self.zeta, self.wd, self.ops)
            S = self.ops.sqrt(self.P * self.P + self.Q * self.Q)
            self._bound = second_derivative_bound(ay, au, self.zeta) + self.eta * self.eta * S
        return self._bound
