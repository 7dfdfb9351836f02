"""Certified trajectories: every sample and impact enclosed in a ball proven to contain the truth.

The closed-form flight in python-flint ``arb`` balls; impacts isolated (no earlier crossing,
one crossing) and narrowed by interval Newton; where no proof is possible it stops or doubles
the bits, never guesses (``docs/numerics.rst``).
"""

from __future__ import annotations

import dataclasses
import math
import os
import threading
import time
from collections.abc import Callable
from decimal import ROUND_CEILING, Decimal, localcontext
from fractions import Fraction
from typing import Any

from precise_impact.core import flight
from precise_impact.core.budget import Deadline, enforce_max_time, parse_max_time
from precise_impact.core.compat import UNSET, warn_renamed
from precise_impact.core.flow import steady_state
from precise_impact.core.impact import oscillator_saltation
from precise_impact.core.params import Params, check_count, decimal_str, exact, params_or_values
from precise_impact.core.precision import (
    Precision,
    exact_value,
    float_up,
    log10_fraction,
)
from precise_impact.core.result import ResultMixin, ball_columns
from precise_impact.core.trajectory import Trajectory
from precise_impact.errors import (
    BudgetExceededError,
    CertificationError,
    OptionalDependencyError,
    ParameterError,
)
from precise_impact.io.figures import plot_certified
from precise_impact.io.progress import Progress

__all__ = [
    "certify",
    "CertifiedTrajectory",
    "CertificationError",
    "CertifiedSolver",
    "ball_str",
    "radius_str",
    "working_bits",
    "flow_matrix",
    "run_balls",
    "to_ball",
    "exact_value",
    "float_up",
    "log10_abs",
    "log10_str",
    "MAX_BITS",
    "MIN_BITS",
    "Constants",
    "Flight",
    "Isolator",
    "doubling",
    "point",
    "upper",
    "lower",
    "describe",
    "check_certifiable",
    "out_of_reach",
    "check_target",
    "choose_bits",
    "missed_target",
]

#: Bounds of the working precision (bits).
MIN_BITS, MAX_BITS = 64, 16384
#: Bisection depth at which an interval that is neither cleared nor isolated is declared a
#: tangency the working precision cannot resolve (halves of a forcing period: 2^-60 T ~ 1e-17 T
#: beyond the bits' own limit is never needed).
_MAX_DEPTH_EXTRA = 40
#: Most significant digits :func:`ball_str` gives a midpoint: MAX_BITS (16384) bits hold 4932
#: decimal digits, so a radius below that relative accuracy is stated as ~1e-5000 relative.
_MAX_DIGITS = 5000
_LOCK = threading.RLock()


def _flint():
    try:
        import flint  # noqa: PLC0415 -- optional: python-flint loaded on first use
    except ImportError as e:  # pragma: no cover - CI installs it
        raise OptionalDependencyError(
            "python-flint", "certified trajectories (ball arithmetic)", "pip install python-flint"
        ) from e
    return flint


def to_ball(q: Fraction):
    """The exact rational ``q`` as a python-flint ball at the current working precision."""
    flint = _flint()
    return flint.arb(flint.fmpq(q.numerator, q.denominator))


def log10_abs(x) -> float:
    """``log10 |x|`` of an exact arb (a dyadic point such as a radius) at any magnitude
    (``-inf`` for 0): no float underflow below 1e-308."""
    man, exp = x.man_exp()
    man, exp = abs(int(man)), int(exp)
    return -math.inf if man == 0 else math.log10(man) + exp * math.log10(2)


def log10_str(lg: float, digits: int = 3) -> str:
    """``10^lg`` in scientific notation with ``digits`` significant digits (``'1.26e-331'``),
    at any magnitude (``'0'`` for ``-inf``): how a ratio or radius known by its ``log10``
    (:func:`log10_abs`, :func:`~precise_impact.core.precision.log10_fraction`) is printed
    below the float range."""
    if lg == -math.inf:
        return "0"
    e = math.floor(lg)
    m = round(10 ** (lg - e), digits - 1)
    if m >= 10:  # 9.999 rounded up to 10.0
        m, e = m / 10, e + 1
    return f"{m:.{digits - 1}f}e{e:+03d}"


def ball_str(b, digits: int | None = None) -> tuple[str, str]:
    """``(midpoint, radius)`` of a ball as decimal strings, rigorously: the radius is rounded up
    and includes the decimal rounding of the midpoint, so ``[mid - rad, mid + rad]`` contains
    the ball.

    Parameters
    ----------
    b : flint.arb
        The ball.
    digits : int or None, default ``None``
        Significant digits of the midpoint; ``None``: three more than the ball's accuracy.

    Returns
    -------
    tuple of str
        Midpoint and radius (the radius with 3 significant digits, rounded up).
    """
    mid, rad = exact_value(b.mid()), exact_value(b.rad())
    if digits is None:
        if rad == 0:
            digits = 40
        else:
            # three digits below the ball's accuracy, from the exact ratio's log10 (a float
            # ratio overflowed past 1e300: every radius below 1e-300 was stated as ~1e-303)
            scale = max(abs(mid), rad)
            digits = max(3, min(_MAX_DIGITS, math.ceil(log10_fraction(scale / rad))) + 3)
    with localcontext() as ctx:
        ctx.prec = digits
        dm = Decimal(mid.numerator) / Decimal(mid.denominator)  # rounded to `digits`
    err = abs(Fraction(dm) - mid) + rad
    if err == 0:
        return format(dm, "f") if abs(dm) < 10**6 else str(dm), "0"
    with localcontext() as ctx:
        ctx.prec = 3
        ctx.rounding = ROUND_CEILING
        dr = Decimal(err.numerator) / Decimal(err.denominator)
    return str(dm), str(dr).replace("E", "e")


