"""Which attractor each start of a Lyapunov estimate ended on, and the exact LLE of periodic ones.

Starts on different attractors are never averaged: periodic starts are grouped by their
Newton-refined orbit (exact LLE ``ln |mu_max| / (p T)``), the others split by Student-t tests on
their LLEs and impact rates.  The tests and the finite-time error bar on a periodic orbit are
derived in ``docs/numerics.rst`` (Lyapunov exponents).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from precise_impact.analysis.lyapunov.result import means_stderr
from precise_impact.analysis.orbits.newton import find_orbit
from precise_impact.analysis.orbits.result import floquet_resolution, floquet_second_exponent
from precise_impact.analysis.periodicity import detect_period
from precise_impact.core.precision import Precision
from precise_impact.core.stats import lle_stderr
from precise_impact.errors import IntegrationError

__all__ = [
    "attribute",
    "MAX_PERIOD",
    "SPLIT_ALPHA",
    "TEST_BLOCKS",
    "TEST_BLOCK_PERIODS",
    "t_quantile",
    "tails_separated",
    "periodic_bias_bound",
]

#: Longest period looked for (as the sweeps).
MAX_PERIOD = 32

#: Family-wise two-sided level of each consistency test (module docstring, *Grouping*):
#: each of the ``n (n - 1) / 2`` pairs of non-periodic starts is tested at ``SPLIT_ALPHA / pairs``.
SPLIT_ALPHA = 1e-3

#: Blocks per start (at most) and periods per block (at least) of the per-start error bars the
#: tests use: ~20 blocks give each ~19 degrees of freedom, and 100 periods are several
#: correlation times of the local growth rates (tens of periods).
TEST_BLOCKS, TEST_BLOCK_PERIODS = 20, 100


def _same_cycle(a: np.ndarray, b: np.ndarray, tol: float) -> bool:
    """The last ``p`` samples of two starts are the same cycle up to a shift."""
    p = len(a)
    return any(np.max(np.abs(np.roll(a, s, axis=0) - b)) <= tol for s in range(p))


def _beta_cf(a: float, b: float, x: float) -> float:
    """The continued fraction of the regularized incomplete beta function (modified Lentz;
    Press et al., *Numerical Recipes*, 3rd ed., sec. 6.4), to float64's rounding."""
    tiny = 1e-300
    c, d = 1.0, 1.0 - (a + b) * x / (a + 1.0)
    d = 1.0 / (d if abs(d) > tiny else tiny)
    h = d
    for m in range(1, 100_000):
        for aa in (
            m * (b - m) * x / ((a + 2 * m - 1) * (a + 2 * m)),
            -(a + m) * (a + b + m) * x / ((a + 2 * m) * (a + 2 * m + 1)),
        ):
            d = 1.0 + aa * d
            d = 1.0 / (d if abs(d) > tiny else tiny)
            c = 1.0 + aa / c
            c = c if abs(c) > tiny else tiny
            h *= d * c
        if abs(d * c - 1.0) <= 1e-16:
            break
    return h


def _log_beta_half(a: float) -> float:
    """``ln B(a, 1/2) = ln Gamma(a) + ln sqrt(pi) - ln Gamma(a + 1/2)``; for large ``a`` from
    the asymptotic series of ``ln Gamma(a + 1/2) - ln Gamma(a)`` (the difference of two
    ``lgamma`` values ~1e5 lost ~5 digits at a = 5e4)."""
    if a < 64.0:
        return math.lgamma(a) + 0.5 * math.log(math.pi) - math.lgamma(a + 0.5)
    r = 1.0 / a
    diff = 0.5 * math.log(a) - r / 8 + r**3 / 192 - r**5 / 640 + 17 * r**7 / 14336
    return 0.5 * math.log(math.pi) - diff


