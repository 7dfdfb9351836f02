"""System parameters as exact rationals, written once for every model and precision.

``0.712`` rounded to float64 is a different system (chaos amplifies the difference), so each
parameter is a :class:`fractions.Fraction` rounded once, correctly, into each precision.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from decimal import Decimal, InvalidOperation
from fractions import Fraction
from typing import Any

import numpy as np

from precise_impact.errors import ParameterError

__all__ = [
    "Params",
    "as_params",
    "params_or_values",
    "exact",
    "exact_grid",
    "check_count",
    "check_tol",
    "PARAM_NAMES",
    "RUNTIME_PARAMS",
    "I_ETA",
    "I_ZETA",
    "I_A",
    "I_R",
    "I_XW",
    "MAX_DIGITS",
    "MAX_EXPONENT",
]

#: Order of the fields, also the order of the CLI flags and of ``--json`` output.
PARAM_NAMES = ("zeta", "a", "eta", "x_w", "R", "x0", "v0", "t0")

#: Parameters that are heyoka runtime parameters (changed without recompiling),
#: in the order of the integrator's ``pars`` vector.  ``R`` only enters the impact
#: callback; it is given the slot *before* ``x_w`` so that heyoka, which sizes the
#: parameter vector by the highest index used in the equations and events,
#: still allocates it.
RUNTIME_PARAMS = ("eta", "zeta", "a", "R", "x_w")
#: Positions of eta, zeta, a, R and x_w in an integrator's runtime-parameter vector
#: (``RUNTIME_PARAMS`` order), looked up once for every event callback.
I_ETA, I_ZETA, I_A, I_R, I_XW = (RUNTIME_PARAMS.index(n) for n in ("eta", "zeta", "a", "R", "x_w"))

# The box in which every precision integrates the system (legal values run; others are
# refused by name).  Taylor coefficients of the forcing grow like eta^k: at eta = 1e20
# float64 overflows within one step (heyoka: non-finite state), so eta is bounded by 1e3,
# three decades past the paper's resonance region, and below by 1e-3 (a forcing period of
# 6283 time units).  Amplitudes, positions and velocities to 1e6, start times to 1e9
# (sample times then keep 6 digits of the period in float64), damping to 1e3
# (overdamped by three decades).
ETA_MIN, ETA_MAX = Fraction(1, 1000), 1000
ZETA_MAX = 1000
STATE_MAX = 10**6
T0_MAX = 10**9

_DEFAULTS = {
    "zeta": "0.05",
    "a": "1",
    "eta": "0.712",
    "x_w": "2",
    "R": "1",
    "x0": "0",
    "v0": "0",
    "t0": "0",
}


#: Longest decimal string accepted for one number (a 5000-digit decimal is refused, not expanded).
MAX_DIGITS = 400

#: Default magnitude range of a number: 0, or 10**-MAX_EXPONENT <= abs(value) <= 10**MAX_EXPONENT.
#: Inside it every value converts to float64 without overflow or underflow (float64 reaches
#: 1.8e308 and 2.2e-308), so no precision sees an infinite or flushed-to-zero parameter.
MAX_EXPONENT = 100


def exact(name: str, value: Any, max_exponent: int = MAX_EXPONENT) -> Fraction:
    """Convert a user value to an exact rational, or raise :class:`ParameterError`.

    The one number parser of the package: every parameter, tolerance, coupling, grid
    bound and component value goes through it.

    Parameters
    ----------
    name : str
        The parameter's name (for the error message).
    value : str, int, float, Fraction, Decimal or numpy scalar
        Decimal strings (``"0.712"``, ``"1e-3"``, ``"102/53"``), ``int``,
        :class:`~fractions.Fraction`, :class:`~decimal.Decimal`, ``float`` and numpy
        integer / floating scalars.  A float is read as the *shortest decimal that
        round-trips to it* (``0.712`` means the decimal 0.712, which is what the user
        typed), not as its binary value.
    max_exponent : int, default :data:`MAX_EXPONENT` (100)
        The value must be 0 or have ``10**-max_exponent <= |value| <= 10**max_exponent``.

    Raises
    ------
    ParameterError
        NaN, infinities, booleans, other types, strings longer than :data:`MAX_DIGITS`
        characters, and magnitudes outside the range.  Sizes and exponents are checked
        *before* any exact arithmetic, so ``'1e999999999'`` is refused at once instead of
        being expanded into a billion-digit integer.
    """
    rng = f"0, or 1e-{max_exponent} <= |{name}| <= 1e{max_exponent}"
    if isinstance(value, (bool, np.bool_)):
        raise ParameterError(name, value, "expected a finite number, got a boolean")
    if isinstance(value, np.integer):
        value = int(value)
    elif isinstance(value, np.floating):
        value = float(value)
    if isinstance(value, Fraction):
        q = value
    elif isinstance(value, int):
        if (
            value.bit_length() > 4 * max_exponent + 4
        ):  # |value| > ~16^max_exponent: refuse before printing it
            raise ParameterError(name, f"<integer of {value.bit_length()} bits>", rng)
        q = Fraction(value)
    elif isinstance(value, float):
        if not math.isfinite(value):
            raise ParameterError(name, value, "every value must be finite (no NaN or inf)")
        q = Fraction(repr(value))
    elif isinstance(value, (str, Decimal)):
        q = _parse_decimal(name, value, max_exponent, rng)
    else:
        raise ParameterError(
            name,
            value,
            f"expected a decimal string, int, Fraction or float, got {type(value).__name__}",
        )
    if q != 0:
        # log2 |q| lies in (e - 1, e + 1): far inside the range no 10**max_exponent is built (a
        # million-digit power cost ~1.5 s a call with max_exponent = 10**6)
        e = q.numerator.bit_length() - q.denominator.bit_length()
        if abs(e) + 2 >= 3 * max_exponent and not (
            Fraction(1, 10**max_exponent) <= abs(q) <= 10**max_exponent
        ):
            raise ParameterError(name, _short(value), rng)
    return q


def _short(value: Any) -> str:
    s = str(value)
    return s if len(s) <= 40 else s[:20] + "..." + s[-10:]


def _parse_decimal(name: str, value: str | Decimal, max_exponent: int, rng: str) -> Fraction:
    """A decimal string, ratio or Decimal -> Fraction, with sizes bounded before expansion."""
    if isinstance(value, Decimal):
        d = value
    else:
        s = value.strip()
        if len(s) > MAX_DIGITS:
            raise ParameterError(name, _short(s), f"at most {MAX_DIGITS} characters")
        if "/" in s:
            num, _, den = s.partition("/")
            a, b = (
                _parse_decimal(name, num, max_exponent, rng),
                _parse_decimal(name, den, max_exponent, rng),
            )
            if b == 0:
                raise ParameterError(name, s, "a ratio p/q needs q != 0")
            return a / b
        try:
            d = Decimal(s)
        except (InvalidOperation, ValueError):
            raise ParameterError(
                name,
                _short(value),
                "expected a decimal number such as '0.712' or a ratio such as '102/53'",
            ) from None
    if not d.is_finite():
        raise ParameterError(name, _short(value), "every value must be finite (no NaN or inf)")
    # adjusted() is the exponent of the leading digit: known without expanding the number.
    if not d.is_zero() and not -max_exponent - 1 <= d.adjusted() <= max_exponent:
        raise ParameterError(name, _short(value), rng)
    return Fraction(d)


def check_count(value: Any, name: str = "periods", maximum: int = 10**8, minimum: int = 0) -> int:
    """Validate a count (periods, points per period ...) given as int, numpy integer or integer
    string.

    Raises :class:`ParameterError` naming ``name`` and the one range
    ``minimum <= name <= maximum`` for anything else (the string's length is bounded
    before it is converted).
    """
    rng = f"an integer with {minimum} <= {name} <= {maximum}"
    if isinstance(value, str):
        s = value.strip()
        if len(s) > 30:
            raise ParameterError(name, _short(s), rng)
        try:
            value = int(s)
        except ValueError:
            raise ParameterError(name, value, rng) from None
    if (
        isinstance(value, (bool, np.bool_))
        or not isinstance(value, (int, np.integer))
        or not minimum <= value <= maximum
    ):
        raise ParameterError(
            name, value if not isinstance(value, int) or value.bit_length() < 200 else "<huge>", rng
        )
    return int(value)


def check_tol(tol: Any, name: str = "tol") -> Fraction | None:
    """Validate an integrator tolerance: ``None`` (the precision's epsilon) or exact
    ``0 < tol < 1``."""
    if tol is None:
        return None
    q = exact(name, tol, max_exponent=3000)  # mp:8192's epsilon is ~1e-2466
    if not 0 < q < 1:
        raise ParameterError(name, str(tol), "tolerance must satisfy 0 < tol < 1")
    return q


def exact_grid(
    lo: Any, hi: Any, n: Any, name: str, minimum: Fraction = Fraction(0), strict: bool = False
) -> list[Fraction]:
    """``n`` exact, evenly spaced values from ``lo`` to ``hi`` (both included, in that order:
    ``hi < lo`` gives a descending grid).

    Errors name ``{name}_min`` (``lo``), ``{name}_max`` (``hi``) or ``n``; both ends must be
    ``>= minimum`` (``> minimum`` when ``strict``), and differ when ``n > 1``.
    """
    lo_q, hi_q = exact(f"{name}_min", lo), exact(f"{name}_max", hi)
    n = check_count(n, "n", 1_000_000, minimum=1)  # the number of {name} values
    for end, q in ((f"{name}_min", lo_q), (f"{name}_max", hi_q)):
        if q < minimum or (strict and q == minimum):
            raise ParameterError(
                end, decimal_str(q), f"must be {'>' if strict else '>='} {decimal_str(minimum)}"
            )
    if hi_q == lo_q and n > 1:
        raise ParameterError(
            f"{name}_max",
            decimal_str(hi_q),
            f"must differ from {name}_min = {decimal_str(lo_q)} (or be equal with n = 1)",
        )
    if n == 1:
        return [lo_q]
    return [lo_q + (hi_q - lo_q) * Fraction(i, n - 1) for i in range(n)]


def decimal_str(q: Fraction) -> str:
    """The exact decimal string of ``q`` if it terminates, else ``'p/q'``."""
    den = q.denominator
    twos = fives = 0
    while den % 2 == 0:
        den //= 2
        twos += 1
    while den % 5 == 0:
        den //= 5
        fives += 1
    if den != 1:
        return f"{q.numerator}/{q.denominator}"
    places = max(twos, fives)
    d = Decimal(q.numerator * 10**places // q.denominator).scaleb(-places)
    s = format(d, "f")
    if "." in s:
        s = s.rstrip("0").rstrip(".")
    return s if s not in ("-0", "") else "0"


@dataclasses.dataclass(frozen=True)
class Params:
    """Parameters of the dimensionless impact oscillator, eq. (2) of the paper.

    ``x'' + 2 zeta x' + x = a cos(eta tau)`` for ``x < x_w``; at ``x = x_w``,
    ``x'(+) = -R x'(-)``.  Initial state ``(x0, v0)`` at time ``t0``.

    Every field is an exact :class:`~fractions.Fraction`; construct with
    :meth:`Params.make`, which validates.  Allowed ranges (checked before any work):

    ===========  ==================================  ============
    name         allowed                             default
    ===========  ==================================  ============
    zeta         0 <= zeta <= 1e3 (damping ratio)    0.05
    a            abs(a) <= 1e6 (forcing amplitude)   1
    eta          1e-3 <= eta <= 1e3 (frequency)      0.712
    x_w          abs(x_w) <= 1e6 (wall position)     2
    R            0 <= R <= 1 (restitution)           1
    x0           <= x_w, abs(x0) <= 1e6              0
    v0           abs(v0) <= 1e6                      0
    t0           abs(t0) <= 1e9 (start time, phase)  0
    ===========  ==================================  ============

    Defaults are the paper's (zeta = 0.05, a = 1, x_w = 2, R = 1, chaotic eta = 0.712).

    See Also
    --------
    precise_impact.solvers.simulate.simulate : integrate from these parameters.
    precise_impact.core.precision.Precision : the arithmetic the engines use.
    precise_impact.core.flow.steady_state : the smooth oscillator's steady state.
    """

    zeta: Fraction
    a: Fraction
    eta: Fraction
    x_w: Fraction
    R: Fraction
    x0: Fraction
    v0: Fraction
    t0: Fraction

    def __post_init__(self) -> None:
        # However a Params is built (make, the constructor, dataclasses.replace), its
        # fields are exact rationals inside their ranges.
        for n in PARAM_NAMES:
            v = getattr(self, n)
            if not isinstance(v, Fraction):
                object.__setattr__(self, n, exact(n, v))
        self.validate()

    @classmethod
    def make(cls, **values: Any) -> Params:
        """Build and validate.  Unknown names are refused; missing ones take defaults.

        Parameters
        ----------
        **values
            Any of ``zeta, a, eta, x_w, R, x0, v0, t0`` as decimal strings, Fractions,
            ints or floats (a float is read as its shortest round-trip decimal); ``None``
            or a missing name takes the paper's default (table above).

        Returns
        -------
        Params
            Exact, validated parameters.

        Raises
        ------
        ParameterError
            An unknown name or a value outside its range.
        """
        unknown = sorted(set(values) - set(PARAM_NAMES))
        if unknown:
            raise ParameterError(
                unknown[0],
                values[unknown[0]],
                f"unknown parameter; known: {', '.join(PARAM_NAMES)}",
            )
        merged = {n: values[n] if values.get(n) is not None else _DEFAULTS[n] for n in PARAM_NAMES}
        return cls(**{n: exact(n, merged[n]) for n in PARAM_NAMES})

    def validate(self) -> None:
        """Check every range; raise :class:`ParameterError` naming the first bad one."""
        if not 0 <= self.zeta <= ZETA_MAX:
            raise ParameterError(
                "zeta",
                decimal_str(self.zeta),
                f"damping ratio must satisfy 0 <= zeta <= {ZETA_MAX}",
            )
        if not ETA_MIN <= self.eta <= ETA_MAX:
            raise ParameterError(
                "eta",
                decimal_str(self.eta),
                f"forcing frequency ratio must satisfy {decimal_str(ETA_MIN)} <= eta <= {ETA_MAX}",
            )
        for n in ("a", "x_w", "x0", "v0"):
            if abs(getattr(self, n)) > STATE_MAX:
                raise ParameterError(n, decimal_str(getattr(self, n)), f"|{n}| <= {STATE_MAX:.0e}")
        if abs(self.t0) > T0_MAX:
            raise ParameterError("t0", decimal_str(self.t0), f"|t0| <= {T0_MAX:.0e}")
        if not (0 <= self.R <= 1):
            raise ParameterError(
                "R", decimal_str(self.R), "restitution coefficient must satisfy 0 <= R <= 1"
            )
        if self.x0 > self.x_w:
            raise ParameterError(
                "x0",
                decimal_str(self.x0),
                f"the start must not lie inside the wall: x0 <= x_w = {decimal_str(self.x_w)}",
            )

    def replace(self, **values: Any) -> Params:
        """A copy with some fields changed (validated).

        Parameters
        ----------
        **values
            Fields to change, as in :meth:`make`.

        Returns
        -------
        Params
            The new parameters.
        """
        d = {n: getattr(self, n) for n in PARAM_NAMES}
        d.update(values)
        return Params.make(**d)

    def decimal(self) -> dict[str, str]:
        """Every field as an exact decimal string.

        Returns
        -------
        dict of str to str
            ``{name: exact decimal string}`` (``'p/q'`` for non-terminating rationals).
        """
        return {n: decimal_str(getattr(self, n)) for n in PARAM_NAMES}

    def __str__(self) -> str:
        return "Params(" + ", ".join(f"{k}={v}" for k, v in self.decimal().items()) + ")"

    @classmethod
    def from_mapping(cls, m: Mapping[str, Any]) -> Params:
        """Build from a mapping ``{name: value}`` (e.g. parsed JSON); see :meth:`make`.

        Parameters
        ----------
        m : Mapping
            Parameter names to values.

        Returns
        -------
        Params
            Exact, validated parameters.

        Raises
        ------
        ParameterError
            ``m`` is not a mapping, or a name or value is refused by :meth:`make`.
        """
        if not isinstance(m, Mapping):
            raise ParameterError("params", type(m).__name__, "a Params or a mapping {name: value}")
        return cls.make(**{str(k): v for k, v in m.items()})


def as_params(value: Any, name: str = "params") -> Params:
    """The one conversion of a user's ``params`` argument: a :class:`Params` (validated
    however it was built), a plain mapping ``{name: value}`` (:meth:`Params.from_mapping`),
    or a :class:`ParameterError` naming ``name``."""
    if isinstance(value, Params):
        value.validate()
        return value
    if isinstance(value, Mapping):
        return Params.from_mapping(value)
    raise ParameterError(name, type(value).__name__, "a Params or a mapping {name: value}")


def params_or_values(params: Any, param_values: Mapping[str, Any]) -> Params:
    """``params`` (as :func:`as_params`) with ``param_values`` replaced, or, when ``params`` is
    ``None``, ``Params.make(**param_values)``: the calling convention of ``simulate`` and the
    orbit finders, written once."""
    if params is None:
        return Params.make(**param_values)
    params = as_params(params)
    return params.replace(**param_values) if param_values else params
