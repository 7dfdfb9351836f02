"""Single-pole op-amps: ``A(s) = A0 / (1 + s / w_a)``, ``w_a = 2 pi GBW / A0`` (TL072: 3 MHz).

``quasi-static`` (default) lags each stage by its closed-loop time constant; ``dynamic`` makes
every output a state (stiff).
"""

from __future__ import annotations

import math


def inverting(out, N, gbw: float, target_rate):
    return out - N / (2 * math.pi * gbw) * target_rate


def integrator_input(vin, gbw: float, in_rate):
    return vin - in_rate / (2 * math.pi * gbw)


def dynamic_network(hy, p: dict, A0: float, gbw: float, v_os: float):
    """Every op-amp output a state.

    States: ``V_s, V_q`` (U4, U2 outputs), ``V_p, V_mq`` (U1, U3 outputs), and the
    capacitor voltages ``Vc1 = v-(U4) - V_s``, ``Vc2 = v-(U2) - V_q``; each output obeys
    ``V_o' = w_a (A0 (V_os - v-) - V_o)`` with ``v-`` from its network node.
    """
    V_s, V_q, V_p, V_mq, Vc1, Vc2 = hy.make_vars("V_s", "V_q", "V_p", "V_mq", "Vc1", "Vc2")
    wa = 2 * math.pi * gbw / A0
    V3 = p["V_A"] * hy.cos(p["Omega"] * hy.time)
    g1 = 1 / p["R1"] + 1 / p["R6"] + 1 / p["R7"] + 1 / p["R2"]
    vm1 = (V3 / p["R1"] + V_mq / p["R6"] + V_s / p["R7"] + V_p / p["R2"]) / g1
    vm3 = (V_q / p["R4"] + V_mq / p["R5"]) / (1 / p["R4"] + 1 / p["R5"])
    vm2 = V_q + Vc2
    vm4 = V_s + Vc1

    def out_rate(vo, vm):
        return wa * (A0 * (v_os - vm) - vo)

    rhs = [
        (V_s, out_rate(V_s, vm4)),
        (V_q, out_rate(V_q, vm2)),
        (V_p, out_rate(V_p, vm1)),
        (V_mq, out_rate(V_mq, vm3)),
        (Vc1, (V_q - vm4) / (p["R8"] * p["C1"])),
        (Vc2, (V_p - vm2) / (p["R3"] * p["C2"])),
    ]
    return [V_s, V_q, V_p, V_mq, Vc1, Vc2], rhs
