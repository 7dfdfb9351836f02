"""Forward-mode dual numbers: exact first derivatives through the closed-form flight.

Each operation applies the chain rule exactly, so a derivative carries the rounding of its value
(a few ulps), not a finite difference's ``h^2`` truncation against ``eps / h`` rounding.
:class:`Dual` is float64; :class:`BallDual` carries python-flint balls, enclosing the derivative
over the value's ball (Krawczyk's ``F'(Y)``; Moore, Kearfott, Cloud 2009, sec. 5.4).
"""

from __future__ import annotations

import contextlib
import math
from typing import Any

import numpy as np

from precise_impact.core import flight

__all__ = [
    "Dual",
    "DualOps",
    "DUAL",
    "BallDual",
    "BallDualOps",
    "BALL_DUAL",
    "seed",
    "value",
    "gradient",
]


class Dual:
    """``value + gradient . d``: a number with its exact first derivatives (float64 value,
    gradient a float64 array)."""

    __slots__ = ("v", "g")

    #: The value's arithmetic (an ops namespace of :mod:`precise_impact.core.flight`).
    scalar: Any = flight.FLOAT

    @staticmethod
    def coerce(x: Any) -> Any:
        """A plain number as the value's type."""
        return float(x)

    def __init__(self, v: Any, g: np.ndarray) -> None:
        self.v = self.coerce(v)
        self.g = g

    # arithmetic ------------------------------------------------------------------------
    def __add__(self, o: Any) -> Dual:
        if isinstance(o, Dual):
            return type(self)(self.v + o.v, self.g + o.g)
        return type(self)(self.v + self.coerce(o), self.g)

    __radd__ = __add__

    def __sub__(self, o: Any) -> Dual:
        if isinstance(o, Dual):
            return type(self)(self.v - o.v, self.g - o.g)
        return type(self)(self.v - self.coerce(o), self.g)

    def __rsub__(self, o: Any) -> Dual:
        return type(self)(self.coerce(o) - self.v, -self.g)

    def __neg__(self) -> Dual:
        return type(self)(-self.v, -self.g)

    def __pos__(self) -> Dual:
        return self

    def __mul__(self, o: Any) -> Dual:
        if isinstance(o, Dual):
            return type(self)(self.v * o.v, self.g * o.v + o.g * self.v)
        f = self.coerce(o)
        return type(self)(self.v * f, self.g * f)

    __rmul__ = __mul__

    def __truediv__(self, o: Any) -> Dual:
        if isinstance(o, Dual):
            q = self.v / o.v
            return type(self)(q, (self.g - o.g * q) / o.v)
        f = self.coerce(o)
        return type(self)(self.v / f, self.g / f)

    def __rtruediv__(self, o: Any) -> Dual:
        q = self.coerce(o) / self.v
        return type(self)(q, -self.g * (q / self.v))

    def __pow__(self, n: Any) -> Dual:
        n = float(n)
        return type(self)(self.v**n, self.g * (n * self.v ** (n - 1)))

    def __abs__(self) -> Dual:
        return -self if self.v < 0 else self

    # comparisons on the value (branching code sees the number it would see in float64)
    def __eq__(self, o: Any) -> bool:  # type: ignore[override]
        return self.v == (o.v if isinstance(o, Dual) else o)

    def __ne__(self, o: Any) -> bool:  # type: ignore[override]
        return not self.__eq__(o)

    def __lt__(self, o: Any) -> bool:
        return self.v < (o.v if isinstance(o, Dual) else o)

    def __le__(self, o: Any) -> bool:
        return self.v <= (o.v if isinstance(o, Dual) else o)

    def __gt__(self, o: Any) -> bool:
        return self.v > (o.v if isinstance(o, Dual) else o)

    def __ge__(self, o: Any) -> bool:
        return self.v >= (o.v if isinstance(o, Dual) else o)

    __hash__ = None  # type: ignore[assignment]

    def __float__(self) -> float:
        return float(self.v)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.v!r}, {self.g!r})"


class DualOps:
    """The ops namespace of :mod:`precise_impact.core.flight` for :class:`Dual` (and float)
    numbers: each function applies its chain rule to a dual and the value's arithmetic
    (``dual.scalar``) to a plain number."""

    name = "dual"
    dual: Any = Dual
    pi: Any = math.pi
    u = 2.0**-53

    def exp(self, x: Any) -> Any:
        if isinstance(x, Dual):
            e = x.scalar.exp(x.v)
            return type(x)(e, x.g * e)
        return self.dual.scalar.exp(self.dual.coerce(x))

    def sqrt(self, x: Any) -> Any:
        if isinstance(x, Dual):
            r = x.scalar.sqrt(x.v)
            return type(x)(r, x.g / (2 * r))
        return self.dual.scalar.sqrt(self.dual.coerce(x))

    def cos_sin(self, x: Any) -> tuple[Any, Any]:
        if isinstance(x, Dual):
            c, s = x.scalar.cos_sin(x.v)
            return type(x)(c, x.g * -s), type(x)(s, x.g * c)
        return self.dual.scalar.cos_sin(self.dual.coerce(x))

    def cos(self, x: Any) -> Any:
        return self.cos_sin(x)[0]

    def sin(self, x: Any) -> Any:
        return self.cos_sin(x)[1]

    def num(self, q: Any) -> Any:
        return self.dual.scalar.num(q)

    @staticmethod
    def context():
        return contextlib.nullcontext()


DUAL = DualOps()


class BallDual(Dual):
    """A dual number of python-flint balls: value and gradient (an object array of balls)
    evaluated in ball arithmetic, so the gradient encloses the derivative over the value's
    whole ball. Comparisons are arb's: true only when proven (``==`` only for equal exact
    points)."""

    __slots__ = ()
    scalar: Any = flight.ARB

    @staticmethod
    def coerce(x: Any) -> Any:
        import flint  # noqa: PLC0415 -- optional: loaded on first use

        return x if isinstance(x, flint.arb) else flint.arb(x)


class BallDualOps(DualOps):
    """The ops namespace of :mod:`precise_impact.core.flight` for :class:`BallDual` and arb."""

    name = "arb-dual"
    dual = BallDual
    u = 0.0  # balls carry their own rounding

    @property
    def pi(self) -> Any:  # type: ignore[override]
        import flint  # noqa: PLC0415 -- optional: loaded on first use

        return flint.arb.pi()


BALL_DUAL = BallDualOps()


def seed(values: Any, size: int | None = None, offset: int = 0, dual: type[Dual] = Dual) -> list:
    """Duals of ``values`` seeded in directions ``offset, offset + 1, ...`` of ``size``
    (:class:`Dual`, or ``dual=BallDual`` for balls)."""
    values = [dual.coerce(v) for v in values]
    size = len(values) + offset if size is None else size
    out = []
    for i, v in enumerate(values):
        g: np.ndarray
        if dual is Dual:
            g = np.zeros(size)
            g[offset + i] = 1.0
        else:
            g = np.array([dual.coerce(int(j == offset + i)) for j in range(size)], dtype=object)
        out.append(dual(v, g))
    return out


def value(x: Any) -> float:
    return x.v if isinstance(x, Dual) else float(x)


def gradient(x: Any, size: int) -> np.ndarray:
    return x.g if isinstance(x, Dual) else np.zeros(size)
