"""Branch points (grazing, period-doubling, fold) as augmented systems with exact Jacobians.

``F(y; theta) = 0`` (impact-sequence equations plus the branch condition), evaluated in dual
numbers (:mod:`precise_impact.core.dual`): Newton locates the landmark and the implicit-function
theorem gives ``d eta / d theta``.  The conditions: ``docs/numerics.rst``, "Landmarks as
augmented systems".
"""

from __future__ import annotations

import dataclasses
import math
from fractions import Fraction
from typing import Any

import numpy as np

from precise_impact.analysis.orbits.continuation import continue_orbit
from precise_impact.analysis.orbits.newton import find_orbit
from precise_impact.analysis.orbits.shooting import ShootingSystem, from_orbit
from precise_impact.core import flight
from precise_impact.core.dual import DUAL, Dual, seed
from precise_impact.core.impact import oscillator_saltation
from precise_impact.core.params import Params, exact
from precise_impact.errors import ConvergenceError, ParameterError, check_type

__all__ = ["BranchPoint", "KINDS", "THETA", "check_theta"]

#: The defining conditions a :class:`BranchPoint` may have (``orbit``: none, ``eta`` held at
#: ``eta_fixed``: the orbit itself, for carrying it through parameter changes).
KINDS = ("graze_free", "graze", "period-doubling", "fold", "orbit")
#: The parameters a landmark is differentiated in (``R`` stays fixed).
THETA = ("zeta", "a", "x_w")

_EPS = 2.0**-52


