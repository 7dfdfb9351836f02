"""The compiled LLE kernels of the fast engine (float64, numba): tangent flow and QR.

Exact flow matrices between impacts, the saltation matrix at each impact, a QR every
``QR_EVERY`` samples; estimators: :mod:`precise_impact.analysis.lyapunov.fast`.  References:
Benettin et al., Meccanica 15 (1980) 9-30; Müller, Chaos Solitons Fractals 5 (1995) 1671.
"""

from __future__ import annotations

import math
import os
from fractions import Fraction
from typing import Any

import numba
import numpy as np

from precise_impact.core.compat import UNSET, renamed
from precise_impact.core.impact import (
    BOUNCES_ENDLESS,
    BOUNCES_REST,
    elastic_bounce_count,
    short_elastic_flight,
)
from precise_impact.core.params import as_params, check_count
from precise_impact.core.stats import lle_stderr
from precise_impact.errors import Interrupted
from precise_impact.io.progress import ProgressArg
from precise_impact.solvers.fast.control import (
    POLL_PERIODS,
    STATUS_INTERRUPTED,
    STOP_ABORT,
    STOP_NONE,
    load_flag,
    new_flag,
    run_kernel,
    store_count,
)
from precise_impact.solvers.fast.crossing import JIT, mul2
from precise_impact.solvers.fast.dd import dd_period
from precise_impact.solvers.fast.single import (
    FLIGHT_SAMPLES,
    STATUS_BUDGET,
    STATUS_ENDLESS_BOUNCES,
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_SLOW_IMPACT,
    STATUS_TEXT,
    _flight,
    _setup,
    chatter_tail,
    compiled_saltation,
    rebase,
    sample_time,
    slow_impact,
)

EPS = 2.220446049250313e-16  # float64's machine epsilon (the bounce prediction's floor)
#: The shared prediction of R = 1 bounce sequences, compiled for the kernel.
_bounce_count = numba.njit(**JIT)(elastic_bounce_count)
_short_flight = numba.njit(**JIT)(short_elastic_flight)

__all__ = ["lle_orbit", "lle_batch", "lle_batch_serial", "fast_lle", "QR_EVERY", "LLE_KERNELS"]

#: Samples between two QRs of the tangent basis in :func:`lle_orbit` (the basis grows or
#: shrinks by at most ~e^2 per period between impacts; large growth forces a QR at once).
QR_EVERY = 4