def radius_str(r) -> str:
    """A radius (an exact non-negative arb, e.g. ``b.rad()``, or a Fraction) as a decimal
    string in scientific notation, 3 significant digits rounded up: ``'0'`` only for an exact
    0, never rounded to 0 at any magnitude (a float underflows to 0.0 below 1e-308 and would
    state exactness)."""
    q = r if isinstance(r, Fraction) else exact_value(r)
    if q == 0:
        return "0"
    with localcontext() as ctx:
        ctx.prec = 3
        ctx.rounding = ROUND_CEILING
        d = Decimal(q.numerator) / Decimal(q.denominator)
    return f"{d:.2e}"


def _finite_or_none(x: float) -> float | None:
    """``x``, or ``None`` for a non-finite value (``-inf``: the log10 radius of an exact point),
    so that the JSON stays strict."""
    return x if math.isfinite(x) else None


def max_radius_str(balls) -> str:
    """The largest radius of ``balls`` as :func:`radius_str` (chosen exactly, not by float)."""
    return radius_str(max((b.rad() for b in balls), key=exact_value))


class Flight(flight.Flight):
    """The closed-form flight of the single oscillator from ``(s, x_s, v_s)``, all balls,
    evaluated at ball or point times (also the master of the certified pair,
    :mod:`precise_impact.solvers.certified.coupled`): :class:`precise_impact.core.flight.Flight`
    in ball arithmetic."""

    __slots__ = {"c": "The system's constants in balls (:class:`Constants`)."}

    def __init__(self, c: Constants, s, xs, vs) -> None:
        super().__init__(c.P, c.Q, c.eta, c.zeta, c.w, flight.ARB, s, xs, vs)
        self.c = c

    def gap(self, t):
        """``(x - x_w, x')`` at ``t``: the wall gap :class:`Isolator` works on."""
        x, v = self.at(t)
        return x - self.c.xw, v

    def acceleration_bound(self):
        """A proven bound of ``|x''|`` on the flight (``tau >= 0``): the upper end of the ball
        :meth:`precise_impact.core.flight.Flight.acceleration_bound`."""
        return super().acceleration_bound().upper()


class Constants:
    """The exact parameters as balls at the working precision, and the derived constants of
    the flight (``P, Q`` of the steady state, ``omega_d = sqrt(1 - zeta^2)``, ``T``)."""

    def __init__(self, params: Params, bits: int) -> None:
        flint = _flint()
        ss = steady_state(params)
        self.eta, self.zeta, self.a = to_ball(params.eta), to_ball(params.zeta), to_ball(params.a)
        self.xw, self.R = to_ball(params.x_w), to_ball(params.R)
        self.P, self.Q = to_ball(ss.P), to_ball(ss.Q)
        self.w = flight.damped_frequency(self.zeta, flight.ARB)
        self.T = 2 * flint.arb.pi() / self.eta
        self.t0 = to_ball(params.t0)
        self.bits = bits


def point(x):
    """The exact midpoint of a ball (a dyadic point)."""
    return _flint().arb(x.mid())


def upper(x):
    """The upper end of a ball as an exact point."""
    return _flint().arb(x.upper())


def lower(x):
    """The lower end of a ball as an exact point."""
    return _flint().arb(x.lower())


def _interval(lo, hi):
    return lo.union(hi)


def describe(t, what: str) -> str:
    """``"<what> at t = <mid> +- <rad>"`` for an error message."""
    m, _ = ball_str(t, 20)
    return f"{what} at t = {m} (a ball of radius {radius_str(t.rad())})"


class Isolator:
    """Impact isolation in ball arithmetic, for any wall gap ``g`` of a flight.

    ``gap(t)`` returns ``(g, g')`` (balls; the wall is ``g = 0``, the inside ``g > 0``) and
    ``A`` is a proven bound of ``|g''|`` over the flight.  Written once, used for the single
    oscillator and both oscillators of the certified pair.

    Parameters
    ----------
    bits : int
        Working precision (for the messages and the bisection depth limit).
    """

    def __init__(self, bits: int) -> None:
        self.bits = bits
        self.max_depth = bits + _MAX_DEPTH_EXTRA

    def first_crossing(self, gap, A, a, b, depth: int = 0, *, check_start: bool = False):
        """The first crossing of ``g = 0`` in ``[a, b]`` (exact points) as a ball narrowed by
        interval Newton, or ``None`` with ``g < 0`` proven on ``[a, b]``.  ``g(a) < 0`` is
        assumed (proven by the caller) unless ``check_start``, which proves it first."""
        if check_start:
            ga, _ = gap(a)
            if not ga < 0:
                raise CertificationError(
                    describe(a, "a wall contact cannot be excluded") + f" (gap {ga}) "
                    f"at {self.bits} bits"
                )
        # depth first, left half first, on an explicit stack: the bisection may go bits + 40
        # levels deep, past Python's recursion limit (a RecursionError at 1024 bits before)
        todo = [(a, b, depth)]
        while todo:
            a, b, depth = todo.pop()
            h = b - a
            m = point((a + b) / 2)
            gm, vm = gap(m)
            if gm + abs(vm) * h / 2 + A * h * h / 8 < 0:
                continue  # cleared: g < 0 on [a, b]
            vlo = vm - A * h / 2
            vhi = vm + A * h / 2
            if vhi < 0:
                continue  # g decreasing from g(a) < 0
            if vlo > 0:
                gb, _ = gap(b)
                if gb < 0:
                    continue  # increasing and still below the wall at b
                if gb > 0:
                    return self.newton(gap, a, b)
            if depth > self.max_depth:
                raise CertificationError(
                    describe(_interval(a, b), "a crossing cannot be separated from a graze")
                    + f" with gap in {gap(_interval(a, b))[0]} at {self.bits} bits"
                )
            todo.append((m, b, depth + 1))
            todo.append((a, m, depth + 1))
        return None

    def newton(self, gap, a, b):
        """The unique crossing in ``[a, b]`` (``g' > 0`` proven there, ``g(a) < 0 < g(b)``)."""
        J = _interval(a, b)
        width = J.rad()
        for _ in range(200):
            m = point(J)
            gm, _ = gap(m)
            _, vJ = gap(J)
            N = m - gm / vJ
            Jn = J.intersection(N)
            if not (Jn.rad() < width * 0.75):
                J = Jn
                break
            J, width = Jn, Jn.rad()
        return J

    def depart(self, gap, A, s):
        """After an impact at the ball ``s`` (``g = 0``, ``g'+ < 0``): the first point from which
        the scan may go on, with ``g < 0`` proven from the impact to it."""
        _, v = gap(s)
        if not v < 0:
            raise CertificationError(
                describe(s, "a tangential or sticking impact (velocity after it not proven < 0)")
                + f", {v}, at {self.bits} bits"
            )
        h = point(-v.upper() / (4 * A))  # g' stays < 0 for a quarter of |g'+| / A
        while True:
            b = point(upper(s) + h)
            J = _interval(lower(s), b)
            _, vm = gap(point(J))
            if vm + A * J.rad() < 0:
                gb, _ = gap(b)
                if gb < 0:
                    return b
            h = point(h / 2)
            if h < s.rad() * 4 or h.is_zero():
                raise CertificationError(
                    describe(s, "an impact whose departure cannot be proven")
                    + f" at {self.bits} bits"
                )