def _betainc(a: float, b: float, x: float, y: float, log_front: float) -> float:
    """``I_x(a, b)``, the regularized incomplete beta function, in float64; ``y = 1 - x`` and
    ``log_front = a ln x + b ln y - ln B(a, b)`` formed by the caller without cancellation
    (``1 - x``, or ``a ln x`` for ``x`` near 1 and ``a`` ~1e5, lose digits)."""
    if x <= 0.0:
        return 0.0
    if y <= 0.0:
        return 1.0
    front = math.exp(log_front)
    if x < (a + 1.0) / (a + b + 2.0):
        return front * _beta_cf(a, b, x) / a
    return 1.0 - front * _beta_cf(b, a, y) / b


@functools.lru_cache(maxsize=256)
def _t_quantile_cached(alpha: float, dof: float) -> float:
    """The two-sided Student-t quantile by Newton on the tail probability inside a bisection
    bracket, in float64 (no shared mpmath state): ~5 tail evaluations of ~20 us each, where 60
    bisection steps in mpmath took 15-110 ms (the attractor tests spent 95 % of their time in
    them: one quantile per Welch test, at a non-integer dof).  Against a 40-digit mpmath root:
    (16 + dof) ulps relative (tests/analysis/test_attractors.py)."""
    if not math.isfinite(dof) or dof > 1e6:
        return math.sqrt(2.0) * _erfinv(1.0 - alpha)
    nu = float(dof)

    log_b = _log_beta_half(nu / 2.0)

    def tail(x: float) -> float:  # two-sided tail probability P(|t_nu| > x)
        s2 = x * x / nu
        log_front = -nu / 2.0 * math.log1p(s2) + 0.5 * (math.log(s2) - math.log1p(s2)) - log_b
        return _betainc(nu / 2.0, 0.5, 1.0 / (1.0 + s2), s2 / (1.0 + s2), log_front)

    # its derivative is -2 times the density, (2 / (sqrt(nu) B(nu/2, 1/2))) (1 + x^2/nu)^-(nu+1)/2
    log_c = math.log(2.0) - 0.5 * math.log(nu) - log_b
    lo, hi = 0.0, 1.0
    while tail(hi) > alpha:
        lo, hi = hi, 2.0 * hi
    x = 0.5 * (lo + hi)
    for _ in range(200):
        f = tail(x) - alpha
        lo, hi = (x, hi) if f > 0 else (lo, x)
        density = math.exp(log_c - (nu + 1) / 2 * math.log1p(x * x / nu))
        new = x + f / density if density > 0 else 0.5 * (lo + hi)
        if not lo < new < hi:
            new = 0.5 * (lo + hi)
        if abs(new - x) <= 4e-16 * new:
            return new
        x = new
    return x


def _erfinv(y: float) -> float:
    """``erfinv(y)`` for ``0 <= y < 1`` by Newton on ``math.erf`` (float64)."""
    x = 0.0 if y <= 0 else math.sqrt(-math.log((1.0 - y) / 2.0))  # a start on the right side
    for _ in range(100):
        step = (math.erf(x) - y) / (2.0 / math.sqrt(math.pi) * math.exp(-x * x))
        x -= step
        if abs(step) <= 1e-16 * max(abs(x), 1.0):
            break
    return x


def t_quantile(alpha: float, dof: float) -> float:
    """Two-sided Student-t quantile: ``x`` with ``P(|t_dof| > x) = alpha``.

    Parameters
    ----------
    alpha : float
        Two-sided tail probability, ``0 < alpha < 1``.
    dof : float
        Degrees of freedom (``> 0``; ``inf`` or above ``1e6``: the normal quantile).

    Returns
    -------
    float
        The quantile (mpmath's regularised incomplete beta function, bisected to ~1e-17).

    Examples
    --------
    >>> import math
    >>> from precise_impact.analysis.lyapunov.attractors import t_quantile
    >>> round(t_quantile(0.05, math.inf), 4), round(t_quantile(0.05, 10), 4)
    (1.96, 2.2281)
    """
    return _t_quantile_cached(
        float(alpha), round(float(dof), 6) if math.isfinite(dof) else math.inf
    )


