"""The fast engine: compiled closed forms (float64, numba) for the single oscillator.

The exact 2x2 flow (also the tangent flow) between impacts and a crossing search that cannot
miss an impact; what it does not resolve returns a status and goes to heyoka
(``docs/numerics.rst``).
"""

from __future__ import annotations

import math
import time

import numba
import numpy as np

from precise_impact.core.impact import is_contact as _is_contact
from precise_impact.core.params import as_params, check_count
from precise_impact.core.precision import Precision
from precise_impact.core.trajectory import Trajectory
from precise_impact.errors import BudgetExceededError, IntegrationError
from precise_impact.solvers.base import Unresolved, note_fallback, with_fallback
from precise_impact.solvers.fast.control import STATUS_INTERRUPTED
from precise_impact.solvers.fast.crossing import (
    JIT,
    PHASE_ERROR,
    STEP_LEVELS,
    coefficients,
    flight_bounds,
    mul2,
    newton_start,
    no_crossing,
    phi,
    refine_crossing,
)
from precise_impact.solvers.fast.dd import DD_EPS, dd_period, dd_setup, gap_dd, two_prod
from precise_impact.solvers.heyoka.single import HeyokaSolver

STATUS_OK = 0
STATUS_CONTACT = 1  # a tangential contact (rounding-level excursion): rerun with heyoka
STATUS_SLOW_IMPACT = 2  # an impact slower than v_floor (chattering / sticking): rerun with heyoka
STATUS_BUDGET = 3  # max_impacts exhausted
STATUS_NONFINITE = 4
#: R = 1 bounces under the wall force predicted to reach rest or to outrun the impact budget
#: (core.impact.elastic_bounce_count; the LLE kernel only): refused, not rerun
STATUS_ENDLESS_BOUNCES = 5
# 6: STATUS_INTERRUPTED (solvers.fast.control)

__all__ = [
    "FastSolver",
    "compiled_saltation",
    "strobe",
    "orbit_map",
    "STATUS_TEXT",
    "STATUS_OK",
]

#: How a result the heyoka fallback computed says so (``stats['engine']``).
_HEYOKA_FALLBACK = note_fallback("heyoka")

STATUS_TEXT = {
    STATUS_OK: "ok",
    STATUS_CONTACT: "tangential contact (the contact rule is heyoka's)",
    STATUS_SLOW_IMPACT: "impact slower than the speed floor (chattering or sticking)",
    STATUS_BUDGET: "impact budget exhausted",
    STATUS_NONFINITE: "non-finite state",
    STATUS_ENDLESS_BOUNCES: "R = 1 bounces on the wall without end (predicted)",
    STATUS_INTERRUPTED: "stopped (interrupted, or another orbit of the batch went to heyoka)",
}


@numba.njit(**JIT)
def compiled_saltation(t, vm, eta, zeta, a, xw, R):
    """``[[-R, 0], [(acc+ + R acc-) / v-, -R]]`` (core.impact.oscillator_saltation)."""
    f = a * math.cos(eta * t) - xw  # the acceleration at the wall without damping, once
    am = f - 2.0 * zeta * vm
    ap = f + 2.0 * zeta * R * vm
    return -R, 0.0, (ap + R * am) / vm, -R


#: Samples one flight records at most before it returns (the caller re-anchors there).
FLIGHT_SAMPLES = 16

#: Anchors of refined flights a solve keeps (``stats['refined_anchors']``: ``(base, t, x, v)``
#: rows, the flight from ``(x, v)`` at local time ``t``; absolute time ``t + base 2 pi/eta``).
REFINED_LOG = 64


@numba.njit(**JIT)
def sample_time(tb, T, T_lo, step, k):
    """Sample ``k``: ``tb + (k // step) (T + T_lo) + (k % step) T / step`` (one formula for every
    caller; ``T + T_lo`` is the period in double-double,
    :func:`~precise_impact.solvers.fast.dd.dd_period`, so whole periods carry no rounding of
    ``T`` into the forcing's phase)."""
    j = k // step
    return tb + (j * T + j * T_lo) + (k % step) * (T / step)


