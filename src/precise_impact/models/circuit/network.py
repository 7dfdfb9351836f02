"""The op-amp network of Fig. 2 as equations in volts and seconds, with its effects.

Each stage is built from an :class:`OpAmp` carrying only the effects a scene switched on;
with none, the network is exactly the mechanical eq. (2a) rescaled (``docs/circuit.rst``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from fractions import Fraction
from typing import Any

from precise_impact.models.circuit.effects import (
    opamp_gain,
    opamp_gbw,
    opamp_offset,
    opamp_saturation,
)

__all__ = ["NETWORK_PARS", "OpAmp", "inverting", "integrator", "network_rhs", "opamp_from_effects"]

#: heyoka runtime parameters of the circuit models, in this order.
NETWORK_PARS = (
    "R1",
    "R2",
    "R3",
    "R4",
    "R5",
    "R6",
    "R7",
    "R8",
    "C1",
    "C2",
    "V_A",
    "Omega",
    "V_wall",
)


@dataclasses.dataclass(frozen=True)
class OpAmp:
    """The op-amp effects switched on (``None`` = ideal in that respect)."""

    A0: Fraction | None = None
    v_os: Fraction | None = None
    v_sat: Fraction | None = None
    gbw: Fraction | None = None
    gbw_mode: str = "quasi-static"

    @property
    def ideal(self) -> bool:
        return self.A0 is None and self.v_os is None and self.v_sat is None and self.gbw is None

    @property
    def dynamic(self) -> bool:
        return self.gbw is not None and self.gbw_mode == "dynamic"

    def gain(self) -> Fraction | None:
        """Open-loop DC gain used (the GBW model needs one: 2e5 if opamp_gain is off)."""
        if self.A0 is not None:
            return self.A0
        return Fraction(200000) if self.gbw is not None else None


def opamp_from_effects(effects: Mapping[str, Mapping[str, Any]]) -> OpAmp:
    """Build the :class:`OpAmp` from validated effects (only the ones present)."""
    g = effects.get("opamp_gain")
    o = effects.get("opamp_offset")
    s = effects.get("opamp_saturation")
    b = effects.get("opamp_gbw")
    return OpAmp(
        A0=None if g is None else g["A0"],
        v_os=None if o is None else o["v_os"],
        v_sat=None if s is None else s["v_sat"],
        gbw=None if b is None else b["gbw"],
        gbw_mode="quasi-static" if b is None else b["mode"],
    )


def _num(q):
    return float(q)


def inverting(hy, inputs, Rf, op: OpAmp, target_rate=None, unclamped=None):
    """Algebraic inverting (summing) stage: inputs = [(V_i, R_i)], feedback ``Rf``.

    The ideal output, then each switched-on effect's own transformation
    (:mod:`precise_impact.models.circuit.effects`), in the order offset, finite gain,
    gain-bandwidth, saturation. ``target_rate`` (d/dt of the ideal output) enables the quasi-static
    GBW lag.
    """
    ideal = (
        -Rf * hy.sum([v / r for v, r in inputs])
        if len(inputs) > 1
        else -Rf * inputs[0][0] / inputs[0][1]
    )
    if op.ideal:
        return ideal
    N = 1 + Rf * hy.sum([1 / r for _, r in inputs]) if len(inputs) > 1 else 1 + Rf / inputs[0][1]
    out = ideal
    if op.v_os is not None:
        out = opamp_offset.inverting(out, N, _num(op.v_os))
    if op.gain() is not None:
        out = opamp_gain.inverting(out, N, _num(op.gain()))
    if op.gbw is not None and op.gbw_mode == "quasi-static" and target_rate is not None:
        out = opamp_gbw.inverting(out, N, _num(op.gbw), target_rate)
    if op.v_sat is not None:
        out = opamp_saturation.inverting(hy, out, _num(op.v_sat), unclamped)
    return out


def integrator(hy, V_in, R, C, V_out, op: OpAmp, in_rate=None):
    """Right-hand side ``dV_out/dt`` of an inverting integrator (input ``V_in`` through ``R``)."""
    if op.ideal:
        return -V_in / (R * C)
    vin = V_in
    if op.gbw is not None and op.gbw_mode == "quasi-static" and in_rate is not None:
        vin = opamp_gbw.integrator_input(vin, _num(op.gbw), in_rate)
    if op.v_os is not None:
        vin = opamp_offset.integrator_input(vin, _num(op.v_os))
    if op.gain() is not None:
        return opamp_gain.integrator_rhs(vin, V_out, R, C, _num(op.gain()))
    return -vin / (R * C)


def saturation_events(hy, op: OpAmp, unclamped, fp_type, cooldown):
    """The saturation effect's terminal events (none when it is off)."""
    if op.v_sat is None:
        return []
    return opamp_saturation.events(hy, unclamped, _num(op.v_sat), fp_type, cooldown)