def _welch(
    d: float, s1: float, n1: int, s2: float, n2: int, alpha: float
) -> tuple[float, float] | None:
    """``(|d| / sqrt(s1^2 + s2^2), K)`` of a Welch test, or ``None`` when it is not available."""
    if not (math.isfinite(d) and math.isfinite(s1) and math.isfinite(s2)) or n1 < 2 or n2 < 2:
        return None
    v = s1 * s1 + s2 * s2
    if v == 0:
        return (0.0 if d == 0 else math.inf), 0.0
    dof = v * v / ((s1**4 / (n1 - 1) if s1 else 0.0) + (s2**4 / (n2 - 1) if s2 else 0.0))
    return abs(d) / math.sqrt(v), t_quantile(alpha, dof)


def tails_separated(a: np.ndarray, b: np.ndarray) -> tuple[bool, float]:
    """Whether two tails of stroboscopic samples are separated at their own resolution.

    Parameters
    ----------
    a, b : numpy.ndarray
        Shape ``(n, 2)`` and ``(m, 2)``: ``(x, v)`` samples, ``n, m >= 2``.

    Returns
    -------
    (bool, float)
        ``separated`` (the smallest distance between a point of ``a`` and one of ``b``
        exceeds the largest nearest-neighbour distance within ``a`` and within ``b``: single
        linkage at the samples' resolution puts them in different clusters) and that
        smallest distance.
    """
    a, b = np.asarray(a, float), np.asarray(b, float)
    cross = float(np.min(np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1])))

    def coarsest(s):
        d = np.hypot(s[:, None, 0] - s[None, :, 0], s[:, None, 1] - s[None, :, 1])
        np.fill_diagonal(d, np.inf)
        return float(np.max(np.min(d, axis=1)))

    return cross > max(coarsest(a), coarsest(b)), cross


def periodic_bias_bound(orbit: Any) -> float:
    """Bound ``B`` on the finite-time offset ``B / t`` of the LLE estimate on a periodic orbit.

    Parameters
    ----------
    orbit : PeriodicOrbit
        A refined orbit (:func:`~precise_impact.analysis.orbits.newton.find_orbit`).

    Returns
    -------
    float
        ``max_c ln cond(V_c) + max_r max_i |ln sigma_i(Phi_r) - lambda r T|`` (module
        docstring, *Finite-time error bar*), from the compiled engine's monodromy at each
        cycle point (float64); ``nan`` where the engine does not resolve the orbit.
    """
    from precise_impact.solvers.fast.single import STATUS_OK, orbit_map  # noqa: PLC0415 -- heavy: numba engine, loaded on first use

    p = orbit.params
    if not p.zeta < 1 or (p.zeta == 0 and p.eta == 1):
        return math.nan
    sys = (float(p.eta), float(p.zeta), float(p.a), float(p.x_w), float(p.R))
    t0, T, lam, per = float(p.t0), 2 * math.pi / float(p.eta), float(orbit.lle), int(orbit.period)
    x, v = float(orbit.x), float(orbit.v)
    cond = 0.0
    rem = 0.0
    for r in range(per):
        st, xr, vr, a00, a01, a10, a11, _ = orbit_map(
            *sys, t0, x, v, r
        )  # r periods from the first point
        if st != STATUS_OK:
            return math.nan
        if r:
            sv = np.linalg.svd(np.array([[a00, a01], [a10, a11]]), compute_uv=False)
            with np.errstate(divide="ignore"):
                rem = max(rem, float(np.max(np.abs(np.log(sv) - lam * r * T))))
        st, _, _, m00, m01, m10, m11, _ = orbit_map(
            *sys, t0, xr, vr, per
        )  # the monodromy at that point
        if st != STATUS_OK:
            return math.nan
        _, V = np.linalg.eig(np.array([[m00, m01], [m10, m11]]))
        cond = max(cond, float(np.linalg.cond(V)))
    return math.log(cond) + rem if math.isfinite(cond) and cond > 0 else math.inf


def _weighted(values: Sequence[float], weights: Sequence[float]) -> float:
    w = np.asarray(weights, float)
    return float(np.sum(np.asarray(values, float) * w) / np.sum(w))


