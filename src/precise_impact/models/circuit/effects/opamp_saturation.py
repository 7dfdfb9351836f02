"""Output saturation at ``+-v_sat`` (TL072 at +-15 V supplies: +-13.5 V typ).

Clips the algebraic stages U1 and U3, with terminal events at the kinks.
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