# long: one compiled loop (numba) over periods, flights and impacts, carrying the tangent basis,
# its QR and the per-block sums in locals; the flight itself is _flight.
@numba.njit(**JIT)
def lle_orbit(  # noqa: C901, PLR0912, PLR0915 -- numba kernel: one compiled loop
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
    stop,
    counts,
    slot,
):
    """Both Lyapunov exponents of one orbit: tangent flow ``Phi``, saltation at every impact,
    Gram-Schmidt QR every ``QR_EVERY`` samples (and at block ends); the tangent basis starts
    at the identity at ``t0`` and is never restarted (the transient's logs are discarded,
    not its basis).

    Returns ``(status, log1, log2, impacts, x, v, refined)`` summed over the ``periods``
    measured periods (``impacts``: those in the measured periods; ``refined``: the flights
    refined in double-double, the whole run); ``block_sums[j]`` gets the
    first-exponent logs of block ``j`` (``blocks`` equal blocks, for batch means),
    ``block_impacts[j]`` the impacts in block ``j``, and ``xs_tail, vs_tail`` the
    stroboscopic samples of the last ``len(xs_tail)`` periods.  Every
    :data:`~precise_impact.solvers.fast.control.POLL_PERIODS` periods it publishes the
    periods done in ``counts[slot]`` and looks at the stop flag ``stop[0]``: set, it returns
    ``STATUS_INTERRUPTED`` with the sums so far.

    Notes
    -----
    The clock is local (:func:`~precise_impact.solvers.fast.single.rebase`: absolute time
    ``t + base T``).  The tangent basis is kept at the flight's anchor, ``W``: at a sample the
    basis is ``w = Phi W``.  A QR ``w = q r`` there replaces ``W`` by ``W r^-1`` (so that
    ``Phi W = q``); at an impact the basis becomes ``S Phi W`` and the new anchor's ``W``.
    """
    P, Q, w, S, err_scale, h_max, v_floor, steps = _setup(eta, zeta, a, xw)
    err_tail = err_scale * (abs(xw) + S + 1.0)  # a flight's float64 gap error, at least
    T, T_lo = dd_period(eta)
    # samples per flight from one anchor: Phi(k T) ~ exp(-zeta k T) must not underflow
    # (measured at eta = 0.005: 16 samples of exp(-62.8) each, status non-finite)
    n_buf = FLIGHT_SAMPLES
    if zeta * T * FLIGHT_SAMPLES > 600.0:
        n_buf = max(1, int(600.0 / (zeta * T)))
    buf = np.empty((n_buf, 6))
    t, x, v, base = t0, x0, v0, 0
    n_ref = 0
    W00, W01, W10, W11 = (
        1.0,
        0.0,
        0.0,
        1.0,
    )  # the basis at the anchor: columns (W00, W10), (W01, W11)
    c00, c01, c10, c11 = 1.0, 0.0, 0.0, 1.0  # the basis at the last sample
    log1 = 0.0
    log2 = 0.0
    # ln det W, tracked exactly: det Phi(dt) = exp(-2 zeta dt) (Liouville), det S = R^2.  The
    # second exponent's log at a QR is ln det(Phi W) - ln r11, not ln r22 of Gram-Schmidt:
    # after slow impacts (saltation ~1/v) the columns are parallel to rounding and r22 was
    # cancellation noise or 0 (measured: eta = 1.137, x_w = -0.97, R = 1: lambda2 = -inf
    # where lambda1 + lambda2 = -2 zeta exactly)
    D = 0.0
    lnR2 = 2.0 * math.log(R) if R > 0.0 else -math.inf
    predicted = False  # the current R = 1 bounce sequence has been predicted
    n_imp = 0
    n_meas = 0
    total = transient + periods
    keep = xs_tail.shape[0]
    per_block = max(1, periods // blocks)
    for j in range(blocks):
        block_sums[j] = 0.0
        block_impacts[j] = 0
    k = 1
    next_poll = 0
    while k <= total:
        if k >= next_poll:  # publish the progress, look at the stop flag (both atomic)
            store_count(counts, slot, k - 1)
            if load_flag(stop, 0) != STOP_NONE:
                return STATUS_INTERRUPTED, log1, log2, n_meas, x, v, n_ref
            next_poll = k + POLL_PERIODS
        st, ns, hit, tc, vc, F00, F01, F10, F11, ref = _flight(
            t, x, v, t0, T, T_lo, 1, k - base, total - base,
            eta, zeta, a, xw, P, Q, w, S, err_scale, h_max, steps, buf,
        )  # fmt: skip
        n_ref += ref
        for i in range(ns):
            xk, vk = buf[i, 0], buf[i, 1]
            p00, p01, p10, p11 = buf[i, 2], buf[i, 3], buf[i, 4], buf[i, 5]
            c00, c01, c10, c11 = mul2(p00, p01, p10, p11, W00, W01, W10, W11)
            jt = k - (total - keep) - 1
            if jt >= 0:
                xs_tail[jt], vs_tail[jt] = xk, vk
            if not (math.isfinite(xk) and math.isfinite(vk)):
                return STATUS_NONFINITE, log1, log2, n_meas, xk, vk, n_ref
            # Gram-Schmidt QR of the basis (core.linalg.gram_schmidt2) every QR_EVERY samples,
            # at the end of the transient and of every block, and whenever the basis has
            # grown large (saltations at slow impacts): the logs of a product of
            # upper-triangular factors are the sums of their logs, so fewer QRs give the
            # same exponents and block sums.  A basis shrunk below 1e-100 is taken at once
            # too (a long damped period: measured at eta = 0.005, four periods between QRs
            # underflowed the squares of Gram-Schmidt to 0, status non-finite).
            km = k - transient
            if (
                (km % QR_EVERY == 0)
                or km == 0
                or (km > 0 and km % per_block == 0)
                or k == total
                or not 1e-100 < abs(c00) + abs(c10) + abs(c01) + abs(c11) < 1e150
            ):
                r11 = math.sqrt(c00 * c00 + c10 * c10)
                q0, q1 = c00 / r11, c10 / r11
                proj = q0 * c01 + q1 * c11
                d0, d1 = c01 - proj * q0, c11 - proj * q1
                r22 = math.sqrt(d0 * d0 + d1 * d1)
                if not 1e-150 < r11 < math.inf:  # under- or overflowed: not resolved here
                    return STATUS_NONFINITE, log1, log2, n_meas, xk, vk, n_ref
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
                ts = sample_time(t0, T, T_lo, 1, k - base)
                if k > transient:
                    l1 = math.log(r11)
                    log1 += l1
                    log2 += (D - 2.0 * zeta * (ts - t)) - l1
                    j = (k - transient - 1) // per_block
                    if j < blocks:
                        block_sums[j] += l1
                D = 2.0 * zeta * (ts - t)  # det(Phi W) = det(q u) = 1 after the QR
            k += 1
        if st != STATUS_OK:
            return st, log1, log2, n_meas, x, v, n_ref
        if not hit:  # re-anchor at the last sample, its whole periods moved into base
            ts = sample_time(t0, T, T_lo, 1, k - 1 - base)
            D -= 2.0 * zeta * (ts - t)
            t, base = rebase(ts, t0, T, T_lo, base)
            x, v = buf[ns - 1, 0], buf[ns - 1, 1]
            W00, W01, W10, W11 = c00, c01, c10, c11
            continue
        if R >= 1.0:
            # R = 1 under the wall force (core.impact.elastic_bounce_count): the first short
            # flight of a bounce sequence predicts its impacts; rest on the wall or more than
            # the budget is refused at once (STATUS_ENDLESS_BOUNCES: log1, log2 carry the
            # impact's time and speed for the message), not run to the floor
            gc = a * math.cos(eta * tc) - xw
            if _short_flight(vc, gc, eta):
                if not predicted:
                    predicted = True
                    t_end = t0 + (total - base) * T  # local, as tc
                    nb, end, _ = _bounce_count(tc, vc, t_end, eta, zeta, a, xw, EPS)
                    rest = end == BOUNCES_REST or end == BOUNCES_ENDLESS
                    if rest or nb > max_impacts - n_imp:
                        return STATUS_ENDLESS_BOUNCES, tc + base * T, vc, n_meas, x, v, n_ref
            else:
                predicted = False
        if slow_impact(tc, vc, v_floor, eta, zeta, a, xw, R):
            return STATUS_SLOW_IMPACT, log1, log2, n_meas, x, v, n_ref
        # the basis just before the impact, then through the saltation matrix
        s00, s01, s10, s11 = compiled_saltation(tc, vc, eta, zeta, a, xw, R)
        W00, W01, W10, W11 = mul2(s00, s01, s10, s11, *mul2(F00, F01, F10, F11, W00, W01, W10, W11))
        D += lnR2 - 2.0 * zeta * (tc - t)
        n_imp += 1
        if k > transient:  # the impact lies before sample k: measured period k - transient
            n_meas += 1
            j = (k - transient - 1) // per_block
            if j < blocks:
                block_impacts[j] += 1
        if n_imp >= max_impacts:
            return STATUS_BUDGET, log1, log2, n_meas, x, v, n_ref
        if chatter_tail(tc, vc, eta, zeta, a, xw, R, err_tail):  # not refined hop by hop
            return STATUS_SLOW_IMPACT, log1, log2, n_meas, x, v, n_ref
        t, base = rebase(tc, t0, T, T_lo, base)
        x, v = xw, -R * vc
    store_count(counts, slot, total)
    return STATUS_OK, log1, log2, n_meas, x, v, n_ref


def _batch(
    pars,
    starts,
    periods,
    transient,
    blocks,
    max_impacts,
    abort,
    status,
    log1,
    log2,
    imps,
    bsums,
    bimps,
    xt,
    vt,
    refined,
    stop,
    counts,
    i,
):
    st, l1, l2, ni, _, _, nr = lle_orbit(
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
        stop,
        counts,
        i,
    )
    status[i], log1[i], log2[i], imps[i], refined[i] = st, l1, l2, ni, nr
    if abort and st != STATUS_OK and st != STATUS_INTERRUPTED and load_flag(stop, 0) == STOP_NONE:
        store_count(stop, 0, STOP_ABORT)  # the batch goes to the fallback: stop the others


_batch_one = numba.njit(**JIT)(_batch)


def _make_batch(parallel: bool):
    rng = numba.prange if parallel else range

    # the outputs are the caller's arrays and nothing is returned: a result to box would
    # call into Python on the way out (see precise_impact.solvers.fast.control)
    def run(
        pars,
        starts,
        periods,
        transient,
        blocks,
        max_impacts,
        abort,
        status,
        log1,
        log2,
        imps,
        bsums,
        bimps,
        xt,
        vt,
        refined,
        stop,
        counts,
    ):
        for i in rng(pars.shape[0]):
            _batch_one(
                pars,
                starts,
                periods,
                transient,
                blocks,
                max_impacts,
                abort,
                status,
                log1,
                log2,
                imps,
                bsums,
                bimps,
                xt,
                vt,
                refined,
                stop,
                counts,
                i,
            )

    return numba.njit(parallel=parallel, **JIT)(run)


#: The compiled batch kernels, by ``parallel``: ``kernel(pars, starts, periods, transient,
#: blocks, max_impacts, abort_on_failure, status, log1, log2, impacts, block_sums,
#: block_impacts, xs_tail, vs_tail, refined, stop, counts)`` fills the caller's arrays and returns
#: nothing; :func:`lle_batch` is the way to call them (signals, progress).
LLE_KERNELS = {True: _make_batch(True), False: _make_batch(False)}

#: The threads of the parallel kernel: ``'unused'``, ``'running'`` in this process, or
#: ``'lost'`` in a child forked after they started.  GNU OpenMP's pool does not survive
#: ``fork()``: the child's parallel kernel printed "Terminating: fork() called from a process
#: already using GNU OpenMP" and ran none of its orbits, and ``lyapunov(model='fast')``
#: returned LLE 0.0 with no impacts (a ``multiprocessing`` pool with the 'fork' start method
#: after one fast run in the parent).  A child that lost them runs the serial kernel.
_THREADS = {"state": "unused"}


def _lose_threads() -> None:
    if _THREADS["state"] == "running":
        _THREADS["state"] = "lost"


os.register_at_fork(after_in_child=_lose_threads)


def _kernel(parallel: bool):
    """The batch kernel to run: the parallel one unless this process lost its threads."""
    if parallel and _THREADS["state"] != "lost":
        _THREADS["state"] = "running"
        return LLE_KERNELS[True]
    return LLE_KERNELS[False]


def batch_outputs(n: int, blocks: int, keep: int) -> tuple[np.ndarray, ...]:
    """The batch kernels' output arrays for ``n`` orbits, zeroed: ``status, log1, log2,
    impacts`` (per orbit), ``block sums, block impacts`` (``n x blocks``) and the last ``keep``
    stroboscopic ``x, v`` (``n x keep``) and the flights refined in double-double (per orbit);
    the kernels write into them (nothing is returned)."""
    return (
        np.zeros(n, np.int64),
        np.zeros(n),
        np.zeros(n),
        np.zeros(n, np.int64),
        np.zeros((n, blocks)),
        np.zeros((n, blocks), np.int64),
        np.zeros((n, keep)),
        np.zeros((n, keep)),
        np.zeros(n, np.int64),
    )


def lle_batch(
    pars: np.ndarray,
    starts: np.ndarray,
    periods: int,
    transient: int,
    blocks: int,
    max_impacts: int,
    keep: int,
    *,
    parallel: bool = True,
    abort_on_failure: bool = False,
    progress: ProgressArg = False,
) -> tuple:
    """``lle_orbit`` for many orbits (one per row of ``pars`` = eta, zeta, a, x_w, R and of
    ``starts`` = t0, x0, v0), stopped cleanly by Ctrl-C or SIGTERM.

    Parameters
    ----------
    pars, starts : numpy.ndarray
        Shapes ``(n, 5)`` and ``(n, 3)``.
    periods, transient, blocks, max_impacts : int
        As :func:`lle_orbit`, for every orbit.
    keep : int
        Stroboscopic samples of the last periods kept per orbit.
    parallel : bool, default ``True``
        The orbits on every core (numba threads); ``False`` on one (inside a worker
        process of a sweep, which is already one per core).
    abort_on_failure : bool, default ``False``
        An orbit the engine does not resolve stops the others (their status is then
        ``STATUS_INTERRUPTED``): for a batch that goes to the fallback engine as a whole.
    progress : bool, None or callable, default ``False``
        Periods done over all orbits (:func:`~precise_impact.solvers.fast.control.run_kernel`).

    Returns
    -------
    tuple
        ``(status, log1, log2, impacts, block_sums, block_impacts, xs_tail, vs_tail, refined)``,
        one row per orbit.

    Raises
    ------
    Interrupted
        Ctrl-C or SIGTERM during the run (its ``partial`` is the tuple above, with the
        work done so far).
    """
    n = pars.shape[0]
    out = batch_outputs(n, blocks, keep)
    stop, counts = new_flag(), np.zeros(n, np.int64)
    length = transient + periods
    args = (pars, starts, periods, transient, blocks, max_impacts, bool(abort_on_failure))
    kernel = _kernel(bool(parallel))
    try:
        run_kernel(
            kernel,
            (*args, *out, stop, counts),
            stop,
            counts,
            n * length,
            progress,
            label="lle periods",
            what=lambda done: (
                f"interrupted after {done // max(n, 1)} of {length} periods"
                + (f" per start ({n} starts)" if n > 1 else "")
            ),
        )
    except Interrupted as e:
        e.partial = out  # the sums so far (status STATUS_INTERRUPTED)
        raise
    return out


def lle_batch_serial(pars, starts, periods, transient, blocks, max_impacts, keep, **kw) -> tuple:
    """:func:`lle_batch` on one core (inside a worker process of a sweep)."""
    return lle_batch(
        pars, starts, periods, transient, blocks, max_impacts, keep, parallel=False, **kw
    )


def kernel_inputs(params: Any, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The LLE kernels' inputs for ``n`` starts: rows ``(eta, zeta, a, x_w, R)`` and starts
    ``(t0, x0, v0 + j/4)``, ``j = 0..n-1`` (the variational method's ensemble), float64."""
    row = [float(getattr(params, k)) for k in ("eta", "zeta", "a", "x_w", "R")]
    pars = np.array([row] * n)
    starts = np.array(
        [[float(params.t0), float(params.x0), float(params.v0 + Fraction(j, 4))] for j in range(n)]
    )
    return pars, starts


def fast_lle(
    params,
    periods: int = 6000,
    transient: int = 1000,
    initial_conditions: int = 4,
    segments: Any = UNSET,
    max_impacts: int = 10**8,
    blocks: Any = UNSET,
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
    segments : int, default 20
        Batch means per start for the standard error (as ``segments`` of
        :func:`~precise_impact.analysis.lyapunov.lyapunov`).
    max_impacts : int, default ``10**8``
        Impact budget per start.
    blocks : int
        Deprecated spelling of ``segments``.

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

    params = as_params(params)
    periods = check_count(periods, "periods", minimum=1)
    transient = check_count(transient, "transient")
    n = check_count(initial_conditions, "initial_conditions", 1000, minimum=1)
    segments = renamed(segments, blocks, old="blocks", new="segments", where="fast_lle", default=20)
    blocks = check_count(segments, "segments", 10_000, minimum=1)
    if blocks > periods:
        blocks = periods
    max_impacts = check_count(max_impacts, "max_impacts", 10**12, minimum=1)
    pars, starts = kernel_inputs(params, n)
    status, log1, log2, imps, bsums, _, _, _, refined = lle_batch(
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
    lle = float(np.mean([per[i]["lle"] for i in ok])) if ok else math.nan
    # batch means, floored at the rounding of the sums: one log per period and per impact
    terms = len(ok) * periods + float(sum(imps[i] for i in ok))
    return {
        "lle": lle,
        "lambda2": float(np.mean([per[i]["lambda2"] for i in ok])) if ok else math.nan,
        "stderr": lle_stderr(bm, lle, terms, time=len(ok) * time_total) if ok else math.nan,
        "per_start": per,
        "impacts": int(imps.sum()),
        "refined_flights": int(refined.sum()),
        "status": [p["status"] for p in per],
    }