def attribute(
    result: Any,
    tails: Sequence[tuple[np.ndarray, np.ndarray]],
    per_start: Sequence[tuple],
    precision: str = "float64",
    impact_blocks: Sequence[Any] | None = None,
    periods: Sequence[int] | None = None,
    alpha: float = SPLIT_ALPHA,
) -> Any:
    """Group the starts of ``result`` by attractor; put the headline attractor's LLE in place.

    Parameters
    ----------
    result : LyapunovResult
        A finished estimate (changed in place and returned).
    tails : sequence of (x, v) arrays
        Each start's last stroboscopic samples (at least ``3 MAX_PERIOD`` for a period test).
    per_start : sequence of (float, float, array)
        Each start's own finite-time ``lambda1``, ``lambda2`` and batch means of ``lambda1``.
    precision : str, default ``'float64'``
        Precision of the Newton refinement (``'float64'`` or ``'mp:BITS'``).
    impact_blocks : sequence of arrays or None, default ``None``
        Each start's impacts per period in each block (the impact-rate test and its error
        bar); an entry may be ``None``.  ``None``: no impact-rate test, and the per-start
        rate is ``result.n_impacts`` shared out by measured periods (only meaningful for one start).
    periods : sequence of int or None, default ``None``
        Each start's measured periods; ``None``: ``result.periods`` shared out evenly.
    alpha : float, default :data:`SPLIT_ALPHA`
        Family-wise two-sided level of each consistency test between non-periodic starts
        (each pair at ``alpha / pairs``).

    Returns
    -------
    LyapunovResult
        With ``stats['attractors']`` (one entry per attractor: ``id``, ``kind``
        ``'periodic'`` or ``'not periodic'``, ``starts``, ``lle`` (the group's finite-time
        value), ``stderr``, ``impact_rate``, and for a periodic one ``period``, ``impacts``,
        ``multipliers``, ``floquet_lle``, ``residual``, ``bias_bound``),
        ``stats['per_start']`` (per start: ``lle``, ``stderr``, ``impact_rate``,
        ``impact_rate_stderr``, ``periods``, ``attractor`` = the group's ``id``; existing
        per-start entries are kept and extended), ``stats['headline_attractor']`` and
        ``stats['headline_rule']``, ``stats['lle_source']`` (``'floquet'``,
        ``'finite-time'``), ``stats['finite_time']`` (the headline group's finite-time
        estimate: ``lle``, ``stderr`` = ``sqrt(stderr_batch^2 + bias^2 + resolution^2)``,
        ``stderr_batch``, ``bias_bound`` (``None`` off periodic orbits), ``resolution``,
        ``spectrum``, ``note``) and, when the starts split, ``stats['warning']`` and
        ``stats['split_tests']`` (the pairs of starts tested and the outcome).  ``lle``,
        ``spectrum`` and ``stderr`` are the headline group's: Floquet values on a periodic
        orbit (``stderr``: the float64 rounding of the multipliers, ``1e-12 / (p T)``), else
        the mean over its starts and the batch-means error of their blocks (one group of
        every start: the estimate is left as it was).

    References
    ----------
    .. [1] M. di Bernardo et al., *Piecewise-smooth Dynamical Systems* (2008), sec. 6
           (Floquet multipliers of impacting orbits).
    .. [2] B. L. Welch, Biometrika 34 (1947) 28-35 (unequal-variance comparison of means).
    """
    params = result.params
    T = 2 * math.pi / float(params.eta)
    n = len(tails)
    if periods is None:
        periods = [result.periods // n + (1 if j < result.periods % n else 0) for j in range(n)]
    periods = [int(k) for k in periods]
    dur = [k * T for k in periods]
    blocks = [np.asarray(ps[2], float).ravel() for ps in per_start]
    eps = float(Precision.parse(precision).eps_fraction)
    starts = _per_start(result, per_start, blocks, periods, impact_blocks, eps, dur)
    groups, loose = _periodic_groups(params, tails, precision)
    free, tests = _split_loose(starts, tails, loose, alpha)
    groups = sorted(groups + free, key=lambda g: min(g["starts"]))
    for i, g in enumerate(groups):
        g["id"] = i
        g["starts"].sort()
        st = g["starts"]
        g["lle"] = _weighted([starts[j]["lle"] for j in st], [dur[j] for j in st])
        g["stderr"] = lle_stderr(
            np.concatenate([blocks[j] for j in st]),
            g["lle"],
            sum(starts[j]["_terms"] for j in st),
            eps,
            sum(dur[j] for j in st),
        )
        rates = [starts[j]["impact_rate"] for j in st]
        g["impact_rate"] = (
            _weighted(rates, [periods[j] for j in st]) if all(map(math.isfinite, rates)) else None
        )
        for j in st:
            starts[j]["attractor"] = i
    if len(groups) == 1:  # every start on one attractor: the run's own batch-means error
        groups[0]["stderr"] = result.lle_stderr
    _periodic_error_bars(groups, starts, dur, T)
    head, finite, source = _headline(result, groups, per_start, dur, T)
    _record(result, groups, starts, per_start, head, finite, source, tests)
    return result


def _per_start(
    result: Any,
    per_start: Sequence[tuple],
    blocks: list[np.ndarray],
    periods: list[int],
    impact_blocks: Sequence[Any] | None,
    eps: float,
    dur: list[float],
) -> list[dict]:
    """Step 1 of :func:`attribute`: each start's LLE, its batch-means error floored at the
    rounding of its sum (``eps``: the working precision's; one log per period and per impact),
    impact rate and the rate's error (floor ``1 / N``: an integer count over ``N`` periods)."""
    n = len(blocks)
    starts = []
    for j in range(n):
        ib = None if impact_blocks is None else impact_blocks[j]
        if ib is not None:
            ib = np.asarray(ib, float).ravel()
            rate = float(np.mean(ib))
            rate_se = math.hypot(
                means_stderr(ib) if len(ib) > 1 else math.nan, 1.0 / max(periods[j], 1)
            )
        else:
            rate = result.n_impacts / max(sum(periods), 1) if n == 1 else math.nan
            rate_se = math.nan
        lle = float(per_start[j][0])
        terms = periods[j] * (1.0 + (rate if math.isfinite(rate) else 0.0))
        starts.append(
            {
                "lle": lle,
                "stderr": lle_stderr(blocks[j], lle, terms, eps, dur[j]),
                "_terms": terms,
                "impact_rate": rate,
                "impact_rate_stderr": rate_se,
                "periods": periods[j],
                "_nb": len(blocks[j]),
                "_nr": 0 if ib is None else len(ib),
            }
        )
    return starts


def _periodic_groups(
    params: Any, tails: Sequence[tuple[np.ndarray, np.ndarray]], precision: str
) -> tuple[list[dict], list[int]]:
    """Step 2: starts whose tails are periodic, refined by Newton and grouped by orbit (one
    Newton run per orbit); the others are returned as ``loose`` indices."""
    groups: list[dict] = []
    loose: list[int] = []
    for j, (xs, vs) in enumerate(tails):
        xs, vs = np.asarray(xs, float), np.asarray(vs, float)
        p = detect_period(xs, vs, MAX_PERIOD) if len(xs) >= 3 * MAX_PERIOD else 0
        if not params.zeta < 1:
            p = 0  # the orbit finder is underdamped only: an overdamped start stays finite-time
        orbit = None
        if p > 0:
            cycle = np.column_stack([xs[-p:], vs[-p:]])
            tol = 1e-6 * (1 + float(np.max(np.abs(cycle))))
            known = next(
                (g for g in groups if g["period"] == p and _same_cycle(g["_cycle"], cycle, tol)),
                None,
            )
            if known is not None:  # an orbit already refined: no second Newton run
                known["starts"].append(j)
                continue
            try:
                orbit = find_orbit(
                    params, p, guess=(float(xs[-1]), float(vs[-1])), precision=precision
                )
            except IntegrationError:  # Newton did not settle (e.g. a contact): not claimed
                orbit = None
        if orbit is None:
            loose.append(j)
            continue
        groups.append(
            {
                "kind": "periodic",
                "starts": [j],
                "period": p,
                "impacts": orbit.impacts,
                "multipliers": [
                    [float(complex(m).real), float(complex(m).imag)] for m in orbit.multipliers
                ],
                "floquet_lle": orbit.lle,
                "residual": orbit.residual,
                "_orbit": orbit,
                "_cycle": cycle,
            }
        )
    return groups, loose


def _consistent(
    starts: list[dict],
    tails: Sequence[tuple[np.ndarray, np.ndarray]],
    j: int,
    k: int,
    level: float,
) -> dict:
    """The tests between two non-periodic starts (module docstring, *Grouping*); the record
    has ``same`` = whether every available test found them consistent."""
    a, b = starts[j], starts[k]
    rec: dict = {"starts": [j, k]}
    ok = True
    w = _welch(a["lle"] - b["lle"], a["stderr"], a["_nb"], b["stderr"], b["_nb"], level)
    if w is not None:
        rec["lle_z"], rec["lle_k"] = w
        ok &= w[0] <= w[1]
    w = _welch(
        a["impact_rate"] - b["impact_rate"],
        a["impact_rate_stderr"],
        a["_nr"],
        b["impact_rate_stderr"],
        b["_nr"],
        level,
    )
    if w is not None:
        rec["rate_z"], rec["rate_k"] = w
        ok &= w[0] <= w[1]
    ta, tb = (np.column_stack([np.asarray(c, float) for c in tails[i]]) for i in (j, k))
    if len(ta) >= 2 and len(tb) >= 2:
        sep, dist = tails_separated(ta, tb)
        rec["tail_distance"], rec["tails_separated"] = dist, sep
        if "lle_z" not in rec and "rate_z" not in rec:  # the tails decide only without bars
            ok &= not sep
    rec["same"] = bool(ok)
    return rec


def _split_loose(
    starts: list[dict],
    tails: Sequence[tuple[np.ndarray, np.ndarray]],
    loose: list[int],
    alpha: float,
) -> tuple[list[dict], list[dict]]:
    """Step 3: non-periodic starts split into attractors; a start joins the first group every
    member of which it is consistent with (Bonferroni over the pairs), else starts a group."""
    tests: list[dict] = []
    level = alpha / max(1, len(loose) * (len(loose) - 1) // 2)
    free: list[dict] = []

    def same(j: int, k: int) -> bool:
        tests.append(_consistent(starts, tails, j, k, level))
        return tests[-1]["same"]

    for j in loose:
        g = next((g for g in free if all(same(j, k) for k in g["starts"])), None)
        if g is None:
            free.append({"kind": "not periodic", "starts": [j]})
        else:
            g["starts"].append(j)
    return free, tests


def _periodic_error_bars(groups: list[dict], starts: list[dict], dur: list[float], T: float):
    """Step 4: on a periodic orbit the finite-time error bar adds the ``O(1/t)`` offset bound
    and the float64 resolution of the Floquet value (module docstring)."""
    for g in groups:
        if g["kind"] != "periodic":
            continue
        st = g["starts"]
        o = g["_orbit"]
        B = periodic_bias_bound(o)
        g["bias_bound"] = B
        res = floquet_resolution(o.lle, o.period * T)
        for j in st:
            starts[j]["stderr_batch"] = starts[j]["stderr"]
            starts[j]["stderr"] = math.sqrt(starts[j]["stderr"] ** 2 + (B / dur[j]) ** 2 + res**2)
        bias = B * len(st) / sum(dur[j] for j in st)  # the weighted mean of B / t_j
        g["stderr_batch"] = g["stderr"]
        g["stderr"] = math.sqrt(g["stderr"] ** 2 + bias**2 + res**2)
        g["_ft"] = (bias, res)


def _headline(
    result: Any, groups: list[dict], per_start: Sequence[tuple], dur: list[float], T: float
) -> tuple[dict, dict, str]:
    """Step 5: the headline attractor (most starts; ties: the earliest start) and its values
    put in ``result`` (Floquet values on a periodic orbit, never an average over attractors)."""
    head = max(groups, key=lambda g: (len(g["starts"]), -min(g["starts"])))
    st = head["starts"]
    lam2 = [per_start[j][1] for j in st]
    finite = {
        "lle": head["lle"],
        "stderr": head["stderr"],
        "stderr_batch": head.get("stderr_batch", head["stderr"]),
        "bias_bound": None,
        "resolution": 0.0,
        "spectrum": None
        if result.spectrum is None
        else (head["lle"], _weighted(lam2, [dur[j] for j in st])),
        "starts": list(st),
        "note": "batch-means standard error of the headline attractor's starts; the O(1/t) "
        "end effect of the never-restarted tangent basis is not included (far below it off "
        "periodic orbits)",
    }
    if len(groups) == 1:  # one attractor: the estimate as it was
        finite.update(lle=result.lle, spectrum=result.spectrum)
    if head["kind"] == "periodic":
        bias, res = head["_ft"]
        finite.update(
            bias_bound=bias,
            resolution=res,
            stderr=head["stderr"],
            note="sqrt(stderr_batch^2 + bias_bound^2 + resolution^2): bias_bound bounds the "
            "O(1/t) finite-time offset on this periodic orbit (ln cond of the monodromy's "
            "eigenvectors and the partial-orbit factor, over the starts' durations), resolution "
            "is the float64 resolution 1e-12 / (p T) of the Floquet value",
        )
        o = head["_orbit"]
        mu = [abs(complex(m)) for m in o.multipliers]
        pT = o.period * T
        result.lle = o.lle
        if result.spectrum is not None:
            zeta, R = float(o.params.zeta), float(o.params.R)
            result.spectrum = (
                o.lle,
                floquet_second_exponent(o.lle, mu[1], zeta, R, o.impacts, pT),
            )
        result.lle_stderr = floquet_resolution(o.lle, pT)
        return head, finite, "floquet"
    if len(groups) > 1:  # the headline attractor alone, never an average over attractors
        result.lle = head["lle"]
        if result.spectrum is not None:
            result.spectrum = finite["spectrum"]
        result.lle_stderr = head["stderr"]
    return head, finite, "finite-time"


def _record(
    result: Any,
    groups: list[dict],
    starts: list[dict],
    per_start: Sequence[tuple],
    head: dict,
    finite: dict,
    source: str,
    tests: list[dict],
) -> None:
    """Step 6: the attractors, per-start values, headline and warning into ``result.stats``."""
    n = len(starts)
    for g in groups:
        for k in ("_orbit", "_cycle", "_ft"):
            g.pop(k, None)
    old = result.stats.get("per_start")
    rows = []
    for j, s in enumerate(starts):
        row = (
            dict(old[j])
            if isinstance(old, list) and j < len(old) and isinstance(old[j], dict)
            else {}
        )
        row.update({k: v for k, v in s.items() if not k.startswith("_")})
        row.setdefault("lambda2", float(per_start[j][1]))
        rows.append(row)
    result.stats["per_start"] = rows
    result.stats["attractors"] = groups
    result.stats["headline_attractor"] = head["id"]
    result.stats["headline_rule"] = (
        "the attractor with the most starts (ties: the one with the earliest start); "
        "never an average over attractors"
    )
    result.stats["lle_source"] = source
    result.stats["finite_time"] = finite
    if tests:
        result.stats["split_tests"] = tests
    if len(groups) > 1:
        desc = "; ".join(
            f"#{g['id']} starts {g['starts']} "
            + (
                f"period {g['period']} LLE {g['floquet_lle']:.6g}"
                if g["kind"] == "periodic"
                else f"not periodic LLE {g['lle']:.6g} +- {g['stderr']:.2g}"
            )
            for g in groups
        )
        result.stats["warning"] = (
            f"the {n} starts end on {len(groups)} attractors ({desc}); lle is attractor "
            f"#{head['id']}'s ({len(head['starts'])} of {n} starts, the most; ties: the "
            "earliest start), not an average"
        )
