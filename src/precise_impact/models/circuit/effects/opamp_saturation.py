"""Output saturation at ``+-v_sat`` (TL072 at +-15 V supplies: +-13.5 V typ).

Clips the algebraic stages (U1, U3) with heyoka's ``select``; because heyoka picks
the branch of ``select`` once per Taylor step, :func:`events` adds terminal events
that end a step exactly where an unclipped output meets a rail.  The integrators
(U2, U4) are not clipped in the ODE models (for the paper's parameters they stay far
inside the rails; a clipped integrator loses its virtual ground, which the ngspice
netlist models) and the dynamic-GBW mode does not clip.
"""

from __future__ import annotations


def clamp(hy, v, v_sat: float):
    """``min(max(v, -v_sat), v_sat)``."""
    return hy.select(hy.gt(v, v_sat), v_sat + 0 * v, hy.select(hy.lt(v, -v_sat), -v_sat + 0 * v, v))


def inverting(hy, out, v_sat: float, unclamped=None):
    if unclamped is not None:
        unclamped.append(out)
    return clamp(hy, out, v_sat)


def _continue(ta, d_sgn) -> bool:
    return True


def events(hy, unclamped, v_sat: float, fp_type, cooldown):
    """Terminal events at ``unclamped = +-v_sat`` (the step ends at the kink)."""
    return [
        hy.t_event(e - lvl, callback=_continue, fp_type=fp_type, cooldown=cooldown)
        for e in unclamped
        for lvl in (v_sat, -v_sat)
    ]
