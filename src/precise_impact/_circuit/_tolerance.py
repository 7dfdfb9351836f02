"""Component tolerances: E-series nominal values and seeded Monte Carlo draws.

Resistors are rounded to the E96 series (1 % parts), capacitors to E24 (5 % parts),
then each part is drawn uniformly within +-tolerance of its nominal value from a
seeded generator (numpy PCG64), so a scene's draw is reproducible.  IEC 60063
defines the series.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any, Mapping

import numpy as np

from ._components import Components

__all__ = ["E24", "E96", "e_series_round", "draw_components"]

E24 = (10, 11, 12, 13, 15, 16, 18, 20, 22, 24, 27, 30, 33, 36, 39, 43, 47, 51, 56, 62, 68, 75, 82, 91)
E96 = (100, 102, 105, 107, 110, 113, 115, 118, 121, 124, 127, 130, 133, 137, 140, 143, 147, 150, 154, 158,
       162, 165, 169, 174, 178, 182, 187, 191, 196, 200, 205, 210, 215, 221, 226, 232, 237, 243, 249, 255,
       261, 267, 274, 280, 287, 294, 301, 309, 316, 324, 332, 340, 348, 357, 365, 374, 383, 392, 402, 412,
       422, 432, 442, 453, 464, 475, 487, 499, 511, 523, 536, 549, 562, 576, 590, 604, 619, 634, 649, 665,
       681, 698, 715, 732, 750, 768, 787, 806, 825, 845, 866, 887, 909, 931, 953, 976)

_RESISTORS = ("R1", "R2", "R3", "R4", "R5", "R6", "R7", "R8")
_CAPACITORS = ("C1", "C2")


def e_series_round(value: Fraction, series: tuple[int, ...]) -> Fraction:
    """The series value nearest to ``value`` in log scale (exact rational)."""
    if value <= 0:
        raise ValueError("E-series values are positive")
    digits = len(str(series[0]))  # 2 for E24, 3 for E96
    decade = math.floor(math.log10(float(value))) - (digits - 1)
    best, best_err = None, math.inf
    for d in (decade - 1, decade, decade + 1):
        for m in series:
            cand = Fraction(m) * Fraction(10) ** d
            err = abs(math.log(float(cand) / float(value)))
            if err < best_err:
                best, best_err = cand, err
    return best


def draw_components(comp: Components, settings: Mapping[str, Any]) -> Components:
    """E-series nominal values, then one seeded draw within the tolerances.

    ``settings``: ``resistor_pct`` (E96 when <= 1 %, else E24), ``capacitor_pct`` (E24),
    ``seed``.  A tolerance of 0 keeps the E-series nominal value.  Draws are uniform
    in ``[1 - tol, 1 + tol]`` and rounded to 1e-6 relative (exact rationals).
    """
    rng = np.random.Generator(np.random.PCG64(int(settings.get("seed", 0))))
    r_tol = Fraction(settings.get("resistor_pct", 1)) / 100
    c_tol = Fraction(settings.get("capacitor_pct", 5)) / 100
    new = {}
    for names, tol, series in ((_RESISTORS, r_tol, E96 if r_tol <= Fraction(1, 100) else E24), (_CAPACITORS, c_tol, E24)):
        for n in names:
            nominal = e_series_round(getattr(comp, n), series)
            u = Fraction(round(rng.uniform(-1.0, 1.0) * 10**6), 10**6)
            new[n] = nominal * (1 + tol * u)
    return comp.replace(**new)