# long: one compiled loop (numba): the step-halving search carries its bracket, proof bounds
# and status in locals across iterations; split into calls it would pass ~15 values per step.
@numba.njit(**JIT)
def _flight(  # noqa: PLR0912, PLR0915 -- numba kernel: one compiled loop
    t0,
    x0,
    v0,
    tb,
    T,
    T_lo,
    step,
    k,
    k_last,
    eta,
    zeta,
    a,
    xw,
    P,
    Q,
    w,
    S,
    err_scale,
    h_max,
    steps,
    buf,
):
    """A free flight from ``(x0, v0)`` at ``t0`` (the anchor) to the first upward crossing of
    ``x = x_w``, recording the samples ``k, k + 1, ...`` (times :func:`sample_time`) on the way.

    Returns ``(status, ns, hit, t, v, F, refined)``.  ``buf[i]`` (``i < ns``) holds sample
    ``k + i``: ``x, v`` and the flow matrix ``Phi(t_sample - t0)`` (four entries; it is also the
    tangent flow).  ``hit`` true: a crossing at ``t`` (after the recorded samples, at or
    before the next one), ``v > 0`` the velocity there, ``F = Phi(t - t0)``; a crossing at
    exactly a sample time leaves that sample to the caller (it is post-impact).  ``hit``
    false: the flight stopped at its last recorded sample (sample ``k_last``, or ``buf`` full)
    and the caller re-anchors there.  A sample time equal to ``t0`` is recorded at once.
    ``refined``: 1 if the flight needed double-double (below).

    ``steps[k]`` holds the flow and the forcing rotation over ``h_max / 2^k``
    (``Phi``, ``cos``/``sin(eta h)``): steps stay on these sizes (halved when a proof
    fails, doubled after a success), so a step costs a 2x2 product instead of five
    transcendentals.  Each such step adds at most ``err_scale / 8`` (relative) to the
    error of the state; ``m`` counts them since the last evaluation from the anchor
    (a step of another size: the first one and every one ending at a sample), and the
    proofs use the error bound ``err (1 + m / 8)``.

    A near-tangential contact (the gap within float64's evaluation error of the wall, no
    proof either way down to the time resolution) switches the rest of the flight to
    double-double (:func:`~precise_impact.solvers.fast.dd.gap_dd` from the anchor, error
    ``DD_ERR`` instead of ``err_scale``): the same proofs and the crossing by Newton on the
    double-double gap.  Only a contact within double-double's own rounding of the wall (the
    reference engine's contact rule, :func:`~precise_impact.core.impact.is_contact`, at that
    depth) is left unresolved (``STATUS_CONTACT``).
    """
    n_buf = buf.shape[0]
    ns = 0
    ts = sample_time(tb, T, T_lo, step, k)
    while ts <= t0 and k <= k_last and ns < n_buf:  # a sample at the anchor itself
        buf[ns, 0], buf[ns, 1], buf[ns, 2], buf[ns, 3], buf[ns, 4], buf[ns, 5] = (
            x0,
            v0,
            1.0,
            0.0,
            0.0,
            1.0,
        )
        ns += 1
        k += 1
        ts = sample_time(tb, T, T_lo, step, k)
    if k > k_last or ns == n_buf:
        return STATUS_OK, ns, False, t0, v0, 1.0, 0.0, 0.0, 1.0, 0
    precise = 0  # 1: evaluations in double-double from the anchor (a refined flight)
    dds = _NO_DD
    h_min = _h_min(ts, precise)
    cl, sl = math.cos(eta * t0), math.sin(eta * t0)  # forcing phase at lo
    y0, u0 = x0 - (P * cl + Q * sl), v0 - eta * (Q * cl - P * sl)  # minus the particular solution
    yl, ul = y0, u0  # homogeneous state at lo
    F00, F01, F10, F11 = 1.0, 0.0, 0.0, 1.0  # Phi(lo - t0)
    # amplitudes of y and y' (they only decay) and derivative bounds over the whole flight
    ay, M, J, J4 = flight_bounds(y0, u0, zeta, w, eta, S)
    # rounding error of g = x - x_w evaluated from the anchor: the terms, and the forcing
    # phase eta t rounded (an absolute error eps eta |t| in cos and sin) up to the flight's
    # last possible sample
    t_far = max(abs(t0), abs(sample_time(tb, T, T_lo, step, min(k + n_buf, k_last))))
    scale = abs(xw) + S + ay + 1.0
    err0 = err_scale * scale + PHASE_ERROR * S * eta * t_far
    acc_lo = a * cl - 2.0 * zeta * v0 - x0
    lo, g_lo, gp_lo = t0, x0 - xw, v0
    exact_start = True  # (x0, v0) is the exact state at t0 (no evaluation error)
    h = min(h_max, ts - t0)
    lev = 0 if h == h_max else -1  # h = h_max / 2^lev, or -1: not a cached size
    m_lo = 0  # cached steps chained since the last evaluation from the anchor
    n_lev = steps.shape[0]
    while True:
        hi = lo + h
        at_sample = hi >= ts
        if at_sample and hi > ts:
            hi = ts
            h = ts - lo
            lev = -1
        # the state at hi: in double-double, or a cached step from lo, or from the anchor
        if precise:
            g_hi, gp_hi, acc_hi, G00, G01, G10, G11 = _gap_precise(hi, t0, eta, zeta, w, xw, dds)
            err = _precise_error(scale, g_lo, g_hi, gp_lo, gp_hi, h, M)
            yh, uh, ch_, sh_, m_hi = yl, ul, cl, sl, 0  # the float64 state is not used again
        else:
            if lev >= 0:
                f00, f01, f10, f11, ch, sh = (
                    steps[lev, 0],
                    steps[lev, 1],
                    steps[lev, 2],
                    steps[lev, 3],
                    steps[lev, 4],
                    steps[lev, 5],
                )
                yh, uh = f00 * yl + f01 * ul, f10 * yl + f11 * ul
                ch_, sh_ = cl * ch - sl * sh, sl * ch + cl * sh
                G00, G01 = f00 * F00 + f01 * F10, f00 * F01 + f01 * F11
                G10, G11 = f10 * F00 + f11 * F10, f10 * F01 + f11 * F11
                m_hi = m_lo + 1
            else:
                G00, G01, G10, G11 = phi(hi - t0, zeta, w)
                yh, uh = G00 * y0 + G01 * u0, G10 * y0 + G11 * u0
                ch_, sh_ = math.cos(eta * hi), math.sin(eta * hi)
                m_hi = 0
            err = err0 * (1.0 + 0.125 * max(m_lo, m_hi))
            xph, vph = P * ch_ + Q * sh_, eta * (Q * ch_ - P * sh_)
            g_hi, gp_hi = xph + yh - xw, vph + uh
            acc_hi = -eta * eta * xph - 2.0 * zeta * uh - yh
        proven = no_crossing(g_lo, gp_lo, acc_lo, g_hi, gp_hi, h, J, J4, err, exact_start)
        if proven:
            # no crossing in (lo, hi]
            yl, ul, cl, sl = yh, uh, ch_, sh_
            F00, F01, F10, F11 = G00, G01, G10, G11
            lo, g_lo, gp_lo, acc_lo = hi, g_hi, gp_hi, acc_hi
            exact_start = False
            m_lo = m_hi
            if at_sample:
                buf[ns, 0], buf[ns, 1] = g_hi + xw, gp_hi
                buf[ns, 2], buf[ns, 3], buf[ns, 4], buf[ns, 5] = G00, G01, G10, G11
                ns += 1
                k += 1
                if k > k_last or ns == n_buf:
                    return STATUS_OK, ns, False, lo, gp_lo, G00, G01, G10, G11, precise
                ts = sample_time(tb, T, T_lo, step, k)
                h_min = _h_min(ts, precise)
                h, lev = h_max, 0 - precise
            elif lev > 0:
                lev -= 1
                h = 2.0 * h
            elif lev < 0:
                h = min(2.0 * h, h_max)
                lev = 0 if h == h_max and not precise else -1
            continue
        # not proven: a crossing bracketed with g' > 0 on [lo, hi], or halve
        if g_hi > err and gp_lo - M * h > 0.0 and g_lo < 0.0:
            # a sign change and g' > 0 on [lo, hi]: exactly one root; safeguarded Newton on
            # the closed form from the root of the Hermite cubic
            if precise:
                tc, gp, acc, p00, p01, p10, p11 = refine_crossing_dd(
                    lo, hi, g_lo, gp_lo, g_hi, gp_hi, t0, eta, zeta, w, xw, dds
                )
                if is_contact(gp, acc, DD_ERR * scale):
                    return STATUS_CONTACT, ns, False, lo, gp_lo, F00, F01, F10, F11, precise
                return STATUS_OK, ns, True, tc, gp, p00, p01, p10, p11, precise
            tc, gp, p00, p01, p10, p11 = _crossing(
                lo, hi, g_lo, gp_lo, g_hi, gp_hi, t0, eta, zeta, w, P, Q, y0, u0, xw
            )
            return STATUS_OK, ns, True, tc, gp, p00, p01, p10, p11, precise
        if h <= h_min or lo + 0.5 * h <= lo:
            if not np.isfinite(g_hi):
                return STATUS_NONFINITE, ns, False, lo, gp_lo, F00, F01, F10, F11, precise
            if precise:  # within double-double's rounding of the wall
                return STATUS_CONTACT, ns, False, lo, gp_lo, F00, F01, F10, F11, precise
            # float64 cannot decide: the rest of the flight in double-double, from lo
            precise = 1
            dds = dd_setup(t0, x0, v0, eta, zeta, a)
            if not exact_start:
                g_lo, gp_lo, acc_lo, _, _, _, _ = _gap_precise(lo, t0, eta, zeta, w, xw, dds)
            h_min = _h_min(ts, precise)
            h, lev = min(h_max, ts - lo), -1
            continue
        h = 0.5 * h
        if lev >= 0:
            lev = lev + 1 if lev + 1 < n_lev else -1