def network_rhs(hy, p: dict, V_s, V_q, op: OpAmp, V_q_of=None):
    """The smooth flow of the network: returns ``(dV_s/dt, dV_q/dt, extras)``.

    ``p`` maps component names to heyoka parameters; ``V_q_of`` optionally replaces
    the U2 stage (the switched-capacitor model supplies its own).  In dynamic-GBW
    mode the caller must use :func:`dynamic_network` instead.
    """
    V3 = p["V_A"] * hy.cos(p["Omega"] * hy.time)
    if op.ideal:
        # eqs. (3)-(4) with ideal op-amps, expanded so that every state and the source
        # appear once, each with its coefficient made of component values:
        # V_q' = R2/(R3 C2) (V3/R1 - (R5/R4) V_q/R6 + V_s/R7), V_s' = -V_q/(R8 C1)
        g = p["R2"] / (p["R3"] * p["C2"])
        dVq = (g / p["R1"]) * V3 - (g * p["R5"] / (p["R4"] * p["R6"])) * V_q + (g / p["R7"]) * V_s
        V_mq = -(p["R5"] / p["R4"]) * V_q
        V_p = -p["R2"] * (V3 / p["R1"] + V_mq / p["R6"] + V_s / p["R7"])
        return (
            -V_q / (p["R8"] * p["C1"]),
            dVq,
            {"V_p": V_p, "V_mq": V_mq, "V3": V3, "unclamped": []},
        )
    rate3 = -p["V_A"] * p["Omega"] * hy.sin(p["Omega"] * hy.time)
    qs = op.gbw is not None and op.gbw_mode == "quasi-static"
    # ideal rates for the quasi-static lag (first order in tau, so ideal rates suffice)
    Vs_rate_ideal = -V_q / (p["R8"] * p["C1"])
    Vmq_ideal = -(p["R5"] / p["R4"]) * V_q
    Vp_ideal = -p["R2"] * (V3 / p["R1"] + Vmq_ideal / p["R6"] + V_s / p["R7"])
    Vq_rate_ideal = -Vp_ideal / (p["R3"] * p["C2"])
    unclamped: list = []
    V_mq = inverting(
        hy,
        [(V_q, p["R4"])],
        p["R5"],
        op,
        target_rate=-(p["R5"] / p["R4"]) * Vq_rate_ideal if qs else None,
        unclamped=unclamped,
    )
    Vmq_rate_ideal = -(p["R5"] / p["R4"]) * Vq_rate_ideal
    Vp_rate_ideal = -p["R2"] * (
        rate3 / p["R1"] + Vmq_rate_ideal / p["R6"] + Vs_rate_ideal / p["R7"]
    )
    V_p = inverting(
        hy,
        [(V3, p["R1"]), (V_mq, p["R6"]), (V_s, p["R7"])],
        p["R2"],
        op,
        target_rate=Vp_rate_ideal if qs else None,
        unclamped=unclamped,
    )
    dVs = integrator(hy, V_q, p["R8"], p["C1"], V_s, op, in_rate=Vq_rate_ideal if qs else None)
    dVq = integrator(hy, V_p, p["R3"], p["C2"], V_q, op, in_rate=Vp_rate_ideal if qs else None)
    return dVs, dVq, {"V_p": V_p, "V_mq": V_mq, "V3": V3, "unclamped": unclamped}


def dynamic_network(hy, p: dict, op: OpAmp):
    """Dynamic-GBW network
    (:func:`~precise_impact.models.circuit.effects.opamp_gbw.dynamic_network`)."""
    return opamp_gbw.dynamic_network(
        hy, p, _num(op.gain()), _num(op.gbw), 0.0 if op.v_os is None else _num(op.v_os)
    )
