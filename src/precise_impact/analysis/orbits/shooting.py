"""Periodic orbits as impact sequences: the shooting system that continuation solves.

``2n`` equations in the impact times and velocities with an exact Jacobian, smooth through
grazing (the multi-segment formulation of COCO's hybrid toolbox and TC-HAT); derivation in
``docs/numerics.rst``.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any

import numpy as np

from precise_impact.core import flight
from precise_impact.core.crossing import safeguarded_newton
from precise_impact.core.flow import acceleration
from precise_impact.core.impact import oscillator_saltation

__all__ = ["ShootingSystem", "CONTINUABLE"]

#: Parameters a branch can be continued in.
CONTINUABLE = ("eta", "x_w", "zeta", "a", "R")


class ShootingSystem:
    """The impact-sequence equations of a period-``p``, ``n``-impact orbit, in float64.

    Parameters
    ----------
    base : dict
        Float values of ``eta``, ``zeta``, ``a``, ``x_w``, ``R``, ``t0``.
    parameter : str
        The continued parameter (one of :data:`CONTINUABLE`); its value is the last unknown.
    period, impacts : int
        ``p`` and ``n``.
    """

    def __init__(self, base: dict, parameter: str, period: int, impacts: int) -> None:
        self.base = dict(base)
        self.parameter = parameter
        self.period = int(period)
        self.impacts = int(impacts)
        self.size = 2 * self.impacts if self.impacts else 2

    # ---- the closed-form flight -------------------------------------------------------
    def values(self, lam: float) -> tuple:
        d = dict(self.base)
        d[self.parameter] = lam
        eta, zeta, a, xw, R = (float(d[k]) for k in ("eta", "zeta", "a", "x_w", "R"))
        den = (1 - eta * eta) ** 2 + (2 * zeta * eta) ** 2
        if not (0 <= zeta < 1) or den == 0 or eta <= 0 or not 0 < R <= 1:
            raise ValueError(f"outside the system's range: eta={eta!r}, zeta={zeta!r}, R={R!r}")
        P, Q = flight.steady_coefficients(eta, zeta, a)
        return eta, zeta, a, xw, R, P, Q, flight.damped_frequency(zeta, flight.FLOAT)

    @staticmethod
    def phi(tau, zeta, w):
        """The homogeneous flow matrix ``Phi(tau)`` (also the tangent flow of a flight)."""
        return np.array(flight.flow_matrix(tau, zeta, w, flight.NUMPY)).reshape(2, 2)

    def flow(self, vals, s, x, v, t):
        """State at time(s) ``t`` of the flight from ``(s, x, v)`` (no wall)."""
        eta, zeta, a, xw, R, P, Q, w = vals
        return flight.Flight(P, Q, eta, zeta, w, flight.NUMPY, s, x, v).at(
            np.asarray(t, dtype=float)
        )

    @staticmethod
    def field(vals, t, x, v):
        eta, zeta, a = vals[0], vals[1], vals[2]
        return np.array([v, acceleration(t, x, v, eta, zeta, a, math.cos)])

    def forcing_period(self, vals) -> float:
        return 2 * math.pi / vals[0]

    # ---- the equations ----------------------------------------------------------------
    def residual(self, u: np.ndarray, lam: float, jacobian: bool = False):
        """``G(u, lam)`` and, with ``jacobian``, ``dG/du`` (exact)."""
        vals = self.values(lam)
        pT = self.period * self.forcing_period(vals)
        n, xw, R, zeta, w = self.impacts, vals[3], vals[4], vals[1], vals[7]
        G = np.empty(self.size)
        J = np.zeros((self.size, self.size)) if jacobian else None
        if n == 0:
            t0 = self.base["t0"]
            xe, ve = self.flow(vals, t0, u[0], u[1], t0 + pT)
            G[:] = (xe - u[0], ve - u[1])
            if jacobian:
                J[:] = self.phi(pT, zeta, w) - np.eye(2)
            return (G, J) if jacobian else G
        for i in range(n):
            ti, vi = u[2 * i], u[2 * i + 1]
            j = (i + 1) % n
            te = u[2 * j] + (pT if j == 0 else 0.0)
            xe, ve = self.flow(vals, ti, xw, vi, te)
            G[2 * i] = xe - xw
            G[2 * i + 1] = -R * ve - u[2 * j + 1]
            if jacobian:
                Ph = self.phi(te - ti, zeta, w)
                fe = self.field(vals, te, xe, ve)
                fs = Ph @ self.field(vals, ti, xw, vi)
                rows = (2 * i, 2 * i + 1)
                for r, k, sc in ((rows[0], 0, 1.0), (rows[1], 1, -R)):
                    J[r, 2 * i] += -sc * fs[k]  # start time
                    J[r, 2 * i + 1] += sc * Ph[k, 1]  # start velocity
                    J[r, 2 * j] += sc * fe[k]  # end time
                J[rows[1], 2 * j + 1] += -1.0
        return (G, J) if jacobian else G

    def parameter_derivative(self, u: np.ndarray, lam: float) -> np.ndarray:
        """``dG/dlam`` by a central difference (one-sided second order at an end of the
        parameter's range): step ``h = eps^(1/3) (1 + |lam|)``, error
        ``O(h^2) ~ 1e-11`` relative (it enters only the corrector's Jacobian and the tangent,
        never the equations, so the solutions are exact to rounding)."""
        h = 6e-6 * (1 + abs(lam))
        try:
            return (self.residual(u, lam + h) - self.residual(u, lam - h)) / (2 * h)
        except (
            ValueError
        ):  # at an end of the parameter's range (R = 1, zeta = 0): one-sided, also O(h^2)
            for s in (-1.0, 1.0):
                try:
                    g0, g1, g2 = (self.residual(u, lam + s * k * h) for k in (0, 1, 2))
                except ValueError:
                    continue
                return s * (-3 * g0 + 4 * g1 - g2) / (2 * h)
            raise

    # ---- the orbit it describes -------------------------------------------------------
    def _cycle(self, u, vals):
        """Impacts sorted into ``[t0, t0 + pT)`` as (time, v_after, v_before)."""
        n, pT, t0 = self.impacts, self.period * self.forcing_period(vals), self.base["t0"]
        xw = vals[3]
        out = []
        for i in range(n):
            j = (i + 1) % n
            te = u[2 * j] + (pT if j == 0 else 0.0)
            _, ve = self.flow(vals, u[2 * i], xw, u[2 * i + 1], te)
            out.append((float((te - t0) % pT + t0), float(u[2 * j + 1]), float(ve)))
        out.sort()
        return out, pT

    def states(self, u: np.ndarray, lam: float) -> np.ndarray:
        """The ``p`` stroboscopic states ``(x, v)`` at ``t0 + k T``, ``k = 0 .. p-1``."""
        vals = self.values(lam)
        T, t0 = self.forcing_period(vals), self.base["t0"]
        out = np.empty((self.period, 2))
        if self.impacts == 0:
            for k in range(self.period):
                out[k] = self.flow(vals, t0, u[0], u[1], t0 + k * T)
            return out
        cyc, pT = self._cycle(u, vals)
        for k in range(self.period):
            tk = t0 + k * T
            before = [c for c in cyc if c[0] <= tk]
            ti, va, _ = before[-1] if before else (cyc[-1][0] - pT, cyc[-1][1], 0.0)
            out[k] = self.flow(vals, ti, vals[3], va, tk)
        return out

    def monodromy(self, u: np.ndarray, lam: float) -> np.ndarray:
        """Jacobian of ``P^p`` at the orbit's point at ``t0``: flow matrices and saltation
        matrices (:func:`~precise_impact.core.impact.oscillator_saltation`) in order."""

        vals = self.values(lam)
        eta, zeta, a, xw, R, w = vals[0], vals[1], vals[2], vals[3], vals[4], vals[7]
        T, t0 = self.forcing_period(vals), self.base["t0"]
        if self.impacts == 0:
            return self.phi(self.period * T, zeta, w)
        cyc, pT = self._cycle(u, vals)
        M, prev = np.eye(2), t0
        for ti, _, vb in cyc:
            S = np.array(oscillator_saltation(ti, vb, eta, zeta, a, xw, R, math.cos), dtype=float)
            M = S @ self.phi(ti - prev, zeta, w) @ M
            prev = ti
        return self.phi(t0 + pT - prev, zeta, w) @ M

    def scaled_monodromy(self, u: np.ndarray, lam: float) -> np.ndarray:
        """``N = exp(zeta p T) M``: :meth:`monodromy` with the decay ``exp(-zeta tau)`` of each
        flight left out (the flights' ``tau`` add up to ``p T``), so that it never underflows:
        ``M``'s entries reach 0 in float64 once ``zeta p T > 745`` (``zeta = 0.999``,
        ``eta = 0.001``: ``exp(-6277)``) while ``N`` has ``det N = R^(2n)``."""
        vals = self.values(lam)
        eta, zeta, a, xw, R, w = vals[0], vals[1], vals[2], vals[3], vals[4], vals[7]
        T, t0 = self.forcing_period(vals), self.base["t0"]

        def rot(tau):  # Phi(tau) exp(zeta tau): det 1
            c, s = math.cos(w * tau), math.sin(w * tau) / w
            return np.array([[c + zeta * s, s], [-s, c - zeta * s]])

        if self.impacts == 0:
            return rot(self.period * T)
        cyc, pT = self._cycle(u, vals)
        N, prev = np.eye(2), t0
        for ti, _, vb in cyc:
            S = np.array(oscillator_saltation(ti, vb, eta, zeta, a, xw, R, math.cos), dtype=float)
            N = S @ rot(ti - prev) @ N
            prev = ti
        return rot(t0 + pT - prev) @ N

    def floquet_lle(self, u: np.ndarray, lam: float) -> float:
        """``ln |mu_max| / (p T)`` from logarithms: ``-zeta + ln |nu_max| / (p T)`` with ``nu``
        the eigenvalues of :meth:`scaled_monodromy` (``mu = exp(-zeta p T) nu``).  Without
        impacts ``N = Phi(p T) exp(zeta p T)`` has ``det N = 1`` and (underdamped) its
        eigenvalues on the unit circle: exactly ``-zeta``.  For the orbits whose multipliers
        underflow in float64 (``-inf`` before)."""
        vals = self.values(lam)
        zeta = vals[1]
        if self.impacts == 0:
            return -zeta
        pT = self.period * self.forcing_period(vals)
        nu = float(np.max(np.abs(np.linalg.eigvals(self.scaled_monodromy(u, lam)))))
        return -zeta + math.log(nu) / pT if nu > 0 else -math.inf

    def grazing_tests(self, u: np.ndarray, lam: float) -> tuple[float, float]:
        """``(x_w - highest interior maximum of x, lowest arrival velocity v^-)``.

        The first is the margin of every flight below the wall (``+inf`` when no flight has
        an interior maximum); the second, of every impact's approach (``+inf`` with no
        impacts).  The orbit is admissible while both are ``>= 0``; each crosses zero at a
        grazing bifurcation.  Interior maxima: sign changes of ``v`` on a grid finer than a
        quarter of the shortest oscillation, refined by Newton on ``v = 0``.
        """
        vals = self.values(lam)
        eta, xw = vals[0], vals[3]
        T, t0 = self.forcing_period(vals), self.base["t0"]
        if self.impacts == 0:
            flights = [(t0, float(u[0]), float(u[1]), t0 + self.period * T)]
            vmin = math.inf
        else:
            cyc, pT = self._cycle(u, vals)
            flights = [
                (
                    cyc[i][0],
                    xw,
                    cyc[i][1],
                    cyc[(i + 1) % len(cyc)][0] + (pT if i + 1 == len(cyc) else 0.0),
                )
                for i in range(len(cyc))
            ]
            vmin = min(c[2] for c in cyc)
        step = 0.2 / max(1.0, eta)
        best = -math.inf
        for s, x, v, e in flights:
            m = max(8, int(math.ceil((e - s) / step)))
            ts = np.linspace(s, e, m + 1)
            xs, vs = self.flow(vals, s, x, v, ts)
            idx = np.nonzero((vs[:-1] > 0) & (vs[1:] <= 0))[0]
            if self.impacts:
                idx = idx[(idx > 0) | (vs[0] > 0)]
            for k in idx:
                tm = _refine_max(self, vals, s, x, v, ts[k], ts[k + 1])
                if self.impacts and not (s < tm < e):
                    continue
                best = max(best, float(self.flow(vals, s, x, v, tm)[0]))
        return (xw - best if best > -math.inf else math.inf), vmin


def _refine_max(sys: ShootingSystem, vals, s, x, v, lo, hi) -> float:
    """The zero of ``v`` in ``[lo, hi]`` (``v(lo) > 0 >= v(hi)``): the one safeguarded Newton
    (:func:`~precise_impact.core.crossing.safeguarded_newton`) on ``f = -v``, ``f' = -x''``."""

    def minus_v(t):
        xt, vt = sys.flow(vals, s, x, v, t)
        return -vt, -sys.field(vals, float(t), float(xt), float(vt))[1]

    f_lo, df_lo = minus_v(lo)
    t, _ = safeguarded_newton(minus_v, lo, hi, f_lo, df_lo, 4e-16 * (1 + abs(hi)), 60)
    return float(t)


def from_orbit(system: ShootingSystem, params: Any, x: float, v: float, lam: float) -> np.ndarray:
    """Initial unknowns from a point ``(x, v)`` of an orbit at ``t0``: one period simulated
    by the fast engine (:class:`~precise_impact.solvers.fast.single.FastSolver`) gives the impact
    times and velocities (``n = 0``: the point itself)."""
    if system.impacts == 0:
        return np.array([x, v], dtype=float)
    from precise_impact.solvers.fast.single import FastSolver  # noqa: PLC0415 -- heavy: numba ~0.5 s, loaded on first use

    q = params.replace(x0=Fraction(x), v0=Fraction(v), **{system.parameter: Fraction(lam)})
    tr = FastSolver().solve(q, system.period)
    ts = [float(t) for t in tr.impacts_t]
    vb = [float(w) for w in tr.impacts_v_before]
    if len(ts) != system.impacts:
        raise ValueError(
            f"the orbit has {len(ts)} impacts per {system.period} period(s), not {system.impacts}"
        )
    u = np.empty(system.size)
    for i, (t, w) in enumerate(zip(ts, vb, strict=True)):
        u[2 * i], u[2 * i + 1] = t, -system.values(lam)[4] * w
    return u
