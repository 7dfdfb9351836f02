"""Component tolerances: E-series nominal values and seeded Monte Carlo draws.

Written once; the op-amp network, the switched-capacitor model, the coupled circuit
and the ngspice netlist all draw their parts here.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from decimal import Decimal
from fractions import Fraction
from typing import Any

import numpy as np

from precise_impact.core.params import decimal_str, exact
from precise_impact.errors import ParameterError
from precise_impact.models.circuit.components import Components
from precise_impact.models.circuit.effects.catalogue import validate_effects

__all__ = ["actual_components", "E24", "E96", "e_series_round", "draw_components"]

# IEC 60063 value tables
E24 = (
    10,
    11,
    12,
    13,
    15,
    16,
    18,
    20,
    22,
    24,
    27,
    30,
    33,
    36,
    39,
    43,
    47,
    51,
    56,
    62,
    68,
    75,
    82,
    91,
)
E96 = (
    100,
    102,
    105,
    107,
    110,
    113,
    115,
    118,
    121,
    124,
    127,
    130,
    133,
    137,
    140,
    143,
    147,
    150,
    154,
    158,
    162,
    165,
    169,
    174,
    178,
    182,
    187,
    191,
    196,
    200,
    205,
    210,
    215,
    221,
    226,
    232,
    237,
    243,
    249,
    255,
    261,
    267,
    274,
    280,
    287,
    294,
    301,
    309,
    316,
    324,
    332,
    340,
    348,
    357,
    365,
    374,
    383,
    392,
    402,
    412,
    422,
    432,
    442,
    453,
    464,
    475,
    487,
    499,
    511,
    523,
    536,
    549,
    562,
    576,
    590,
    604,
    619,
    634,
    649,
    665,
    681,
    698,
    715,
    732,
    750,
    768,
    787,
    806,
    825,
    845,
    866,
    887,
    909,
    931,
    953,
    976,
)
_SERIES = {"E24": (E24, 10), "E96": (E96, 100)}
_RESISTORS = ("R1", "R2", "R3", "R4", "R5", "R6", "R7", "R8")
_CAPACITORS = ("C1", "C2")


def e_series_round(value: Any, series: str = "E96") -> Fraction:
    """The nearest value of ``series`` ('E96' or 'E24'), nearest in log scale, exact.

    Source: IEC 60063 value tables (:data:`E96`, :data:`E24`).
    """
    if series not in _SERIES:
        raise ParameterError("series", series, "one of E96, E24")
    q = exact("value", value)
    if q <= 0:
        raise ParameterError("value", decimal_str(q), "must be > 0")
    table, scale = _SERIES[series]
    k = math.floor(math.log10(q.numerator) - math.log10(q.denominator))
    best, best_d = None, None
    for dec in (k - 1, k, k + 1):
        for m in table:
            cand = Fraction(m, scale) * (Fraction(10) ** dec)
            d = abs(math.log(cand.numerator / cand.denominator * q.denominator / q.numerator))
            if best_d is None or d < best_d - 1e-15:
                best, best_d = cand, d
    return best


def draw_components(
    components: Components, settings: Mapping[str, Any] | None = None
) -> Components:
    """Realised part values: E-series nominal, then a seeded draw within tolerance.

    Keywords (``settings``, the ``tolerance`` effect's table; missing keys take the
    catalogue defaults of :mod:`precise_impact.models.circuit.effects.catalogue`):

    * ``resistor_pct`` (default 1 %): R1-R8 are rounded to the nearest **E96**
      value (the 1 % series), then multiplied by ``1 + resistor_pct/100 * u``.
    * ``capacitor_pct`` (default 5 %): C1, C2 are rounded to the nearest **E24**
      value (the 5 % series), then multiplied by ``1 + capacitor_pct/100 * u``.
    * ``seed`` (default 0): ``u`` are ``numpy.random.default_rng(seed).uniform(-1, 1)``
      drawn in the fixed order R1..R8, C1, C2 (ten draws always, so a part's draw
      does not depend on another's tolerance).  Uniform within the band, as
      LTspice's ``mc(value, tol)``.

    Drawn values are rounded to 6 significant digits and kept exact.  V_A, Omega,
    V_wall and V_unit (sources, not parts) are unchanged.  The paper's nominal
    design (10 kOhm, 100 kOhm, 100 nF) is in both series, so with zero
    percentages this returns the components unchanged.
    """
    vals = validate_effects({"tolerance": dict(settings or {})}, "spice")["tolerance"]
    rng = np.random.default_rng(int(vals["seed"]))
    u = rng.uniform(-1.0, 1.0, size=len(_RESISTORS) + len(_CAPACITORS))
    out = {}
    for i, name in enumerate(_RESISTORS + _CAPACITORS):
        is_r = name.startswith("R")
        nominal = e_series_round(getattr(components, name), "E96" if is_r else "E24")
        pct = vals["resistor_pct"] if is_r else vals["capacitor_pct"]
        factor = 1 + float(pct) / 100 * float(u[i])
        drawn = nominal * Fraction(Decimal(f"{factor:.12g}"))
        out[name] = Fraction(Decimal(f"{float(drawn):.6g}")) if pct else nominal
    return components.replace(**out)


def actual_components(design: Components, effects: Mapping[str, Mapping[str, Any]]) -> Components:
    """The components a model simulates: ``design``, or its tolerance draw if that effect is on.

    Parameters
    ----------
    design : Components
        The design values.
    effects : mapping
        Validated effects of the model (only ``'tolerance'`` matters here).

    Returns
    -------
    Components
        ``draw_components(design, effects["tolerance"])`` or ``design`` itself.
    """
    t = effects.get("tolerance")
    return design if t is None else draw_components(design, t)
