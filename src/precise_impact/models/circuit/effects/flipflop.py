"""D flip-flop A1 wired as a toggle (74HC74-class: ~14 ns clock-to-output typ).

It adds its propagation delay between the comparator's edge and the switch command.
"""

from __future__ import annotations

from collections.abc import Mapping
from fractions import Fraction


def delay(settings: Mapping | None) -> Fraction:
    return Fraction(0) if settings is None else settings["delay"]