#: The double-double flight of a flight not (yet) refined (a placeholder of the right type).
_NO_DD = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

#: The evaluation error of the double-double gap, relative to the flight's scale
#: ``|x_w| + S + A + 1`` (as ``err_scale`` for float64): 64 units of double-double's roundoff.
DD_ERR = 64.0 * DD_EPS

#: The reference engine's contact rule (core.impact.is_contact), compiled.
is_contact = numba.njit(**JIT)(_is_contact)


@numba.njit(**JIT)
def _h_min(ts, precise):
    """The shortest step before a search gives up: 64 ulp of the time in float64, 4 ulp once
    double-double evaluates the gap (the time itself stays float64)."""
    return (4.0 if precise else 64.0) * 2.220446049250313e-16 * max(1.0, abs(ts))


@numba.njit(**JIT)
def _gap_precise(t, t0, eta, zeta, w, xw, dds):
    """``(g, g', g'', Phi(t - t0))`` of the refined flight: the gap in double-double rounded to
    float64 (its low parts are below the proofs' error), the flow matrix in float64."""
    gh, _, gph, _, ach, _ = gap_dd(t, t0, eta, zeta, xw, *dds)
    p00, p01, p10, p11 = phi(t - t0, zeta, w)
    return gh, gph, ach, p00, p01, p10, p11


