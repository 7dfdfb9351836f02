"""(1,n) response curves: impact velocity ``V`` against ``sigma = x_w`` or ``omega = eta``.

Branches come from the continuation started on the closed-form orbits; the undamped Budd-Dux
closed forms (:func:`budd_dux_orbit`, :func:`budd_dux_points`) are the references (Budd & Dux
1994).  Derivation and classification: ``docs/guide/response_curves.rst``.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import os
import time
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.analysis.orbits.branch import Bifurcation
from precise_impact.analysis.orbits.continuation import continue_orbit
from precise_impact.analysis.orbits.one_impact import one_impact_orbits
from precise_impact.core import flight
from precise_impact.core.budget import Cost, check_cost
from precise_impact.core.impact import oscillator_saltation
from precise_impact.core.params import Params, check_count, decimal_str, exact, params_or_values
from precise_impact.core.result import ResultMixin, columns
from precise_impact.errors import (
    BudgetExceededError,
    ConvergenceError,
    IntegrationError,
    ParameterError,
    check_type,
)
from precise_impact.io.figures import finish, legend_outside, new_figure

__all__ = [
    "response_curve",
    "ResponseCurve",
    "budd_dux_orbit",
    "budd_dux_points",
    "budd_dux_locate",
]

#: The kinds of a response curve's points, in the order the legend lists them.
KINDS = ("stable", "unstable", "elliptic", "unphysical", "virtual")
_STYLE = {
    "stable": {"color": "tab:blue", "linestyle": "-", "linewidth": 1.8},
    "unstable": {"color": "tab:red", "linestyle": "--", "linewidth": 1.4},
    "elliptic": {"color": "tab:green", "linestyle": "-.", "linewidth": 1.4},
    "unphysical": {"color": "tab:orange", "linestyle": (0, (5, 1, 1, 1)), "linewidth": 1.2},
    "virtual": {"color": "0.6", "linestyle": ":", "linewidth": 1.2},
}
_MARK = {
    "fold": {"marker": "^", "color": "k"},
    "period-doubling": {"marker": "s", "color": "tab:purple"},
    "grazing": {"marker": "o", "color": "tab:orange"},
    "neimark-sacker": {"marker": "D", "color": "tab:green"},
    "branch-point": {"marker": "x", "color": "k"},
}
_PARAMS = ("x_w", "eta")
_LABEL = {"x_w": "sigma = x_w", "eta": "omega = eta"}


#: Seconds per continuation point of a (1,1) response curve, measured on this project's
#: 2-core machine (zeta 0, a 1, R 0.8, eta 2.8, x_w -2 .. 0.5 from -1, warm): 102 points in
#: 3.5-3.7 s, 36 ms; priced at 40 ms and linear in n (an assumption: flights n periods long).
SECONDS_PER_POINT = 0.04
#: Bytes per point held (its orbit, eigenvalues and classification; priced generously).
BYTES_PER_POINT = 4000.0


def budd_dux_orbit(theta: Any, eta: Any, R: Any, n: int = 1, a: Any = 1, ops: Any = None) -> tuple:
    """The undamped (``zeta = 0``) ``(1,n)`` orbit with impact phase ``theta`` in closed form.

    Generic in the number type: every operation goes through ``ops`` (a
    :mod:`precise_impact.core.flight` ops namespace), so the same lines give float64 and
    mpmath at any precision.

    Parameters
    ----------
    theta : number
        ``omega t*`` of the impact (any real; ``2 pi``-periodic).
    eta, R : number
        ``omega`` and ``r``, numbers of ``ops`` (``0 <= R < 1``, ``eta != 1``,
        ``sin(n pi / eta) != 0``).
    n : int, default 1
        Forcing periods per impact.
    a : number, default 1
        The forcing amplitude.
    ops : ops namespace or None, default ``None``
        ``flight.FLOAT`` for ``None``; ``flight.MpmathOps(dps=50)`` for 50 digits.

    Returns
    -------
    tuple
        ``(sigma, V, trace, det)``: the wall position, the impact velocity ``v^-`` (negative:
        a virtual orbit) and the trace and determinant of the monodromy matrix
        ``S Phi(n T)`` (``det = r^2``).  The fold test is ``1 - trace + det`` (a multiplier
        ``+1``), the period-doubling test ``1 + trace + det`` (``-1``).

    Raises
    ------
    ZeroDivisionError
        ``V = 0`` (a grazing impact has no saltation matrix), ``eta = 1``, ``R = 1`` or an
        ``eta = n / k`` resonance.

    See Also
    --------
    budd_dux_points : the folds, period-doublings and grazings from these closed forms.
    response_curve : the continued curve.

    Examples
    --------
    >>> from precise_impact.analysis.impact_surface.response import budd_dux_orbit
    >>> s, V, tr, det = budd_dux_orbit(2.0, 2.8, 0.8)
    >>> round(s, 6), round(V, 6), round(det, 12)
    (-1.552456, 3.72227, 0.64)
    """
    if ops is None:  # floats: each a real number, refused by name before any arithmetic
        for name, x in (("theta", theta), ("eta", eta), ("R", R), ("a", a)):
            exact(name, check_type(x, numbers.Real, name, "a real number (float or Fraction)"))
    ops = flight.FLOAT if ops is None else ops
    gamma = a / (1 - eta * eta)
    ch, sh = ops.cos_sin(n * ops.pi / eta)
    beta = (1 + R) / (1 - R) * ch / sh
    c, s = ops.cos_sin(theta)
    sigma = gamma * (c + beta * eta * s)
    V = -2 * eta * gamma * s / (1 - R)
    S = oscillator_saltation(theta / eta, V, eta, 0 * eta, a, sigma, R, ops.cos)
    p00, p01, p10, p11 = flight.flow_matrix(2 * n * ops.pi / eta, 0 * eta, 1 + 0 * eta, ops)
    trace = S[0][0] * p00 + S[0][1] * p10 + S[1][0] * p01 + S[1][1] * p11
    det = (S[0][0] * S[1][1] - S[0][1] * S[1][0]) * (p00 * p11 - p01 * p10)
    return sigma, V, trace, det


def _test(kind: str, theta, eta, R, n, a, ops):
    _, _, tr, det = budd_dux_orbit(theta, eta, R, n, a, ops)
    return 1 - tr + det if kind == "fold" else 1 + tr + det


def budd_dux_points(
    eta: Any, R: Any, n: int = 1, a: Any = 1, dps: int = 50, samples: int = 2000
) -> list[dict]:
    """Folds, period-doublings and grazings of the undamped ``(1,n)`` curve in ``sigma``.

    Folds: the turning points ``tan theta = beta omega`` of the ellipse (closed form), checked
    to carry a multiplier ``+1``; period-doublings: the zeros of ``1 + trace + det`` in
    ``theta`` (sign changes on ``samples`` phases, refined by :func:`mpmath.findroot`);
    grazings: ``V = 0`` at ``theta = 0, pi``.  All at ``dps`` digits.  A fold or
    period-doubling at ``V = 0`` (the tests' ``1 / V``) is decided by the test's limit there:
    at ``2 n / omega`` odd (``Phi(n T) = -I``, both multipliers ``r``) only the grazings.

    Parameters
    ----------
    eta, R : decimal
        ``omega`` and ``r`` (``0 <= R < 1``), exact decimals or fractions.
    n : int, default 1
        Forcing periods per impact.
    a : decimal, default 1
        The forcing amplitude.
    dps : int, default 50
        Digits (``15 <= dps <= 1000``).
    samples : int, default 2000
        Phases on which the period-doubling test's sign changes are looked for.

    Returns
    -------
    list of dict
        ``{"type", "theta", "x_w", "V", "test"}`` with mpmath numbers (``test``: the
        multiplier test at the point; ``0`` for a grazing), sorted by ``theta``; a point
        with ``V < 0`` lies on the virtual part.

    Raises
    ------
    ParameterError
        Bad input.

    See Also
    --------
    budd_dux_orbit : the closed forms.
    response_curve : the continuation these points check.

    Examples
    --------
    >>> from precise_impact.analysis.impact_surface.response import budd_dux_points
    >>> pts = budd_dux_points("2.8", "0.8", dps=30)
    >>> [(p["type"], round(float(p["x_w"]), 9)) for p in pts if p["V"] > 0]
    [('fold', -1.780235601), ('period-doubling', -0.068575652)]
    """
    dps = check_count(dps, "dps", 1000, minimum=15)
    n = check_count(n, "n", 1000, minimum=1)
    samples = check_count(samples, "samples", 10**6, minimum=8)
    eq, Rq, aq = exact("eta", eta), exact("R", R), exact("a", a)
    if not 0 <= Rq < 1:
        raise ParameterError("R", str(R), "0 <= R < 1 (the ellipse degenerates at R = 1)")
    if eq <= 0 or eq == 1 or (n / eq).denominator == 1 or aq == 0:
        raise ParameterError(
            "eta", str(eta), "eta > 0, not 1 and not n / k (where sin(n pi / eta) = 0); a != 0"
        )
    ops = flight.MpmathOps(dps=dps)
    mp = ops.ctx
    e, r, av = ops.num(eq), ops.num(Rq), ops.num(aq)
    gamma = av / (1 - e * e)
    ch, sh = _half_turn(eq, n, ops)
    beta = (1 + r) / (1 - r) * ch / sh
    # a test "vanishes" below half the working digits (the tests at the points themselves are
    # ~1e-dps; a limit by mp.diff keeps more than half the digits)
    tol = mp.mpf(10) ** (-(dps // 2))
    out = []
    tf = mp.atan(beta * e)
    for theta in (tf, tf + mp.pi):
        if beta == 0:  # the turning points are the grazings theta = 0, pi (V = 0): the limit
            test = _graze_limit("fold", theta, (e, r, n, av, ops))
            if not abs(test) <= tol:
                continue  # no multiplier +1 there (at Phi(n T) = -I both multipliers are r)
            s, V = gamma * mp.cos(theta), mp.zero
        else:
            s, V, tr, det = budd_dux_orbit(theta, e, r, n, av, ops)
            test = 1 - tr + det
        out.append({"type": "fold", "theta": theta, "x_w": s, "V": V, "test": test})
    for theta in (mp.zero, mp.pi):
        out.append(
            {
                "type": "grazing",
                "theta": theta,
                "x_w": gamma * mp.cos(theta),
                "V": mp.zero,
                "test": mp.zero,
            }
        )
    out += _period_doublings(e, r, n, av, ops, samples, tol)
    out.sort(key=lambda p: p["theta"])
    return out


def _half_turn(eq: Fraction, n: int, ops: Any) -> tuple:
    """``(cos, sin)(n pi / omega)``, exact where ``2 n / omega`` is an odd integer (``Phi(n T)
    = -I``, ``beta = 0``: the rounded ``pi`` would leave ``cos ~ 10^-dps``, and the folds
    ``tan theta = beta omega`` a rounding's distance from the grazings)."""
    k = Fraction(2 * n) / eq
    if k.denominator == 1 and k.numerator % 2 == 1:
        return ops.num(0), ops.num(1 if k.numerator % 4 == 1 else -1)
    return ops.cos_sin(n * ops.pi / ops.num(eq))


def _h(kind: str, args: tuple):
    """``theta -> V * test``: smooth through ``V = 0``, where the test has the saltation
    matrix's ``1 / V`` (``args = (eta, R, n, a, ops)``)."""

    def h(th):
        _, V, tr, det = budd_dux_orbit(th, *args)
        return V * (1 - tr + det if kind == "fold" else 1 + tr + det)

    return h


def _graze_limit(kind: str, theta0: Any, args: tuple) -> Any:
    """The test's limit at a grazing ``theta0`` (``V(theta0) = 0``), never the test evaluated
    a rounding away from it: ``(V test)' / V'`` (l'Hopital) where ``V test`` vanishes, infinite
    (``mp.inf``, a pole: no bifurcation) where it does not."""
    eta, R, n, a, ops = args
    mp = ops.ctx
    h = _h(kind, args)
    # h(theta0) and h'(theta0) from theta0 +- d (h at theta0 itself has the saltation's 0 / 0):
    # errors d^2 ~ 10^(-dps/2) and rounding 10^-dps / d ~ 10^(-3 dps/4)
    d = mp.mpf(10) ** (-(mp.dps // 4))
    hp, hm = h(theta0 + d), h(theta0 - d)
    dh = (hp - hm) / (2 * d)
    dV = -2 * eta * a / (1 - eta * eta) * mp.cos(theta0) / (1 - R)
    if abs(hp + hm) / 2 > mp.mpf(10) ** (-(mp.dps // 2) + 2) * (1 + abs(dh)):
        return mp.inf
    return dh / dV


def _period_doublings(e, r, n, av, ops, samples: int, tol: Any) -> list[dict]:
    """The zeros of ``V (1 + trace + det)`` (:func:`_h`) in ``theta``: sign changes on
    ``samples`` phases (float), refined at the working precision; a zero at ``V = 0`` (``theta
    = 0, pi``, a zero of the factor ``V``) is kept only if the test's limit there vanishes."""
    mp = ops.ctx
    args = (e, r, n, av, ops)
    h = _h("period-doubling", args)
    hf = _h("period-doubling", (float(e), float(r), n, float(av), flight.FLOAT))
    grid = [2 * math.pi * (k + 0.5) / samples for k in range(samples + 1)]
    fl = [hf(th) for th in grid]
    out = []
    for k in range(samples):
        t0, t1 = grid[k], grid[k + 1]
        if not (fl[k] < 0) != (fl[k + 1] < 0):
            continue
        theta = mp.findroot(h, (mp.mpf(t0), mp.mpf(t1)), solver="anderson")
        graze = [g for g in (mp.pi, 2 * mp.pi) if t0 < g < t1 and abs(theta - g) <= tol]
        if graze:  # the root is V's: the limit decides
            test = _graze_limit("period-doubling", graze[0], args)
            if not abs(test) <= tol:
                continue
            theta, s, V = graze[0], av / (1 - e * e) * mp.cos(graze[0]), mp.zero
        else:
            s, V, tr, det = budd_dux_orbit(theta, *args)
            test = 1 + tr + det
        out.append({"type": "period-doubling", "theta": theta, "x_w": s, "V": V, "test": test})
    return out


def budd_dux_locate(
    kind: str, eta: Any, x_w: Any, V: Any, R: Any, n: int = 1, a: Any = 1, dps: int = 50
) -> dict:
    """A fold or period-doubling of the undamped ``(1,n)`` curve in ``omega`` at fixed
    ``sigma``, by Newton's method on the closed forms (:func:`budd_dux_orbit`) at ``dps``
    digits from a guess.

    Solves ``sigma(theta, omega) = x_w`` and the multiplier test (``1 - trace + det`` for a
    fold, ``1 + trace + det`` for a period-doubling) for ``(theta, omega)``; the starting
    ``theta`` is the impact phase of the orbit with velocity ``V`` at ``(eta, x_w)``.

    Parameters
    ----------
    kind : str
        ``'fold'`` or ``'period-doubling'``.
    eta : float or decimal
        The guess of ``omega``.
    x_w : decimal
        ``sigma`` (fixed).
    V : float or decimal
        The guess of the impact velocity.
    R : decimal
        ``r`` (``0 <= R < 1``).
    n : int, default 1
        Forcing periods per impact.
    a : decimal, default 1
        The forcing amplitude.
    dps : int, default 50
        Digits (``15 <= dps <= 1000``).

    Returns
    -------
    dict
        ``{"type", "theta", "eta", "x_w", "V", "test"}`` (mpmath numbers; ``x_w`` is
        ``sigma`` recomputed at the root, ``test`` the test function there).

    Raises
    ------
    ParameterError
        Bad input.
    ValueError
        Newton's method did not converge from the guess (mpmath's ``findroot``).

    See Also
    --------
    budd_dux_points : the same points in ``sigma`` at fixed ``omega``.
    response_curve : the continuation these points check.

    Examples
    --------
    >>> from precise_impact.analysis.impact_surface.response import budd_dux_locate
    >>> p = budd_dux_locate("fold", 2.8, "-1.7802356013215904924", 4.08, "0.8", dps=30)
    >>> round(float(p["eta"]), 12)
    2.8
    """
    if kind not in ("fold", "period-doubling"):
        raise ParameterError("kind", str(kind), "fold or period-doubling")
    dps = check_count(dps, "dps", 1000, minimum=15)
    n = check_count(n, "n", 1000, minimum=1)
    Rq = exact("R", R)
    if not 0 <= Rq < 1:
        raise ParameterError("R", str(R), "0 <= R < 1")
    ops = flight.MpmathOps(dps=dps)
    mp = ops.ctx
    xw, r, av = ops.num(exact("x_w", x_w)), ops.num(Rq), ops.num(exact("a", a))
    e0, v0 = mp.mpf(str(eta)), mp.mpf(str(V))
    gamma = av / (1 - e0 * e0)
    ch, sh = ops.cos_sin(n * ops.pi / e0)
    beta = (1 + r) / (1 - r) * ch / sh
    s0 = -(1 - r) * v0 / (2 * e0 * gamma)
    c0 = xw / gamma - beta * e0 * s0
    th0 = mp.atan2(s0, c0)
    test = "fold" if kind == "fold" else "pd"

    def eqs(th, e):
        return (
            budd_dux_orbit(th, e, r, n, av, ops)[0] - xw,
            _test(test, th, e, r, n, av, ops),
        )

    th, e = mp.findroot(eqs, (th0, e0))
    sg, Vr, tr, det = budd_dux_orbit(th, e, r, n, av, ops)
    return {
        "type": kind,
        "theta": th,
        "eta": e,
        "x_w": sg,
        "V": Vr,
        "test": 1 - tr + det if kind == "fold" else 1 + tr + det,
    }


@dataclasses.dataclass
class ResponseCurve(ResultMixin):
    """A ``(1,n)`` response curve: impact velocity ``V`` against ``x_w`` or ``eta``.

    Attributes
    ----------
    params : Params
        The system at the starting orbit (``parameter = at``).
    n : int
        Forcing periods per impact.
    parameter : str
        ``'x_w'`` (Budd-Dux ``sigma``) or ``'eta'`` (``omega``).
    start, stop, at : Fraction
        The range and where the branches were started.
    values, V : numpy.ndarray of float
        The parameter and the impact velocity ``v^-`` along the curve (continuation order).
    kind : numpy.ndarray of str
        Per point: ``'stable'``, ``'unstable'``, ``'elliptic'`` (``zeta = 0``, ``R = 1``),
        ``'unphysical'`` (``V >= 0`` but a flight crosses the wall: an earlier intermediate
        impact) or ``'virtual'`` (``V < 0``: not an orbit of the impacting system).
    x, v : numpy.ndarray of float
        The orbit's stroboscopic state at ``t0`` (a starting guess for
        :func:`~precise_impact.analysis.orbits.newton.find_orbit`).
    branch : numpy.ndarray of int
        Which continued branch each point lies on (a branch is one connected curve).
    bifurcations : list of Bifurcation
        Folds, period-doublings, grazings (and Neimark-Sacker points) located by the
        continuation, each once; ``impact_v`` is their ``V``.
    stop_reasons : list of str
        Why each branch ended (``'closed'``: it came back to its first point).
    elapsed_s : float
        Wall time (diagnostic).

    See Also
    --------
    response_curve : computes it.
    budd_dux_points : the closed-form folds and period-doublings (``zeta = 0``).
    """

    params: Params
    n: int
    parameter: str
    start: Fraction
    stop: Fraction
    at: Fraction
    values: np.ndarray
    V: np.ndarray
    kind: np.ndarray
    x: np.ndarray
    v: np.ndarray
    branch: np.ndarray
    bifurcations: list
    stop_reasons: list
    elapsed_s: float

    def _tables(self) -> dict:
        """``to_dataframe()`` tables: ``points`` (default) and ``bifurcations``."""

        def points() -> dict:
            return columns(
                ("branch", None, np.asarray(self.branch)),
                (self.parameter, "1", np.asarray(self.values, dtype=float)),
                ("V", "1", np.asarray(self.V, dtype=float)),
                ("kind", None, np.asarray(self.kind)),
                ("x", "1", np.asarray(self.x, dtype=float)),
                ("v", "1", np.asarray(self.v, dtype=float)),
            )

        def bifurcations() -> dict:
            return columns(
                ("type", None, [b.type for b in self.bifurcations]),
                (self.parameter, "1", np.array([b.value for b in self.bifurcations], float)),
                ("V", "1", np.array([_bif_v(b) for b in self.bifurcations], float)),
                ("admissible", None, [b.admissible for b in self.bifurcations]),
            )

        return {"points": points, "bifurcations": bifurcations}

    def counts(self) -> dict[str, int]:
        """Points per kind (each point counted once)."""
        return {k: int(np.sum(np.asarray(self.kind) == k)) for k in KINDS}

    def to_dict(self) -> dict[str, Any]:
        """The CLI's ``--json`` object: ``params``, ``n``, ``parameter``, ``from``, ``to``,
        ``at``, ``points`` (``[{branch, NAME, V, kind, x, v}]``), ``bifurcations`` and
        ``counts``."""
        return {
            "params": self.params.decimal(),
            "n": self.n,
            "parameter": self.parameter,
            "from": decimal_str(self.start),
            "to": decimal_str(self.stop),
            "at": decimal_str(self.at),
            "counts": self.counts(),
            "points": [
                {
                    "branch": int(b),
                    self.parameter: float(lam),
                    "V": float(V),
                    "kind": str(k),
                    "x": float(x),
                    "v": float(v),
                }
                for b, lam, V, k, x, v in zip(
                    self.branch, self.values, self.V, self.kind, self.x, self.v, strict=True
                )
            ],
            "bifurcations": [b.to_dict() for b in self.bifurcations],
            "stop_reasons": list(self.stop_reasons),
            "elapsed_s": self.elapsed_s,
        }

    def draw(self, ax: Any) -> None:
        """Draw the curve on ``ax``: one line style per kind, markers for the bifurcations."""
        vals, V = np.asarray(self.values, float), np.asarray(self.V, float)
        kind, br = np.asarray(self.kind), np.asarray(self.branch)
        seen: set = set()
        for k in KINDS:  # the legend in a fixed order: the parts first, then the markers
            if np.any(kind == k):
                ax.plot([], [], label=k, **_STYLE[k])
                seen.add(k)
        for i in range(len(vals) - 1):
            if br[i] != br[i + 1]:
                continue
            # a segment takes the kind of its less physical end (so a part starts at its point)
            k = max(kind[i], kind[i + 1], key=KINDS.index)
            ax.plot(vals[i : i + 2], V[i : i + 2], label=None if k in seen else k, **_STYLE[k])
            seen.add(k)
        for b in self.bifurcations:
            m = _MARK.get(b.type, {"marker": "*", "color": "k"})
            ax.plot(
                [b.value],
                [_bif_v(b)],
                linestyle="none",
                markersize=7,
                markerfacecolor="none" if not b.admissible else m["color"],
                markeredgecolor=m["color"],
                marker=m["marker"],
                label=None if b.type in seen else b.type,
            )
            seen.add(b.type)
        ax.axhline(0, color="k", linewidth=0.5)
        ax.set_xlabel(_LABEL[self.parameter])
        ax.set_ylabel("impact velocity V")

    def plot(self, path: str | os.PathLike | None = None):
        """``V`` against the parameter (:meth:`draw`), the legend naming every part and
        marker (hollow markers: on a virtual or unphysical part).

        Parameters
        ----------
        path : str, os.PathLike or None, default ``None``
            Also write the figure there (``.png``, ``.pdf``, ``.svg``), atomically.

        Returns
        -------
        matplotlib.figure.Figure
        """
        fig, axes = new_figure(figsize=(8.0, 4.8))
        ax = axes[0, 0]
        self.draw(ax)
        p = self.params
        fixed = ", ".join(
            f"{k} = {decimal_str(getattr(p, k))}"
            for k in ("eta", "x_w", "zeta", "a", "R")
            if k != self.parameter
        )
        ax.set_title(
            f"(1,{self.n}) response curve: V against {_LABEL[self.parameter]}\n{fixed}", fontsize=10
        )
        legend_outside(ax)
        return finish(fig, path, dpi=120)

    def save_all(self, out: str | os.PathLike) -> dict[str, Path]:
        """Write ``response.json`` and ``response.png`` into the directory ``out``.

        Parameters
        ----------
        out : str or os.PathLike
            The directory (created if missing).

        Returns
        -------
        dict of str to pathlib.Path
            The files under the keys ``'json'`` and ``'png'``.
        """
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        files = {"json": self.save(out / "response.json"), "png": out / "response.png"}
        self.plot(files["png"])
        return files


def _bif_v(b: Bifurcation) -> float:
    iv = getattr(b, "impact_v", None)
    return float(iv[0]) if iv else math.nan


def _kinds(br: Any) -> np.ndarray:
    iv = np.asarray(br.impact_v, float).min(axis=1)
    wm = np.asarray(br.wall_margin, float)
    st = np.asarray(br.stability, dtype=object)
    return np.where(iv < 0, "virtual", np.where(wm < 0, "unphysical", st)).astype(str)


def _closed(lam: np.ndarray, x: np.ndarray, v: np.ndarray) -> int | None:
    """The index where a branch has come back to its first point (a closed curve), or None."""
    pts = np.column_stack([lam, x, v])
    steps = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    if len(steps) < 4:
        return None
    d = np.linalg.norm(pts - pts[0], axis=1)
    far = np.nonzero(d > 4 * np.median(steps))[0]
    if not len(far):
        return None
    # back within two typical steps of the first point (steps adapt: the median is the
    # typical one; a larger tolerance would take the other sheet near a fold for the start)
    back = np.nonzero((np.arange(len(d)) > far[0]) & (d <= 2 * np.median(steps)))[0]
    return int(back[0]) if len(back) else None


def response_curve(
    params: Any = None,
    n: int = 1,
    parameter: str = "x_w",
    start: Any = None,
    stop: Any = None,
    *,
    at: Any = None,
    max_points: int = 400,
    progress: bool | None = None,
    max_time: Any = None,
    **param_values: Any,
) -> ResponseCurve:
    """The ``(1,n)`` response curve: ``V`` of the one-impact-per-``n``-periods orbits against
    ``x_w`` (``sigma``) or ``eta`` (``omega``), every part told apart.

    The orbits at ``parameter = at`` come from the closed form
    (:func:`~precise_impact.analysis.orbits.one_impact.one_impact_orbits`); each is continued
    (:func:`~precise_impact.analysis.orbits.continuation.continue_orbit`) towards ``stop``
    and towards ``start`` through folds, grazings and the virtual parts, until the
    parameter leaves the range or the curve closes.

    Parameters
    ----------
    params : Params, mapping or None, default ``None``
        The system (``0 <= zeta < 1``, ``0 < R <= 1``).
    n : int, default 1
        Forcing periods per impact (``1 <= n <= 64``).
    parameter : str, default ``'x_w'``
        ``'x_w'`` or ``'eta'``.
    start, stop : decimal
        The range.
    at : decimal or None, default ``None``
        Where the branches start: a value in the range with a physical ``(1,n)`` orbit
        (``None``: ``start``).
    max_points : int, default 400
        Points per branch and direction at most.
    progress : bool or None, default ``None``
        A progress line on stderr (``None``: only when stderr is a terminal).
    max_time : decimal or None, default ``None``
        Time budget in seconds (checked between branches).
    **param_values
        Parameter values replacing those of ``params``.

    Returns
    -------
    ResponseCurve
        Points with their kinds, the located bifurcations, ``plot(path)``.

    Raises
    ------
    ParameterError
        Bad input, before any work.
    ConvergenceError
        No physical ``(1,n)`` orbit at ``at``.
    BudgetExceededError
        ``max_time`` ran out.

    See Also
    --------
    budd_dux_points : the closed-form folds and period-doublings at ``zeta = 0``.
    precise_impact.analysis.orbits.continuation.continue_orbit : the continuation used.

    Examples
    --------
    >>> import precise_impact as pi
    >>> from precise_impact.analysis.impact_surface.response import response_curve
    >>> p = pi.Params.make(zeta="0", a="1", R="0.8", eta="2.8", x_w="-1", x0="-2")
    >>> rc = response_curve(p, 1, "x_w", "-2", "0.5", at="-1", max_points=200)
    >>> fold = [b for b in rc.bifurcations if b.type == "fold" and b.admissible]
    >>> round(fold[0].value, 9)
    -1.780235601
    """
    t_start = time.perf_counter()
    params = params_or_values(params, param_values)
    n = check_count(n, "n", 64, minimum=1)
    max_points = check_count(max_points, "max_points", 100_000, minimum=2)
    lo_q, hi_q, at_q, budget = _check_range(parameter, start, stop, at, max_time)
    # priced before any work: both directions of max_points from the start, each point
    # SECONDS_PER_POINT x n (its flights are n periods long)
    check_cost(
        Cost(2 * max_points * n * SECONDS_PER_POINT, 2 * max_points * BYTES_PER_POINT,
             f"response: 2 x {max_points} points of (1,{n}) orbits"),
        budget, size="max_points",
    )  # fmt: skip
    changes: dict = {parameter: at_q}
    if parameter == "x_w":
        changes["x0"] = min(params.x0, at_q, lo_q, hi_q)
    p_at = params.replace(**changes)
    # an orbit whose impact falls on the stroboscopic phase t0 (always so at zeta = 0, R = 1,
    # where the impact phase is 0 or pi) starts Newton on the wall in a tangential contact:
    # then the section is moved by a quarter period (V and the bifurcations do not depend
    # on it)
    for attempt in (0, 1):
        try:
            orbits = one_impact_orbits(p_at, dps=30, grid=400, period=n)
            if not orbits:
                raise ConvergenceError(
                    f"no physical (1,{n}) orbit at {parameter} = {decimal_str(at_q)}: choose 'at' "
                    "where one exists (one_impact_orbits lists them)"
                )
            vals_l: list = []
            V_l: list = []
            x_l: list = []
            v_l: list = []
            kind_l: list = []
            br_l: list = []
            reasons: list = []
            bifs: list = []
            k = 0
            for orb in orbits:
                _check_time(budget, t_start, max_time)
                g = (float(orb.x), float(orb.v))
                if _on_curve(vals_l, x_l, br_l, float(at_q), g[0]):
                    continue  # the second orbit at ``at`` already lies on a traced branch
                pieces = []
                for j, end in enumerate(e for e in (hi_q, lo_q) if e != at_q):
                    _check_time(budget, t_start, max_time)
                    piece, reason, cut = _piece(
                        p_at, parameter, at_q, end, n, g, max_points, progress, (lo_q, hi_q),
                        reverse=j == 1, branch=k, bifs=bifs,
                    )  # fmt: skip
                    pieces.append(piece)
                    reasons.append(reason)
                    if cut is not None:
                        break  # a closed curve: the other direction is the same curve
                _append_pieces(pieces, k, vals_l, V_l, x_l, v_l, kind_l, br_l)
                k += 1
            break
        except IntegrationError:
            if attempt == 1 or not orbits:
                raise
            quarter = Fraction(round(math.pi / 2 / float(p_at.eta) * 10**6), 10**6)
            p_at = p_at.replace(t0=p_at.t0 + quarter)
    return ResponseCurve(
        params=p_at,
        n=n,
        parameter=parameter,
        start=lo_q,
        stop=hi_q,
        at=at_q,
        values=np.array(vals_l, float),
        V=np.array(V_l, float),
        kind=np.array(kind_l, dtype=str),
        x=np.array(x_l, float),
        v=np.array(v_l, float),
        branch=np.array(br_l, int),
        bifurcations=_unique(bifs),
        stop_reasons=reasons,
        elapsed_s=time.perf_counter() - t_start,
    )


def _check_range(parameter: str, start: Any, stop: Any, at: Any, max_time: Any) -> tuple:
    """The range, the starting value and the time budget, checked: ``(lo, hi, at, budget)``."""
    if parameter not in _PARAMS:
        raise ParameterError("parameter", str(parameter), "x_w or eta")
    if start is None or stop is None:
        raise ParameterError("start" if start is None else "stop", "None", "a decimal value")
    lo_q, hi_q = exact("start", start), exact("stop", stop)
    at_q = lo_q if at is None else exact("at", at)
    if lo_q == hi_q:
        raise ParameterError("stop", str(stop), f"a value of {parameter} other than start")
    if not min(lo_q, hi_q) <= at_q <= max(lo_q, hi_q):
        raise ParameterError("at", str(at), f"a value between start = {start} and stop = {stop}")
    if parameter == "eta" and not at_q > 0:
        raise ParameterError("at", str(at), "eta > 0")
    budget = None if max_time is None else float(exact("max_time", max_time))
    if budget is not None and not budget > 0:
        raise ParameterError("max_time", str(max_time), "a positive number of seconds")
    return lo_q, hi_q, at_q, budget


def _piece(
    p_at, parameter, at_q, end, n, g, max_points, progress, within, *, reverse, branch, bifs
) -> tuple:
    """One direction of the continuation from ``at_q`` to ``end``: ``((lam, V, kind, x, v),
    stop reason, closing index or None)``; its bifurcations appended to ``bifs``."""
    res = continue_orbit(
        p_at,
        parameter,
        at_q,
        end,
        n,
        impacts=1,
        guess=g,
        virtual="10",
        max_points=max_points,
        doublings=0,
        progress=progress,
        within=within,
    )
    b = res.branches[0]
    lam, V, kd = (
        np.asarray(b.values, float),
        np.asarray(b.impact_v, float)[:, 0],
        _kinds(b),
    )
    xs, vs = np.asarray(b.x, float)[:, 0], np.asarray(b.v, float)[:, 0]
    cut = _closed(lam, xs, vs)
    reason = b.stop_reason
    if cut is not None:
        lam, V, kd, xs, vs = (a[: cut + 1] for a in (lam, V, kd, xs, vs))
        reason = "closed (came back to its first point)"
    for bf in res.bifurcations:
        if bf.branch == 0:
            bf.branch = branch
            bifs.append(bf)
    if reverse:
        lam, V, kd, xs, vs = (a[::-1] for a in (lam, V, kd, xs, vs))
    return (lam, V, kd, xs, vs), reason, cut


def _check_time(budget: float | None, t_start: float, max_time: Any) -> None:
    """Raise :class:`BudgetExceededError` once ``budget`` seconds have passed since ``t_start``."""
    if budget is not None and time.perf_counter() - t_start > budget:
        raise BudgetExceededError(f"max_time = {max_time} s ran out")


def _append_pieces(
    pieces: list, k: int, vals_l: list, V_l: list, x_l: list, v_l: list, kind_l: list, br_l: list
) -> None:
    """Branch ``k``'s pieces (start-ward reversed first) appended to the curve's columns."""
    if len(pieces) == 2:
        pieces = [pieces[1], pieces[0]]
    for lam, V, kd, xs, vs in pieces:
        x_l.extend(xs)
        v_l.extend(vs)
        vals_l.extend(lam)
        V_l.extend(V)
        kind_l.extend(kd)
        br_l.extend([k] * len(lam))


def _on_curve(lam_l: list, x_l: list, br_l: list, lam: float, x: float) -> bool:
    """The orbit with stroboscopic ``x`` at ``lam`` lies on a traced branch: within
    ``1e-2 (1 + |x|)`` of the broken line through its points in ``(lam, x)`` (the chords
    of steps of ~1/40 of the range miss the curve by far less; two distinct orbits at one
    parameter value lie O(1) apart except near a fold, where they are on one branch)."""
    if not lam_l:
        return False
    L, X, B = np.asarray(lam_l, float), np.asarray(x_l, float), np.asarray(br_l)
    tol = 1e-2 * (1 + abs(x))
    for i in range(len(L) - 1):
        if B[i] != B[i + 1] or not min(L[i], L[i + 1]) - tol <= lam <= max(L[i], L[i + 1]) + tol:
            continue
        d = np.array([L[i + 1] - L[i], X[i + 1] - X[i]])
        q = np.array([lam - L[i], x - X[i]])
        f = float(np.clip(q @ d / max(float(d @ d), 1e-300), 0.0, 1.0))
        if float(np.linalg.norm(q - f * d)) <= tol:
            return True
    return False


def _unique(bifs: list) -> list:
    """Each located point once (a closed curve continued from two orbits, or both directions,
    meets the same point again): same type, parameter and ``V`` to ``1e-8``."""
    out: list = []
    for b in bifs:
        if any(
            o.type == b.type
            and abs(o.value - b.value) <= 1e-8 * (1 + abs(b.value))
            and abs(_bif_v(o) - _bif_v(b)) <= 1e-6 * (1 + abs(_bif_v(b)))
            for o in out
        ):
            continue
        out.append(b)
    out.sort(key=lambda b: b.value)
    return out