class _Engine:
    #: The scan's step, a fraction of the forcing period (each step is cleared or bisected).
    steps_per_period = 16

    def __init__(self, params: Params, bits: int) -> None:
        self.p = params
        self.bits = bits
        self.c = Constants(params, bits)
        self.iso = Isolator(bits)

    def run(
        self, periods: int, progress=None, start: tuple | None = None, deadline=None, k0: int = 0
    ):
        """Samples ``(k, t, x, v)`` and impacts ``(t, v_before, v_after)`` over ``periods``, from
        the initial condition of the parameters or from ``start = (x0, v0)`` balls at ``t0``
        (a box: every state in it is followed, the balls enclose them all).  ``deadline``: a
        :class:`~precise_impact.core.budget.Deadline` checked after every period.  ``k0``:
        with ``start``, the box is at the sample time ``t0 + k0 T`` and the run covers periods
        ``k0 + 1 .. k0 + periods`` (one step of :mod:`~precise_impact.solvers.certified.lohner`).
        A :class:`CertificationError` carries the samples proven before it as ``partial``."""
        samples: list = []
        try:
            return self._run(periods, progress, start, deadline, samples, k0)
        except CertificationError as e:
            e.partial = samples
            raise

    def _run(
        self, periods: int, progress, start: tuple | None, deadline, samples: list, k0: int = 0
    ):
        c = self.c
        p = self.p
        iso = self.iso
        x0, v0 = (to_ball(p.x0), to_ball(p.v0)) if start is None else start
        s = c.t0 if k0 == 0 else c.t0 + k0 * c.T
        samples.append((k0, s, x0, v0))
        impacts = []
        fl = Flight(c, s, x0, v0)
        if start is not None:
            if not x0 < c.xw:
                raise CertificationError(
                    f"the start box x in {x0} is not proven below the wall x_w"
                )
            a = s
        elif p.x0 == p.x_w:
            if p.v0 > 0:
                # an impact at t0; samples are right-continuous (docs/numerics.rst, as every
                # engine): sample 0 holds the state after it
                impacts.append((s, v0, -c.R * v0))
                fl = Flight(c, s, c.xw, -c.R * v0)
                samples[0] = (0, c.t0, x0, -c.R * v0)
            elif p.v0 == 0:
                raise CertificationError("the start (x0 = x_w, v0 = 0) is a contact: not certified")
            a = iso.depart(fl.gap, fl.acceleration_bound(), s)
        else:
            a = s
        hstep = point(c.T / self.steps_per_period)
        for k in range(k0 + 1, k0 + periods + 1):
            tk = c.t0 + k * c.T
            end = upper(tk)
            while True:
                b = a + hstep
                b = point(b) if b < end else end
                hit = iso.first_crossing(fl.gap, fl.acceleration_bound(), a, b)
                if hit is None:
                    if b is end or not (b < end):
                        break
                    a = b
                    continue
                if hit.overlaps(tk):
                    raise CertificationError(
                        describe(hit, "an impact on a sample time") + f" at {self.bits} bits"
                    )
                _, vb = fl.at(hit)
                va = -c.R * vb
                impacts.append((hit, vb, va))
                fl = Flight(c, hit, c.xw, va)
                a = iso.depart(fl.gap, fl.acceleration_bound(), hit)
                if not (a < end):
                    if a.overlaps(tk) or a > end:
                        # the departure interval reaches past the sample: x < x_w proven on it
                        break
            x, v = fl.at(tk)
            samples.append((k, tk, x, v))
            a = end
            if progress is not None:
                progress.update(k)
            if deadline is not None:
                deadline.check(f"{k} of {periods} periods at {self.bits} bits")
        return samples, impacts