@numba.njit(**JIT)
def _precise_error(scale, g_lo, g_hi, gp_lo, gp_hi, h, M):
    """The proofs' error bound in double-double: the gap's evaluation error, and the float64
    arithmetic of the proofs on values this small (8 eps times the sizes of their terms)."""
    terms = abs(g_lo) + abs(g_hi) + h * (abs(gp_lo) + abs(gp_hi)) + h * h * M
    return DD_ERR * scale + 8.0 * 2.220446049250313e-16 * terms


@numba.njit(**JIT)
def _crossing(lo, hi, g_lo, gp_lo, g_hi, gp_hi, t0, eta, zeta, w, P, Q, y0, u0, xw):
    """The bracketed crossing in float64 (:func:`refine_crossing`), with ``v`` and the flow
    matrix carried to the root to first order from the last evaluation (the next terms are
    O(step^2), below rounding): ``v' = x''``, ``Phi' = A Phi``."""
    tn, tc, gp, acc, p00, p01, p10, p11 = refine_crossing(
        lo, hi, g_lo, gp_lo, g_hi, gp_hi, t0, eta, zeta, w, P, Q, y0, u0, xw,
        False, 0.0, 1.0, 1.0, 0.0, 0.0,
    )  # fmt: skip
    if tn != tc:
        d = tn - tc
        gp += acc * d
        p00, p01, p10, p11 = (
            p00 + d * p10,
            p01 + d * p11,
            p10 - d * (p00 + 2.0 * zeta * p10),
            p11 - d * (p01 + 2.0 * zeta * p11),
        )
    return tn, gp, p00, p01, p10, p11


