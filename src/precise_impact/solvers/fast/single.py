"""The fast engine: compiled closed forms (float64, numba) for the single oscillator.

The exact 2x2 flow (also the tangent flow) between impacts and a crossing search that cannot
miss an impact; what it does not resolve returns a status and goes to heyoka
(``docs/numerics.rst``).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from precise_impact.solvers.fast.crossing import (
    JIT,
    PHASE_ERROR,
    STEP_LEVELS,
    coefficients,
    flight_bounds,
    mul2,
    no_crossing,
    phi,
    refine_crossing,
)

STATUS_OK = 0
STATUS_CONTACT = 1  # a tangential contact (rounding-level excursion): rerun with heyoka
STATUS_SLOW_IMPACT = 2  # an impact slower than v_floor (chattering / sticking): rerun with heyoka
STATUS_BUDGET = 3  # max_impacts exhausted
STATUS_NONFINITE = 4

__all__ = [
    "FastSolver",
    "fast_lle",
    "compiled_saltation",
    "strobe",
    "lle_orbit",
    "orbit_map",
    "lle_batch",
    "lle_batch_serial",
    "STATUS_TEXT",
    "STATUS_OK",
]

STATUS_TEXT = {
    STATUS_OK: "ok",
    STATUS_CONTACT: "tangential contact (the contact rule is heyoka's)",
    STATUS_SLOW_IMPACT: "impact slower than the speed floor (chattering or sticking)",
    STATUS_BUDGET: "impact budget exhausted",
    STATUS_NONFINITE: "non-finite state",
}


@numba.njit(**JIT)
def compiled_saltation(t, vm, eta, zeta, a, xw, R):
    """``[[-R, 0], [(acc+ + R acc-) / v-, -R]]`` (core.impact.oscillator_saltation)."""
    f = a * math.cos(eta * t) - xw  # the acceleration at the wall without damping, once
    am = f - 2.0 * zeta * vm
    ap = f + 2.0 * zeta * R * vm
    return -R, 0.0, (ap + R * am) / vm, -R


#: Samples between two QRs of the tangent basis in :func:`lle_orbit` (the basis grows or
#: shrinks by at most ~e^2 per period between impacts; large growth forces a QR at once).
QR_EVERY = 4

#: Samples one flight records at most before it returns (the caller re-anchors there).
FLIGHT_SAMPLES = 16


@numba.njit(**JIT)
def sample_time(tb, T, step, k):
    """Sample ``k``: ``tb + (k // step) T + (k % step) T / step`` (one formula for every caller)."""
    return tb + (k // step) * T + (k % step) * (T / step)


@numba.njit(**JIT)
def _flight(
    t0, x0, v0, tb, T, step, k, k_last, eta, zeta, a, xw, P, Q, w, S, err_scale, h_max, steps, buf
):
    """A free flight from ``(x0, v0)`` at ``t0`` (the anchor) to the first upward crossing of
    ``x = x_w``, recording the samples ``k, k + 1, ...`` (times :func:`sample_time`) on the way.

    Returns ``(status, ns, hit, t, v, F)``.  ``buf[i]`` (``i < ns``) holds sample ``k + i``:
    ``x, v`` and the flow matrix ``Phi(t_sample - t0)`` (four entries; it is also the
    tangent flow).  ``hit`` true: a crossing at ``t`` (after the recorded samples, at or
    before the next one), ``v > 0`` the velocity there, ``F = Phi(t - t0)``; a crossing at
    exactly a sample time leaves that sample to the caller (it is post-impact).  ``hit``
    false: the flight stopped at its last recorded sample (sample ``k_last``, or ``buf`` full)
    and the caller re-anchors there.  A sample time equal to ``t0`` is recorded at once.

    ``steps[k]`` holds the flow and the forcing rotation over ``h_max / 2^k``
    (``Phi``, ``cos``/``sin(eta h)``): steps stay on these sizes (halved when a proof
    fails, doubled after a success), so a step costs a 2x2 product instead of five
    transcendentals.  Each such step adds at most ``err_scale / 8`` (relative) to the
    error of the state; ``m`` counts them since the last evaluation from the anchor
    (a step of another size: the first one and every one ending at a sample), and the
    proofs use the error bound ``err (1 + m / 8)``.
    """
    n_buf = buf.shape[0]
    ns = 0
    ts = sample_time(tb, T, step, k)
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
        ts = sample_time(tb, T, step, k)
    if k > k_last or ns == n_buf:
        return STATUS_OK, ns, False, t0, v0, 1.0, 0.0, 0.0, 1.0
    h_min = 64.0 * 2.220446049250313e-16 * max(1.0, abs(ts))
    cl, sl = math.cos(eta * t0), math.sin(eta * t0)  # forcing phase at lo
    y0, u0 = x0 - (P * cl + Q * sl), v0 - eta * (Q * cl - P * sl)  # minus the particular solution
    yl, ul = y0, u0  # homogeneous state at lo
    F00, F01, F10, F11 = 1.0, 0.0, 0.0, 1.0  # Phi(lo - t0)
    # amplitudes of y and y' (they only decay) and derivative bounds over the whole flight
    ay, M, J, J4 = flight_bounds(y0, u0, zeta, w, eta, S)
    # rounding error of g = x - x_w evaluated from the anchor: the terms, and the forcing
    # phase eta t rounded (an absolute error eps eta |t| in cos and sin) up to the flight's
    # last possible sample
    t_far = max(abs(t0), abs(sample_time(tb, T, step, min(k + n_buf, k_last))))
    err0 = err_scale * (abs(xw) + S + ay + 1.0) + PHASE_ERROR * S * eta * t_far
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
        # the state at hi: a cached step from lo, or from the anchor
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
        proven = no_crossing(g_lo, gp_lo, acc_lo, g_hi, gp_hi, h, J, J4, err, exact_start)
        if proven:
            # no crossing in (lo, hi]
            yl, ul, cl, sl = yh, uh, ch_, sh_
            F00, F01, F10, F11 = G00, G01, G10, G11
            lo, g_lo, gp_lo = hi, g_hi, gp_hi
            acc_lo = -eta * eta * xph - 2.0 * zeta * ul - yl
            exact_start = False
            m_lo = m_hi
            if at_sample:
                buf[ns, 0], buf[ns, 1] = g_hi + xw, gp_hi
                buf[ns, 2], buf[ns, 3], buf[ns, 4], buf[ns, 5] = G00, G01, G10, G11
                ns += 1
                k += 1
                if k > k_last or ns == n_buf:
                    return STATUS_OK, ns, False, lo, gp_lo, G00, G01, G10, G11
                ts = sample_time(tb, T, step, k)
                h_min = 64.0 * 2.220446049250313e-16 * max(1.0, abs(ts))
                h, lev = h_max, 0
            elif lev > 0:
                lev -= 1
                h = 2.0 * h
            elif lev < 0:
                h = min(2.0 * h, h_max)
                lev = 0 if h == h_max else -1
            continue
        # not proven: a crossing bracketed with g' > 0 on [lo, hi], or halve
        if g_hi > err and gp_lo - M * h > 0.0 and g_lo < 0.0:
            # a sign change and g' > 0 on [lo, hi]: exactly one root; safeguarded Newton on
            # the closed form from the root of the Hermite cubic
            tn, tc, gp, acc, p00, p01, p10, p11 = refine_crossing(
                lo,
                hi,
                g_lo,
                gp_lo,
                g_hi,
                gp_hi,
                t0,
                eta,
                zeta,
                w,
                P,
                Q,
                y0,
                u0,
                xw,
                False,
                0.0,
                1.0,
                1.0,
                0.0,
                0.0,
            )
            if tn != tc:
                # v and the flow matrix at tn to first order from tc (the next terms are
                # O(step^2), below rounding): v' = x'', Phi' = A Phi
                d = tn - tc
                gp += acc * d
                p00, p01, p10, p11 = (
                    p00 + d * p10,
                    p01 + d * p11,
                    p10 - d * (p00 + 2.0 * zeta * p10),
                    p11 - d * (p01 + 2.0 * zeta * p11),
                )
                tc = tn
            return STATUS_OK, ns, True, tc, gp, p00, p01, p10, p11
        if h <= h_min:
            if not np.isfinite(g_hi):
                return STATUS_NONFINITE, ns, False, lo, gp_lo, F00, F01, F10, F11
            return STATUS_CONTACT, ns, False, lo, gp_lo, F00, F01, F10, F11
        h = 0.5 * h
        if lev >= 0:
            lev = lev + 1 if lev + 1 < n_lev else -1
        if lo + h <= lo:
            return STATUS_CONTACT, ns, False, lo, gp_lo, F00, F01, F10, F11


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
def strobe(eta, zeta, a, xw, R, t0, x0, v0, n, step, max_impacts, imp_t, imp_vb, xs, vs, ts):
    """Samples at ``t0 + k (2 pi / eta) / step`` (``k = 0..n``) and every impact.

    ``xs, vs, ts`` (length ``n + 1``) and ``imp_t, imp_vb`` (capacity) are filled in place.
    Returns ``(status, impacts, samples_done)``; ``impacts > len(imp_t)`` means the capacity
    was too small (the caller retries with more).
    """
    P, Q, w, S, err_scale, h_max, v_floor, steps = _setup(eta, zeta, a, xw)
    T = 2.0 * math.pi / eta
    buf = np.empty((FLIGHT_SAMPLES, 6))
    t, x, v = t0, x0, v0
    xs[0], vs[0], ts[0] = x, v, t
    n_imp = 0
    cap = imp_t.shape[0]
    k = 1
    while k <= n:
        st, ns, hit, tc, vc, _, _, _, _ = _flight(
            t, x, v, t0, T, step, k, n, eta, zeta, a, xw, P, Q, w, S, err_scale, h_max, steps, buf
        )
        for i in range(ns):
            xs[k], vs[k], ts[k] = buf[i, 0], buf[i, 1], sample_time(t0, T, step, k)
            k += 1
        if st != STATUS_OK:
            return st, n_imp, k - 1
        if not hit:
            t, x, v = ts[k - 1], xs[k - 1], vs[k - 1]  # re-anchor at the last sample
            continue
        if vc < v_floor:
            return STATUS_SLOW_IMPACT, n_imp, k - 1
        if n_imp < cap:
            imp_t[n_imp] = tc
            imp_vb[n_imp] = vc
        n_imp += 1
        if n_imp >= max_impacts:
            return STATUS_BUDGET, n_imp, k - 1
        t, x, v = tc, xw, -R * vc
    return STATUS_OK, n_imp, n


@numba.njit(**JIT)
def lle_orbit(
    eta,
    zeta,
    a,
    xw,
    R,
    t0,
    x0,
    v0,
    periods,
    transient,
    blocks,
    max_impacts,
    block_sums,
    block_impacts,
    xs_tail,
    vs_tail,
):
    """Both Lyapunov exponents of one orbit: tangent flow ``Phi``, saltation at every impact,
    Gram-Schmidt QR every ``QR_EVERY`` samples (and at block ends); the tangent basis starts
    at the identity at ``t0`` and is never restarted (the transient's logs are discarded,
    not its basis).

    Returns ``(status, log1, log2, impacts, x, v)`` summed over the ``periods`` measured
    periods (``impacts``: those in the measured periods); ``block_sums[j]`` gets the
    first-exponent logs of block ``j`` (``blocks`` equal blocks, for batch means),
    ``block_impacts[j]`` the impacts in block ``j``, and ``xs_tail, vs_tail`` the stroboscopic samples of the last ``len(xs_tail)`` periods.

    Notes
    -----
    The tangent basis is kept at the flight's anchor, ``W``: at a sample the basis is
    ``w = Phi W``.  A QR ``w = q r`` there replaces ``W`` by ``W r^-1`` (so that
    ``Phi W = q``); at an impact the basis becomes ``S Phi W`` and the new anchor's ``W``.
    """
    P, Q, w, S, err_scale, h_max, v_floor, steps = _setup(eta, zeta, a, xw)
    T = 2.0 * math.pi / eta
    buf = np.empty((FLIGHT_SAMPLES, 6))
    t, x, v = t0, x0, v0
    W00, W01, W10, W11 = (
        1.0,
        0.0,
        0.0,
        1.0,
    )  # the basis at the anchor: columns (W00, W10), (W01, W11)
    c00, c01, c10, c11 = 1.0, 0.0, 0.0, 1.0  # the basis at the last sample
    log1 = 0.0
    log2 = 0.0
    n_imp = 0
    n_meas = 0
    total = transient + periods
    keep = xs_tail.shape[0]
    per_block = max(1, periods // blocks)
    for j in range(blocks):
        block_sums[j] = 0.0
        block_impacts[j] = 0
    k = 1
    while k <= total:
        st, ns, hit, tc, vc, F00, F01, F10, F11 = _flight(
            t, x, v, t0, T, 1, k, total, eta, zeta, a, xw, P, Q, w, S, err_scale, h_max, steps, buf
        )
        for i in range(ns):
            xk, vk = buf[i, 0], buf[i, 1]
            p00, p01, p10, p11 = buf[i, 2], buf[i, 3], buf[i, 4], buf[i, 5]
            c00, c01, c10, c11 = mul2(p00, p01, p10, p11, W00, W01, W10, W11)
            jt = k - (total - keep) - 1
            if jt >= 0:
                xs_tail[jt], vs_tail[jt] = xk, vk
            if not (math.isfinite(xk) and math.isfinite(vk)):
                return STATUS_NONFINITE, log1, log2, n_meas, xk, vk
            # Gram-Schmidt QR of the basis (core.linalg.gram_schmidt2) every QR_EVERY samples,
            # at the end of the transient and of every block, and whenever the basis has
            # grown large (saltations at slow impacts): the logs of a product of
            # upper-triangular factors are the sums of their logs, so fewer QRs give the
            # same exponents and block sums.
            km = k - transient
            if (
                (km % QR_EVERY == 0)
                or km == 0
                or (km > 0 and km % per_block == 0)
                or k == total
                or abs(c00) + abs(c10) + abs(c01) + abs(c11) > 1e150
            ):
                r11 = math.sqrt(c00 * c00 + c10 * c10)
                q0, q1 = c00 / r11, c10 / r11
                proj = q0 * c01 + q1 * c11
                d0, d1 = c01 - proj * q0, c11 - proj * q1
                r22 = math.sqrt(d0 * d0 + d1 * d1)
                if not math.isfinite(r11):
                    return STATUS_NONFINITE, log1, log2, n_meas, xk, vk
                # W <- W r^-1: first column / r11, second (column - proj * new first) / r22
                W00, W10 = W00 / r11, W10 / r11
                if r22 > 0.0:
                    u0, u1 = d0 / r22, d1 / r22
                    W01, W11 = (W01 - proj * W00) / r22, (W11 - proj * W10) / r22
                else:  # a plastic impact collapsed the basis: re-seed (-q1, q0), W = Phi^-1 of it
                    u0, u1 = -q1, q0
                    det = p00 * p11 - p01 * p10
                    W01, W11 = (p11 * u0 - p01 * u1) / det, (p00 * u1 - p10 * u0) / det
                c00, c10, c01, c11 = q0, q1, u0, u1
                if k > transient:
                    l1 = math.log(r11)
                    log1 += l1
                    log2 += math.log(r22) if r22 > 0.0 else -math.inf
                    j = (k - transient - 1) // per_block
                    if j < blocks:
                        block_sums[j] += l1
            k += 1
        if st != STATUS_OK:
            return st, log1, log2, n_meas, x, v
        if not hit:  # re-anchor at the last sample
            t, x, v = sample_time(t0, T, 1, k - 1), buf[ns - 1, 0], buf[ns - 1, 1]
            W00, W01, W10, W11 = c00, c01, c10, c11
            continue
        if vc < v_floor:
            return STATUS_SLOW_IMPACT, log1, log2, n_meas, x, v
        # the basis just before the impact, then through the saltation matrix
        s00, s01, s10, s11 = compiled_saltation(tc, vc, eta, zeta, a, xw, R)
        W00, W01, W10, W11 = mul2(s00, s01, s10, s11, *mul2(F00, F01, F10, F11, W00, W01, W10, W11))
        n_imp += 1
        if k > transient:  # the impact lies before sample k: measured period k - transient
            n_meas += 1
            j = (k - transient - 1) // per_block
            if j < blocks:
                block_impacts[j] += 1
        if n_imp >= max_impacts:
            return STATUS_BUDGET, log1, log2, n_meas, x, v
        t, x, v = tc, xw, -R * vc
    return STATUS_OK, log1, log2, n_meas, x, v


@numba.njit(**JIT)
def orbit_map(eta, zeta, a, xw, R, t0, x0, v0, periods):
    """The ``periods``-fold stroboscopic map from ``(x0, v0)`` at ``t0`` and its Jacobian.

    Returns ``(status, x, v, M00, M01, M10, M11, impacts)``: the state at
    ``t0 + periods 2 pi / eta`` and the monodromy ``M = d(x, v) / d(x0, v0)``, the product of
    the flight flows and the saltation matrices of the impacts on the way (no QR: for a
    periodic orbit's Floquet multipliers over a few periods).
    """
    P, Q, w, S, err_scale, h_max, v_floor, steps = _setup(eta, zeta, a, xw)
    T = 2.0 * math.pi / eta
    buf = np.empty((FLIGHT_SAMPLES, 6))
    t, x, v = t0, x0, v0
    W00, W01, W10, W11 = 1.0, 0.0, 0.0, 1.0  # the Jacobian at the anchor
    c00, c01, c10, c11 = 1.0, 0.0, 0.0, 1.0
    n_imp = 0
    k = 1
    xk, vk = x0, v0
    while k <= periods:
        st, ns, hit, tc, vc, F00, F01, F10, F11 = _flight(
            t,
            x,
            v,
            t0,
            T,
            1,
            k,
            periods,
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
        )
        for i in range(ns):
            xk, vk = buf[i, 0], buf[i, 1]
            p00, p01, p10, p11 = buf[i, 2], buf[i, 3], buf[i, 4], buf[i, 5]
            c00, c01, c10, c11 = mul2(p00, p01, p10, p11, W00, W01, W10, W11)
            k += 1
        if st != STATUS_OK:
            return st, xk, vk, c00, c01, c10, c11, n_imp
        if not hit:
            t, x, v = sample_time(t0, T, 1, k - 1), xk, vk
            W00, W01, W10, W11 = c00, c01, c10, c11
            continue
        if vc < v_floor:
            return STATUS_SLOW_IMPACT, xk, vk, c00, c01, c10, c11, n_imp
        s00, s01, s10, s11 = compiled_saltation(tc, vc, eta, zeta, a, xw, R)
        W00, W01, W10, W11 = mul2(s00, s01, s10, s11, *mul2(F00, F01, F10, F11, W00, W01, W10, W11))
        n_imp += 1
        t, x, v = tc, xw, -R * vc
    return STATUS_OK, xk, vk, c00, c01, c10, c11, n_imp


def _batch(
    pars,
    starts,
    periods,
    transient,
    blocks,
    max_impacts,
    keep,
    status,
    log1,
    log2,
    imps,
    bsums,
    bimps,
    xt,
    vt,
    i,
):
    st, l1, l2, ni, _, _ = lle_orbit(
        pars[i, 0],
        pars[i, 1],
        pars[i, 2],
        pars[i, 3],
        pars[i, 4],
        starts[i, 0],
        starts[i, 1],
        starts[i, 2],
        periods,
        transient,
        blocks,
        max_impacts,
        bsums[i],
        bimps[i],
        xt[i],
        vt[i],
    )
    status[i], log1[i], log2[i], imps[i] = st, l1, l2, ni


_batch_one = numba.njit(**JIT)(_batch)


def _make_batch(parallel: bool):
    rng = numba.prange if parallel else range

    def run(pars, starts, periods, transient, blocks, max_impacts, keep):
        n = pars.shape[0]
        status = np.zeros(n, np.int64)
        log1 = np.zeros(n)
        log2 = np.zeros(n)
        imps = np.zeros(n, np.int64)
        bsums = np.zeros((n, blocks))
        bimps = np.zeros((n, blocks), np.int64)
        xt = np.zeros((n, keep))
        vt = np.zeros((n, keep))
        for i in rng(n):
            _batch_one(
                pars,
                starts,
                periods,
                transient,
                blocks,
                max_impacts,
                keep,
                status,
                log1,
                log2,
                imps,
                bsums,
                bimps,
                xt,
                vt,
                i,
            )
        return status, log1, log2, imps, bsums, bimps, xt, vt

    return numba.njit(parallel=parallel, cache=True, error_model="numpy")(run)


#: ``lle_orbit`` for many orbits (one per row of ``pars`` = eta, zeta, a, x_w, R and of
#: ``starts`` = t0, x0, v0): ``(status, log1, log2, impacts, block_sums, block_impacts, xs_tail,
#: vs_tail)``.
#: ``lle_batch`` runs the orbits on every core (numba threads), ``lle_batch_serial`` on one
#: (inside a worker process of a sweep, which is already one per core).
lle_batch = _make_batch(True)
lle_batch_serial = _make_batch(False)


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
        from precise_impact.core.params import check_count
        from precise_impact.core.precision import Precision

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
        import time

        from precise_impact.core.params import as_params, check_count
        from precise_impact.core.trajectory import Trajectory
        from precise_impact.errors import BudgetExceededError, IntegrationError

        params = as_params(params)
        periods = check_count(periods, "periods")
        per_period = check_count(per_period, "per_period", 100_000)
        why = self._unsupported(params)
        if why is None:
            step = max(per_period, 1)
            n = periods * step
            p = [
                float(getattr(params, k))
                for k in ("eta", "zeta", "a", "x_w", "R", "t0", "x0", "v0")
            ]
            cap = min(self.max_impacts, 4 * periods + 64)
            start = time.perf_counter()
            while True:
                xs, vs, ts = np.empty(n + 1), np.empty(n + 1), np.empty(n + 1)
                it, iv = np.empty(cap), np.empty(cap)
                st, n_imp, done = strobe(*p, n, step, self.max_impacts, it, iv, xs, vs, ts)
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
            if st == STATUS_OK:
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
                    stats={"engine": "fast", "impacts": int(n_imp)},
                )
                if per_period > 0:
                    traj.dense_t, traj.dense_x, traj.dense_v = ts, xs, vs
                return traj
            why = STATUS_TEXT[st] + f" after sample {done} of {n}"
        if not self.fallback:
            raise IntegrationError(f"the fast engine does not resolve this orbit: {why}")
        from precise_impact.solvers.heyoka.single import HeyokaSolver

        traj = HeyokaSolver(self.precision, max_impacts=self.max_impacts).solve(
            params, periods, per_period=per_period
        )
        traj.model = "fast"
        traj.stats["engine"] = f"heyoka (fallback: {why})"
        return traj


def fast_lle(
    params,
    periods: int = 6000,
    transient: int = 1000,
    initial_conditions: int = 4,
    blocks: int = 20,
    max_impacts: int = 10**8,
):
    """Both Lyapunov exponents from the compiled engine, per start and combined.

    Parameters
    ----------
    params : Params or mapping
        System; the starts are ``(x0, v0 + j/4)``, ``j = 0..initial_conditions-1`` (as the
        variational method).
    periods : int, default 6000
        Measured forcing periods per start.
    transient : int, default 1000
        Discarded periods per start (the tangent basis is *not* restarted after them).
    initial_conditions : int, default 4
        Starts, run in parallel.
    blocks : int, default 20
        Batch means per start for the standard error.
    max_impacts : int, default ``10**8``
        Impact budget per start.

    Returns
    -------
    dict
        ``lle``, ``lambda2`` (per unit time, means over the starts), ``stderr`` (batch
        means over all blocks of all starts), ``per_start`` (a list of dicts), ``impacts``
        (in the measured periods),
        ``status`` (per start: ``'ok'`` or the reason the engine stopped).

    References
    ----------
    .. [1] G. Benettin, L. Galgani, A. Giorgilli, J.-M. Strelcyn, Meccanica 15 (1980) 9-30.
    .. [2] P. C. Müller, Chaos Solitons Fractals 5 (1995) 1671-1681 (saltation matrices).
    """
    from fractions import Fraction

    from precise_impact.core.params import as_params, check_count

    params = as_params(params)
    periods = check_count(periods, "periods", minimum=1)
    transient = check_count(transient, "transient")
    n = check_count(initial_conditions, "initial_conditions", 1000, minimum=1)
    blocks = check_count(blocks, "blocks", 10_000, minimum=1)
    if blocks > periods:
        blocks = periods
    max_impacts = check_count(max_impacts, "max_impacts", 10**12, minimum=1)
    pars = np.array(
        [
            [
                float(params.eta),
                float(params.zeta),
                float(params.a),
                float(params.x_w),
                float(params.R),
            ]
        ]
        * n
    )
    starts = np.array(
        [[float(params.t0), float(params.x0), float(params.v0 + Fraction(j, 4))] for j in range(n)]
    )
    status, log1, log2, imps, bsums, _, _, _ = lle_batch(
        pars, starts, periods, transient, blocks, max_impacts, 1
    )
    T = 2 * math.pi / float(params.eta)
    per_block = periods // blocks
    time_total = periods * T
    per = [
        {
            "lle": float(log1[i] / time_total),
            "lambda2": float(log2[i] / time_total),
            "impacts": int(imps[i]),
            "status": STATUS_TEXT[int(status[i])],
        }
        for i in range(n)
    ]
    ok = [i for i in range(n) if status[i] == STATUS_OK]
    bm = (bsums[ok] / (per_block * T)).ravel() if ok else np.array([])
    return {
        "lle": float(np.mean([per[i]["lle"] for i in ok])) if ok else math.nan,
        "lambda2": float(np.mean([per[i]["lambda2"] for i in ok])) if ok else math.nan,
        "stderr": float(np.std(bm, ddof=1) / math.sqrt(len(bm))) if len(bm) > 1 else math.nan,
        "per_start": per,
        "impacts": int(imps.sum()),
        "status": [p["status"] for p in per],
    }
