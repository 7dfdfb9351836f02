"""The periodic orbit result type, shared by the Newton finder and the closed forms."""

from __future__ import annotations

import dataclasses
import math

import mpmath

from precise_impact.core.params import Params
from precise_impact.core.result import ResultMixin

__all__ = [
    "PeriodicOrbit",
    "area_preserving",
    "classify",
    "UNDERFLOW",
    "floquet_second_exponent",
    "floquet_resolution",
]


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
        Every multiplier inside the unit circle (asymptotically stable).  False for an
        ``'elliptic'`` orbit.
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
    stability : str
        ``'stable'``, ``'unstable'`` or ``'elliptic'``.  ``'elliptic'`` (neutral) when the
        system conserves area, ``zeta = 0`` and ``R = 1`` (then ``det M = R^(2n)
        exp(-2 zeta p T) = 1`` identically), and the multipliers are a complex pair: both lie
        on the unit circle exactly, so ``stable`` is false (not by rounding) and ``lle`` is
        ``0.0``.  Empty at construction: filled from ``stable``.
    steps : list of float
        Sizes ``max |dz|`` of the Newton steps, in order (float64 first, then the
        multiprecision refinement); their ratios show the quadratic convergence.

    See Also
    --------
    precise_impact.analysis.orbits.newton.find_orbit : returns it.
    precise_impact.analysis.orbits.one_impact.one_impact_orbits : returns a list of them.
    precise_impact.analysis.orbits.proof.ProvenOrbit : the proven counterpart.
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
    stability: str = ""
    steps: list = dataclasses.field(default_factory=list)

    def __post_init__(self) -> None:
        if not self.stability:
            self.stability = "stable" if self.stable else "unstable"

    def _num(self, z):
        """A float (float64: JSON numbers round-trip it exactly), or (multiprecision) a decimal
        string with every digit of the working precision (a JSON number would round it to
        float64)."""
        if isinstance(z, float):
            return z
        bits = int(self.precision.split(":")[1]) if self.precision.startswith("mp:") else 53
        return mpmath.nstr(z, int(bits * 0.30103) + 2, strip_zeros=False)

    def to_dict(self) -> dict:
        """The CLI's ``--json`` object: ``params``, ``period``, ``impacts``, ``state``,
        ``multipliers`` (``[re, im]`` pairs), ``stable``, ``stability``, ``lle``, ``residual``,
        ``iterations``, ``steps``, ``method``, ``precision``.

        ``state.t`` is a number; ``state.x`` and ``state.v`` are JSON numbers in float64 and
        decimal strings at ``mp:BITS`` (every digit of the working precision, which a JSON
        number would round away): ``float()`` or ``mpmath.mpf()`` reads either."""
        return {
            "params": self.params.decimal(),
            "period": self.period,
            "impacts": self.impacts,
            "state": {"t": self.t, "x": self._num(self.x), "v": self._num(self.v)},
            "multipliers": [[float(m.real), float(m.imag)] for m in self.multipliers],
            "stable": self.stable,
            "stability": self.stability,
            "lle": self.lle,  # -inf (R = 0) is "-inf" (ResultMixin: strict JSON)
            "residual": self.residual,
            "iterations": self.iterations,
            "steps": [float(h) for h in self.steps],
            "method": self.method,
            "precision": self.precision,
        }


#: Below this modulus a float64 multiplier has lost bits to underflow (the 2x2 products that
#: make it keep 53 bits above 2^-969 = 2^(-1022 + 53)): its logarithm is then taken from the
#: scaled monodromy instead (``ShootingSystem.floquet_lle``).
UNDERFLOW = 2.0**-969


def floquet_second_exponent(
    lle: float, mu2: float, zeta: float, R: float, impacts: int, pT: float
) -> float:
    """The second Floquet exponent ``ln |mu_2| / (p T)``; from ``|mu_1 mu_2| = |det M| =
    R^(2n) exp(-2 zeta p T)`` (logarithms, exact) when ``|mu_2|`` is below :data:`UNDERFLOW`:
    ``2 n ln R / (p T) - 2 zeta - lle`` (``-inf`` only for a plastic impact, ``R = 0``).
    Before, an underflowed ``mu_2`` gave ``-inf`` (``zeta = 0.999``, ``eta = 0.001``: the
    spectrum ``(-0.999, -inf)`` instead of ``(-0.999, -0.999)``)."""
    if mu2 > UNDERFLOW:
        return math.log(mu2) / pT
    if impacts and R == 0:
        return -math.inf
    return (2 * impacts * math.log(R) if impacts else 0.0) / pT - 2 * zeta - lle


def floquet_resolution(lle: float, pT: float) -> float:
    """The float64 resolution of a Floquet LLE ``ln |mu| / (p T)``: the eigenvalue's rounding,
    ``1e-12 / (p T)`` (``|mu|`` from a float64 2x2 monodromy, generously), floored at two ulps
    of the value: the logarithm and the division each round to half an ulp of their result, so
    a bar below that could not cover the value it is reported with (it matters only where
    ``|ln mu| > ~2000``, e.g. ``zeta p T = 6277``)."""
    return max(1e-12 / pT, 2 * math.ulp(lle)) if math.isfinite(lle) else 1e-12 / pT


def area_preserving(zeta, R, impacts: int) -> bool:
    """``det M = R^(2n) exp(-2 zeta p T)`` is exactly 1 for every orbit: ``zeta = 0`` and
    (``R = 1`` or ``n = 0``).  Then ``det M - 1`` is pure rounding (no Neimark-Sacker test)
    and a complex pair of multipliers lies on the unit circle exactly."""
    return zeta == 0 and (R == 1 or impacts == 0)


def classify(multipliers: list, neutral: bool) -> str:
    """``'stable'``, ``'unstable'`` or ``'elliptic'`` from the multipliers (largest modulus first).

    With ``neutral`` (:func:`area_preserving`) ``det M = 1`` exactly, so the pair is
    complex, on the unit circle, iff ``|tr M| < 2``: ``'elliptic'``; otherwise it is
    ``mu, 1/mu`` with ``|mu| >= 1``: ``'unstable'``.  The decision rests on the trace, which
    rounding moves by ``~eps``, never on ``|mu| - 1``, which is rounding alone."""
    if neutral:
        tr = sum(complex(m) for m in multipliers).real
        return "elliptic" if abs(tr) < 2 else "unstable"
    return "stable" if abs(multipliers[0]) < 1 else "unstable"
