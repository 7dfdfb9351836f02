"""Input offset voltage ``V_os`` at each op-amp's non-inverting input (TL072: 3 mV typ).

Inverting stage: the output gains ``V_os N`` (``N`` = noise gain ``1 + R_f sum G_i``).
Integrator: the capacitor integrates ``(V_in - V_os) / R`` instead of ``V_in / R``.
"""

from __future__ import annotations


def inverting(out, N, v_os: float):
    return out + v_os * N


def integrator_input(vin, v_os: float):
    return vin - v_os