@dataclasses.dataclass
class BranchPoint:
    """A landmark: its defining condition and the unknowns at which it was last solved.

    Attributes
    ----------
    kind : str
        One of :data:`KINDS`.
    period, impacts : int
        Of the orbit (``impacts = 0`` for ``graze_free``).
    y : numpy.ndarray
        Unknowns: impact times and post-impact velocities ``(t_1, v_1, ..., t_n, v_n)`` (or
        ``(x_0, v_0)`` at ``t = 0`` without impacts), then ``t_m`` for a grazing, then ``eta``.
    theta : numpy.ndarray
        ``(zeta, a, x_w)`` it was solved at.
    R : float
        Restitution coefficient (fixed).
    flight_index : int
        The flight whose maximum grazes (``graze``).
    """

    kind: str
    period: int
    impacts: int
    y: np.ndarray
    theta: np.ndarray
    R: float = 1.0
    flight_index: int = 0
    eta_fixed: float = math.nan

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"kind {self.kind!r}: one of {', '.join(KINDS)}")
        if (self.kind == "graze_free") != (self.impacts == 0) and self.kind != "orbit":
            raise ValueError(
                f"a {self.kind} landmark needs "
                + ("a non-impacting orbit" if self.kind == "graze_free" else "impacts")
            )

    @property
    def eta(self) -> float:
        return float(self.y[-1])

    # ---- the equations ------------------------------------------------------------------
    def residual(self, y: Any, theta: Any, ops: Any = DUAL) -> list:
        """``F(y; theta)`` in the numbers of ``y`` and ``theta`` (floats or duals)."""
        zeta, a, xw = theta
        eta = y[-1]
        R = self.R
        n, p = self.impacts, self.period
        P, Q = flight.steady_coefficients(eta, zeta, a)
        wd = flight.damped_frequency(zeta, ops)
        pT = p * 2 * ops.pi / eta  # math.pi in FLOAT and DUAL; a ball of pi in arb
        F: list = []
        if n == 0:
            fl = flight.Flight(P, Q, eta, zeta, wd, ops, 0.0, y[0], y[1])
            xe, ve = fl.at(pT)
            F += [xe - y[0], ve - y[1]]
            flights = [fl]
            ends: list = []
        else:
            flights, ends = [], []
            for i in range(n):
                ti, vi = y[2 * i], y[2 * i + 1]
                j = (i + 1) % n
                te = y[2 * j] + pT if j == 0 else y[2 * j]
                fl = flight.Flight(P, Q, eta, zeta, wd, ops, ti, xw, vi)
                xe, ve = fl.at(te)
                F += [xe - xw, -R * ve - y[2 * j + 1]]
                flights.append(fl)
                ends.append((ti, te, ve))
        if self.kind == "orbit":
            F.append(eta - self.eta_fixed)
        elif self.kind in ("graze_free", "graze"):
            tm = y[2 * max(n, 1)]
            xm, vm = flights[self.flight_index if n else 0].at(tm)
            F += [vm, xm - xw]
        else:
            M = _monodromy(ends, eta, zeta, a, xw, R, wd, ops)
            tr = M[0][0] + M[1][1]
            det = M[0][0] * M[1][1] - M[0][1] * M[1][0]
            F.append(1 + tr + det if self.kind == "period-doubling" else 1 - tr + det)
        return F

    def jacobian(self, y: np.ndarray | None = None, theta: np.ndarray | None = None):
        """``(F, F_y, F_theta)`` at ``(y, theta)`` (default: the stored point), exact to
        rounding (one evaluation in dual numbers)."""
        y = self.y if y is None else np.asarray(y, dtype=float)
        theta = self.theta if theta is None else np.asarray(theta, dtype=float)
        m = len(y)
        size = m + len(theta)
        yd = seed(y, size)
        td = seed(theta, size, offset=m)
        F = self.residual(yd, td)
        val = np.array([f.v if isinstance(f, Dual) else float(f) for f in F])
        G = np.array([f.g if isinstance(f, Dual) else np.zeros(size) for f in F])
        return val, G[:, :m], G[:, m:]

    def solve(
        self,
        theta: Any = None,
        y0: np.ndarray | None = None,
        *,
        chord: np.ndarray | None = None,
        iterations: int = 40,
    ) -> BranchPoint:
        """The landmark at ``theta`` by Newton from ``y0`` (default the stored point): a new
        :class:`BranchPoint`.  ``chord`` (a fixed ``F_y``) evaluates ``F`` in float64 only and
        converges linearly at the rate ``|theta - theta_0|`` (cheap for Monte Carlo draws).

        Raises
        ------
        ConvergenceError
            No convergence (the landmark left the branch, or ``theta`` is too far away).
        """
        theta = self.theta if theta is None else np.asarray(theta, dtype=float)
        y = (self.y if y0 is None else np.asarray(y0, dtype=float)).copy()
        for _ in range(iterations):
            try:
                if chord is None:
                    F, J, _ = self.jacobian(y, theta)
                else:
                    F = np.array(
                        [float(f) for f in self.residual(list(y), list(theta), flight.FLOAT)]
                    )
                    J = chord
                if not np.all(np.isfinite(F)):
                    break
                dy = np.linalg.solve(J, -F)
            except (OverflowError, ValueError, ZeroDivisionError, np.linalg.LinAlgError):
                break  # Newton left the region where the orbit's equations are defined
            y = y + dy
            if float(np.max(np.abs(dy))) <= 8 * _EPS * (1 + float(np.max(np.abs(y)))):
                return dataclasses.replace(self, y=y, theta=theta.copy())
        raise ConvergenceError(
            f"{self.kind} landmark: Newton did not converge at theta = {theta.tolist()}"
        )

    def sensitivity(self) -> np.ndarray:
        """``d eta / d theta`` at the stored point by the implicit-function theorem:
        ``dy/dtheta = -F_y^-1 F_theta`` with the exact Jacobians."""
        _, Fy, Ft = self.jacobian()
        return -np.linalg.solve(Fy, Ft)[-1]

    def multipliers(self) -> np.ndarray:
        """Floquet multipliers of the orbit at the stored point (float64)."""
        zeta, a, xw = (float(t) for t in self.theta)
        eta = self.eta
        wd = flight.damped_frequency(zeta, flight.FLOAT)
        n = self.impacts
        if n == 0:
            pT = self.period * 2 * math.pi / eta
            return np.linalg.eigvals(
                np.array(flight.flow_matrix(pT, zeta, wd, flight.FLOAT)).reshape(2, 2)
            )
        ends = self._ends()
        M = _monodromy(ends, eta, zeta, a, xw, self.R, wd, flight.FLOAT)
        return np.linalg.eigvals(np.array(M, dtype=float))

    def admissible(self, slack: float = 1e-9) -> bool:
        """The orbit at the landmark is physical: impact times increasing, every impact
        arriving (``v^- > 0``), every interior maximum at or below the wall (the grazing one
        touches it), the grazing flight's touch a maximum (``x'' <= 0``)."""
        n = self.impacts
        xw = float(self.theta[2])
        if n:
            ts = [self.y[2 * i] for i in range(n)]
            pT = self.period * 2 * math.pi / self.eta
            if not all(b > a for a, b in zip(ts, ts[1:] + [ts[0] + pT], strict=True)):
                return False
            if not all(ve > 0 for _, _, ve in self._ends()):
                return False
        maxima = self.interior_maxima()
        return all(x <= xw + slack * (1 + abs(xw)) for x, _, _ in maxima[1:]) and (
            not maxima or maxima[0][0] <= xw + 1e-3
        )

    def states(self) -> np.ndarray:
        """The ``p`` stroboscopic states ``(x, v)`` at ``t = k 2 pi / eta`` (``t0 = 0``)."""
        zeta, a, xw = (float(t) for t in self.theta)
        n = self.impacts
        base = {"eta": self.eta, "zeta": zeta, "a": a, "x_w": xw, "R": self.R, "t0": 0.0}
        sysm = ShootingSystem(base, "eta", self.period, n)
        u = self.y[: 2 * max(n, 1)]
        return sysm.states(u, self.eta)

    def stable(self) -> bool:
        """All Floquet multipliers inside the unit circle."""
        return bool(np.max(np.abs(self.multipliers())) < 1)

    def _ends(self) -> list:
        zeta, a, xw = (float(t) for t in self.theta)
        y, eta, n = self.y, self.eta, self.impacts
        P, Q = flight.steady_coefficients(eta, zeta, a)
        wd = flight.damped_frequency(zeta, flight.FLOAT)
        pT = self.period * 2 * math.pi / eta
        ends = []
        for i in range(n):
            j = (i + 1) % n
            te = y[2 * j] + pT if j == 0 else y[2 * j]
            fl = flight.Flight(P, Q, eta, zeta, wd, flight.FLOAT, y[2 * i], xw, y[2 * i + 1])
            ends.append((y[2 * i], te, fl.at(te)[1]))
        return ends

    def interior_maxima(self, eta: float | None = None, grid: int = 400) -> list[tuple]:
        """``(x_max, t_max, flight)`` of every flight's interior maxima (highest first)."""
        zeta, a, xw = (float(t) for t in self.theta)
        eta = self.eta if eta is None else eta
        y, n = self.y, self.impacts
        P, Q = flight.steady_coefficients(eta, zeta, a)
        wd = flight.damped_frequency(zeta, flight.NUMPY)
        pT = self.period * 2 * math.pi / eta
        out = []
        spans = (
            [(0.0, y[0], y[1], pT)]
            if n == 0
            else [
                (y[2 * i], xw, y[2 * i + 1], y[0] + pT if i == n - 1 else y[2 * i + 2])
                for i in range(n)
            ]
        )
        for k, (s, x, v, e) in enumerate(spans):
            ts = np.linspace(s, e, grid + 1)
            fl = flight.Flight(P, Q, eta, zeta, wd, flight.NUMPY, s, x, v)
            xs, vs = fl.at(ts)
            for i in np.nonzero((vs[:-1] > 0) & (vs[1:] <= 0))[0]:
                if n and i == 0:
                    continue
                out.append((float(xs[i]), float(ts[i]), k))
        return sorted(out, reverse=True)