@numba.njit(**JIT)
def refine_crossing_dd(lo, hi, g_lo, gp_lo, g_hi, gp_hi, t0, eta, zeta, w, xw, dds):
    """The bracketed crossing of a refined flight: safeguarded Newton on the double-double gap
    (the twin of :func:`~precise_impact.solvers.fast.crossing.refine_crossing`; the bracket
    shrinks with every evaluation, a step leaving it bisects), to the float64 time nearest the
    root.  Returns ``(t, g'(t), g''(t), Phi(t - t0))``."""
    a_, b_ = lo, hi
    tr = lo + newton_start(g_lo, gp_lo, g_hi, gp_hi, hi - lo)
    for _ in range(200):
        if not (a_ < tr < b_):
            tr = 0.5 * (a_ + b_)
        g, gp, acc, p00, p01, p10, p11 = _gap_precise(tr, t0, eta, zeta, w, xw, dds)
        if g > 0.0:
            b_ = tr
        else:
            a_ = tr
        tn = tr - g / gp
        if tn == tr or b_ - a_ <= 2.220446049250313e-16 * abs(tr):
            break
        tr = tn
    return tr, gp, acc, p00, p01, p10, p11


@numba.njit(**JIT)
def _setup(eta, zeta, a, xw):
    P, Q, w = coefficients(eta, zeta, a)
    S = math.sqrt(P * P + Q * Q)
    err_scale = 64.0 * 2.220446049250313e-16
    h_max = 0.25 * min(2.0 * math.pi / eta, 2.0 * math.pi)  # 1/4 of the shorter period
    v_floor = 1e-9 * max(1.0, abs(a), abs(xw))  # chattering reaches it within ~30 impacts
    steps = np.empty((STEP_LEVELS, 6))
    h = h_max
    for k in range(STEP_LEVELS):
        f00, f01, f10, f11 = phi(h, zeta, w)
        steps[k, 0], steps[k, 1], steps[k, 2], steps[k, 3] = f00, f01, f10, f11
        steps[k, 4], steps[k, 5] = math.cos(eta * h), math.sin(eta * h)
        h = 0.5 * h
    return P, Q, w, S, err_scale, h_max, v_floor, steps


@numba.njit(**JIT)
def rebase(t, tb, T, T_lo, base):
    """``(t, base)`` with the whole forcing periods of the local time ``t`` (counted from
    ``tb``) moved into the integer ``base``: the absolute time is ``t + base (T + T_lo)``.

    The kernels keep their clock local, so ``cos(eta t)`` is evaluated at ``|t| <~ 20 T``
    with a phase error of a few ulp at every length of run (an absolute clock's error grows
    as ``eps eta t``: ~1e-8 after 10^7 periods, where it made near-tangential contacts
    undecidable once every ~3 10^6 periods at eta = 0.712).  The periods moved are exact
    ones, ``2 pi / eta`` in double-double (:func:`~precise_impact.solvers.fast.dd.dd_period`):
    moving float64 periods would shift the forcing's phase by ``j (eta T - 2 pi) ~ 1e-15 j``
    at every move, always the same way (measured: a grazing orbit pushed 3e-14 through the
    wall after 16 periods).  ``t - j T`` is exact (Sterbenz, ``j T`` exact by two_prod); the
    rest rounds once: half an ulp of the local time per move.
    """
    j = math.floor((t - tb) / T)
    if j >= 1.0:
        p, e = two_prod(j, T)
        return ((t - p) - e) - j * T_lo, base + int(j)
    return t, base


@numba.njit(**JIT)
def slow_impact(tc, vc, v_floor, eta, zeta, a, xw, R):
    """An impact slower than ``v_floor`` that the mass does not leave (the acceleration at the
    wall after it, ``a cos(eta t) - x_w + 2 zeta R v``, is not negative): chattering or
    sticking, for the heyoka engine's rules.  A slow impact the mass leaves (a near-grazing
    impact) is an ordinary impact."""
    return vc < v_floor and a * math.cos(eta * tc) - xw + 2.0 * zeta * R * vc >= 0.0


