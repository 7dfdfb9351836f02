"""The singularity set of the impact map: impact points whose next flight touches the wall
tangentially, found as curves by pseudo-arclength continuation of the grazing condition
``F(phase, v, s) = (x(t + s) - x_w, x'(t + s)) = 0``, with its images under the map.
Physical and virtual tangencies: ``docs/guide/impact_map.rst``, "The singularity set".
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from precise_impact.core import flight
from precise_impact.core.params import Params, as_params
from precise_impact.core.result import ResultMixin
from precise_impact.errors import ParameterError
from precise_impact.io.figures import finish, new_figure

__all__ = ["SingularityResult", "singularity_set", "grazing_residual"]


class _Flights:
    """Float flights of one system (the closed form of :mod:`precise_impact.core.flight`)."""

    def __init__(self, params: Params) -> None:
        self.eta, self.zeta, self.a = float(params.eta), float(params.zeta), float(params.a)
        self.x_w, self.R = float(params.x_w), float(params.R)
        self.P, self.Q = flight.steady_coefficients(self.eta, self.zeta, self.a)
        self.wd = flight.damped_frequency(self.zeta, flight.FLOAT)
        self.c = 2 * math.pi / self.eta

    def flight(self, phase: float, v: float, ops: Any = flight.FLOAT) -> flight.Flight:
        return flight.Flight(
            self.P, self.Q, self.eta, self.zeta, self.wd, ops,
            phase * self.c, self.x_w, -self.R * v,
        )  # fmt: skip

    def F(self, z: np.ndarray) -> np.ndarray:
        phase, v, s = z
        fl = self.flight(phase, v)
        x, xd = fl.at(phase * self.c + s)
        return np.array([x - self.x_w, xd])

    def DF(self, z: np.ndarray) -> np.ndarray:
        """2x3 Jacobian by central differences (steps ~ eps^(1/3): error ~1e-10, enough for
        the continuation's predictor and Newton's convergence; residuals are exact)."""
        J = np.empty((2, 3))
        for j in range(3):
            h = 6e-6 * max(1.0, abs(z[j]))
            e = np.zeros(3)
            e[j] = h
            J[:, j] = (self.F(z + e) - self.F(z - e)) / (2 * h)
        return J

    def first_crossing(self, phase: float, v: float, t_from: float, t_to: float):
        """A bracket ``(a, b)`` of the first crossing of the wall in ``(t_from, t_to]``
        (``x(a) < x_w <= x(b)``; never-miss scan: an interval whose ends lie below the wall by
        more than ``M h^2 / 8`` holds no crossing), or None."""
        fl = self.flight(phase, v)
        M = 1.01 * fl.acceleration_bound() + 1e-300

        def g(t):
            return fl.at(t)[0] - self.x_w

        def scan(a, ga, b, gb, depth=0):
            if gb >= 0:
                return a, b
            if max(ga, gb) + M * (b - a) ** 2 / 8 < 0 or depth > 40:
                return None
            m = 0.5 * (a + b)
            gm = g(m)
            return scan(a, ga, m, gm, depth + 1) or scan(m, gm, b, gb, depth + 1)

        lo = t_from
        glo = g(lo)
        while lo < t_to:
            hi = min(lo + 0.5, t_to)
            ghi = g(hi)
            r = scan(lo, glo, hi, ghi)
            if r is not None:
                return r
            lo, glo = hi, ghi
        return None


def grazing_residual(params: Any, phase: Any, v: Any, s: Any, ops: Any = flight.FLOAT):
    """``(x(t + s) - x_w, x'(t + s))`` of the flight from the impact ``(phase, v)``: zero on the
    grazing condition.  Generic in the arithmetic ``ops``
    (:data:`~precise_impact.core.flight.FLOAT`, :class:`~precise_impact.core.flight.MpmathOps`).

    Parameters
    ----------
    params : Params or mapping
    phase, v, s : number
        Impact phase, incoming speed, flight time to the tangency.
    ops : ops namespace, default FLOAT

    Returns
    -------
    tuple
        ``(x - x_w, x')`` at ``t + s``.

    See Also
    --------
    precise_impact.analysis.impact_surface.singularity.singularity_set : its zero set.

    Examples
    --------
    >>> from precise_impact.analysis.impact_surface.singularity import grazing_residual
    >>> r = grazing_residual({"eta": "0.74"}, 0.3, 1.0, 2.0)
    >>> len(r)
    2
    """
    params = as_params(params)
    num = ops.num if hasattr(ops, "num") and not isinstance(ops, flight.FloatOps) else float
    eta, zeta, a, x_w, R = (num(getattr(params, k)) for k in ("eta", "zeta", "a", "x_w", "R"))
    if not isinstance(ops, flight.FloatOps):
        phase, v, s = ops.mpf(phase), ops.mpf(v), ops.mpf(s)
    P, Q = flight.steady_coefficients(eta, zeta, a)
    wd = flight.damped_frequency(zeta, ops)
    t = 2 * ops.pi * phase / eta
    fl = flight.Flight(P, Q, eta, zeta, wd, ops, t, x_w, -R * v)
    x, xd = fl.at(t + s)
    return x - x_w, xd


def _newton(fl: _Flights, z: np.ndarray, extra=None, tol: float = 1e-14, it: int = 30):
    """Newton on ``F = 0`` plus one linear condition ``extra = (n, z0)``: ``n . (z - z0) = 0``."""
    for _ in range(it):
        r = fl.F(z)
        J = fl.DF(z)
        if extra is not None:
            n, z0 = extra
            A = np.vstack([J, n])
            b = np.concatenate([r, [n @ (z - z0)]])
        else:  # fixed phase: solve for (v, s)
            A = J[:, 1:]
            b = r
        dz = np.linalg.solve(A, b)
        if extra is None:
            dz = np.concatenate([[0.0], dz])
        z = z - dz
        if np.abs(dz).max() < tol * max(1.0, np.abs(z).max()):
            return z, True
    return z, bool(np.abs(fl.F(z)).max() < 1e-12)


def _seeds(fl: _Flights, v_max: float, n_phase: int, n_v: int):
    """Starting points: on a phase grid, a sign change in ``v`` of the ``k``-th maximum's height
    above the wall, for every maximum up to the first that reaches the wall (a later one grazes
    only a virtual flight; the first alone misses the grazes of flights whose earlier maxima
    stay below the wall), refined by Newton at fixed phase."""
    out = []
    T = 2 * math.pi / fl.eta
    vs = np.linspace(v_max / n_v, v_max, n_v)
    for phase in np.arange(n_phase) / n_phase:
        prev: list = []
        for v in vs:
            f = fl.flight(phase, v, flight.NUMPY)
            t0 = phase * fl.c
            ts = t0 + np.linspace(1e-9, 3 * max(T, 2 * math.pi), 1500)
            x, xd = f.at(ts)
            k = np.nonzero((xd[:-1] > 0) & (xd[1:] <= 0))[0]
            h = x[k] - fl.x_w
            above = np.nonzero(h > 0)[0]
            n = above[0] + 1 if len(above) else len(k)
            for j in range(min(n, len(prev))):
                if (h[j] > 0) != (prev[j] > 0):
                    z, ok = _newton(fl, np.array([phase, v, ts[k[j]] - t0]))
                    if ok and 0 < z[1] <= v_max and z[2] > 0:
                        out.append(z)
            prev = list(h[:n])
    return out


@dataclasses.dataclass
class SingularityResult(ResultMixin):
    """The singularity set as curves, and its images.

    Attributes
    ----------
    params : Params
    branches : list of dict
        One per continued curve: ``phase``, ``v``, ``s`` (flight time to the tangency) and
        ``physical`` (no earlier crossing) lists; ``graze_phase`` (the image just before the
        discontinuity: the grazing contact, ``v = 0``) and ``after_phase``, ``after_v`` (just
        after: the same flight's next impact), ``None`` where there is none within 50 periods.
    max_step : float
        The largest distance between neighbouring points (continuity).

    See Also
    --------
    precise_impact.analysis.impact_surface.singularity.singularity_set : returns it.
    precise_impact.analysis.impact_surface.impact_map.ImpactMapResult : the scatter under it.

    Examples
    --------
    >>> from precise_impact.analysis.impact_surface.singularity import singularity_set
    >>> r = singularity_set({"eta": "0.74"}, seed_phases=4, seed_speeds=20, max_points=40)
    >>> all(len(b["phase"]) == len(b["v"]) for b in r.branches)
    True
    """

    params: Params
    branches: list
    max_step: float

    def to_dict(self) -> dict:
        return {
            "params": self.params.decimal(),
            "max_step": self.max_step,
            "branches": self.branches,
        }

    def _tables(self) -> dict:
        def rows() -> dict:
            cols: dict = {"branch": [], "phase": [], "v": [], "s": [], "physical": []}
            for i, b in enumerate(self.branches):
                for j in range(len(b["phase"])):
                    cols["branch"].append(i)
                    for k in ("phase", "v", "s", "physical"):
                        cols[k].append(b[k][j])
            return cols

        return {"points": rows}

    def draw(self, ax: Any) -> None:
        """Draw the curves (physical parts solid, virtual dotted) and images on ``ax``."""
        first = True
        for b in self.branches:
            ph, v = np.array(b["phase"]), np.array(b["v"])
            phys = np.array(b["physical"], dtype=bool)
            # break lines at phase wraps and at physical / virtual changes
            for mask, style, lab in ((phys, "-", "singularity set"), (~phys, ":", None)):
                y = np.where(mask, v, np.nan)
                y[1:][np.abs(np.diff(ph)) > 0.5] = np.nan
                ax.plot(ph, y, style, color="tab:blue", lw=1.5, label=lab if first else None)
            ga = [p for p, q in zip(b["graze_phase"], phys, strict=True) if q]
            ax.plot(ga, np.zeros(len(ga)), "|", color="tab:green", ms=8,
                    label="image: grazing (v = 0)" if first else None)  # fmt: skip
            aph = [p for p, q in zip(b["after_phase"], phys, strict=True) if q and p is not None]
            av = [w for w, q in zip(b["after_v"], phys, strict=True) if q and w is not None]
            ax.plot(aph, av, ".", color="tab:purple", ms=2,
                    label="image: next impact past the graze" if first else None)  # fmt: skip
            first = False

    def plot(self, path: Any = None, *, orbit: Any = None):
        """The set over an impact-map scatter (``orbit``: an ImpactMapResult) or alone."""
        if orbit is not None:
            return orbit.plot(path, singularity=self)
        fig, axes = new_figure(figsize=(7.0, 4.5))
        ax = axes[0, 0]
        self.draw(ax)
        ax.set_xlim(0, 1)
        ax.set_ylim(bottom=0)
        ax.set_xlabel("impact phase  eta t / 2 pi  mod 1")
        ax.set_ylabel("impact velocity v")
        ax.legend(loc="best", fontsize=8)
        return finish(fig, path)


def singularity_set(
    params: Any,
    *,
    v_max: float = 4.0,
    step: float = 0.01,
    max_points: int = 4000,
    seed_phases: int = 24,
    seed_speeds: int = 80,
) -> SingularityResult:
    """The singularity set of the impact map by pseudo-arclength continuation.

    Parameters
    ----------
    params : Params or mapping
        The system.
    v_max : float, default 4.0
        Impact speeds considered, ``0 < v <= v_max``.
    step : float, default 0.01
        Arclength step in ``(phase, v, s)``.
    max_points : int, default 4000
        Points per branch at most.
    seed_phases, seed_speeds : int
        The grid searched for starting points.

    Returns
    -------
    SingularityResult
        The curves (each point a zero of :func:`grazing_residual` to float64 rounding) and
        their images.

    Raises
    ------
    ParameterError
        Bad input, before any work.

    See Also
    --------
    precise_impact.analysis.impact_surface.impact_map.impact_map : the map it belongs to.
    precise_impact.analysis.impact_surface.singularity.grazing_residual : the condition.

    Examples
    --------
    >>> from precise_impact.analysis.impact_surface.singularity import singularity_set
    >>> r = singularity_set({"eta": "0.74"}, seed_phases=4, seed_speeds=20, max_points=50)
    >>> r.max_step < 0.05
    True
    """
    params = as_params(params)
    if not 0 < float(v_max) <= 1e3:
        raise ParameterError("v_max", v_max, "0 < v_max <= 1000")
    if not 0 < float(step) <= 0.1:
        raise ParameterError("step", step, "0 < step <= 0.1")
    if not params.zeta < 1:
        raise ParameterError("zeta", params.decimal()["zeta"], "zeta < 1 (underdamped flights)")
    fl = _Flights(params)
    seeds = _seeds(fl, float(v_max), seed_phases, seed_speeds)
    branches: list[np.ndarray] = []
    for z0 in seeds:
        # a seed already on a computed branch is skipped
        if any(np.min(np.linalg.norm(b - z0, axis=1)) < 5 * step for b in branches):
            continue
        pts = _continue(fl, z0, float(step), float(v_max), max_points)
        branches.append(pts)
    out = []
    max_step = 0.0
    T = 2 * math.pi / fl.eta
    for b in branches:
        if len(b) > 1:
            d = np.diff(b[:, :2], axis=0)
            d[:, 0] = (d[:, 0] + 0.5) % 1 - 0.5
            max_step = max(max_step, float(np.linalg.norm(d, axis=1).max()))
        phys, gph, aph, av = [], [], [], []
        for phase, v, s in b:
            t = phase * fl.c
            fl_ = fl.flight(phase, v)
            M = fl_.acceleration_bound() + 1e-300
            # the gap is < 0 for 0 < tau < 2 R v / M after the start; it ends ~ -x'' delta^2 / 2
            # ~ -1e-10 below the wall delta = 1e-5 before the tangency (rounding ~1e-16: no
            # flicker); a maximum, x'' < 0, is required
            earlier = fl.first_crossing(phase, v, t + fl.R * v / M, t + s - 1e-5 * max(1.0, s))
            acc = fl.a * math.cos(fl.eta * (t + s)) - fl.x_w  # x'' at x = x_w, x' = 0
            physical = earlier is None and acc < 0
            phys.append(bool(physical))
            gph.append(float(((t + s) / fl.c) % 1))
            nxt = fl.first_crossing(phase, v, t + s + 1e-5 * max(1.0, s), t + s + 50 * T)
            if nxt is None:
                aph.append(None)
                av.append(None)
            else:
                # refine the crossing by bisection on the bracket the scan returned
                lo, hi = nxt
                for _ in range(60):
                    m = 0.5 * (lo + hi)
                    lo, hi = (m, hi) if fl_.at(m)[0] < fl.x_w else (lo, m)
                aph.append(float((hi / fl.c) % 1))
                av.append(float(fl_.at(hi)[1]))
        out.append(
            {
                "phase": [float(p) for p in b[:, 0]],
                "v": [float(p) for p in b[:, 1]],
                "s": [float(p) for p in b[:, 2]],
                "physical": phys,
                "graze_phase": gph,
                "after_phase": aph,
                "after_v": av,
            }
        )
    return SingularityResult(params=params, branches=out, max_step=max_step)


def _continue(fl: _Flights, z0: np.ndarray, ds: float, v_max: float, max_points: int):
    """Both directions from ``z0``; stop at ``v <= 0``, ``v > v_max``, ``s <= 0``, a full turn in
    phase, or ``max_points``."""
    halves = []
    for sign in (1.0, -1.0):
        z = z0.copy()
        J = fl.DF(z)
        tan = np.cross(J[0], J[1])
        tan = sign * tan / np.linalg.norm(tan)
        pts = [z.copy()]
        travelled = 0.0
        h = ds
        while len(pts) < max_points // 2:
            pred = z + h * tan
            new, ok = _newton(fl, pred, extra=(tan, pred))
            if not ok or np.linalg.norm(new - z) > 2 * h:
                if h < ds / 64:
                    break
                h /= 2
                continue
            Jn = fl.DF(new)
            tn = np.cross(Jn[0], Jn[1])
            tn /= np.linalg.norm(tn)
            if tn @ tan < 0:
                tn = -tn
            travelled += abs(new[0] - z[0])
            z, tan = new, tn
            h = min(ds, 1.5 * h)
            if not (0 < z[1] <= v_max) or z[2] <= 0 or travelled > 1.0:
                break
            z[0] = z[0] % 1.0 if travelled <= 1.0 else z[0]
            pts.append(z.copy())
        halves.append(pts)
    back = halves[1][1:][::-1]
    return np.array(back + halves[0])