def _monodromy(ends: list, eta, zeta, a, xw, R, wd, ops) -> list:
    """``S_0 Phi_{n-1} ... S_1 Phi_0`` after impact 0: similar to the stroboscopic monodromy."""
    M: list = [[1.0, 0.0], [0.0, 1.0]]
    for ti, te, ve in ends:
        ph = flight.flow_matrix(te - ti, zeta, wd, ops)
        Ph = [[ph[0], ph[1]], [ph[2], ph[3]]]
        S = oscillator_saltation(te, ve, eta, zeta, a, xw, R, ops.cos)
        M = _mul(S, _mul(Ph, M))
    return M


def _mul(A: list, B: list) -> list:
    return [[A[i][0] * B[0][j] + A[i][1] * B[1][j] for j in range(2)] for i in range(2)]


def check_theta(theta: Any) -> np.ndarray:
    """``theta = (zeta, a, x_w)`` as a float array, or one :class:`ParameterError` naming it."""
    wanted = "(zeta, a, x_w): three numbers"
    check_type(theta, (tuple, list, np.ndarray), "theta", wanted)
    if len(theta) != 3:
        raise ParameterError("theta", f"{len(theta)} values", wanted)
    return np.array([float(exact(f"theta[{i}]", t)) for i, t in enumerate(theta)])


