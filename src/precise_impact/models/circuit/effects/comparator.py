"""Comparator U5 (LT1394: 7 ns propagation delay typ, no built-in hysteresis).

It trips when ``V_s`` falls to ``V_wall - h/2`` and re-arms when ``V_s`` rises
above ``V_wall + h/2`` (total hysteresis ``h``); its output changes ``delay`` after
the crossing.
"""

from __future__ import annotations

from collections.abc import Mapping
from fractions import Fraction


def thresholds(V_wall: Fraction, settings: Mapping | None) -> tuple[Fraction, Fraction]:
    """``(v_trip, v_rearm)``; both ``V_wall`` when the effect is off."""
    h = Fraction(0) if settings is None else settings["hysteresis"]
    return V_wall - h / 2, V_wall + h / 2


def delay(settings: Mapping | None) -> Fraction:
    return Fraction(0) if settings is None else settings["delay"]
