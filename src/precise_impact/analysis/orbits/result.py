"""The periodic orbit result type, shared by the Newton finder and the closed forms."""

from __future__ import annotations

import dataclasses
import math

from precise_impact.core.params import Params
from precise_impact.core.result import ResultMixin

__all__ = ["PeriodicOrbit"]


@dataclasses.dataclass
class PeriodicOrbit(ResultMixin):
    """A periodic orbit of the stroboscopic map and its Floquet multipliers.

    Attributes
    ----------
    params : Params
        The system (its ``t0`` is the stroboscopic phase of :attr:`x`, :attr:`v`).
    period : int
        Forcing periods ``p`` of the orbit (``x(t0 + p T) = x(t0)``, ``T = 2 pi / eta``).
    impacts : int
        Impacts per orbit (``p`` periods).
    t, x, v : float
        A point of the orbit: the state at the stroboscopic time ``t = t0``.
    multipliers : list of complex
        Eigenvalues of the monodromy matrix over ``p`` periods (flow and saltation
        matrices), largest modulus first.
    stable : bool
        Every multiplier inside the unit circle.
    lle : float
        ``ln |mu_max| / (p T)``: the exact largest Lyapunov exponent of the orbit.
    residual : float
        ``max |P^p(z) - z|`` at the returned point (the map evaluated once more).
    iterations : int
        Newton iterations taken (0 for a closed form).
    method : str
        ``'newton'`` or ``'closed form'``.
    precision : str
        The working precision.
    """

    params: Params
    period: int
    impacts: int
    t: float
    x: float
    v: float
    multipliers: list
    stable: bool
    lle: float
    residual: float
    iterations: int = 0
    method: str = "newton"
    precision: str = "float64"

    def _num(self, z):
        """A float, or (multiprecision) a decimal string with every digit of the working precision."""
        if isinstance(z, float):
            return z
        import mpmath

        bits = int(self.precision.split(":")[1]) if self.precision.startswith("mp:") else 53
        return mpmath.nstr(z, int(bits * 0.30103) + 2, strip_zeros=False)

    def to_dict(self) -> dict:
        """The CLI's ``--json`` object: ``params``, ``period``, ``impacts``, ``state``,
        ``multipliers`` (``[re, im]`` pairs), ``stable``, ``lle``, ``residual``,
        ``iterations``, ``method``, ``precision``."""
        return {
            "params": self.params.decimal(),
            "period": self.period,
            "impacts": self.impacts,
            "state": {"t": self.t, "x": self._num(self.x), "v": self._num(self.v)},
            "multipliers": [[float(m.real), float(m.imag)] for m in self.multipliers],
            "stable": self.stable,
            "lle": self.lle if math.isfinite(self.lle) else None,
            "residual": self.residual,
            "iterations": self.iterations,
            "method": self.method,
            "precision": self.precision,
        }
