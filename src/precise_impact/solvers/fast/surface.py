"""The impact map on the fast engine: impact after impact in one compiled call (float64, numba).

:func:`impact_orbit` iterates ``(phase, v) -> (next phase, next v)`` on the local clock; a run
of short flights into the wall or an undecidable contact ends the call with a status, and the
caller goes on with heyoka (:func:`~precise_impact.analysis.impact_surface.impact_map.impact_map`;
``docs/guide/impact_map.rst``).
"""

from __future__ import annotations

import math
from fractions import Fraction

import numba
import numpy as np

from precise_impact.solvers.fast.control import (
    POLL_PERIODS,
    STATUS_INTERRUPTED,
    STOP_NONE,
    load_flag,
    new_flag,
    run_kernel,
    store_count,
)
from precise_impact.solvers.fast.crossing import JIT
from precise_impact.solvers.fast.dd import dd_period
from precise_impact.solvers.fast.single import (
    FLIGHT_SAMPLES,
    STATUS_BUDGET,
    STATUS_OK,
    STATUS_SLOW_IMPACT,
    STATUS_TEXT,
    _flight,
    _setup,
    rebase,
    sample_time,
    slow_impact,
)

__all__ = ["impact_orbit", "run_impact_orbit", "local_start", "STATUS_TEXT", "STATUS_OK"]

EPS = 2.220446049250313e-16  # float64's machine epsilon (the heyoka watch's floor)

#: The heyoka engine's chattering watch (solvers.heyoka.single._ZenoWatch): a run is a
#: sequence of impacts with the wall force into the wall and a short next flight,
#: ``2 R v / g max(1, eta) <= RUN_FLIGHT``; it rests the mass at speeds below
#: ``sqrt(RUN_FLOOR eps max(1, |a|, |x_w|) g) / R``.
RUN_FLIGHT = 0.1
RUN_FLOOR = 500.0


@numba.njit(**JIT)
def in_run(tc, vc, eta, a, xw, R):
    """``(short, floor)``: the impact ``(tc, vc)`` starts a short flight into the wall (the
    heyoka watch's run), and its speed is below that watch's floor (rest on the wall)."""
    g = a * math.cos(eta * tc) - xw
    if not g > 0.0:
        return False, False
    short = 2.0 * min(R, 1.0) * vc * max(1.0, eta) <= RUN_FLIGHT * g
    floor = vc * R < math.sqrt(RUN_FLOOR * EPS * max(1.0, abs(a), abs(xw)) * g)
    return short or floor, floor


@numba.njit(**JIT)
def local_phase(tc, T, T_lo):
    """``(t / (2 pi / eta)) mod 1`` of the local time ``t`` (whole periods in double-double
    away from the absolute time: the same phase); ``T + T_lo`` the period."""
    q = tc / T
    q = q - q * (T_lo / T)
    return q - math.floor(q)