@dataclasses.dataclass
class CertifiedTrajectory(ResultMixin):
    """A trajectory with proven enclosures (:func:`certify`).

    Attributes
    ----------
    params : Params
        The system (exact).
    periods : int
        Forcing periods; samples at ``t_k = t0 + k 2 pi / eta`` (exact times, enclosed in balls).
    bits : int
        Working precision used.
    bits_choice : str
        How ``bits`` was chosen (given, or automatic from the target radius and the measured
        growth, and any retries).
    samples : list of tuple
        ``(k, t, x, v)`` with ``t, x, v`` python-flint ``arb`` balls.
    impacts : list of tuple
        ``(t, v_before, v_after)`` balls, in order.
    elapsed_s : float
        Wall time of the final run (diagnostic).
    method : str
        The enclosure (``'lohner'`` or ``'interval'``, :func:`certify`).

    See Also
    --------
    precise_impact.solvers.certified.single.certify : returns it.
    precise_impact.core.trajectory.Trajectory : the floating-point counterpart.
    """

    params: Params
    periods: int
    bits: int
    bits_choice: str
    samples: list
    impacts: list
    elapsed_s: float
    method: str = "interval"

    def _tables(self) -> dict:
        """``to_dataframe()`` tables: ``samples`` (default) and ``impacts``, each ball as its
        midpoint and its radius (``rad_*``, a proven bound on the midpoint's error)."""
        return {
            "samples": lambda: ball_columns(("period", "t", "x", "v"), self.samples),
            "impacts": lambda: ball_columns(("t", "v_before", "v_after"), self.impacts),
        }

    @property
    def x(self) -> list:
        """The sample balls of ``x``."""
        return [s[2] for s in self.samples]

    @property
    def v(self) -> list:
        """The sample balls of ``v``."""
        return [s[3] for s in self.samples]

    def plot(
        self, path: str | os.PathLike | None = None, units: str = "dimensionless", components=None
    ):
        """The enclosures' midpoints in the phase plane beside their radii
        (:func:`precise_impact.io.figures.plot_certified`).

        Parameters
        ----------
        path : str, os.PathLike or None, default ``None``
            Also write the figure there (``.png``, ``.pdf``, ``.svg``, atomically).
        units : {'dimensionless', 'circuit'}, default ``'dimensionless'``
            ``'circuit'``: the volts of ``components`` (default: the nominal design).
        components : Components or None

        Returns
        -------
        matplotlib.figure.Figure
        """
        return plot_certified(self, path, units=units, components=components)

    def radii(self) -> list[float]:
        """``max(rad x, rad v)`` per sample (floats rounded up: bounds; a radius below 1e-308
        is the smallest subnormal ``5e-324``, never 0.0: its size is :meth:`log10_radii`)."""
        return [float_up(exact_value(max(s[2].rad(), s[3].rad()))) for s in self.samples]

    def log10_radii(self) -> list[float]:
        """``log10 max(rad x, rad v)`` per sample (``-inf`` for an exact point), any magnitude."""
        return [log10_abs(max(s[2].rad(), s[3].rad())) for s in self.samples]

    def max_radius(self) -> float:
        """The largest radius of any sample (a float rounded up: ``5e-324`` if below 1e-308,
        see :meth:`max_log10_radius`)."""
        return max(self.radii())

    def max_log10_radius(self) -> float:
        """``log10`` of the largest radius of any sample, at any magnitude."""
        return max(self.log10_radii())

    def growth_digits_per_period(self) -> float:
        """Decimal digits of radius lost per forcing period (least squares over the samples
        after the first)."""
        return growth_slope(self.log10_radii())

    def contains(self, k: int, x: Any, v: Any) -> bool:
        """Whether the exact decimals ``x, v`` lie in sample ``k``'s balls.

        Parameters
        ----------
        k : int
            Sample index (period).
        x, v : str, Fraction or number
            The values to check (exact decimals; floats are read as their shortest decimal).

        Returns
        -------
        bool

        Raises
        ------
        ParameterError
            ``k`` is not an integer with ``0 <= k <= periods``.
        """
        k = check_count(k, "k", self.periods, minimum=0)
        _, _, bx, bv = self.samples[k]
        # exactly, in rationals: no rounding, and no dependence on python-flint's process-wide
        # precision
        return all(
            abs(exact(n, q, 10**6) - exact_value(b.mid())) <= exact_value(b.rad())
            for n, q, b in (("x", x, bx), ("v", v, bv))
        )

    def to_dict(self) -> dict:
        """The CLI's ``--json`` object: ``params``, ``periods``, ``bits``, ``bits_choice``,
        ``samples`` (``{"period", "t", "x", "v", "x_rad", "v_rad"}``: decimal midpoints and
        rigorous radii as decimal strings), ``impacts`` (``{"t", "t_rad", "v_before",
        "v_after", "v_rad"}``), ``max_radius`` (a string in scientific notation, rounded up,
        :func:`radius_str`: never 0 for a ball of any radius), ``max_log10_radius`` (``None``
        when every sample is an exact point), ``growth_digits_per_period``, ``elapsed_s``:
        strict JSON."""
        out = []
        for k, t, x, v in self.samples:
            tm, _ = ball_str(t)
            xm, xr = ball_str(x)
            vm, vr = ball_str(v)
            out.append({"period": k, "t": tm, "x": xm, "v": vm, "x_rad": xr, "v_rad": vr})
        imps = []
        for t, vb, va in self.impacts:
            tm, tr = ball_str(t)
            bm, br = ball_str(vb)
            am, ar = ball_str(va)
            imps.append(
                {
                    "t": tm,
                    "t_rad": tr,
                    "v_before": bm,
                    "v_after": am,
                    "v_rad": max(br, ar, key=Fraction),
                }
            )
        return {
            "params": self.params.decimal(),
            "periods": self.periods,
            "bits": self.bits,
            "bits_choice": self.bits_choice,
            "samples": out,
            "impacts": imps,
            "max_radius": max_radius_str(b for row in self.samples for b in row[2:]),
            "max_log10_radius": _finite_or_none(self.max_log10_radius()),
            "growth_digits_per_period": self.growth_digits_per_period(),
            "elapsed_s": self.elapsed_s,
            "method": self.method,
        }


