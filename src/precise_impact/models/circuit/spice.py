"""ngspice backend: the circuit of the paper's Fig. 2 simulated by a real circuit simulator.

Writes the netlist from the same :class:`~precise_impact.models.circuit.components.Components`,
runs ``ngspice -b`` (>= 39) and maps node voltages back to the oscillator.  The netlist, the
mapping of effects and the ngspice pitfalls it avoids are in ``docs/circuit.rst``.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import shutil
import subprocess
import tempfile
import time as _time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from mpmath import libmp

from precise_impact.core.mpcontext import mp_context
from precise_impact.core.params import check_count, decimal_str, exact
from precise_impact.core.precision import Precision
from precise_impact.core.trajectory import Trajectory
from precise_impact.errors import NgspiceNotFoundError, ParameterError, SpiceError
from precise_impact.models.circuit.components import (
    Components,
    design_and_start,
    dimensionless,
    to_circuit,
    to_mechanical,
)
from precise_impact.models.circuit.effects.catalogue import EFFECTS, validate_effects
from precise_impact.models.circuit.effects.tolerance import (
    E24,
    E96,
    actual_components,
    draw_components,
    e_series_round,
)  # the one implementation

__all__ = [
    "SpiceSolver",
    "spice_netlist",
    "run_spice",
    "draw_components",
    "e_series_round",
    "SpiceResult",
    "SpiceError",
    "NgspiceNotFoundError",
    "find_ngspice",
    "E24",
    "E96",
    "IDEAL_OPAMP_GAIN",
    "IDEAL_TAU",
    "IDEAL_RON",
    "SWITCH_ROFF",
    "IDEAL_GBW",
    "COMPARATOR_WIDTH",
    "DEFAULT_OPTIONS",
    "OUTPUT_FILE",
]

#: Open-loop gain of the ideal op-amps (VCVS), see the module docstring.
IDEAL_OPAMP_GAIN = 1e9
#: Time constant of the comparator and flip-flop lags without a delay effect [s] (latches: 10 ps).
IDEAL_TAU = 1e-10
#: On-resistance of the ideal switches [ohm]: extra damping 2 R_on / R3 = 2e-7.
IDEAL_RON = 1e-3
#: Off-resistance of every switch [ohm]: leak 2/(R_off C2) = 2e-5 1/s vs omega = 1e3 1/s.
SWITCH_ROFF = 1e12
#: GBW [Hz] of the op-amp pole model when ``opamp_saturation`` needs it and there is no
#: ``opamp_gbw``.
IDEAL_GBW = 1e9
#: Comparator tanh width in units of V_unit.
COMPARATOR_WIDTH = 1e-6
#: ``.options`` written into every netlist (ngspice defaults otherwise).
DEFAULT_OPTIONS = {"method": "gear"}
#: Name of the data file ``wrdata`` writes (relative to ngspice's working directory).
OUTPUT_FILE = "spice_out.txt"

_LATCH_W = 0.05  # restoring tanh width of the master's input NOT(ps) [V]
_LATCH_TAU = 1e-11  # tracking time constant of master and slave [s] (IDEAL_TAU / 10)
_EN_W = 0.02  # clock (enable) tanh width [V]
_CLK_LO, _CLK_HI = 0.4, 0.6  # master / slave clock thresholds on cmp [V]
_SW_W = 0.02  # switch-drive tanh width in pol [V]
_INJ_TAU = 1e-8  # shortest lag of the charge-injection pulse [s]
_PARASITIC_C = 5e-12  # node capacitance added with break-before-make [F]
_CLAMP_G = 1e3  # saturation clamp strength [A/V] against the op-amp drive d [A per V]
_CLAMP_K = 1e3  # saturation clamp knee sharpness [1/V] (knee width ~1 mV)


# ================================================================== netlist
def _f(x: Any) -> str:
    """A number for the netlist: 17 significant digits (round-trips float64)."""
    return repr(float(x) + 0.0) if not isinstance(x, str) else x


def _check_inputs(components, effects, periods, tmax, x0, v0, t0):
    if not isinstance(components, Components):
        raise ParameterError(
            "components", type(components).__name__, "a Components (see nominal_components)"
        )
    eff = validate_effects(effects, "spice")
    periods = check_count(periods, "periods", 10**6)
    if periods < 1:
        raise ParameterError("periods", periods, "an integer >= 1")
    tm = exact("tmax", tmax)
    if tm <= 0:
        raise ParameterError("tmax", decimal_str(tm), "TMAX of .tran must be > 0 s")
    x0q, v0q, t0q = exact("x0", x0), exact("v0", v0), exact("t0", t0)
    x_w = -components.V_wall / components.V_unit
    if x0q > x_w:
        raise ParameterError(
            "x0",
            decimal_str(x0q),
            f"the start must not lie inside the wall: x0 <= x_w = {decimal_str(x_w)}",
        )
    period_s = 2 * math.pi / float(components.Omega)
    if float(tm) > period_s:
        raise ParameterError(
            "tmax", decimal_str(tm), f"TMAX must not exceed one forcing period ({period_s:.6g} s)"
        )
    return eff, periods, tm, x0q, v0q, t0q


def _timing(eff: dict, comp: Components | None = None) -> dict:
    """Time constants and switch values the effects map to (module docstring table).

    ``settle``: time after a polarity crossing by which the op-amps have settled
    (10 time constants of the slowest closed loop; U1's noise gain
    ``1 + R2 (1/R1 + 1/R6 + 1/R7)`` is the largest).
    """
    out = {
        "tau_c": IDEAL_TAU,
        "hysteresis": 0.0,
        "tau_ff": IDEAL_TAU,
        "ron": IDEAL_RON,
        "bbm": 0.0,
        "charge_injection": 0.0,
        "slew": None,
    }
    if "comparator" in eff:
        d = float(eff["comparator"]["delay"])
        out["tau_c"] = d / math.log(2) if d > 0 else IDEAL_TAU
        out["hysteresis"] = float(eff["comparator"]["hysteresis"])
    if "flipflop" in eff:
        d = float(eff["flipflop"]["delay"])
        out["tau_ff"] = d / math.log(2) if d > 0 else IDEAL_TAU
    sw = eff.get("switch")
    if sw is not None:
        out["ron"] = float(sw["ron"]) if sw["ron"] > 0 else IDEAL_RON
        out["bbm"] = float(sw["bbm"])
        out["charge_injection"] = float(sw["charge_injection"])
        out["slew"] = float(sw["slew_rate"]) if out["bbm"] > 0 else None
    gbw = float(eff["opamp_gbw"]["gbw"]) if "opamp_gbw" in eff else None
    if gbw is None and out["slew"] is not None:
        gbw = float(EFFECTS["opamp_gbw"].settings["gbw"].default)
    elif gbw is None and "opamp_saturation" in eff:
        gbw = IDEAL_GBW
    # time after the polarity crossing by which U2's output has settled
    settle = 10 * out["tau_ff"] + 10 * out["bbm"] / math.log(2) + 2 * out["bbm"]
    if out["charge_injection"]:
        out["tau_inj"] = max(_INJ_TAU, 5 * (out["tau_ff"] + out["bbm"] / math.log(2)))
        settle += 10 * out["tau_inj"]
    if gbw is not None:
        noise_gain = 2.0
        if comp is not None:
            noise_gain = max(
                noise_gain, float(1 + comp.R2 * (1 / comp.R1 + 1 / comp.R6 + 1 / comp.R7))
            )
        settle += 10 * noise_gain / (2 * math.pi * gbw)
    out["settle"] = settle
    return out


def _opamp(
    name: str, out: str, inn: str, eff: dict, ic_out: float, slew: float | None = None
) -> list[str]:
    """Lines of one op-amp (inverting input ``inn``, output ``out``)."""
    lines = []
    gain = float(eff["opamp_gain"]["A0"]) if "opamp_gain" in eff else IDEAL_OPAMP_GAIN
    if "opamp_offset" in eff:
        inp = f"{name}_np"
        lines.append(f"V{name}OS {inp} 0 DC {_f(eff['opamp_offset']['v_os'])}")
    else:
        inp = "0"
    sat = float(eff["opamp_saturation"]["v_sat"]) if "opamp_saturation" in eff else None
    gbw = float(eff["opamp_gbw"]["gbw"]) if "opamp_gbw" in eff else None
    if gbw is None and slew is None and sat is None:
        lines.append(f"E{name} {out} 0 {inp} {inn} {_f(gain)}")
        return lines
    # single-pole macro-model: C dV_o/dt = d - V_o/A with C = 1/(2 pi GBW) [F, with 1 A/V]
    # (open loop A/(1 + s A/(2 pi GBW))); slew: the input stage saturates at
    # SR/(2 pi GBW) volts; saturation: a stiff soft clamp of V_o at +-v_sat.
    if gbw is not None:
        gbw_used = gbw
    elif slew is not None:
        gbw_used = float(EFFECTS["opamp_gbw"].settings["gbw"].default)
    else:
        gbw_used = IDEAL_GBW
    d = f"(V({inp})-V({inn}))" if inp != "0" else f"(-V({inn}))"
    node = f"{name}_o"
    drive = f"{d} - V({node})/{_f(gain)}"
    if slew is not None:
        k = slew / (2 * math.pi * gbw_used)
        drive = f"{_f(k)}*tanh(({drive})/{_f(k)})"
    if sat is not None:
        drive += (
            f" - {_f(_CLAMP_G)}*(softplus(V({node})-{_f(sat)}) - softplus(-V({node})-{_f(sat)}))"
        )
    lines.append(f"B{name}G 0 {node} I = {drive}")
    lines.append(f"C{name}P {node} 0 {_f(1 / (2 * math.pi * gbw_used))} IC={_f(ic_out)}")
    lines.append(f"E{name} {out} 0 {node} 0 1")
    return lines


def spice_netlist(
    components: Components,
    effects: Mapping[str, Mapping[str, Any]] | None,
    periods: int,
    tmax: Any,
    x0: Any = 0,
    v0: Any = 0,
    t0: Any = 0,
    *,
    options: Mapping[str, Any] | None = None,
    output_file: str = OUTPUT_FILE,
) -> str:
    """The ngspice netlist of the paper's Fig. 2 for ``components`` and ``effects``.

    Parameters
    ----------
    components : Components
        Design values (e.g. ``nominal_components(Params.make(eta='0.74'))``).
    effects : mapping or None
        ``{effect: {setting: value}}`` from the catalogue
        (:data:`precise_impact.models.circuit.effects.catalogue.EFFECTS`), model ``'spice'``;
        ``None`` / ``{}`` is the ideal circuit.  Mapping: module docstring.
    periods : int >= 1
        Forcing periods ``2 pi / Omega`` simulated (TSTOP = periods * period).
    tmax : decimal/number > 0, <= one period
        TMAX (largest time step) of ``.tran`` [s].
    x0, v0 : decimal/number, default 0
        Dimensionless initial state; ``V_s = -x0 V_unit``,
        ``V_q = v0 omega R8 C1 V_unit`` (inverse of ``to_mechanical``), given as
        capacitor ``IC=`` values and ``.ic`` node voltages with ``.tran ... uic``.
        ``x0 <= x_w = -V_wall / V_unit``.
    t0 : decimal/number, default 0
        Dimensionless start time: SPICE time 0 is ``tau = t0``, the source is
        ``V3 = V_A cos(Omega time + eta t0)`` (a cosine from t0).
    options : mapping or None, default None
        Extra/overriding ``.options`` (name -> value; ``None`` value writes the bare
        flag); merged over :data:`DEFAULT_OPTIONS` (``method=gear``); every other
        option keeps its ngspice default (reltol 1e-3, abstol 1e-12, vntol 1e-6,
        trtol 7, maxord 2).  ``method=trap`` rings on the logic nodes (pitfall 6).
    output_file : str, default :data:`OUTPUT_FILE`
        File ``wrdata`` writes (columns: time, V(s), V(q), V(pol), V(cmp)).

    Returns
    -------
    str
        The netlist text.

    Raises
    ------
    ParameterError
        Everything is validated before any text is built.

    Notes
    -----
    With ``tolerance`` the netlist uses :func:`draw_components`' values; the
    initial state is mapped with the *design* values (what an experimenter
    would set).
    """
    eff, periods, tm, x0q, v0q, t0q = _check_inputs(components, effects, periods, tmax, x0, v0, t0)
    opts = _netlist_options(options)
    if not re.fullmatch(r"[A-Za-z0-9_.\-]+", output_file):
        raise ParameterError(
            "output_file", output_file, "a plain file name (letters, digits, _ . -)"
        )

    comp = actual_components(components, eff)
    c = {
        n: float(getattr(comp, n))
        for n in (
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
            "V_unit",
        )
    }
    ic = _initial_values(components, c, x0q, v0q, t0q)
    tm_ = _timing(eff)
    L = _netlist_header(components, comp, eff, ic)
    L += _analogue_section(c, eff, ic, tm_["slew"])
    L += _comparator_section(c, tm_, ic["cmp0"])
    L += _switch_section(c, tm_)
    L += _analysis_section(periods, tm, ic, opts, output_file)
    return _wrap("\n".join(L)) + "\n"


def _netlist_options(options: Mapping[str, Any] | None) -> dict[str, Any]:
    """``.options`` of the netlist: :data:`DEFAULT_OPTIONS` with ``options`` checked and merged."""
    opts = dict(DEFAULT_OPTIONS)
    for k, v in (options or {}).items():
        if not isinstance(k, str) or not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", k):
            raise ParameterError("options", k, "an ngspice option name")
        if v is not None and (
            isinstance(v, bool) or not re.fullmatch(r"[A-Za-z0-9_.+\-]+", str(v))
        ):
            raise ParameterError(
                f"options.{k}", v, "a number or a word (no spaces), or None for a flag"
            )
        opts[k] = v
    return opts


def _initial_values(components: Components, c: dict, x0q, v0q, t0q) -> dict[str, float]:
    """Time scales, the source phase and the node voltages at the start (``omega``, ``eta``,
    ``period_s``, ``phi``, ``vs0``, ``vq0``, ``vmq0``, ``vp0``, ``cmp0``)."""
    omega = float(components.omega())
    eta = float(components.Omega) / omega
    period_s = 2 * math.pi / c["Omega"]
    _, vs0, vq0 = to_circuit(components, 0.0, float(x0q), float(v0q), omega)
    mp = mp_context(libmp.dps_to_prec(40))  # this thread's own: the global one is shared
    phi = float(  # eta t0 = Omega t0 / omega, rounded once
        mp.mpf(components.Omega.numerator)
        / components.Omega.denominator
        * mp.mpf(t0q.numerator)
        / t0q.denominator
        / components.omega(40)
    )
    vmq0 = -c["R5"] / c["R4"] * vq0
    vp0 = -c["R2"] * (c["V_A"] * math.cos(phi) / c["R1"] + vmq0 / c["R6"] + vs0 / c["R7"])
    x0f = float(x0q)
    cmp0 = 1.0 if x0f >= float(-components.V_wall / components.V_unit) and float(v0q) > 0 else 0.0
    return {
        "omega": omega,
        "eta": eta,
        "period_s": period_s,
        "phi": phi,
        "vs0": vs0,
        "vq0": vq0,
        "vmq0": vmq0,
        "vp0": vp0,
        "cmp0": cmp0,
    }


def _netlist_header(components: Components, comp: Components, eff: dict, ic: dict) -> list[str]:
    """The comment header (effects, design and drawn values, time scales) and ``softplus``."""
    L: list[str] = []
    a = L.append
    a("* precise_impact: electronic impact oscillator (Denysenko, Balcerzak, Dabrowski, Fig. 2)")
    a(
        "* generated by precise_impact.models.circuit.spice; effects: "
        f"{', '.join(sorted(eff)) or 'none (ideal parts)'}"
    )
    a("* design: " + ", ".join(f"{k}={v}" for k, v in components.decimal().items()))
    if "tolerance" in eff:
        a("* drawn:  " + ", ".join(f"{k}={v}" for k, v in comp.decimal().items()))
    a(f"* omega = {ic['omega']!r} rad/s, eta = {ic['eta']!r}, period = {ic['period_s']!r} s")
    a("")
    a(f".func softplus(x) = max(x,0) + ln(1+exp(-abs(x)*{_f(_CLAMP_K)}))/{_f(_CLAMP_K)}")
    return L


def _analogue_section(c: dict, eff: dict, ic: dict, slew) -> list[str]:
    """The forcing source V3 and the op-amp stages U1 (sum), U2 and U4 (integrators), U3."""
    phi, vs0, vq0, vmq0, vp0 = ic["phi"], ic["vs0"], ic["vq0"], ic["vmq0"], ic["vp0"]
    L: list[str] = []
    a = L.append
    a("* ---- forcing source V3 = V_A cos(Omega t + eta t0)")
    a(f"B3 v3 0 V = {_f(c['V_A'])}*cos({_f(c['Omega'])}*time + {_f(phi)})")
    a("* ---- U1 summing amplifier: V_p = -R2 (V3/R1 + V_mq/R6 + V_s/R7)")
    a(f"R1 v3 n1 {_f(c['R1'])}")
    a(f"R6 mq n1 {_f(c['R6'])}")
    a(f"R7 s n1 {_f(c['R7'])}")
    a(f"R2 n1 p {_f(c['R2'])}")
    L += _opamp("U1", "p", "n1", eff, vp0)
    a("* ---- U2 integrator: V_q' = -V_p/(R3 C2); C2 between ca and cb, reversed by U6/U7")
    a(f"R3 p n2 {_f(c['R3'])}")
    a(f"C2 ca cb {_f(c['C2'])} IC={_f(-vq0)}")
    L += _opamp("U2", "q", "n2", eff, vq0, slew=slew)
    a("* ---- U3 inverter: V_mq = -(R5/R4) V_q")
    a(f"R4 q n3 {_f(c['R4'])}")
    a(f"R5 n3 mq {_f(c['R5'])}")
    L += _opamp("U3", "mq", "n3", eff, vmq0)
    a("* ---- U4 integrator: V_s' = -V_q/(R8 C1)")
    a(f"R8 q n4 {_f(c['R8'])}")
    a(f"C1 n4 s {_f(c['C1'])} IC={_f(-vs0)}")
    L += _opamp("U4", "s", "n4", eff, vs0)
    return L


def _comparator_section(c: dict, tm_: dict, cmp0: float) -> list[str]:
    """U5 (the comparator, with hysteresis if set) and A1 (the toggle flip-flop driving pol)."""
    tau_c, hyst, tau_ff = tm_["tau_c"], tm_["hysteresis"], tm_["tau_ff"]
    vu = c["V_unit"]
    L: list[str] = []
    a = L.append
    a("* ---- U5 comparator: cmp -> 1 when V_s < V_wall (x > x_w); smooth, output pole tau_c")
    w = _f(COMPARATOR_WIDTH * vu)
    if hyst:
        a(
            "* hysteresis as a gated set/reset cell (no positive feedback: one solution at any "
            "step size)"
        )
        a(
            f"BU5 0 cmp I = 0.5*(1+tanh(({_f(c['V_wall'] - hyst / 2)}-V(s))/{w}))*(1-V(cmp))"
            f" - 0.5*(1+tanh((V(s)-{_f(c['V_wall'] + hyst / 2)})/{w}))*V(cmp)"
        )
    else:
        a(f"BU5 0 cmp I = 0.5*(1+tanh(({_f(c['V_wall'])}-V(s))/{w})) - V(cmp)")
    a(f"CU5 cmp 0 {_f(tau_c)} IC={_f(cmp0)}")
    a("* ---- A1 toggle flip-flop: master-slave gated track/hold cells, clock = cmp")
    a(f".func lreg(v) = 0.5*(1+tanh((v-0.5)/{_LATCH_W}))")
    a(
        "* non-overlapping clocks: master tracks NOT ps while cmp < 0.4, slave tracks m "
        "while cmp > 0.6"
    )
    a(f"BA1M 0 m I = 0.5*(1+tanh(({_CLK_LO}-V(cmp))/{_EN_W}))*(1-lreg(V(ps))-V(m))")
    a(f"CA1M m 0 {_f(_LATCH_TAU)} IC=1")
    a(f"BA1S 0 ps I = 0.5*(1+tanh((V(cmp)-{_CLK_HI})/{_EN_W}))*(V(m)-V(ps))")
    a(f"CA1S ps 0 {_f(_LATCH_TAU)} IC=0")
    a("* flip-flop output pol = ps through the lag tau_ff (clock-to-output delay)")
    a("BA1D 0 pol I = V(ps)-V(pol)")
    a(f"CA1D pol 0 {_f(tau_ff)} IC=0")
    return L


def _switch_section(c: dict, tm_: dict) -> list[str]:
    """U6/U7, the analogue switches driven from pol: on-resistance, break-before-make with its
    parasitic capacitances, charge injection."""
    ron, bbm, qinj = tm_["ron"], tm_["bbm"], tm_["charge_injection"]
    L: list[str] = []
    a = L.append
    a("* ---- U6/U7 analogue switches, all driven from the one node pol")
    lon, lmid, loff = math.log(ron), math.log(c["R3"]), math.log(SWITCH_ROFF)
    a(
        f".func lnr(u) = u > 0 ? {_f(lmid)}-{_f(lmid - lon)}*tanh(u) : "
        f"{_f(lmid)}+{_f(loff - lmid)}*tanh(-u)"
    )
    if bbm > 0:
        a(
            "* break-before-make: pold = pol lagged by bbm/ln2; a pair conducts only when pol and "
            "pold agree"
        )
        a("BBM 0 pold I = V(pol)-V(pold)")
        a(f"CBM pold 0 {_f(bbm / math.log(2))} IC=0")
        a(
            f"* parasitic {_PARASITIC_C:g} F on U2's input and C2's terminals: the open-loop gap "
            "has time constants"
        )
        a(f"CPN2 n2 0 {_f(_PARASITIC_C)}")
        a(f"CPCA ca 0 {_f(_PARASITIC_C)}")
        a(f"CPCB cb 0 {_f(_PARASITIC_C)}")
        ua = f"min(0.5-V(pol),0.5-V(pold))/{_SW_W}"
        ub = f"min(V(pol)-0.5,V(pold)-0.5)/{_SW_W}"
    else:
        ua = f"(0.5-V(pol))/{_SW_W}"
        ub = f"(V(pol)-0.5)/{_SW_W}"
    a(f"BU6A n2 ca I = (V(n2)-V(ca))*exp(-lnr({ua}))")
    a(f"BU6B q cb I = (V(q)-V(cb))*exp(-lnr({ua}))")
    a(f"BU7A n2 cb I = (V(n2)-V(cb))*exp(-lnr({ub}))")
    a(f"BU7B q ca I = (V(q)-V(ca))*exp(-lnr({ub}))")
    if qinj:
        tau_inj = tm_["tau_inj"]
        a("* charge injection: Q per toggle into U2's virtual ground, after the switches settled:")
        a("* pinj = pol lagged by tau_inj, current Q |pinj'| integrates to exactly Q per toggle")
        a("BINJD 0 pinj I = V(pol)-V(pinj)")
        a(f"CINJD pinj 0 {_f(tau_inj)} IC=0")
        a(f"BINJ 0 n2 I = {_f(qinj)}*abs(V(pol)-V(pinj))/{_f(tau_inj)}")
    return L


def _analysis_section(periods: int, tm, ic: dict, opts: dict, output_file: str) -> list[str]:
    """Breakpoints at the sample times, ``.ic``, ``.options``, ``.tran`` and the control block."""
    period_s, vs0, vq0, vmq0, vp0, cmp0 = (
        ic["period_s"],
        ic["vs0"],
        ic["vq0"],
        ic["vmq0"],
        ic["vp0"],
        ic["cmp0"],
    )
    L: list[str] = []
    a = L.append
    a("* ---- breakpoints at the stroboscopic sample times k 2 pi/Omega")
    pts = " ".join(f"{_f(k * period_s)} 0" for k in range(periods + 1))
    a("VBRK brk 0 PWL(" + pts + ")")
    a("")
    a(
        f".ic V(s)={_f(vs0)} V(q)={_f(vq0)} V(mq)={_f(vmq0)} V(p)={_f(vp0)} V(ca)=0 "
        f"V(cb)={_f(vq0)} V(cmp)={_f(cmp0)} V(pol)=0 V(ps)=0 V(m)=1"
    )
    a(".options " + " ".join(k if v is None else f"{k}={v}" for k, v in opts.items()))
    tstop = periods * period_s
    a(f".tran {_f(min(float(tm), period_s / 100))} {_f(tstop)} 0 {_f(tm)} uic")
    a(".control")
    a("set wr_singlescale")
    a("option numdgt=17")
    a("run")
    a(f"wrdata {output_file} V(s) V(q) V(pol) V(cmp)")
    a("quit 0")
    a(".endc")
    a(".end")
    return L


def _wrap(text: str, width: int = 1000) -> str:
    """Split long lines with SPICE '+' continuation lines."""
    out = []
    for line in text.split("\n"):
        while len(line) > width:
            cut = line.rfind(" ", 0, width)
            if cut <= 0:
                break
            out.append(line[:cut])
            line = "+ " + line[cut + 1 :]
        out.append(line)
    return "\n".join(out)


# ================================================================== running
@dataclasses.dataclass
class SpiceResult:
    """What :func:`run_spice` returns.

    Attributes
    ----------
    components : Components
        The design values passed in (the mapping to mechanical variables uses these).
    used_components : Components
        The values in the netlist (``draw_components`` output with ``tolerance``).
    effects : dict
        Validated effects ``{name: {setting: exact value}}``.
    periods : int
    tmax : float
        TMAX of ``.tran`` [s].
    t, x, v : numpy float64 arrays, length periods + 1
        Stroboscopic samples at ``tau = t0 + k 2 pi / eta`` (dimensionless).
    t_s : numpy array
        The same sample times in circuit seconds (SPICE time).
    impacts_t : numpy array
        Dimensionless times at which the polarity node ``pol`` crossed 1/2 (the
        C2 reversal), linear interpolation between accepted points.
    impacts_x : numpy array
        x at those times (``impacts_x - x_w`` is the wall overshoot).
    impacts_v_before, impacts_v_after : numpy arrays
        v just before / after each reversal, both extrapolated linearly to the
        polarity crossing: before from the last two accepted points before the
        comparator output rose through 1/2, after from the first two points at
        least a settling time after the crossing (10 flip-flop lags + 10 bbm lags
        + 2 bbm + 10 charge-injection lags + 10 noise-gain/(2 pi GBW) with an
        op-amp pole).  ``-v_after/v_before`` is
        the circuit's effective restitution coefficient.
    dense_t, dense_x, dense_v : numpy arrays or None
        Every accepted time point (only with ``dense=True``).
    elapsed_s : float
        Wall time of the ngspice subprocess.
    netlist : str
    stats : dict
        ``points`` (accepted time points), ``sample_max_offset_s``,
        ``sample_interpolated``, ``parse_s``, ``ngspice_version``.
    """

    components: Components
    used_components: Components
    effects: dict
    periods: int
    tmax: float
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    t_s: np.ndarray
    impacts_t: np.ndarray
    impacts_x: np.ndarray
    impacts_v_before: np.ndarray
    impacts_v_after: np.ndarray
    elapsed_s: float
    netlist: str
    dense_t: np.ndarray | None = None
    dense_x: np.ndarray | None = None
    dense_v: np.ndarray | None = None
    stats: dict = dataclasses.field(default_factory=dict)

    @property
    def n_impacts(self) -> int:
        return len(self.impacts_t)

    def plot(self, path: str | os.PathLike | None = None, units: str = "dimensionless"):
        """Phase portrait and ``x(t)`` of the run (:meth:`Trajectory.plot
        <precise_impact.core.trajectory.Trajectory.plot>` of :meth:`to_trajectory`); with
        ``units='circuit'`` in the seconds and volts of :attr:`components`.

        Returns
        -------
        matplotlib.figure.Figure
        """
        return self.to_trajectory().plot(path, units=units, components=self.components)

    def to_trajectory(self, params=None):
        """A :class:`~precise_impact.Trajectory` (model ``'spice'``, float64).

        ``params`` defaults to ``dimensionless(components)`` (needs a rational omega).
        """
        if params is None:
            params = dimensionless(
                self.components, x0=self.stats["x0"], v0=self.stats["v0"], t0=self.stats["t0"]
            )
        return Trajectory(
            params=params,
            model="spice",
            precision=Precision.parse("float64"),
            tol=None,
            t=self.t,
            x=self.x,
            v=self.v,
            impacts_t=self.impacts_t,
            impacts_v_before=self.impacts_v_before,
            impacts_v_after=self.impacts_v_after,
            dense_t=self.dense_t,
            dense_x=self.dense_x,
            dense_v=self.dense_v,
            elapsed_s=self.elapsed_s,
            stats=dict(self.stats),
        )


def _extrapolate(ts, ys, i0: int, i1: int, t: float) -> float:
    """Linear extrapolation through points i0, i1 to time t."""
    if i1 == i0 or ts[i1] == ts[i0]:
        return float(ys[i1])
    return float(ys[i1] + (ys[i1] - ys[i0]) * (t - ts[i1]) / (ts[i1] - ts[i0]))


def find_ngspice(executable: str | None = None) -> str:
    """The path of the ngspice executable (``executable`` or ``ngspice`` on ``PATH``).

    Raises
    ------
    NgspiceNotFoundError
        It is not there: one line naming ngspice and how to install it.
    """
    exe = shutil.which(executable or "ngspice")
    if exe is None:
        raise NgspiceNotFoundError(
            "the spice model needs the ngspice circuit simulator (>= 39), and "
            f"{executable or 'ngspice'!r} is not on PATH; install it with: apt-get install ngspice"
        )
    return exe


def run_spice(
    components: Components,
    effects: Mapping[str, Mapping[str, Any]] | None,
    periods: int,
    tmax: Any = 10e-6,
    x0: Any = 0,
    v0: Any = 0,
    timeout: float = 600,
    workdir: str | os.PathLike | None = None,
    *,
    t0: Any = 0,
    options: Mapping[str, Any] | None = None,
    dense: bool = False,
    executable: str | None = None,
) -> SpiceResult:
    """Simulate the circuit with ``ngspice -b`` and map it to the dimensionless oscillator.

    Parameters
    ----------
    components, effects, periods
        As :func:`spice_netlist`.
    tmax : decimal, default ``1e-5``
        In seconds: TMAX of ``.tran``.  Error and run time against TMAX:
        ``benchmarks/results/spice_tmax.md``.
    x0, v0 : decimal, default 0
        Dimensionless initial state, as :func:`spice_netlist`.
    timeout : float > 0, default 600 s
        Wall-time limit of the ngspice subprocess (:class:`SpiceError` when hit).
    workdir : path or None, default None
        Directory for the netlist (``circuit.cir``), the log (``ngspice.log``) and
        the data file (kept); ``None``: a temporary directory, removed afterwards.
    t0 : decimal, default 0
        Dimensionless start time, as :func:`spice_netlist`.
    options : mapping or None, default ``None``
        Extra ``.options``, as :func:`spice_netlist`.
    dense : bool, default False
        Also return every accepted time point (``dense_t/x/v``).
    executable : str or None, default None
        The ngspice program (``None``: ``ngspice`` on ``PATH``).

    Returns
    -------
    SpiceResult
        Samples at ``t0 + k 2 pi/eta`` (``k = 0..periods``) mapped with
        :func:`to_mechanical` (design values), impact times from the polarity node,
        ``elapsed_s`` (ngspice wall time) and the netlist.

    Raises
    ------
    ParameterError
        Bad input, before any work.
    NgspiceNotFoundError
        No ngspice (``apt-get install ngspice``).
    SpiceError
        ngspice failed or timed out.
    """
    netlist = spice_netlist(components, effects, periods, tmax, x0, v0, t0, options=options)
    eff, periods, tm, x0q, v0q, t0q = _check_inputs(components, effects, periods, tmax, x0, v0, t0)
    if (
        isinstance(timeout, bool)
        or not isinstance(timeout, (int, float))
        or not (timeout > 0 and math.isfinite(timeout))
    ):
        raise ParameterError("timeout", timeout, "seconds > 0")
    exe = find_ngspice(executable)
    if workdir is None:
        with tempfile.TemporaryDirectory(prefix="precise_impact_spice_") as tmp:
            return _run(
                exe, netlist, Path(tmp), components, eff, periods, tm, x0q, v0q, t0q, timeout, dense
            )
    wd = Path(workdir)
    wd.mkdir(parents=True, exist_ok=True)
    return _run(exe, netlist, wd, components, eff, periods, tm, x0q, v0q, t0q, timeout, dense)


def _run(
    exe, netlist, wd: Path, components, eff, periods, tm, x0q, v0q, t0q, timeout, dense
) -> SpiceResult:
    """Run ngspice on ``netlist`` in ``wd`` and map its output to the mechanical system."""
    proc, out, elapsed = _execute(exe, netlist, wd, periods, tm, timeout)
    t_parse = _time.perf_counter()
    raw = np.fromfile(out, sep=" ")
    if raw.size == 0 or raw.size % 5:
        raise SpiceError(
            f"ngspice output {out} unreadable ({raw.size} numbers, expected a multiple of 5)"
        )
    data = raw.reshape(-1, 5)
    ts, vs, vq, pol, cmp_ = data.T
    parse_s = _time.perf_counter() - t_parse

    omega = float(components.omega())
    period_s = 2 * math.pi / float(components.Omega)
    t0f = float(t0q)
    tk, idx, off, interpolated = _sample_points(ts, periods, period_s)
    vs_k, vq_k = vs[idx].copy(), vq[idx].copy()
    if interpolated:
        vs_k = np.interp(tk, ts, vs)
        vq_k = np.interp(tk, ts, vq)
    # ngspice does not write t = 0 under 'uic' (dctran.c dumps only CKTtime > 0):
    # sample 0 is the initial condition written into the netlist.
    _, vs_k[0], vq_k[0] = to_circuit(components, 0.0, float(x0q), float(v0q), omega)
    tau_k, x_k, v_k = to_mechanical(components, tk, vs_k, vq_k, omega)
    t_imp, x_imp, v_b, v_a = _impacts(components, eff, omega, ts, vs, vq, pol, cmp_)

    version = ""
    m = re.search(r"ngspice-(\S+)", proc.stdout + proc.stderr)
    if m:
        version = m.group(1)
    res = SpiceResult(
        components=components,
        used_components=actual_components(components, eff),
        effects=eff,
        periods=periods,
        tmax=float(tm),
        t=tau_k + t0f,
        x=x_k,
        v=v_k,
        t_s=tk,
        impacts_t=omega * t_imp + t0f,
        impacts_x=x_imp,
        impacts_v_before=np.asarray(v_b, dtype=float),
        impacts_v_after=np.asarray(v_a, dtype=float),
        elapsed_s=elapsed,
        netlist=netlist,
        stats={
            "points": int(len(ts)),
            "sample_max_offset_s": float(off.max()),
            "sample_interpolated": interpolated,
            "parse_s": parse_s,
            "ngspice_version": version,
            "x0": x0q,
            "v0": v0q,
            "t0": t0q,
        },
    )
    if dense:
        dt, dx, dv = to_mechanical(components, ts, vs, vq, omega)
        res.dense_t, res.dense_x, res.dense_v = dt + t0f, dx, dv
    return res


def _execute(exe, netlist, wd: Path, periods, tm, timeout):
    """Write the netlist, run ngspice in batch mode and check it: the process, the output file
    and the run time."""
    cir = wd / "circuit.cir"
    out = wd / OUTPUT_FILE
    log = wd / "ngspice.log"
    cir.write_text(netlist)
    if out.exists():
        out.unlink()
    t_start = _time.perf_counter()
    try:
        proc = subprocess.run(
            [exe, "-b", cir.name], cwd=wd, capture_output=True, text=True, timeout=timeout
        )
    except subprocess.TimeoutExpired as e:
        raise SpiceError(
            f"ngspice did not finish within timeout={timeout} s (TMAX={float(tm)!r} s, {periods} "
            "periods)"
        ) from e
    elapsed = _time.perf_counter() - t_start
    log.write_text(proc.stdout + "\n---- stderr ----\n" + proc.stderr)
    errors = [
        ln
        for ln in (proc.stdout + proc.stderr).splitlines()
        if re.search(r"\berror\b|too small|aborted", ln, re.I)
    ]
    if proc.returncode != 0 or not out.exists() or errors:
        tail = "\n".join((proc.stdout + proc.stderr).strip().splitlines()[-15:])
        raise SpiceError(f"ngspice failed (exit {proc.returncode}); log tail:\n{tail}")
    return proc, out, elapsed


def _sample_points(ts, periods: int, period_s: float):
    """The output points at the stroboscopic times ``k period_s`` (a time point sits on every
    breakpoint): the times, their indices, the offsets and how many are off the grid."""
    tk = np.arange(periods + 1) * period_s
    idx = np.clip(np.searchsorted(ts, tk), 0, len(ts) - 1)
    idx[0] = 0
    # prefer the last point at that time (right-continuous if duplicated)
    hit = np.abs(ts[idx] - tk)
    alt = np.clip(idx - 1, 0, len(ts) - 1)
    use_alt = np.abs(ts[alt] - tk) < hit
    idx = np.where(use_alt, alt, idx)
    while True:
        nxt = np.clip(idx + 1, 0, len(ts) - 1)
        same = (nxt != idx) & (ts[nxt] == ts[idx])
        if not same.any():
            break
        idx = np.where(same, nxt, idx)
    off = np.abs(ts[idx] - tk)
    off[0] = 0.0
    interpolated = int(np.sum(off > 1e-12 * period_s))
    return tk, idx, off, interpolated


def _impacts(components, eff, omega: float, ts, vs, vq, pol, cmp_):
    """The impacts (pol crossing 1/2): times [s], positions and the mechanical velocities
    before and after."""
    s = pol - 0.5
    cross = np.nonzero((s[:-1] < 0) != (s[1:] < 0))[0]
    frac = s[cross] / (s[cross] - s[cross + 1])
    t_imp = ts[cross] + frac * (ts[cross + 1] - ts[cross])
    vs_imp = vs[cross] + frac * (vs[cross + 1] - vs[cross])
    _, x_imp, _ = to_mechanical(components, t_imp, vs_imp, np.zeros_like(vs_imp), omega)
    rises = np.nonzero((cmp_[:-1] < 0.5) & (cmp_[1:] >= 0.5))[0]
    settle = _timing(eff, components)["settle"]
    vb, va = [], []
    for n, i in enumerate(cross):
        # before: the last two points before the comparator output rose through 1/2,
        # extrapolated to the crossing time; after: two points >= settle after it,
        # extrapolated back (the free flight is smooth there)
        j = rises[rises <= i]
        jb = int(j[-1]) if len(j) else int(i)
        k0 = max(jb - 1, 0)
        vb.append(_extrapolate(ts, vq, k0, jb, t_imp[n]))
        ja = int(np.searchsorted(ts, t_imp[n] + settle, side="left"))
        ja = min(max(ja, int(i) + 1), len(ts) - 2)
        va.append(_extrapolate(ts, vq, ja, ja + 1, t_imp[n]))
    _, _, v_b = to_mechanical(
        components, 0.0, np.zeros(len(vb)), np.asarray(vb, dtype=float), omega
    )
    _, _, v_a = to_mechanical(
        components, 0.0, np.zeros(len(va)), np.asarray(va, dtype=float), omega
    )
    return t_imp, x_imp, v_b, v_a


class SpiceSolver:
    """The ngspice model as a :class:`~precise_impact.solvers.base.Solver`.

    Parameters
    ----------
    effects : mapping or None, default ``None``
        Effects to switch on (names and settings as in the effect catalogue).
    tmax : float, default ``10e-6``
        TMAX of ``.tran`` in seconds (error and run time against TMAX:
        ``benchmarks/results/spice_tmax.md``).
    timeout : float, default 600
        Wall-time limit of one ngspice run in seconds.
    executable : str or None, default ``None``
        The ngspice binary (``None``: ``ngspice`` on PATH).

    See Also
    --------
    precise_impact.models.circuit.opamp.CircuitSolver : the same circuit in Python.
    precise_impact.errors.NgspiceNotFoundError : raised without ngspice.

    Notes
    -----
    ngspice computes in float64, so ``precision`` is always float64.  ``solve``
    raises :class:`~precise_impact.errors.NgspiceNotFoundError` (an
    :class:`~precise_impact.errors.OptionalDependencyError`) when ngspice is missing.
    """

    model_name = "spice"

    def __init__(
        self,
        effects: Mapping[str, Mapping[str, Any]] | None = None,
        tmax: Any = 10e-6,
        timeout: float = 600,
        executable: str | None = None,
    ) -> None:

        self.precision = Precision.parse("float64")
        self.effects = validate_effects(effects, "spice")
        self.tmax, self.timeout, self.executable = tmax, timeout, executable

    def solve(
        self,
        params,
        periods: int,
        *,
        per_period: int = 0,
        x0: Any = None,
        v0: Any = None,
        t0: Any = None,
    ) -> Trajectory:
        """Run ngspice for ``periods`` forcing periods; returns a float64
        :class:`~precise_impact.Trajectory`.

        Parameters
        ----------
        params : Params or Components
            The system (nominal design realising ``Params``) or a design of your own.
        periods : int
            Forcing periods.
        per_period : int, default 0
            ``> 0``: also return every accepted ngspice time point as dense output.
        x0, v0, t0 : decimal or None, default ``None``
            Dimensionless initial condition overriding the one of ``params``.

        Returns
        -------
        Trajectory
            Stroboscopic samples read out of the node voltages (float64) and the impacts
            detected at the comparator.

        Raises
        ------
        ParameterError
            Bad input, before any work.
        NgspiceNotFoundError
            ngspice is not installed (``apt-get install ngspice``).
        SpiceError
            ngspice failed or timed out.
        """
        design, x0, v0, t0 = design_and_start(params, x0, v0, t0)
        res = run_spice(
            design,
            self.effects,
            periods,
            tmax=self.tmax,
            x0=x0,
            v0=v0,
            t0=t0,
            timeout=self.timeout,
            dense=per_period > 0,
            executable=self.executable,
        )
        return res.to_trajectory()
