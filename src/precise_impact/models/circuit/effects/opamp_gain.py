"""Finite open-loop DC gain ``A0`` (TL072: 200 V/mV typ).

Inverting stage with noise gain ``N``: ``V_o = V_ideal / (1 + N / A0)``.
Integrator: the virtual ground sits at ``V_os - V_o / A0``, so
``V_o' = -(V_in - V_os + V_o / A0) / (R C (1 + 1/A0))`` (a lossy integrator).
"""

from __future__ import annotations


def inverting(out, N, A0: float):
    return out / (1 + N / A0)


def integrator_rhs(vin, V_out, R, C, A0: float):
    return -(vin + V_out / A0) / (R * C * (1 + 1 / A0))