@numba.njit(**JIT)
def chatter_tail(tc, vc, eta, zeta, a, xw, R, err):
    """An impact that ends a chatter's float64 part: the wall force pushes into the wall (the
    test of :func:`slow_impact`) and the hop after it, post-impact speed ``u = R v``, peaks at
    ``u^2 / (2 A)`` (``A`` that force) within ``64 err`` of the wall.  Such a hop lies inside
    float64's evaluation error band (``err`` the gap's rounding, the float64 ``err0`` of
    :func:`_flight` without the forcing-phase term) for all or nearly all of its flight, so the
    flight's proofs fail and it is refined in double-double (~200 us); so is every later hop
    of the chatter (each ``R^2`` lower), which converges to sticking (``R < 1``: at ``R = 1``
    the hops do not shrink, the bounce sequence is not a chatter).  The caller stops here
    (``STATUS_SLOW_IMPACT``: heyoka's chattering rule) instead of paying for them one by one;
    measured on a chatter grid (eta 4.85, R 0.5): all 1415 refined flights started this way,
    peaking within ``24 err`` (so ``64 err``: none refined; 0.18 s to 0.009 s)."""
    A = a * math.cos(eta * tc) - xw + 2.0 * zeta * R * vc
    u = R * vc
    return R < 1.0 and A >= 0.0 and u * u < 128.0 * err * A


@numba.njit(**JIT)
def log_refined(rlog, n_ref, base, t, x, v):
    """Row ``n_ref`` of ``rlog`` (while it has room): the anchor ``(base, t, x, v)`` of a flight
    refined in double-double (absolute time ``t + base T``; replayable from ``(t, x, v)``)."""
    if n_ref < rlog.shape[0]:
        rlog[n_ref, 0], rlog[n_ref, 1], rlog[n_ref, 2], rlog[n_ref, 3] = base, t, x, v
    return n_ref + 1


@numba.njit(**JIT)
def strobe(eta, zeta, a, xw, R, t0, x0, v0, n, step, max_impacts, imp_t, imp_vb, xs, vs, ts, rlog):
    """Samples at ``t0 + k (2 pi / eta) / step`` (``k = 0..n``) and every impact.

    ``xs, vs, ts`` (length ``n + 1``) and ``imp_t, imp_vb`` (capacity) are filled in place,
    ``rlog`` (``m x 4``) with the anchors of the first ``m`` refined flights
    (:func:`log_refined`).  Returns ``(status, impacts, samples_done, refined)``;
    ``impacts > len(imp_t)`` means the capacity was too small (the caller retries with more).
    The clock is local (:func:`rebase`); ``ts`` and ``imp_t`` are absolute.  A chatter stops
    after the impact whose next hop float64 cannot decide (:func:`chatter_tail`).
    """
    P, Q, w, S, err_scale, h_max, v_floor, steps = _setup(eta, zeta, a, xw)
    err_tail = err_scale * (abs(xw) + S + 1.0)  # a flight's float64 gap error, at least
    T, T_lo = dd_period(eta)
    buf = np.empty((FLIGHT_SAMPLES, 6))
    t, x, v, base = t0, x0, v0, 0
    xs[0], vs[0], ts[0] = x, v, t
    n_imp = 0
    n_ref = 0
    cap = imp_t.shape[0]
    k = 1
    while k <= n:
        kb = base * step
        st, ns, hit, tc, vc, _, _, _, _, ref = _flight(
            t, x, v, t0, T, T_lo, step, k - kb, n - kb,
            eta, zeta, a, xw, P, Q, w, S, err_scale, h_max, steps, buf,
        )  # fmt: skip
        if ref:
            n_ref = log_refined(rlog, n_ref, base, t, x, v)
        for i in range(ns):
            xs[k], vs[k], ts[k] = buf[i, 0], buf[i, 1], sample_time(t0, T, T_lo, step, k)
            k += 1
        if st != STATUS_OK:
            return st, n_imp, k - 1, n_ref
        if not hit:  # re-anchor at the last sample, its whole periods moved into base
            t, base = rebase(sample_time(t0, T, T_lo, step, k - 1 - kb), t0, T, T_lo, base)
            x, v = xs[k - 1], vs[k - 1]
            continue
        if slow_impact(tc, vc, v_floor, eta, zeta, a, xw, R):
            return STATUS_SLOW_IMPACT, n_imp, k - 1, n_ref
        if n_imp < cap:
            imp_t[n_imp] = tc + base * T
            imp_vb[n_imp] = vc
        n_imp += 1
        if n_imp >= max_impacts:
            return STATUS_BUDGET, n_imp, k - 1, n_ref
        if chatter_tail(tc, vc, eta, zeta, a, xw, R, err_tail):
            return STATUS_SLOW_IMPACT, n_imp, k - 1, n_ref
        t, base = rebase(tc, t0, T, T_lo, base)
        x, v = xw, -R * vc
    return STATUS_OK, n_imp, n, n_ref