# long: one compiled loop (numba) over flights and impacts, carrying the local clock, the
# period count and the start of the current run in locals; the flight itself is _flight.
@numba.njit(**JIT)
def impact_orbit(eta, zeta, a, xw, R, t0, base0, v0, n, k_last, out_ph, out_t, out_v, stop, counts):
    """``n`` impacts of the impact map after the impact ``v0`` at local time ``t0`` (absolute
    ``t0 + base0 (T + T_lo)``, :func:`~precise_impact.solvers.fast.single.rebase`).

    ``out_ph, out_t, out_v`` (length ``>= n``) get each impact's phase (from the local clock),
    absolute time and incoming speed.  Returns ``(status, impacts, keep, t, base)``:
    ``impacts`` recorded, of which the first ``keep`` are ordinary for sure: the rest is a run
    of short flights into the wall (the heyoka watch's run) that may end in chattering, so the
    caller goes on from impact ``keep - 1`` (or the start) with the contact rule;
    ``(t, base)`` the local clock of the last impact.  ``STATUS_BUDGET``: no crossing before
    ``k_last`` periods from ``t0``;
    ``STATUS_SLOW_IMPACT``: a run reached the heyoka watch's floor or the engine's
    (:func:`~precise_impact.solvers.fast.single.slow_impact`); ``STATUS_INTERRUPTED``: the
    stop flag ``stop[0]`` was set (polled every ``POLL_PERIODS`` flights, ``counts[0]`` the
    impacts so far).
    """
    P, Q, w, S, err_scale, h_max, v_floor, steps = _setup(eta, zeta, a, xw)
    T, T_lo = dd_period(eta)
    buf = np.empty((FLIGHT_SAMPLES, 6))
    t, x, v, base = t0, xw, -R * v0, 0
    t_imp, base_imp = t0, 0
    n_imp = 0
    keep = 0
    k = 1  # the next sample: t0 + k (T + T_lo), whole periods from the start
    flights = 0
    while n_imp < n:
        flights += 1
        if flights >= POLL_PERIODS:  # publish the progress, look at the stop flag (atomic)
            flights = 0
            store_count(counts, 0, n_imp)
            if load_flag(stop, 0) != STOP_NONE:
                return STATUS_INTERRUPTED, n_imp, keep, t_imp, base_imp + base0
        st, ns, hit, tc, vc, _, _, _, _, _ = _flight(
            t, x, v, t0, T, T_lo, 1, k - base, k_last - base,
            eta, zeta, a, xw, P, Q, w, S, err_scale, h_max, steps, buf,
        )  # fmt: skip
        k += ns
        if st != STATUS_OK:
            return st, n_imp, keep, t_imp, base_imp + base0
        if not hit:
            if k > k_last:
                return STATUS_BUDGET, n_imp, keep, t_imp, base_imp + base0
            # re-anchor at the last sample, its whole periods moved into base
            t, base = rebase(sample_time(t0, T, T_lo, 1, k - 1 - base), t0, T, T_lo, base)
            x, v = buf[ns - 1, 0], buf[ns - 1, 1]
            continue
        short, floor = in_run(tc, vc, eta, a, xw, R)
        if floor or slow_impact(tc, vc, v_floor, eta, zeta, a, xw, R) or (short and R >= 1.0):
            # chattering, sticking, R = 1 bounces on the wall: the contact rule's
            return STATUS_SLOW_IMPACT, n_imp, keep, t_imp, base_imp + base0
        b = base + base0
        out_ph[n_imp] = local_phase(tc, T, T_lo)
        out_t[n_imp] = tc + (b * T + b * T_lo)
        out_v[n_imp] = vc
        n_imp += 1
        if not short:
            keep = n_imp
        t, base = rebase(tc, t0, T, T_lo, base)
        t_imp, base_imp = t, base
        x, v = xw, -R * vc
    store_count(counts, 0, n_imp)
    return STATUS_OK, n_imp, keep, t_imp, base_imp + base0


def local_start(eta: float, t: float | object) -> tuple[float, int]:
    """The absolute time ``t`` (a float or a Fraction) on the local clock: ``(t_local, base)``
    with ``t = t_local + base (T + T_lo)`` exactly up to one rounding of ``t_local``."""
    T, T_lo = dd_period(float(eta))
    period = Fraction(T) + Fraction(T_lo)
    q = Fraction(t)  # type: ignore[arg-type]
    base = max(0, math.floor(q / period))
    return float(q - base * period), int(base)


def run_impact_orbit(
    pars: tuple[float, float, float, float, float],
    t: float,
    base: int,
    v: float,
    n: int,
    k_last: int,
) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, int, int, float, int]:
    """:func:`impact_orbit` for ``pars = (eta, zeta, a, x_w, R)`` from the impact ``v`` at local
    time ``t`` (``base`` whole periods), stoppable by Ctrl-C / SIGTERM
    (:func:`~precise_impact.solvers.fast.control.run_kernel`).

    Returns ``(status, phase, t, v, impacts, keep, t_last, base_last)``: the arrays hold the
    ``impacts`` recorded (``keep`` of them ordinary for sure, :func:`impact_orbit`).

    Raises
    ------
    Interrupted
        Ctrl-C or SIGTERM during the call.
    """
    out_ph, out_t, out_v = np.empty(n), np.empty(n), np.empty(n)
    stop, counts = new_flag(), np.zeros(1, np.int64)
    st, imps, keep, t_last, b_last = run_kernel(
        impact_orbit,
        (*pars, t, base, v, n, k_last, out_ph, out_t, out_v, stop, counts),
        stop,
        what=lambda done: f"interrupted after {int(counts[0])} impact-map events",
    )
    return (
        int(st),
        out_ph[:imps],
        out_t[:imps],
        out_v[:imps],
        int(imps),
        int(keep),
        float(t_last),
        int(b_last),
    )