def seed_landmark(
    kind: str,
    theta: Any,
    eta_inside: float,
    period: int = 1,
    impacts: int = 0,
    guess: tuple | None = None,
    R: float = 1.0,
) -> BranchPoint:
    """A landmark located from an orbit at ``eta_inside`` (on the branch, near the landmark:
    e.g. just inside the bifurcation :func:`~precise_impact.analysis.orbits.continue_orbit`
    located): the orbit's impact sequence (one simulated cycle from ``guess``, refined by
    Newton), the highest interior maximum for a grazing, then Newton on the augmented system.
    """
    if not isinstance(kind, str) or kind not in KINDS:
        raise ParameterError("kind", str(kind)[:40], "one of " + ", ".join(KINDS))
    theta = check_theta(theta)
    zeta, a, xw = theta
    if kind == "graze_free":
        P, Q = flight.steady_coefficients(eta_inside, zeta, a)
        y = np.array([P, eta_inside * Q, 0.0, eta_inside])
        bp = BranchPoint(kind, 1, 0, y, theta, R)
        tm = math.atan2(Q, P) / eta_inside % (2 * math.pi / eta_inside)
        bp.y[2] = tm
        return bp.solve()
    params = Params.make(
        zeta=Fraction(zeta),
        a=Fraction(a),
        x_w=Fraction(xw),
        R=Fraction(R),
        eta=Fraction(eta_inside),
    )
    orbit = find_orbit(params, period, guess=guess, impacts=impacts)
    impacts = int(orbit.impacts) if impacts is None else impacts
    sysm = ShootingSystem(
        {"eta": eta_inside, "zeta": zeta, "a": a, "x_w": xw, "R": R, "t0": float(params.t0)},
        "eta",
        period,
        impacts,
    )
    x0, v0 = np.ravel(orbit.x)[0], np.ravel(orbit.v)[0]
    u = from_orbit(sysm, params, float(x0), float(v0), eta_inside)
    orb = BranchPoint("graze", period, impacts, np.append(u, [0.0, eta_inside]), theta, R)
    if kind == "orbit":
        y = np.append(u, eta_inside)
        return BranchPoint(kind, period, impacts, y, theta, R, eta_fixed=eta_inside).solve()
    if kind == "graze":
        xm, tm, k = orb.interior_maxima()[0]
        y = np.append(u, [tm, eta_inside])
        return BranchPoint(kind, period, impacts, y, theta, R, flight_index=k).solve()
    return BranchPoint(kind, period, impacts, np.append(u, eta_inside), theta, R).solve()


_BIF_TYPE = {"graze_free": "grazing", "graze": "grazing", "period-doubling": "period-doubling"}


def landmark_from_continuation(
    kind: str,
    theta: Any,
    start: float,
    stop: float,
    period: int = 1,
    impacts: int | None = None,
    R: float = 1.0,
    inside: float = 2e-3,
    max_points: int = 400,
) -> tuple[BranchPoint, float]:
    """The first ``kind`` landmark :func:`~precise_impact.analysis.orbits.continue_orbit`
    locates on the branch from ``eta = start`` towards ``stop``, polished by Newton on the
    augmented system: ``(landmark, eta located by the continuation)``.

    Raises
    ------
    ConvergenceError
        The continuation found no such landmark in the range.
    """
    zeta, a, xw = (float(t) for t in theta)
    params = Params.make(
        zeta=Fraction(zeta), a=Fraction(a), x_w=Fraction(xw), R=Fraction(R), eta=Fraction(start)
    )
    res = continue_orbit(
        params,
        "eta",
        Fraction(start),
        Fraction(stop),
        period,
        impacts=impacts,
        max_points=max_points,
        doublings=0,
        virtual=0,
        progress=False,
    )
    want = _BIF_TYPE[kind]
    bifs = [b for b in res.bifurcations if b.type == want and b.admissible and b.branch == 0]
    if not bifs:
        raise ConvergenceError(
            f"no {want} on the period-{period} branch between eta = {start:g} and {stop:g}"
        )
    bif = min(bifs, key=lambda b: abs(b.value - start))
    eta_in = bif.value + (inside if start > bif.value else -inside)
    guess = (float(np.ravel(bif.x)[0]), float(np.ravel(bif.v)[0]))
    if kind == "graze_free":
        return seed_landmark(kind, theta, eta_in, R=R), float(bif.value)
    n = bif.impacts
    return seed_landmark(kind, theta, eta_in, period, n, guess=guess, R=R), float(bif.value)