@numba.njit(**JIT)
def orbit_map(eta, zeta, a, xw, R, t0, x0, v0, periods):
    """The ``periods``-fold stroboscopic map from ``(x0, v0)`` at ``t0`` and its Jacobian.

    Returns ``(status, x, v, M00, M01, M10, M11, impacts)``: the state at
    ``t0 + periods 2 pi / eta`` and the monodromy ``M = d(x, v) / d(x0, v0)``, the product of
    the flight flows and the saltation matrices of the impacts on the way (no QR: for a
    periodic orbit's Floquet multipliers over a few periods).
    """
    P, Q, w, S, err_scale, h_max, v_floor, steps = _setup(eta, zeta, a, xw)
    T, T_lo = dd_period(eta)
    buf = np.empty((FLIGHT_SAMPLES, 6))
    t, x, v, base = t0, x0, v0, 0
    W00, W01, W10, W11 = 1.0, 0.0, 0.0, 1.0  # the Jacobian at the anchor
    c00, c01, c10, c11 = 1.0, 0.0, 0.0, 1.0
    n_imp = 0
    k = 1
    xk, vk = x0, v0
    while k <= periods:
        st, ns, hit, tc, vc, F00, F01, F10, F11, _ = _flight(
            t, x, v, t0, T, T_lo, 1, k - base, periods - base, eta, zeta, a, xw, P, Q, w, S,
            err_scale, h_max, steps, buf,
        )  # fmt: skip
        for i in range(ns):
            xk, vk = buf[i, 0], buf[i, 1]
            p00, p01, p10, p11 = buf[i, 2], buf[i, 3], buf[i, 4], buf[i, 5]
            c00, c01, c10, c11 = mul2(p00, p01, p10, p11, W00, W01, W10, W11)
            k += 1
        if st != STATUS_OK:
            return st, xk, vk, c00, c01, c10, c11, n_imp
        if not hit:
            t, base = rebase(sample_time(t0, T, T_lo, 1, k - 1 - base), t0, T, T_lo, base)
            x, v = xk, vk
            W00, W01, W10, W11 = c00, c01, c10, c11
            continue
        if slow_impact(tc, vc, v_floor, eta, zeta, a, xw, R):
            return STATUS_SLOW_IMPACT, xk, vk, c00, c01, c10, c11, n_imp
        s00, s01, s10, s11 = compiled_saltation(tc, vc, eta, zeta, a, xw, R)
        W00, W01, W10, W11 = mul2(s00, s01, s10, s11, *mul2(F00, F01, F10, F11, W00, W01, W10, W11))
        n_imp += 1
        t, base = rebase(tc, t0, T, T_lo, base)
        x, v = xw, -R * vc
    return STATUS_OK, xk, vk, c00, c01, c10, c11, n_imp


