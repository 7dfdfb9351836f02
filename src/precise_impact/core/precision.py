"""Floating-point precisions: float64, longdouble, float128 and heyoka ``real`` (MPFR).

A :class:`Precision` rounds exact rationals once into its number type, converts back to exact
:mod:`mpmath` values and prints round-trip digits.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from fractions import Fraction
from typing import Any

import mpmath
import numpy as np
from mpmath import libmp

from precise_impact.core import flight
from precise_impact.core.clock import sample_times
from precise_impact.core.mpcontext import mp_context
from precise_impact.core.params import check_tol
from precise_impact.errors import ParameterError

__all__ = [
    "Precision",
    "PRECISION_HELP",
    "MAX_MP_BITS",
    "has_quad",
    "quad_or_mp",
    "exact_value",
    "float_down",
    "float_up",
    "log10_fraction",
]

PRECISION_HELP = (
    "one of 'float64', 'longdouble', 'float128', or 'mp:BITS' with an integer 64 <= BITS <= 8192"
)

_LONGDOUBLE_BITS = np.finfo(np.longdouble).nmant + 1

#: Largest multiprecision width.  8192 bits keep ~2466 digits: a chaotic reference at
#: eta = 0.712 (0.13 digits lost per period) stays accurate for ~18000 periods, far past
#: anything a scene or a dataset asks for, while MPFR operations and heyoka's Taylor order
#: (~ digits / 2) grow with the width: beyond it one step takes seconds and a run
#: looks like a hang.
MAX_MP_BITS = 8192


def _real128() -> type:
    """heyoka's quad-precision type, looked up only when float128 is asked for.

    heyoka is built with quad precision only where the platform's compiler has
    ``__float128`` (x86-64 Linux, not macOS or ARM builds): there a float64 run must
    still work, and a float128 request gets a clear refusal.
    """
    import heyoka as hy  # noqa: PLC0415 -- optional: loaded on first use

    t = getattr(hy, "real128", None)
    if t is None:
        raise ParameterError(
            "precision",
            "float128",
            "this heyoka build has no quad precision (heyoka.real128); use 'longdouble' or "
            "'mp:113'",
        )
    return t


def has_quad() -> bool:
    """Whether this heyoka build has quad precision (``heyoka.real128``)."""
    import heyoka as hy  # noqa: PLC0415 -- optional: loaded on first use

    return hasattr(hy, "real128")


def quad_or_mp() -> str:
    """``'float128'`` where heyoka has quad precision, else ``'mp:113'`` (the same 113-bit
    significand, in MPFR).

    For checks that want "about 34 digits" and must run on every platform.
    """
    return "float128" if has_quad() else "mp:113"


@dataclasses.dataclass(frozen=True)
class Precision:
    """A working precision.

    Attributes
    ----------
    name : str
        ``'float64'``, ``'longdouble'``, ``'float128'`` or ``'mp:BITS'``.
    kind : str
        ``'float64'``, ``'longdouble'``, ``'float128'`` or ``'mp'``.
    bits : int
        Significand bits including the implicit one (53, 64 on x86-64, 113, BITS).

    See Also
    --------
    precise_impact.solvers.base.make_solver : a solver at a precision.
    precise_impact.solvers.simulate.simulate : its ``precision`` argument.
    """

    name: str
    kind: str
    bits: int

    # ----------------------------------------------------------------- parsing
    @property
    def ops(self) -> Any:
        """The closed-form flight's arithmetic in this precision
        (:mod:`precise_impact.core.flight`): float64 through :mod:`math`, ``mp:BITS`` through
        mpmath at ``BITS`` in a context of its own (:class:`~precise_impact.core.flight.MpmathOps`:
        safe in concurrent threads; mpmath's process-global precision is never used).

        Raises
        ------
        ParameterError
            For long double and float128, which only heyoka computes in.

        Examples
        --------
        >>> from precise_impact.core.precision import Precision
        >>> Precision.parse("float64").ops.name, Precision.parse("mp:256").ops.prec
        ('float64', 256)
        """
        if self.kind == "float64":
            return flight.FLOAT
        if self.kind == "mp":
            return _mp_ops(self.bits)
        raise ParameterError(
            "precision", self.name, "float64 or mp:BITS for the closed-form flight (heyoka only)"
        )

    @staticmethod
    def parse(spec: str | Precision) -> Precision:
        """Parse a precision string; raise :class:`ParameterError` if unknown."""
        if isinstance(spec, Precision):
            return spec
        if not isinstance(spec, str) or len(spec) > 40:
            raise ParameterError(
                "precision",
                spec if isinstance(spec, str) and len(spec) <= 40 else type(spec).__name__,
                PRECISION_HELP,
            )
        return Precision._parse(spec)

    @staticmethod
    @functools.lru_cache(maxsize=256)
    def _parse(spec: str) -> Precision:
        s = spec.strip().lower()
        if s in ("float64", "double", "f64"):
            return Precision("float64", "float64", 53)
        if s in ("longdouble", "long double", "ld"):
            return Precision("longdouble", "longdouble", _LONGDOUBLE_BITS)
        if s in ("float128", "quad", "f128"):
            return Precision("float128", "float128", 113)
        if s.startswith("mp:"):
            try:
                bits = int(s[3:])
            except ValueError:
                raise ParameterError("precision", spec, PRECISION_HELP) from None
            if bits < 64:
                raise ParameterError(
                    "precision", spec, "multiprecision needs BITS >= 64 ('mp:BITS')"
                )
            if bits > MAX_MP_BITS:
                raise ParameterError(
                    "precision",
                    spec,
                    f"multiprecision needs 64 <= BITS <= {MAX_MP_BITS} ('mp:BITS')",
                )
            return Precision(f"mp:{bits}", "mp", bits)
        raise ParameterError("precision", spec, PRECISION_HELP)

    # --------------------------------------------------------------- constants
    @property
    def fp_type(self) -> Any:
        """The number type heyoka and numpy use for this precision."""
        if self.kind == "float64":
            return np.float64
        if self.kind == "longdouble":
            return np.longdouble
        if self.kind == "float128":
            return _real128()
        import heyoka as hy  # noqa: PLC0415 -- optional: loaded on first use

        return hy.real

    @property
    def heyoka_kwargs(self) -> dict:
        """Keyword arguments selecting this precision in heyoka constructors."""
        kw: dict = {"fp_type": self.fp_type}
        if self.kind == "mp":
            kw["prec"] = self.bits
        return kw

    @property
    def eps_fraction(self) -> Fraction:
        """Machine epsilon 2**(1 - bits), exact."""
        return Fraction(1, 2 ** (self.bits - 1))

    @property
    def eps(self) -> Any:
        """Machine epsilon in this number type."""
        return self.from_fraction(self.eps_fraction)

    def check_tol(self, tol: Any, name: str = "tol") -> Fraction | None:
        """Validate an integrator tolerance for this precision: ``None`` or ``eps <= tol < 1``.

        ``None`` means the precision's epsilon (heyoka's default).  A tolerance below
        epsilon cannot be met in this precision and is refused, naming the range.
        """
        q = check_tol(tol, name)
        if q is not None and q < self.eps_fraction:
            raise ParameterError(
                name,
                str(tol),
                f"{self.name} needs eps = 2^{1 - self.bits} "
                f"(~{float(self.eps_fraction):.3g}) <= {name} < 1",
            )
        return q

    @property
    def eps_float(self) -> float:
        """Machine epsilon as a Python float (for tolerances in tests)."""
        return 2.0 ** (1 - self.bits)

    @property
    def digits(self) -> int:
        """Significant decimal digits that round-trip: ceil(bits log10 2) + 1."""
        return math.ceil(self.bits * math.log10(2)) + 1

    # ------------------------------------------------------------- conversion
    def nan(self) -> Any:
        """Not-a-number of this precision (a value not recorded; ``to_str`` gives ``'nan'``)."""
        if self.kind == "float64":
            return math.nan
        if self.kind == "longdouble":
            return np.longdouble("nan")
        if self.kind == "float128":
            return _real128()("nan")
        import heyoka as hy  # noqa: PLC0415 -- optional: loaded on first use

        return hy.real("nan", self.bits)

    def _from_mpf_exact(self, m: mpmath.mpf) -> Any:
        """Convert an mpf that is already representable in this precision."""
        if self.kind == "float64":
            return float(m)
        # A decimal string with 10 more digits than round-trip needs lies far
        # inside half an ulp of ``m``, so the target's correctly-rounded parser
        # returns ``m`` itself.
        s = libmp.to_str(m._mpf_, self.digits + 10)
        if self.kind == "longdouble":
            return np.longdouble(s)
        import heyoka as hy  # noqa: PLC0415 -- optional: loaded on first use

        if self.kind == "float128":
            return _real128()(s)
        return hy.real(s, self.bits)

    def from_fraction(self, q: Fraction) -> Any:
        """Round an exact rational to this precision once, to nearest."""
        q = Fraction(q)
        return self._from_mpf_exact(
            _mk(libmp.from_rational(q.numerator, q.denominator, self.bits, "n"))
        )

    def from_decimal(self, s: str) -> Any:
        """Round a decimal string to this precision once, to nearest."""
        return self.from_fraction(Fraction(s))

    def from_mpf(self, m: Any) -> Any:
        """Round an mpmath number (any precision, of any mpmath context) to this precision, to
        nearest."""
        # other numbers (float, int, str) read in a context of this thread's own, exactly for
        # floats and ints, not at mpmath's shared global precision
        m = m if hasattr(m, "_mpf_") else mp_context(self.bits + 64).convert(m)
        return self._from_mpf_exact(_mk(libmp.normalize(*m._mpf_, self.bits, "n")))

    def to_mpf(self, x: Any) -> mpmath.mpf:
        """Exact mpmath value of a number of this precision (independent of mp.prec)."""
        if self.kind == "float64":
            return _mk(libmp.from_float(float(x)))
        if self.kind == "longdouble":
            n, d = np.longdouble(x).as_integer_ratio()
            return _mk(libmp.from_rational(n, d, self.bits, "n"))
        # heyoka prints real128/real with round-trip digits; re-parsing at the
        # same number of bits recovers the exact value.
        return _mk(libmp.from_str(str(x), self.bits, "n"))

    def to_fraction(self, x: Any) -> Fraction:
        """Exact rational value of a number of this precision."""
        man, exp = _mpf_man_exp(self.to_mpf(x))
        return Fraction(man) * Fraction(2) ** exp

    def to_str(self, x: Any) -> str:
        """Decimal string with :attr:`digits` significant digits (round-trips exactly)."""
        return libmp.to_str(self.to_mpf(x)._mpf_, self.digits)

    def to_float(self, x: Any) -> float:
        """``x`` rounded once to the nearest float64."""
        if self.kind == "float64":
            return float(x)
        return float(self.to_mpf(x))

    def floats(self, values: Any) -> np.ndarray:
        """An array of this precision rounded to float64, element by element as :meth:`to_float`
        (one rounding to nearest).  float64 and long double convert in numpy (the hardware's
        rounding is that one rounding); the others go through exact mpmath values (reproduce
        --quick spent 18 of its 55 s sending float64 arrays that way)."""
        if values is None:
            return np.zeros(0)
        if self.kind == "float64":
            return np.asarray(values, dtype=float)
        if self.kind == "longdouble":
            return np.asarray(values, dtype=np.longdouble).astype(float)
        if not len(values):
            return np.zeros(0)
        return np.vectorize(self.to_float, otypes=[float])(values)

    def array(self, values: Any) -> np.ndarray:
        """A numpy array of this precision's type (object array for float128 / mp)."""
        values = list(values)
        if self.kind in ("float64", "longdouble"):
            return np.array(values, dtype=self.fp_type)
        arr = np.empty(len(values), dtype=object)
        for i, v in enumerate(values):
            arr[i] = v
        return arr

    def mp_workprec(self, extra_bits: int = 0):
        """Context manager: mpmath working precision = this precision + ``extra_bits``.

        This sets mpmath's process-global precision, shared by every thread; the package
        computes in contexts of its own instead (:func:`precise_impact.core.mpcontext.mp_context`).
        """
        return mpmath.workprec(self.bits + extra_bits)

    def sample_times(self, t0: Fraction, eta: Fraction, periods: int, per_period: int = 1) -> list:
        """Times ``t0 + j * T / per_period``, ``T = 2 pi / eta``, j = 0..periods*per_period.

        Each rounded once to this precision: :func:`precise_impact.core.clock.sample_times`.

        Parameters
        ----------
        t0, eta : Fraction
            Start time and forcing frequency (exact).
        periods : int
            Forcing periods.
        per_period : int, default 1
            Output times per period.

        Returns
        -------
        list
            ``periods * per_period + 1`` numbers of this precision.
        """
        return sample_times(self, t0, eta, periods, per_period)

    def __str__(self) -> str:
        return self.name


