"""Forward-mode dual numbers: exact first derivatives through plain arithmetic and the
closed-form flight (:mod:`precise_impact.core.flight` is generic over an ops namespace).

A :class:`Dual` carries a value and its gradient with respect to chosen seeds; every
operation applies the chain rule exactly, so the derivative has the rounding error of the
value's own evaluation (a few ulps), never a step's truncation error (unlike a finite
difference, whose step trades ``h^2`` truncation against ``eps / h`` rounding).
"""

from __future__ import annotations

import contextlib
import math
from typing import Any

import numpy as np

__all__ = ["Dual", "DualOps", "DUAL", "seed", "value", "gradient"]


class Dual:
    """``value + gradient . d``: a number with its exact first derivatives."""

    __slots__ = ("v", "g")

    def __init__(self, v: float, g: np.ndarray) -> None:
        self.v = float(v)
        self.g = g

    # arithmetic ------------------------------------------------------------------------
    def __add__(self, o: Any) -> Dual:
        if isinstance(o, Dual):
            return Dual(self.v + o.v, self.g + o.g)
        return Dual(self.v + float(o), self.g)

    __radd__ = __add__

    def __sub__(self, o: Any) -> Dual:
        if isinstance(o, Dual):
            return Dual(self.v - o.v, self.g - o.g)
        return Dual(self.v - float(o), self.g)

    def __rsub__(self, o: Any) -> Dual:
        return Dual(float(o) - self.v, -self.g)

    def __neg__(self) -> Dual:
        return Dual(-self.v, -self.g)

    def __pos__(self) -> Dual:
        return self

    def __mul__(self, o: Any) -> Dual:
        if isinstance(o, Dual):
            return Dual(self.v * o.v, self.g * o.v + o.g * self.v)
        f = float(o)
        return Dual(self.v * f, self.g * f)

    __rmul__ = __mul__

    def __truediv__(self, o: Any) -> Dual:
        if isinstance(o, Dual):
            q = self.v / o.v
            return Dual(q, (self.g - o.g * q) / o.v)
        f = float(o)
        return Dual(self.v / f, self.g / f)

    def __rtruediv__(self, o: Any) -> Dual:
        q = float(o) / self.v
        return Dual(q, -self.g * (q / self.v))

    def __pow__(self, n: Any) -> Dual:
        n = float(n)
        return Dual(self.v**n, self.g * (n * self.v ** (n - 1)))

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
        return self.v

    def __repr__(self) -> str:
        return f"Dual({self.v!r}, {self.g!r})"


def _exp(x: Any) -> Any:
    if isinstance(x, Dual):
        e = math.exp(x.v)
        return Dual(e, x.g * e)
    return math.exp(x)


def _sqrt(x: Any) -> Any:
    if isinstance(x, Dual):
        r = math.sqrt(x.v)
        return Dual(r, x.g / (2 * r))
    return math.sqrt(x)


def _cos(x: Any) -> Any:
    if isinstance(x, Dual):
        return Dual(math.cos(x.v), x.g * -math.sin(x.v))
    return math.cos(x)


def _sin(x: Any) -> Any:
    if isinstance(x, Dual):
        return Dual(math.sin(x.v), x.g * math.cos(x.v))
    return math.sin(x)


class DualOps:
    """The ops namespace of :mod:`precise_impact.core.flight` for :class:`Dual` (and float)
    numbers."""

    name = "dual"
    exp = staticmethod(_exp)
    sqrt = staticmethod(_sqrt)
    cos = staticmethod(_cos)
    sin = staticmethod(_sin)
    pi = math.pi
    u = 2.0**-53

    @staticmethod
    def cos_sin(x: Any) -> tuple[Any, Any]:
        return _cos(x), _sin(x)

    @staticmethod
    def num(q: Any) -> float:
        return float(q)

    @staticmethod
    def context():
        return contextlib.nullcontext()


DUAL = DualOps()


def seed(values: Any, size: int | None = None, offset: int = 0) -> list[Dual]:
    """Duals of ``values`` seeded in directions ``offset, offset + 1, ...`` of ``size``."""
    values = [float(v) for v in values]
    size = len(values) + offset if size is None else size
    out = []
    for i, v in enumerate(values):
        g = np.zeros(size)
        g[offset + i] = 1.0
        out.append(Dual(v, g))
    return out


def value(x: Any) -> float:
    return x.v if isinstance(x, Dual) else float(x)


def gradient(x: Any, size: int) -> np.ndarray:
    return x.g if isinstance(x, Dual) else np.zeros(size)
