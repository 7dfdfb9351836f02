"""Analog switches U6/U7 reversing C2 (ADG5233-class): ``ron``, ``bbm``, ``charge_injection``."""

from __future__ import annotations

from fractions import Fraction


def coupling(ron: Fraction, R2: Fraction, R3: Fraction) -> Fraction:
    """``k = 2 R_on R2 / R3``: the strength of the R_on feed-through (0 when off)."""
    return 2 * ron * R2 / R3


def vq(pol, V_C, V3, V_s, k, R1, R6, R7, rho):
    """U2's output with ``2 R_on`` in series with C2 (``k`` from :func:`coupling`)."""
    return (-pol * V_C + k * (V3 / R1 + V_s / R7)) / (1 + k * rho / R6)


def break_before_make(V_s, V_q, V_p, t_bbm, slew_rate, R8C1):
    """``V_s`` after the open interval: ``V_q(t) = V_q - s SR t``, ``V_s' = -V_q / (R8 C1)``."""
    s = 1 if V_p > 0 else -1
    return V_s - (V_q * t_bbm - s * slew_rate * t_bbm * t_bbm / 2) / R8C1


def injected_voltage(q_inj: Fraction, C2: Fraction) -> Fraction:
    return q_inj / C2