#: Bifurcation types of :func:`~precise_impact.analysis.orbits.continue_orbit` that end the
#: stable admissible part of a branch, and the augmented system of each (``None``: located
#: by the continuation only).
ENDS = {
    "grazing": "graze",
    "period-doubling": "period-doubling",
    "fold": "fold",
    "neimark-sacker": None,
}


def interval_ends(orbit: BranchPoint, span: float = 0.06, max_points: int = 400) -> dict[str, Any]:
    """The ends of the stable admissible interval in ``eta`` of the branch through ``orbit``
    (a ``kind='orbit'`` point): continuation from its ``eta`` both ways (its state as the
    guess, so the same orbit), on each side the first admissible bifurcation along the branch
    that ends its stable admissible part (a grazing, or a fold / period-doubling /
    Neimark-Sacker point).

    Returns
    -------
    dict
        ``{'low': (type, eta, Bifurcation) or None, 'high': ...}``.
    """
    zeta, a, xw = (float(t) for t in orbit.theta)
    eta0 = orbit.eta
    x0, v0 = (float(c) for c in orbit.states()[0])
    params = Params.make(
        zeta=Fraction(zeta),
        a=Fraction(a),
        x_w=Fraction(xw),
        R=Fraction(orbit.R),
        eta=Fraction(eta0),
    )
    out: dict[str, Any] = {}
    for side, stop in (("low", eta0 - span), ("high", eta0 + span)):
        res = continue_orbit(
            params,
            "eta",
            Fraction(eta0),
            Fraction(stop),
            orbit.period,
            impacts=orbit.impacts,
            guess=(Fraction(x0), Fraction(v0)),
            max_points=max_points,
            doublings=0,
            virtual=0,
            progress=False,
            transient=0,
        )
        near = _first_end(res)
        out[side] = None if near is None else (near.type, float(near.value), near)
    return out


def _first_end(res: Any) -> Any:
    """The bifurcation where branch 0 first stops being stable and admissible, walking along
    its points (``bifurcations`` are sorted by value, not by arclength: past a fold the
    branch comes back)."""
    br = res.branches[0]
    vals, stable, adm = (list(getattr(br, k)) for k in ("values", "stable", "admissible"))
    for i in range(1, len(vals)):
        if stable[i] and adm[i]:
            continue
        lo, hi = sorted((float(vals[i - 1]), float(vals[i])))
        cands = [b for b in res.bifurcations if b.branch == 0 and b.type in ENDS]
        if not cands:
            return None
        # located between these two points (a fold's value lies just beyond both: eta is
        # extremal there), so the nearest to the segment
        return min(cands, key=lambda b: max(lo - b.value, b.value - hi, 0.0))
    return None


def end_point(orbit: BranchPoint, end: tuple, inside: float = 2e-3) -> BranchPoint | None:
    """The augmented-system landmark of an interval end from :func:`interval_ends` (``None``
    for an end without one: a Neimark-Sacker point or a tangential impact)."""
    kind = ENDS.get(end[0])
    bif = end[2]
    if kind is None or (kind == "graze" and "velocity" in bif.detail):
        return None
    step = min(inside, abs(orbit.eta - end[1]) / 2)
    eta_in = end[1] + (step if orbit.eta > end[1] else -step)
    carried = orbit
    # the orbit carried to eta_in by Newton on the fixed-eta system, then the landmark
    for t in np.linspace(0, 1, 9)[1:]:
        target = orbit.eta + t * (eta_in - orbit.eta)
        carried = dataclasses.replace(carried, eta_fixed=target).solve()
    y = carried.y
    if kind == "graze":
        xm, tm, k = carried.interior_maxima()[0]
        yy = np.append(y[:-1], [tm, y[-1]])
        return BranchPoint(
            kind, orbit.period, orbit.impacts, yy, orbit.theta.copy(), orbit.R, flight_index=k
        ).solve()
    return BranchPoint(
        kind, orbit.period, orbit.impacts, y.copy(), orbit.theta.copy(), orbit.R
    ).solve()