@functools.lru_cache(maxsize=32)
def _mp_ops(bits: int) -> Any:
    """One :class:`~precise_impact.core.flight.MpmathOps` a precision (a context costs ~6 ms)."""
    return flight.MpmathOps(bits=bits)


def exact_value(exact_arb: Any) -> Fraction:
    """An exact python-flint arb (a dyadic point, e.g. a midpoint or a radius) as the Fraction
    it is (from ``man_exp()``: no rounding, at any magnitude)."""
    man, exp = exact_arb.man_exp()
    man, exp = int(man), int(exp)
    return Fraction(man * 2**exp) if exp >= 0 else Fraction(man, 2 ** (-exp))


def float_down(q: Fraction) -> float:
    """The largest float64 ``<= q``.  ``float()`` rounds to nearest: an enclosure's ends
    rounded that way can lose the value they enclose (eta = 0.985, p = 2: both ends of the
    LLE interval became one float, 1.1e-19 from the truth).  Rounded outward the float64
    interval is at least as wide as the ball and never narrower than the rounding itself
    (one ulp at most on each side)."""
    f = float(q)
    return math.nextafter(f, -math.inf) if Fraction(f) > q else f


def float_up(q: Fraction) -> float:
    """The smallest float64 ``>= q`` (see :func:`float_down`): a bound stays a bound, and a
    positive value below the float range (a radius of 1e-400) is the smallest subnormal,
    ``5e-324``, never ``0.0`` (which would state exactness)."""
    f = float(q)
    return math.nextafter(f, math.inf) if Fraction(f) < q else f


def log10_fraction(q: Fraction) -> float:
    """``log10 |q|`` of a rational at any magnitude (``-inf`` for 0): from the integers'
    own logarithms, so neither ``q`` nor ``1 / q`` passes through a float (which under- or
    overflows beyond 1e+-308)."""
    if q == 0:
        return -math.inf
    return math.log10(abs(q.numerator)) - math.log10(q.denominator)


def _mk(raw: tuple) -> mpmath.mpf:
    """An mpf from a raw mpmath tuple *without* rounding to the global mp.prec."""
    return mpmath.mp.make_mpf(raw)


def _mpf_man_exp(m: mpmath.mpf) -> tuple[int, int]:
    sign, man, exp, _ = m._mpf_
    return (-man if sign else man), exp
