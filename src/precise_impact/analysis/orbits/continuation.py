"""Pseudo-arclength continuation of periodic orbits with their bifurcations.

Follows the impact-sequence system (:mod:`~precise_impact.analysis.orbits.shooting`) through
folds and past grazing; locates grazing, period-doubling (with branch switching), fold and
Neimark-Sacker points by regula falsi on test functions (``docs/numerics.rst``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from precise_impact.analysis.orbits.branch import Bifurcation, Branch, ContinuationResult
from precise_impact.analysis.orbits.newton import find_orbit
from precise_impact.analysis.orbits.result import UNDERFLOW, area_preserving, classify
from precise_impact.analysis.orbits.shooting import CONTINUABLE, ShootingSystem, from_orbit
from precise_impact.core.params import Params, check_count, exact, params_or_values
from precise_impact.errors import ConvergenceError, ParameterError
from precise_impact.io.progress import Progress

__all__ = ["continue_orbit"]

_EPS = 2.0**-52
_TESTS = ("graze_interior", "graze_impact", "period-doubling", "fold", "neimark-sacker")


class _Curve:
    """The branch equations in ``y = (u, lam)`` and their Newton corrector."""

    def __init__(self, system: ShootingSystem) -> None:
        self.s = system

    def jac(self, y):
        G, Gu = self.s.residual(y[:-1], y[-1], jacobian=True)
        return G, np.hstack([Gu, self.s.parameter_derivative(y[:-1], y[-1])[:, None]])

    def tangent(self, y, prev):
        _, J = self.jac(y)
        A = np.vstack([J, prev])
        b = np.zeros(len(y))
        b[-1] = 1.0
        try:
            t = np.linalg.solve(A, b)
        except np.linalg.LinAlgError:
            return None
        t /= np.linalg.norm(t)
        return t if t @ prev >= 0 else -t

    def correct(self, y, tau, base, s, fixed_lam=False, iterations=12):
        """Newton on ``G = 0`` and ``tau . (y - base) = s`` (or ``lam`` fixed); ``(y, iterations)``
        or ``(None, n)``."""
        y = y.copy()
        for it in range(1, iterations + 1):
            try:
                G, J = self.jac(y)
            except ValueError:
                return None, it
            if fixed_lam:
                A, r = J[:, :-1], G
            else:
                A, r = np.vstack([J, tau]), np.append(G, tau @ (y - base) - s)
            try:
                dy = np.linalg.solve(A, -r)
            except np.linalg.LinAlgError:
                return None, it
            if not np.all(np.isfinite(dy)):
                return None, it
            if fixed_lam:
                y[:-1] += dy
            else:
                y += dy
            scale = 1 + float(np.max(np.abs(y)))
            if float(np.max(np.abs(dy))) <= 64 * _EPS * scale:
                try:
                    G = self.s.residual(y[:-1], y[-1])
                except ValueError:
                    return None, it
                # rounding of the closed forms over flights of length ~p T: a few hundred eps
                return (y, it) if float(np.max(np.abs(G))) <= 1e-10 * scale else (None, it)
        return None, iterations


def _ordered(system: ShootingSystem, y) -> bool:
    """Impact times strictly increasing within one orbit (the sequence the system describes)."""
    if system.impacts == 0:
        return True
    try:
        pT = system.period * system.forcing_period(system.values(y[-1]))
    except ValueError:
        return False
    t = np.append(y[0:-1:2], y[0] + pT)
    return bool(np.all(np.diff(t) > 1e-9 * (1 + abs(t[0]))))


class _Point:
    """A corrected branch point with its multipliers and test functions."""

    def __init__(self, system: ShootingSystem, y, tau) -> None:
        self.y, self.tau = y.copy(), tau.copy()
        u, lam = y[:-1], float(y[-1])
        self.lam = lam
        try:
            self.M = system.monodromy(u, lam)
        except ZeroDivisionError:
            # an impact arrives tangentially (v^- = 0 exactly): the grazing point itself, where
            # the saltation matrix and so M are unbounded.  Its multipliers are undefined (NaN:
            # JSON null; the larger one grows without bound towards it, so the stability is
            # the limit's, unstable) and only the grazing tests are kept.
            self.M = np.full((2, 2), math.nan)
        mu = (
            np.linalg.eigvals(self.M)
            if np.all(np.isfinite(self.M))
            else [complex(math.nan, math.nan)] * 2
        )
        self.mu = sorted((complex(m) for m in mu), key=lambda m: -abs(m))
        self.states = system.states(u, lam)
        gi, gv = system.grazing_tests(u, lam)
        tr, det = (
            (float(np.trace(self.M)), float(np.linalg.det(self.M)))
            if np.all(np.isfinite(self.M))
            else (math.nan, math.nan)
        )
        complex_pair = tr * tr < 4 * det
        vals = system.values(lam)
        T = system.forcing_period(vals)
        zeta, R = vals[1], vals[4]
        # each impact's arrival velocity v^- from its flight (negative: from beyond the wall)
        self.impact_v = [c[2] for c in system._cycle(u, vals)[0]] if system.impacts else []
        neutral = area_preserving(zeta, R, system.impacts)
        # det M in closed form (exact up to one rounding of exp): never rounding noise of either
        # sign
        det_exact = R ** (2 * system.impacts) * math.exp(-2 * zeta * system.period * T)
        ns = (det_exact - 1) if complex_pair and not neutral else math.nan
        self.tests = {
            "graze_interior": gi,
            "graze_impact": gv,
            "period-doubling": 1 + tr + det,
            "fold": 1 - tr + det,
            "neimark-sacker": ns,
        }
        self.admissible = bool(gi >= 0 and gv >= 0)
        self.stability = classify(self.mu, neutral)
        if not math.isfinite(abs(self.mu[0])):
            self.lle = math.nan  # a tangential impact: multipliers undefined (above)
        elif self.stability == "elliptic":
            self.lle = 0.0  # |mu| = 1 exactly (det M = 1, complex pair)
        elif abs(self.mu[0]) > UNDERFLOW:
            self.lle = math.log(abs(self.mu[0])) / (system.period * T)
        else:  # M underflowed (zeta p T > ~670): the logarithm from the scaled monodromy
            self.lle = system.floquet_lle(u, lam)


def _sign_change(a: float, b: float) -> bool:
    """``a`` to ``b`` changes sign; ``+inf`` (a grazing test with no interior maximum) counts
    as positive, so a step from no maximum to one above the wall is a sign change too."""
    return not (math.isnan(a) or math.isnan(b)) and (a == 0 or (a < 0) != (b < 0)) and b != 0


def _locate(curve: _Curve, p0: _Point, p1: _Point, test: str):
    """The zero of ``test`` between two branch points: Illinois on the arclength from ``p0``."""
    system = curve.s
    s_hi = float(p0.tau @ (p1.y - p0.y))
    lo, hi, flo, fhi = 0.0, s_hi, p0.tests[test], p1.tests[test]
    best, side = p0, 0
    for _ in range(80):
        s = (lo * fhi - hi * flo) / (fhi - flo) if fhi != flo else 0.5 * (lo + hi)
        if not (min(lo, hi) < s < max(lo, hi)):
            s = 0.5 * (lo + hi)
        y, _ = curve.correct(p0.y + s * p0.tau, p0.tau, p0.y, s)
        if y is None:
            break
        pt = _Point(system, y, p0.tau)
        f = pt.tests[test]
        if math.isnan(f):
            break  # (+inf, no interior maximum, is positive: bisection while an end is inf)
        best = pt
        if f == 0:
            break
        if (f < 0) == (flo < 0):
            lo, flo = s, f
            if side == -1:
                fhi /= 2
            side = -1
        else:
            hi, fhi = s, f
            if side == 1:
                flo /= 2
            side = 1
        if abs(hi - lo) <= 4 * _EPS * (1 + float(np.max(np.abs(y)))):
            break
    return best


def _pairs(curve: _Curve, a: _Point, b: _Point) -> list:
    """``(test, p, q)``: the intervals on which each test's sign is compared.  The grazing
    tests on ``(a, b)``; the multiplier tests too, unless an impact turns tangential between
    ``a`` and ``b`` (``graze_impact`` changes sign): there they have a pole (the saltation
    matrix's ``1 / v^-``), whose sign change would cancel a root's in the same step however
    wide the steps are (a wider range, longer steps), so each side of that point is compared
    on its own, from points ``1e-6`` of the step beside it."""
    sides = [(a, b)]
    if _sign_change(a.tests["graze_impact"], b.tests["graze_impact"]):
        z = _locate(curve, a, b, "graze_impact")
        s_z, s_b = float(a.tau @ (z.y - a.y)), float(a.tau @ (b.y - a.y))
        near = [_point_at(curve, a, s_z + d * 1e-6 * s_b) for d in (-1, 1)]
        if None not in near:
            sides = [(a, near[0]), (near[1], b)]
    out = [(t, a, b) for t in _TESTS if t.startswith("graze")]
    return out + [(t, p, q) for p, q in sides for t in _TESTS if not t.startswith("graze")]


def _point_at(curve: _Curve, p0: _Point, s: float) -> _Point | None:
    """The branch point at arclength ``s`` along ``p0.tau`` (``None``: not found)."""
    y, _ = curve.correct(p0.y + s * p0.tau, p0.tau, p0.y, s)
    return None if y is None else _Point(curve.s, y, p0.tau)


def _is_root(z: _Point, test: str) -> bool:
    """The located point is a zero of a multiplier test, not the sign change through infinity
    that ``M`` (with ``1 / v^-`` in a saltation matrix) makes at a grazing impact.  The tests
    are 2x2 determinants of ``M +- I``: rounding leaves ``~eps (1 + |tr M| + |det M|)``, and
    a regula falsi that converged leaves little more; a pole leaves them huge."""
    M = z.M
    scale = (
        1 + abs(float(np.trace(M))) + abs(float(np.linalg.det(M))) + float(np.max(np.abs(M))) ** 2
    )
    return abs(z.tests[test]) <= 1e-8 * scale and float(np.max(np.abs(M))) < 1e8


_GRAZING_DETAIL = {
    "graze_interior": (
        "a flight's interior maximum touches the wall (an impact appears or vanishes)"
    ),
    "graze_impact": "an impact's approach velocity vanishes (the impact becomes tangential)",
}


def _trace(
    curve: _Curve,
    start: _Point,
    lo: float,
    hi: float,
    max_points: int,
    progress,
    done: list,
    virtual: float = 0.1,
):
    """Continue from ``start`` along ``start.tau`` until ``lam`` leaves ``[lo, hi]``, or the
    orbit has stayed virtual over ``virtual`` of the range; the points and why it stopped."""
    system = curve.s
    span = hi - lo
    pts = [start]
    travelled = 0.0

    def ds_cap(tau):
        return min(0.5 * math.sqrt(system.size), span / 40 / max(abs(tau[-1]), 1e-3))

    ds = 0.25 * ds_cap(start.tau)
    reason = "max_points"
    while len(pts) < max_points:
        p = pts[-1]
        pred = p.y + ds * p.tau
        if not lo <= pred[-1] <= hi:  # the step would leave the range: land on its end instead
            bound = hi if pred[-1] > hi else lo
            end = _end_point(curve, p, pred, bound)
            if end is not None:
                pts.append(end)
                reason = f"reached {system.parameter} = {bound:.12g}"
                break
            ds *= 0.5
            if ds < 1e-9 * (1 + abs(p.lam)):
                reason = (
                    f"step size below 1e-9 at {system.parameter} = {p.lam:.12g} (no orbit at the "
                    "range's end)"
                )
                break
            continue
        y, it, tau = _corrected(curve, p, pred, ds)
        if tau is None or tau @ p.tau < 0.9:
            ds *= 0.5
            if ds < 1e-9 * (1 + abs(p.lam)):
                reason = (
                    f"step size below 1e-9 at {system.parameter} = {p.lam:.12g} (singular or "
                    "ill-ordered impacts)"
                )
                break
            continue
        if not lo <= y[-1] <= hi:
            bound = hi if y[-1] > hi else lo
            end = _end_point(curve, p, y, bound)
            if end is not None:
                pts.append(end)
            reason = f"reached {system.parameter} = {bound:.12g}"
            break
        pts.append(_Point(system, y, tau))
        done[0] += 1
        travelled = 0.0 if pts[-1].admissible else travelled + abs(pts[-1].lam - p.lam)
        if travelled > virtual * span:
            reason = (
                f"virtual (past grazing) over {virtual:g} of the range, at {system.parameter} = "
                f"{y[-1]:.12g}"
            )
            break
        if progress is not None:
            progress.update(min(done[0], progress.total), f"{system.parameter} = {y[-1]:.6g}")
        ds = min(ds * (1.6 if it <= 3 else 1.0 if it <= 6 else 0.5), ds_cap(tau))
    return pts, reason


def _end_point(curve: _Curve, p: _Point, y, bound: float) -> _Point | None:
    """The branch point at ``lam = bound`` between ``p`` and ``y`` (``None``: not found there)."""
    system = curve.s
    guess = p.y + (bound - p.lam) / (y[-1] - p.lam) * (y - p.y)
    guess[-1] = bound
    ye, _ = curve.correct(guess, p.tau, p.y, 0.0, fixed_lam=True)
    if ye is None or not _ordered(system, ye):
        return None
    te = curve.tangent(ye, p.tau)
    return _Point(system, ye, te if te is not None else p.tau)


def _corrected(curve: _Curve, p: _Point, pred, ds: float):
    """The prediction corrected onto the branch: point, Newton iterations, tangent (or ``None``)."""
    y, it = curve.correct(pred, p.tau, p.y, ds)
    tau = None
    # a corrector that lands farther from the prediction than the step itself has jumped to
    # another part of the curve (a fold's other sheet, or back along the branch): refused,
    # the step is halved
    if y is not None and float(np.linalg.norm(y - pred)) > abs(ds):
        return y, it, None
    if y is not None and _ordered(curve.s, y):
        tau = curve.tangent(y, p.tau)
    return y, it, tau


def _switch(system: ShootingSystem, pd: _Point):
    """The first point of the doubled branch born at the period-doubling point ``pd`` and its
    tangent."""
    n, p = system.impacts, system.period
    double = ShootingSystem(system.base, system.parameter, 2 * p, 2 * n)
    lam = pd.lam
    pT = p * system.forcing_period(system.values(lam))
    u = pd.y[:-1]
    u2 = np.concatenate([u, u + np.tile([pT, 0.0], n)])
    _, Gu = double.residual(u2, lam, jacobian=True)
    null = np.linalg.svd(Gu)[2][-1]
    curve = _Curve(double)
    tau0 = np.append(null, 0.0)
    base = np.append(u2, lam)
    for delta in (1e-3, 1e-2, 1e-4):
        delta *= 1 + float(np.max(np.abs(u2)))
        y, _ = curve.correct(base + delta * tau0, tau0, base, delta)
        if y is None or not _ordered(double, y):
            continue
        first, second = y[: 2 * n], y[2 * n : 4 * n] - np.tile([pT, 0.0], n)
        if float(np.max(np.abs(first - second))) < 1e-6 * (1 + float(np.max(np.abs(u2)))):
            continue  # Newton fell back onto the doubled period-p orbit
        tau = curve.tangent(y, tau0)
        if tau is None:
            continue
        if tau @ (y - base) < 0:
            tau = -tau
        return curve, _Point(double, y, tau)
    return None, None


def continue_orbit(
    params: Any = None,
    parameter: str = "eta",
    start: Any = None,
    stop: Any = None,
    period: int = 1,
    *,
    impacts: int | None = None,
    guess: Sequence[Any] | None = None,
    transient: int = 2000,
    max_points: int = 400,
    doublings: int = 2,
    virtual: Any = "0.1",
    progress: bool | None = None,
    max_time: Any = None,
    within: tuple | None = None,
    **param_values: Any,
) -> ContinuationResult:
    """A branch of periodic orbits continued in one parameter, with its bifurcations.

    Parameters
    ----------
    params : Params, mapping or None, default ``None``
        The system; ``None`` builds it from ``param_values`` (the paper's defaults).
    parameter : str, default ``'eta'``
        The continued parameter: ``'eta'``, ``'x_w'``, ``'zeta'``, ``'a'`` or ``'R'``.
    start, stop : decimal
        The range; the branch starts at ``parameter = start`` from the orbit found there
        (:func:`~precise_impact.analysis.orbits.newton.find_orbit`) and runs towards
        ``stop``, through folds, until the parameter leaves the range.
    period : int, default 1
        Forcing periods ``p`` of the orbit (``1 <= p <= 64``).
    impacts : int or None, default ``None``
        Impacts per orbit of the starting orbit (``None``: whatever Newton finds).
    guess : pair or None, default ``None``
        Starting state ``(x, v)`` at ``t0`` for the orbit at ``start`` (an unstable orbit
        needs one); ``None``: the state after ``transient`` periods.
    transient : int, default 2000
        Periods simulated for the default guess.
    max_points : int, default 400
        Points per branch at most (the budget; ``1 <= max_points <= 100000``).
    doublings : int, default 2
        Period-doubling branch switches followed (``0`` switches none; ``<= 8``).
    virtual : decimal, default ``'0.1'``
        How far a branch runs on past grazing while its orbits are virtual, as a fraction
        of the range in the parameter (``0 <= virtual <= 10``; ``0`` ends a branch at its
        first grazing point, ``1`` follows a non-impacting orbit across the whole gap
        between its two grazing frequencies).
    progress : bool or None, default ``None``
        A progress line on stderr (``None``: only when stderr is a terminal).
    max_time : decimal or None, default ``None``
        Time budget in seconds of the starting orbit's transient (``None``: none; see
        :func:`~precise_impact.analysis.orbits.newton.find_orbit`).
    within : pair of decimal or None, default ``None``
        ``(lo, hi)``: the range the branch may run in, containing ``start`` and ``stop``
        (``None``: from ``start`` to ``stop``).  The branch starts at ``start`` towards
        ``stop`` and may come back past ``start`` after a fold, until it leaves
        ``[lo, hi]`` (a response curve started inside its range).
    **param_values
        Parameter values replacing those of ``params``.

    Returns
    -------
    ContinuationResult
        The branches (parameter values, stroboscopic states, multipliers, stability,
        admissibility, LLE) and the located bifurcations; ``plot(path)`` draws them.

    Raises
    ------
    ParameterError
        Bad input, before any work.
    ConvergenceError
        No periodic orbit at ``start`` (see :func:`find_orbit`).

    See Also
    --------
    precise_impact.analysis.orbits.newton.find_orbit : a single orbit at fixed parameters.
    precise_impact.analysis.orbits.branch.brute_force_diagram
        The simulated attractor at the same parameter values.
    precise_impact.analysis.orbits.branch.ContinuationResult : the branches and their bifurcations.

    Notes
    -----
    Orbits past a grazing point stay on the branch as *virtual* orbits (``admissible``
    false: a flight crosses the wall, or an impact arrives from beyond it); their
    bifurcations are reported with ``admissible`` false and never switched at.

    References
    ----------
    .. [1] E. L. Allgower, K. Georg, *Introduction to Numerical Continuation Methods*,
           SIAM 2003 (pseudo-arclength, the Illinois location of test-function zeros).
    .. [2] Yu. A. Kuznetsov, *Elements of Applied Bifurcation Theory*, 3rd ed., Springer
           2004, ch. 10 (test functions, branch switching at period-doubling).
    .. [3] P. Thota, H. Dankowicz, SIAM J. Appl. Dyn. Syst. 7 (2008) 1283-1322 (TC-HAT:
           continuation of impacting orbits, grazing by the tangency condition).

    Examples
    --------
    >>> import precise_impact as pi
    >>> p = pi.Params.make(R="0.8", eta="1")
    >>> res = pi.continue_orbit(p, "eta", "1", "1.1", 1, max_points=20)
    >>> res.parameter, res.branches[0].period
    ('eta', 1)
    """
    t_start = time.perf_counter()
    params = params_or_values(params, param_values)
    p_start, lam0, lam1 = _check_range(params, parameter, start, stop)
    period = check_count(period, "period", 64, minimum=1)
    max_points = check_count(max_points, "max_points", 100_000, minimum=1)
    doublings = check_count(doublings, "doublings", 8)
    virtual = _check_virtual(virtual)
    _check_ends(parameter, p_start, lam0, lam1)
    lo, hi = sorted((float(lam0), float(lam1)))
    if within is not None:
        lo, hi = _check_within(within, parameter, lam0, lam1)

    orbit = find_orbit(
        p_start, period, guess=guess, transient=transient, impacts=impacts, max_time=max_time
    )
    curve, first = _first_point(p_start, parameter, period, orbit, lam0, lam1)

    bar = Progress(max_points * (1 + doublings), f"continuation in {parameter}", enabled=progress)
    done = [0]
    branches: list[Branch] = []
    bifs: list[Bifurcation] = []
    queue = [(curve, first, "start", 0)]
    while queue:
        cv, pt, origin, depth = queue.pop(0)
        pts, reason = _trace(cv, pt, lo, hi, max_points, bar, done, virtual)
        k = len(branches)
        branches.append(
            Branch.from_points(parameter, cv.s.period, cv.s.impacts, origin, pts, reason)
        )
        for a0, b0 in zip(pts[:-1], pts[1:], strict=True):
            for test, a, b in _pairs(cv, a0, b0):
                if not _sign_change(a.tests[test], b.tests[test]):
                    continue
                found = _bifurcation(cv, a, b, test, parameter, k)
                if found is None:
                    continue
                bif, z = found
                if (
                    bif.type == "period-doubling"
                    and bif.admissible
                    and depth < doublings
                    and cv.s.impacts > 0
                ):
                    _switch_into(queue, cv, z, bif, k, parameter, depth)
                bifs.append(bif)
    bar.update(bar.total)
    bifs.sort(key=lambda b: (b.branch, b.value if lam1 > lam0 else -b.value))
    return ContinuationResult(
        params=p_start,
        parameter=parameter,
        start=lam0,
        stop=lam1,
        branches=branches,
        bifurcations=bifs,
        elapsed_s=time.perf_counter() - t_start,
    )


def _check_range(params: Params, parameter: str, start: Any, stop: Any):
    """The parameter and its range checked: the system at ``start``, ``lam0`` and ``lam1``."""
    if parameter not in CONTINUABLE:
        raise ParameterError("parameter", parameter, "one of " + ", ".join(CONTINUABLE))
    if start is None or stop is None:
        raise ParameterError(
            "start" if start is None else "stop", "None", f"a decimal value of {parameter}"
        )
    fields = {k: getattr(params, k) for k in params.decimal()}

    def _at(name, value):
        values = {**fields, parameter: value}
        if name == "stop" and parameter == "x_w":
            # the start (x0, v0) seeds only the orbit at ``start``: the system at ``stop`` is
            # checked without it (x_w = -0.5 is no reason to refuse, whatever x0 is)
            values["x0"] = min(exact("x0", values["x0"]), exact("stop", value))
        try:
            return Params.make(**values)
        except ParameterError as e:
            raise ParameterError(
                name,
                value if isinstance(value, str) else repr(value),
                f"a value of {parameter} the system allows ({e})",
            ) from None

    p_start = _at("start", start)
    lam0, lam1 = getattr(p_start, parameter), getattr(_at("stop", stop), parameter)
    if lam0 == lam1:
        raise ParameterError(
            "stop", str(stop), f"a value of {parameter} other than start = {start}"
        )
    return p_start, lam0, lam1


def _check_within(within: Any, parameter: str, lam0: Any, lam1: Any) -> tuple[float, float]:
    """``within`` checked (a pair containing ``start`` and ``stop``) and as floats."""
    try:
        a, b = within
    except (TypeError, ValueError):
        raise ParameterError("within", repr(within), "a pair (lo, hi) of decimals") from None
    qa, qb = sorted((exact("within", a), exact("within", b)))
    if not qa <= min(lam0, lam1) <= max(lam0, lam1) <= qb:
        raise ParameterError(
            "within", repr(within), f"a range of {parameter} containing start and stop"
        )
    if parameter == "eta" and not qa > 0:
        raise ParameterError("within", repr(within), "eta > 0 over the whole range")
    return float(qa), float(qb)


def _check_virtual(virtual: Any) -> float:
    """``virtual`` checked (``0 <= virtual <= 10``) and as a float."""

    vq = exact("virtual", virtual)
    if not 0 <= vq <= 10:
        raise ParameterError(
            "virtual", str(virtual), "0 <= virtual <= 10 (a fraction of the range)"
        )
    return float(vq)


def _check_ends(parameter: str, p_start: Params, lam0: Any, lam1: Any) -> None:
    """Both ends of the range and the starting system underdamped, with ``R > 0``."""
    for name, q in (("start", lam0), ("stop", lam1)):
        if parameter == "zeta" and not q < 1:
            raise ParameterError(name, str(q), "0 <= zeta < 1 (underdamped) for continuation")
        if parameter == "R" and not q > 0:
            raise ParameterError(name, str(q), "0 < R <= 1 for continuation")
    if not p_start.zeta < 1:
        raise ParameterError(
            "zeta", str(p_start.zeta), "0 <= zeta < 1 (underdamped) for continuation"
        )


def _first_point(p_start: Params, parameter: str, period: int, orbit: Any, lam0: Any, lam1: Any):
    """The branch through ``orbit`` and its first point, the tangent pointing towards ``lam1``."""
    base = {k: float(getattr(p_start, k)) for k in ("eta", "zeta", "a", "x_w", "R", "t0")}
    system = ShootingSystem(base, parameter, period, orbit.impacts)
    u0 = from_orbit(system, p_start, orbit.x, orbit.v, float(lam0))
    curve = _Curve(system)
    y0, _ = curve.correct(np.append(u0, float(lam0)), None, None, 0.0, fixed_lam=True)
    if y0 is None:
        raise ConvergenceError("the impact-sequence system did not converge at the starting orbit")
    G, Gu = system.residual(y0[:-1], y0[-1], jacobian=True)
    t_u = np.linalg.solve(Gu, -system.parameter_derivative(y0[:-1], y0[-1]))
    tau0 = np.append(t_u, 1.0)
    tau0 /= np.linalg.norm(tau0)
    if (lam1 < lam0) != (tau0[-1] < 0):
        tau0 = -tau0
    first = _Point(system, y0, tau0)
    sts = first.states
    for q in range(1, period):
        if period % q == 0 and np.allclose(
            sts[q:], sts[:-q], rtol=0, atol=1e-8 * (1 + np.abs(sts).max())
        ):
            raise ConvergenceError(
                f"the orbit found has period {q}, a divisor of {period}: continue it "
                f"with period {q}"
            )
    return curve, first


def _bifurcation(cv: _Curve, a: _Point, b: _Point, test: str, parameter: str, k: int):
    """The bifurcation where ``test`` changes sign between ``a`` and ``b`` and its point, or
    ``None`` when the sign change is a pole."""
    z = _locate(cv, a, b, test)
    if not test.startswith("graze") and not _is_root(z, test):
        return None  # a pole, not a root: the saltation matrix's 1 / v^- at a grazing impact
    if test.startswith("graze") and not abs(z.tests[test]) <= 1e-8 * (1 + abs(z.lam)):
        return None  # a jump (an interior maximum born above the wall), not a tangency
    if (
        test == "graze_interior"
        and math.inf in (a.tests[test], b.tests[test])
        and min((abs(w) for w in z.impact_v), default=math.inf) <= 1e-6
    ):
        # the maximum is born at the flight's end as the impact turns tangential (v^- = 0):
        # the graze_impact point itself, located there from v^- without the jump
        return None
    kind = test
    detail = ""
    if test.startswith("graze"):
        kind, detail = "grazing", _GRAZING_DETAIL[test]
    elif test == "fold" and (a.tau[-1] < 0) == (b.tau[-1] < 0):
        kind, detail = "branch-point", "a multiplier +1 without a turn in the parameter"
    bif = Bifurcation(
        type=kind,
        parameter=parameter,
        value=z.lam,
        branch=k,
        period=cv.s.period,
        impacts=cv.s.impacts,
        x=z.states[:, 0].tolist(),
        v=z.states[:, 1].tolist(),
        multipliers=[[m.real, m.imag] for m in z.mu],
        admissible=bool(min(z.tests["graze_interior"], z.tests["graze_impact"]) >= -1e-9),
        test=float(z.tests[test]),
        detail=detail,
        impact_v=[float(w) for w in z.impact_v],
    )
    return bif, z


def _switch_into(
    queue: list, cv: _Curve, z: _Point, bif: Bifurcation, k: int, parameter: str, depth: int
) -> None:
    """Queue the doubled branch born at the period-doubling point ``z``; say so in ``bif``."""
    c2, p2 = _switch(cv.s, z)
    if p2 is not None:
        bif.detail = f"switched to the period-{2 * cv.s.period} branch {k + 1 + len(queue)}"
        queue.append(
            (
                c2,
                p2,
                f"period-doubling of branch {k} at {parameter} = {z.lam:.12g}",
                depth + 1,
            )
        )
    else:
        bif.detail = "branch switching failed (no doubled orbit found near the point)"