def growth_slope(log10_radii: list[float]) -> float:
    """Decimal digits of radius lost per period: the least-squares slope of ``log10_radii``
    (one per sample, period 0 first) over the samples after the first (exact points, ``-inf``,
    left out)."""
    r = log10_radii[1:]
    ks = [k for k in range(1, len(r) + 1) if math.isfinite(r[k - 1])]
    if len(ks) < 2:
        return 0.0
    ys = [r[k - 1] for k in ks]
    km, ym = sum(ks) / len(ks), sum(ys) / len(ys)
    den = sum((k - km) ** 2 for k in ks)
    return sum((k - km) * (y - ym) for k, y in zip(ks, ys, strict=True)) / den if den else 0.0


class working_bits:
    """``with working_bits(bits):`` python-flint at ``bits`` under the engine's lock (restored
    after)."""

    def __init__(self, bits: int) -> None:
        self.bits = bits

    def __enter__(self):
        flint = _flint()
        _LOCK.acquire()
        self.old = flint.ctx.prec
        flint.ctx.prec = self.bits
        return self

    def __exit__(self, *exc) -> None:
        _flint().ctx.prec = self.old
        _LOCK.release()


def flow_matrix(c: Constants, tau):
    """The homogeneous (and tangent) flow ``Phi(tau)`` of a flight as a 2x2 list of balls."""
    p00, p01, p10, p11 = flight.flow_matrix(tau, c.zeta, c.w, flight.ARB)
    return [[p00, p01], [p10, p11]]


def _mat_mul(A, B):
    return [[A[i][0] * B[0][j] + A[i][1] * B[1][j] for j in range(2)] for i in range(2)]


def period_jacobian(c: Constants, t_start, impacts, t_end, pre: list | None = None):
    """``Phi(t_end - s_n) S_n ... S_1 Phi(s_1 - t_start)`` (2x2 lists of balls): the flight
    flows (:func:`precise_impact.core.flight.flow_matrix`) and saltation matrices
    (:func:`precise_impact.core.impact.oscillator_saltation`) along ``impacts`` (time ball,
    v- ball, v+ ball), each enclosed over its balls, so the product encloses the map's
    Jacobian over every state they came from.  ``pre`` (a list) receives the product up to
    just before each impact."""
    one, zero = c.eta * 0 + 1, c.eta * 0
    M = [[one, zero], [zero, one]]
    prev = t_start
    for t, vb, _ in impacts:
        M = _mat_mul(flow_matrix(c, t - prev), M)
        if pre is not None:
            pre.append(M)
        S = oscillator_saltation(t, vb, c.eta, c.zeta, c.a, c.xw, c.R, lambda z: z.cos())
        M = _mat_mul(S, M)
        prev = t
    return _mat_mul(flow_matrix(c, t_end - prev), M)


def run_balls(
    params: Params,
    periods: int,
    bits: int,
    start: tuple | None = None,
    progress=None,
    deadline=None,
) -> tuple:
    """``(samples, impacts, constants)`` of one certified run at ``bits`` (the caller holds
    :class:`working_bits`); ``start``: ``(x0, v0)`` balls at ``t0`` instead of the parameters';
    ``progress``: a :class:`~precise_impact.io.progress.Progress` told each finished period;
    ``deadline``: a :class:`~precise_impact.core.budget.Deadline` checked after each period."""
    eng = _Engine(params, bits)
    samples, impacts = eng.run(periods, progress, start, deadline)
    return samples, impacts, eng.c


def _run(
    params: Params, periods: int, bits: int, progress, deadline=None, method: str = "interval"
) -> tuple[list, list]:
    with working_bits(bits):
        if method == "lohner":
            from precise_impact.solvers.certified.lohner import LohnerEngine  # noqa: PLC0415 -- import cycle: lohner builds on this module

            return LohnerEngine(params, bits).run(periods, progress, deadline)
        return run_balls(params, periods, bits, progress=progress, deadline=deadline)[:2]


#: The enclosures :func:`certify` offers (``method``).
METHODS = ("lohner", "interval")


#: The fewest periods proven before a failed attempt over which the radius growth is trusted to
#: project the bits of the whole run (:func:`out_of_reach`): a transient shorter than this
#: (impacts before a trajectory settles) never leads to a refusal.
MIN_MEASURED_PERIODS = 100
#: A projection refuses only when it exceeds ``max_bits`` by this factor (one more doubling
#: beyond ``max_bits`` would still not suffice).
REACH_MARGIN = 2