# --------------------------------------------------------------------------- the solver
class FastSolver:
    """Solver protocol on the compiled closed-form engine (``model = 'fast'``, float64).

    Parameters
    ----------
    max_impacts : int, default ``10**6``
        Impact budget of one solve.
    fallback : bool, default ``True``
        Rerun an orbit the engine does not resolve (a tangential contact, chattering or
        sticking, ``zeta >= 1``) with :class:`~precise_impact.solvers.heyoka.single.HeyokaSolver`
        and say so in ``stats['engine']``; ``False`` raises
        :class:`~precise_impact.errors.IntegrationError` instead.

    Notes
    -----
    Samples at ``t0 + k T / per_period`` are computed in float64 as
    ``t0 + (k // step) T + (k % step) T / step`` (within an ulp or two of the correctly
    rounded times of the other solvers).  Compiled once per machine (numba's on-disk
    cache); the first call in a process loads or compiles (~2 s cold).
    """

    model_name = "fast"

    def __init__(self, max_impacts: int = 10**6, fallback: bool = True) -> None:
        self.max_impacts = check_count(max_impacts, "max_impacts", 10**9, minimum=1)
        self.fallback = bool(fallback)
        self.precision = Precision.parse("float64")

    def _unsupported(self, params) -> str | None:
        if not params.zeta < 1:
            return "zeta >= 1 (the engine's closed form is the underdamped one)"
        if params.zeta == 0 and params.eta == 1:
            return "the undamped resonance (no steady state)"
        if params.x0 == params.x_w and params.v0 == 0:
            return "a start at rest on the wall (sticking decision)"
        return None

    def solve(self, params, periods: int, per_period: int = 0):
        """Integrate ``periods`` forcing periods; see :class:`FastSolver`.

        Parameters
        ----------
        params : Params or mapping
            System and initial condition.
        periods : int
            Forcing periods.
        per_period : int, default 0
            Dense output points per period.

        Returns
        -------
        Trajectory
            ``model = 'fast'``; ``stats['engine']`` is ``'fast'`` or the fallback's reason.
        """
        params = as_params(params)
        periods = check_count(periods, "periods")
        per_period = check_count(per_period, "per_period", 100_000)
        run = with_fallback(
            self._solve, self._solve_heyoka if self.fallback else None, _HEYOKA_FALLBACK
        )
        return run(params, periods, per_period)

    def _solve_heyoka(self, params, periods: int, per_period: int):
        traj = HeyokaSolver(self.precision, max_impacts=self.max_impacts).solve(
            params, periods, per_period=per_period
        )
        traj.model = "fast"
        return traj

    def _solve(self, params, periods: int, per_period: int):
        """The compiled run, or :class:`~precise_impact.solvers.base.Unresolved`."""
        why = self._unsupported(params)
        if why is not None:
            raise Unresolved("fast", why)
        step = max(per_period, 1)
        n = periods * step
        p = [float(getattr(params, k)) for k in ("eta", "zeta", "a", "x_w", "R", "t0", "x0", "v0")]
        cap = min(self.max_impacts, 4 * periods + 64)
        rlog = np.empty((REFINED_LOG, 4))
        start = time.perf_counter()
        while True:
            xs, vs, ts = np.empty(n + 1), np.empty(n + 1), np.empty(n + 1)
            it, iv = np.empty(cap), np.empty(cap)
            st, n_imp, done, n_ref = strobe(*p, n, step, self.max_impacts, it, iv, xs, vs, ts, rlog)
            if n_imp <= cap or st == STATUS_BUDGET:
                break
            cap = min(self.max_impacts, 4 * n_imp + 64)
        elapsed = time.perf_counter() - start
        if st == STATUS_BUDGET:
            raise BudgetExceededError(
                f"impact budget max_impacts={self.max_impacts} exhausted at "
                f"sample {done} of {n}; raise max_impacts or ask for a shorter run"
            )
        if st == STATUS_NONFINITE:
            raise IntegrationError(
                f"the fast engine met a non-finite state after sample {done} of {n}"
            )
        if st != STATUS_OK:
            raise Unresolved("fast", STATUS_TEXT[st] + f" after sample {done} of {n}")
        it, iv = it[:n_imp], iv[:n_imp]
        traj = Trajectory(
            params=params,
            model="fast",
            precision=self.precision,
            tol=self.precision.eps,
            t=ts[::step].copy(),
            x=xs[::step].copy(),
            v=vs[::step].copy(),
            impacts_t=it.copy(),
            impacts_v_before=iv.copy(),
            impacts_v_after=-float(params.R) * iv,
            elapsed_s=elapsed,
            stats={
                "engine": "fast",
                "impacts": int(n_imp),
                "refined_flights": int(n_ref),
                "refined_anchors": rlog[: min(n_ref, REFINED_LOG)].tolist(),
            },
        )
        if per_period > 0:
            traj.dense_t, traj.dense_x, traj.dense_v = ts, xs, vs
        return traj


#: The LLE kernels moved to :mod:`precise_impact.solvers.fast.lle`; importable from here too.
_MOVED_TO_LLE = ("lle_orbit", "lle_batch", "lle_batch_serial", "fast_lle", "QR_EVERY")


def __getattr__(name: str):
    if name in _MOVED_TO_LLE:
        from precise_impact.solvers.fast import lle  # noqa: PLC0415 -- import cycle: lle builds on this module

        return getattr(lle, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