def out_of_reach(e: CertificationError, bits: int, periods: int, max_bits: int) -> str | None:
    """The refusal of a run whose bits are out of reach, or ``None`` to double the bits on.

    After a failed attempt at ``bits``, the radius growth ``g`` (decimal digits per period,
    least squares over the second half of the periods proven before the failure: a trajectory
    that settles onto a stable orbit grows less there) projects the bits the run needs:
    ``bits + g (periods - proven) / log10(2)`` (the failure happens when the radius reaches
    the same level, reached ``g (periods - proven)`` digits later).  Refused only with at least
    :data:`MIN_MEASURED_PERIODS` periods proven, ``g > 0``, and a projection above
    :data:`REACH_MARGIN` x ``max_bits``.
    """
    samples = getattr(e, "partial", None) or []
    proven = len(samples) - 1
    if proven < MIN_MEASURED_PERIODS:
        return None
    half = samples[proven // 2 :]
    ks = [s[0] for s in half]
    ys = [max(log10_abs(b.rad()) for b in s[2:]) for s in half]
    pts = [(k, y) for k, y in zip(ks, ys, strict=True) if math.isfinite(y)]
    if len(pts) < 2:
        return None
    km = sum(k for k, _ in pts) / len(pts)
    ym = sum(y for _, y in pts) / len(pts)
    den = sum((k - km) ** 2 for k, _ in pts)
    g = sum((k - km) * (y - ym) for k, y in pts) / den if den else 0.0
    if not g > 0:
        return None
    need = bits + g * (periods - proven) / math.log10(2)
    if need <= REACH_MARGIN * max_bits:
        return None
    return (
        f"{e} (after {proven} proven periods the radius grows {g:.3g} decimal digits per period:"
        f" {periods} periods need ~{need:.3g} bits, beyond max_bits = {max_bits}; "
        f"ask for fewer periods)"
    )


def check_certifiable(params: Params) -> None:
    """Refuse, before any work, a system the certified engines do not take (the closed-form
    flight needs ``zeta < 1`` and a steady state), and a missing python-flint.

    Parameters
    ----------
    params : Params
        The system.

    Raises
    ------
    ParameterError
        ``zeta >= 1``, or ``zeta = 0`` at ``eta = 1``.
    OptionalDependencyError
        python-flint is not installed.
    """

    if not params.zeta < 1:
        raise ParameterError(
            "zeta", decimal_str(params.zeta), "0 <= zeta < 1 (underdamped) for the certified engine"
        )
    if (1 - params.eta**2) ** 2 + (2 * params.zeta * params.eta) ** 2 == 0:
        raise ParameterError(
            "zeta", "0", "zeta > 0 at eta = 1 (the undamped resonance has no steady state)"
        )
    _flint()


#: Periods of the automatic bits' pilot run per method: the Lohner enclosure grows at the
#: dynamics' rate, whose average over 40 chaotic periods is too noisy to project 10,000
#: (eta = 0.712: 0.20 digits/period over the first 40, 0.12 over 200, 0.116 over 3,000).
PILOT_PERIODS = {"interval": 40, "lohner": 200}


def certified_bits(precision: Any, max_bits: int) -> int | None:
    """The working bits a certified engine runs at: ``'mp:BITS'`` -> ``BITS``, ``'auto'`` ->
    ``None`` (chosen by a pilot run, :func:`choose_bits`); anything else is refused naming
    ``precision``."""
    allowed = f"'auto' or 'mp:BITS' with {MIN_BITS} <= BITS <= {max_bits}"
    if precision == "auto":
        return None
    if isinstance(precision, str) and precision.startswith("mp:"):
        b = precision[3:]
        if b.isdigit() and MIN_BITS <= int(b) <= max_bits:
            return int(b)
        if b.isdigit() and MIN_BITS <= int(b) <= MAX_BITS:  # the two disagree: name the limit
            raise ParameterError(
                "max_bits", max_bits, f"at least the {int(b)} bits of precision = {precision!r}"
            )
    raise ParameterError("precision", precision, allowed)


def check_target(target_radius: Any) -> float:
    """``log10`` of the radius wanted by the automatic bits (exact, so no underflow below
    1e-308); refused naming ``target_radius`` outside ``1e-3000 .. 1e-3``."""
    target = exact("target_radius", target_radius, 3000)
    if not Fraction(1, 10**3000) <= target <= Fraction(1, 1000):
        raise ParameterError(
            "target_radius", str(target_radius), "1e-3000 <= target_radius <= 1e-3"
        )
    return log10_fraction(target)


def choose_bits(
    pilot: Callable[[int, int], Any],
    periods: int,
    method: str,
    log_target: float,
    max_bits: int,
    target_radius: Any,
) -> tuple[int, str]:
    """The automatic working bits of a certified run and how they were chosen.

    ``pilot(n, bits)`` certifies the first ``n`` periods at ``bits`` and returns a result with
    ``growth_digits_per_period()`` and ``log10_radii()`` (or raises
    :class:`~precise_impact.errors.CertificationError`: retried at twice the bits, up to
    ``max_bits``).  The pilot runs :data:`PILOT_PERIODS` periods (``'lohner'``: a tenth of the
    run, 40 to 200) from 128 bits; the radius is projected as
    ``10^(r_pilot + g (periods - n) - 0.30103 (bits - pilot_bits))`` with ``g`` the pilot's
    growth, and the bits are set for ``10^log_target`` with two decimal digits to spare,
    rounded up to a multiple of 64.  A projection above ``max_bits`` is refused naming
    ``target_radius``.  Shared by :func:`certify` and
    :func:`~precise_impact.solvers.certified.coupled.certify_coupled`."""
    n_pilot = min(periods, PILOT_PERIODS[method])
    if method == "lohner":  # a tenth of the run, at least 40 periods, at most 200
        n_pilot = min(periods, max(40, periods // 10), PILOT_PERIODS[method])
    pilot_bits, failed = 128, ""
    while True:  # a pilot without a proof retries at twice the bits, as the run does
        try:
            res = pilot(n_pilot, pilot_bits)
            break
        except CertificationError as e:
            if 2 * pilot_bits > max_bits:
                raise CertificationError(
                    f"{e} (the pilot of {n_pilot} periods, up to max_bits = {max_bits})"
                ) from None
            failed += f"no proof at {pilot_bits} bits ({e}); "
            pilot_bits *= 2
    g = max(res.growth_digits_per_period(), 0.0)
    r_pilot = res.log10_radii()[-1]
    if not math.isfinite(r_pilot):  # an exact last sample: the pilot's rounding level
        r_pilot = -0.30103 * pilot_bits
    need = r_pilot + g * (periods - n_pilot) - log_target + 2  # two digits to spare
    bits = int(64 * math.ceil(max(pilot_bits, pilot_bits + need / 0.30103) / 64))
    choice = (
        f"automatic: radius growth {g:.3f} digits/period "
        f"(pilot of {n_pilot} periods at {pilot_bits} bits"
        + (f"; {failed[:-2]}" if failed else "")
        + f") -> {bits} bits for radius 1e{log_target:.0f} after {periods} periods"
    )
    if bits > max_bits:
        raise ParameterError(
            "target_radius",
            str(target_radius),
            f"a target reachable within max_bits = {max_bits} (needs ~{bits} bits)",
        )
    return bits, choice


def missed_target(
    choice: str, log10_radius: float, log_target: float, bits: int, max_bits: int
) -> str:
    """Why an automatic run is retried at twice the bits (its largest radius missed the
    target and the doubled bits are allowed); ``''``: the run is kept (given bits, target met,
    or no room to double)."""
    if choice.startswith("given") or log10_radius <= log_target or 2 * bits > max_bits:
        return ""
    return f"; radius 1e{log10_radius:.1f} missed the target at {bits} bits, retried at {2 * bits}"


def doubling(
    attempt: Callable[[int, str], Any],
    bits: int,
    choice: str,
    periods: int,
    max_bits: int,
    log_target: float,
    bar: Progress,
) -> Any:
    """Run ``attempt(bits, choice)`` and retry at twice the bits after a failed proof or a
    missed target, up to ``max_bits``; the result (its ``bits_choice`` the whole story).

    Shared by :func:`certify` and
    :func:`~precise_impact.solvers.certified.coupled.certify_coupled`.
    """
    while True:
        try:
            res = attempt(bits, choice)
            missed = missed_target(choice, res.max_log10_radius(), log_target, bits, max_bits)
            if not missed:
                bar.close()  # the run reported every period; show a throttled last one
                res.bits_choice = choice
                return res
            choice += missed
        except BudgetExceededError:
            bar.close()  # end a line redrawn in place before the one-line refusal
            raise
        except CertificationError as e:
            if 2 * bits > max_bits:
                raise CertificationError(f"{e} (and up to max_bits = {max_bits})") from None
            refusal = out_of_reach(e, bits, periods, max_bits)
            if refusal is not None:
                bar.close()
                raise CertificationError(refusal) from None
            choice += f"; no proof at {bits} bits ({e}), retried at {2 * bits}"
        bits *= 2


def certify(
    params: Any = None,
    periods: int = 300,
    *,
    precision: str = "auto",
    target_radius: Any = "1e-30",
    max_bits: int = 8192,
    progress: bool | None = None,
    max_time: Any = None,
    method: str = "lohner",
    bits: Any = UNSET,
    **param_values: Any,
) -> CertifiedTrajectory:
    """A certified trajectory: every stroboscopic sample and impact enclosed in a proven ball.

    Parameters
    ----------
    params : Params, mapping or None, default ``None``
        The system and initial condition (exact rationals); ``None``: the paper's defaults
        with ``param_values``.
    periods : int, default 300
        Forcing periods (``1 <= periods <= 100000``).
    precision : str, default ``'auto'``
        Working precision of the balls, ``'mp:BITS'`` (``64 <= BITS <= max_bits``).
        ``'auto'`` chooses it: a pilot run at 128 bits (doubled until it is proven, up to
        ``max_bits``) of ``min(periods, 40)`` periods (``'interval'``) or a tenth of the run,
        40 to 200 periods (``'lohner'``), measures the growth of the radius per period,
        and the bits are set so that the last sample's radius is below ``target_radius`` with
        two decimal digits to spare (rounded up to a multiple of 64).
    target_radius : decimal, default ``'1e-30'``
        The radius wanted at every sample when ``precision`` is ``'auto'``
        (``1e-3000 <= target_radius <= 1e-3``).
    max_bits : int, default 8192
        The precision is doubled (from ``bits`` or the automatic choice) after a failed proof
        or a missed target, up to this (``<= 16384``).
    progress : bool or None, default ``None``
        A progress line on stderr (``None``: only when stderr is a terminal).
    max_time : decimal or None, default ``None``
        Time budget in seconds (``1 <= max_time <= 604800``): the estimated cost
        (:func:`~precise_impact.core.budget.estimate_cost`, job ``'certify'``) is checked
        against it before any work (at the given bits, or the pilot's 128 and again at the
        automatic choice), and the run stops once it is spent; ``None``: no budget.
    method : {'lohner', 'interval'}, default ``'lohner'``
        The enclosure carried from sample to sample.  ``'lohner'``: a point plus a matrix
        times a box in a frame re-orthogonalised by QR every period, through the impacts by
        the saltation matrices enclosed over the impact-time balls
        (:mod:`precise_impact.solvers.certified.lohner`); its radius grows at the dynamics'
        own rate (0.116 decimal digits per period at eta = 0.712, the Lyapunov exponent's
        ``LLE T / ln 10``).  ``'interval'``: the two balls of ``x`` and ``v`` carried as they
        are (0.25 digits per period there: the box is wrapped by the flow's rotation every
        period), the scheme of version 0.x.
    bits : int or None
        Deprecated: ``precision='mp:BITS'`` (``None``: ``'auto'``).
    **param_values
        Parameter values replacing those of ``params``.

    Returns
    -------
    CertifiedTrajectory
        Balls of every sample and impact, the bits used and how they were chosen.  Samples are
        right-continuous, as in every engine (``docs/numerics.rst``): a start on the wall
        moving into it (``x0 = x_w``, ``v0 > 0``) is an impact at ``t0``, and sample 0 holds
        the state after it, ``(x_w, -R v0)``.

    Raises
    ------
    ParameterError
        Bad input, before any work.
    OverBudgetError
        The estimated cost is over ``max_time``, before any work.
    BudgetExceededError
        ``max_time`` ran out during the run.
    CertificationError
        No proof up to ``max_bits`` (a tangential contact, chattering, an impact on a sample
        time); the message names the time and the ball.  Also, without doubling on, when the
        radius growth measured over a failed attempt projects more bits than ``max_bits``
        can give (:func:`out_of_reach`).
    OptionalDependencyError
        python-flint is not installed.

    See Also
    --------
    precise_impact.solvers.simulate.simulate : the same trajectory in floating point, unproven.
    precise_impact.solvers.certified.coupled.certify_coupled : the master-slave pair certified.
    precise_impact.analysis.orbits.proof.prove_orbit
        A proven periodic orbit instead of a transient.

    References
    ----------
    .. [1] F. Johansson, "Arb: efficient arbitrary-precision midpoint-radius interval
           arithmetic", IEEE Trans. Comput. 66 (2017) 1281-1292.
    .. [2] R. E. Moore, R. B. Kearfott, M. J. Cloud, *Introduction to Interval Analysis*,
           SIAM 2009, ch. 8 (interval Newton).

    Examples
    --------
    >>> import precise_impact as pi
    >>> ct = pi.certify(pi.Params.make(eta="0.74"), 3)
    >>> type(ct).__name__, ct.periods
    ('CertifiedTrajectory', 3)
    """

    params = params_or_values(params, param_values)
    periods = check_count(periods, "periods", 100_000, minimum=1)
    max_bits = check_count(max_bits, "max_bits", MAX_BITS, minimum=MIN_BITS)
    if bits is not UNSET:  # the 0.2 spelling
        warn_renamed("bits=", "precision=", "certify")
        if bits is not None:
            bits = check_count(bits, "bits", max_bits, minimum=MIN_BITS)
    else:
        bits = certified_bits(precision, max_bits)
    if method not in METHODS:
        raise ParameterError("method", str(method), "'lohner' or 'interval'")
    log_target = check_target(target_radius)
    check_certifiable(params)  # (x0 <= x_w holds for every Params)
    enforce_max_time(max_time, "certify", periods=periods, precision=f"mp:{bits or 128}")
    deadline = Deadline(None if max_time is None else parse_max_time(max_time), "certify")
    choice = "given"
    if bits is None:

        def pilot(n: int, b: int) -> CertifiedTrajectory:
            runs = _run(params, n, b, None, deadline, method)
            return CertifiedTrajectory(params, n, b, "pilot", *runs, 0.0, method)

        bits, choice = choose_bits(pilot, periods, method, log_target, max_bits, target_radius)
        enforce_max_time(max_time, "certify", periods=periods, precision=f"mp:{bits}")
    bar = Progress(periods, "certified periods", enabled=progress)

    def attempt(b: int, why: str) -> CertifiedTrajectory:
        t0 = time.perf_counter()
        samples, impacts = _run(params, periods, b, bar, deadline, method)
        return CertifiedTrajectory(
            params, periods, b, why, samples, impacts, time.perf_counter() - t0, method
        )

    return doubling(attempt, bits, choice, periods, max_bits, log_target, bar)


class CertifiedSolver:
    """The certified engine as a model of the registry (``model='certified'``,
    ``precision='mp:BITS'``).

    Its :class:`~precise_impact.core.trajectory.Trajectory` holds the balls' midpoints in the
    working precision; ``stats['x_rad']``, ``stats['v_rad']`` and ``stats['max_radius']``
    (decimal strings in scientific notation, rounded up: :func:`radius_str`, never 0 for a ball
    of any radius) and ``stats['max_log10_radius']`` (``None`` for exact points) carry the
    proven radii.  Dense output is not offered (``per_period`` must be 0): use
    :func:`certify` for the balls themselves.

    Parameters
    ----------
    bits : int
        Working precision (``MIN_BITS <= bits <= MAX_BITS``).

    See Also
    --------
    precise_impact.solvers.certified.single.certify : the function form.
    precise_impact.solvers.certified.single.CertifiedTrajectory : its result.
    precise_impact.solvers.base.Solver : the protocol it follows.
    """

    model_name = "certified"

    def __init__(self, bits: int) -> None:

        self.bits = check_count(bits, "bits", MAX_BITS, minimum=MIN_BITS)
        self.precision = Precision.parse(f"mp:{self.bits}")

    def solve(self, params: Params, periods: int, *, per_period: int = 0):
        """Certify ``periods`` periods at the solver's bits (see the class docstring).

        Parameters
        ----------
        params : Params
            System and initial condition.
        periods : int
            Forcing periods.
        per_period : int, default 0
            Must be 0 (no dense output).

        Returns
        -------
        Trajectory
            Midpoints of the certified balls, radii in ``stats``.
        """

        if per_period:
            raise ParameterError(
                "per_period", str(per_period), "0 for the certified model (no dense output)"
            )
        r = certify(params, periods, precision=f"mp:{self.bits}", max_bits=self.bits)
        P = self.precision
        mid = lambda b: P.from_fraction(exact_value(b.mid()))  # noqa: E731
        return Trajectory(
            params=params,
            model=self.model_name,
            precision=P,
            tol=None,
            t=P.array([mid(s[1]) for s in r.samples]),
            x=P.array([mid(s[2]) for s in r.samples]),
            v=P.array([mid(s[3]) for s in r.samples]),
            impacts_t=P.array([mid(i[0]) for i in r.impacts]),
            impacts_v_before=P.array([mid(i[1]) for i in r.impacts]),
            impacts_v_after=P.array([mid(i[2]) for i in r.impacts]),
            elapsed_s=r.elapsed_s,
            stats={
                "certified": True,
                "bits": self.bits,
                "x_rad": [radius_str(s[2].rad()) for s in r.samples],
                "v_rad": [radius_str(s[3].rad()) for s in r.samples],
                "max_radius": max_radius_str(b for s in r.samples for b in s[2:]),
                "max_log10_radius": _finite_or_none(r.max_log10_radius()),
            },
        )
