"""Bifurcation-point scores: where a model puts the grazing and period-doubling points along eta.

Unlike trajectories, these do not decorrelate after ~100 periods; each point is the root of a
smooth function measured on the model as a black box (``docs/numerics.rst``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from fractions import Fraction
from typing import Any

import numpy as np

from precise_impact.analysis.orbits import continue_orbit, find_orbit, one_impact_orbits
from precise_impact.core.flow import grazing_frequencies, steady_state
from precise_impact.core.params import Params
from precise_impact.errors import IntegrationError
from precise_impact.scenes.run import run_scene
from precise_impact.verification.metrics import scene_for_model

__all__ = ["mechanical_points", "model_grazing", "model_period_doubling", "point_scores"]

#: Periods run before the measured period: the transient exp(-zeta t) from the mechanical
#: steady state (a model's is within ~1e-2 of it) decays below 1e-10 for zeta = 0.05.
SETTLE_PERIODS = 64
#: Offset of the run whose stroboscopic samples identify the model's map: large against a
#: switching model's noise floor (~5e-6 for the datasheet switched-capacitor), small enough
#: that the map's quadratic terms (~1e-3 relative) do not bias the multipliers visibly.
PERTURBATION = 1e-3
#: Dense samples per period for the maximum (a cubic through 7 samples: error ~h^4 ~ 1e-11).
DENSE = 1000


def mechanical_points(params: Params) -> dict:
    """The mechanics' grazing frequency (closed form) and the period-doubling point of its
    stable 1:1 orbit (continuation from eta = 1; ``None`` if there is none in 0.5 <= eta <= 1).

    Parameters
    ----------
    params : Params
        The system (eta is varied).

    Returns
    -------
    dict
        ``{"grazing": float, "period-doubling": float or None, "pd_state": (x, v) or None}``.
    """

    g = float(grazing_frequencies(params)[0])
    p1 = params.replace(eta=Fraction(1))
    stable = [o for o in one_impact_orbits(p1, dps=30) if o.stable]
    pd = state = None
    if stable:
        res = continue_orbit(
            p1,
            "eta",
            "1",
            "0.5",
            1,
            guess=(float(stable[0].x), float(stable[0].v)),
            impacts=1,
            doublings=0,
            virtual=0,
        )
        found = [b for b in res.bifurcations if b.type == "period-doubling" and b.admissible]
        if found:
            pd, state = found[0].value, (found[0].x[0], found[0].v[0])
    return {"grazing": g, "period-doubling": pd, "pd_state": state}


def _peak(tr) -> float:
    """Largest x of the last forcing period of the dense output: a cubic fit through 7 samples."""
    n = DENSE
    t, x = (
        np.asarray(tr.dense_t[-n - 1 :], dtype=float),
        np.asarray(tr.dense_x[-n - 1 :], dtype=float),
    )
    k = int(np.clip(np.argmax(x), 3, len(x) - 4))
    tt, xx = t[k - 3 : k + 4] - t[k], x[k - 3 : k + 4]
    c = np.polyfit(tt, xx, 3)
    roots = np.roots(np.polyder(c))
    best = float(x[k])
    for r in roots:
        if abs(r.imag) < 1e-12 and tt[0] <= r.real <= tt[-1]:
            best = max(best, float(np.polyval(c, r.real)))
    return best


def _approach(
    evaluate: Callable[[float, tuple], tuple],
    eta: float,
    direction: float,
    state: tuple,
    max_evaluations: int,
    reference: Callable[[float], tuple] | None = None,
) -> dict:
    """The root of a smooth test function, approached from its valid side.

    ``evaluate(eta, state) -> (value, valid, end_state)``: ``value > 0`` on the valid side
    (the orbit exists and is measured), ``valid`` false past the point (the model impacted,
    or its orbit escaped).  A secant through the last two valid values predicts the root;
    the next trial goes 0.9 of the way, or halfway to the nearest invalid value when the
    prediction lies beyond it.  Each run starts from the model's own orbit as predicted by
    the mechanical orbit at the new eta, ``reference(eta)``, plus the model's offset from the
    mechanics at the last valid eta (the offset varies slowly with eta; the orbit itself may
    not, near resonance), so the transient stays far below the margin and a coexisting
    attractor is not entered.

    Returns ``{"eta", "resolution", "evaluations", "values", "how", "lost"}``: ``eta`` is the
    secant root through the last two valid values, ``resolution`` its distance from the last
    valid eta; ``how`` is ``'root'`` (the test function reached ~0: the point is located) or
    ``'extrapolated'`` (the orbit was lost, within the bracket ``lost``, while the test
    function was still ``values[-1]``: an imperfect, discontinuity-induced bifurcation of a
    switching model; ``eta`` extrapolates the smooth part).
    """
    pts: list[tuple[float, float]] = []
    ends: list[tuple] = []
    bad = None
    root = resolution = math.inf
    ev = 0
    for ev in range(1, max_evaluations + 1):
        start = state
        if reference is not None:
            if pts:
                r_new, r_old = reference(eta), reference(pts[-1][0])
                start = tuple(n + (e - o) for n, e, o in zip(r_new, ends[-1], r_old, strict=True))
            else:
                start = reference(eta)
        value, valid, end = evaluate(eta, start)
        if not valid or value <= 0:
            if not pts:
                eta -= direction * 0.02  # started past the point: further back
                continue
            if bad is None or abs(eta - pts[-1][0]) < abs(bad - pts[-1][0]):
                bad = eta
        else:
            pts.append((eta, value))
            ends.append(end)
            state = end
        last = pts[-1][0]
        if len(pts) >= 2:
            (e1, g1), (e2, g2) = pts[-2], pts[-1]
            root = e2 - g2 * (e2 - e1) / (g2 - g1) if g2 != g1 else e2
            resolution = abs(root - e2)
            if resolution < 1e-9:
                return {
                    "eta": root,
                    "resolution": resolution,
                    "evaluations": ev,
                    "values": pts,
                    "how": "root",
                    "lost": None,
                }
            target = e2 + 0.9 * (root - e2)
        else:
            target = last + direction * 0.01
        if bad is not None and (target - bad) * direction >= 0:
            target = 0.5 * (last + bad)
            if abs(bad - last) < 1e-9:
                break
        eta = target
    if len(pts) < 2:
        raise IntegrationError("the model's orbit was not found on the near side of the point")
    out = {
        "eta": root,
        "resolution": resolution,
        "evaluations": ev,
        "values": pts,
        "how": "root",
        "lost": None,
    }
    if bad is not None:
        out["lost"] = [min(pts[-1][0], bad), max(pts[-1][0], bad)]
        if pts[-1][1] > 1e-3 * pts[0][1]:  # lost while the test function was far from zero
            out["how"] = "extrapolated"
    return out


def model_grazing(
    run: Callable[..., Any], params: Params, eta_mech: float, max_evaluations: int = 24
) -> dict:
    """The eta at which the model's non-impacting steady state touches the wall.

    Parameters
    ----------
    run : callable
        ``run(params, periods, per_period)`` -> the model's Trajectory (dense output).
    params : Params
        The system (eta replaced by each trial value; the first run starts from the
        mechanical steady state, each later one from the model's state of the run before).
    eta_mech : float
        The mechanics' grazing frequency (the search starts 0.03 below it).
    max_evaluations : int, default 24
        Model runs at most.

    Returns
    -------
    dict
        ``{"eta", "resolution", "evaluations", "values"}``: ``resolution`` is the last secant
        step (the root is known to about that); ``values`` the margins ``x_w - max x``.
    """

    xw = float(params.x_w)

    def mechanics(eta: float) -> tuple:
        ss = steady_state(params.replace(eta=Fraction(eta)))
        return float(ss.P), float(ss.eta * ss.Q)

    def margin(eta: float, state: tuple):
        q = params.replace(
            eta=Fraction(eta), x0=Fraction(state[0]), v0=Fraction(state[1]), t0=Fraction(0)
        )
        tr = run(q, SETTLE_PERIODS + 1, DENSE)
        T = 2 * math.pi / eta
        late = any(t > (SETTLE_PERIODS // 2) * T for t in np.asarray(tr.impacts_t, dtype=float))
        return xw - _peak(tr), not late, (float(tr.x[-1]), float(tr.v[-1]))

    return _approach(
        margin, eta_mech - 0.03, 1.0, mechanics(eta_mech - 0.03), max_evaluations, mechanics
    )


def _monodromy(run: Callable[..., Any], params: Params, eta: float, state: tuple) -> tuple:
    """The model's fitted stroboscopic Jacobian at its 1:1 orbit near ``state``: ``(A, residual,
    settled, end_state)``."""
    q = params.replace(
        eta=Fraction(eta), x0=Fraction(state[0]), v0=Fraction(state[1]), t0=Fraction(0)
    )
    tr = run(q, 150, 0)
    x0, v0 = float(tr.x[-1]), float(tr.v[-1])
    steps = np.hypot(np.diff(np.asarray(tr.x, dtype=float)), np.diff(np.asarray(tr.v, dtype=float)))
    # not escaping: |mu| <= 1 over the last 20 periods, or within the model's noise floor (a
    # switching model's stroboscopic map can hold a 1e-5 period-2 cycle of its delays and
    # hysteresis)
    settled = bool(steps[-1] <= max(steps[-21], 0.1 * PERTURBATION))
    fits, resid = [], 0.0
    for sign in (
        1,
        -1,
    ):  # +-: the map's quadratic terms bias the two fits oppositely, the mean is O(d^2)
        xs = min(x0, float(params.x_w) - PERTURBATION) + sign * PERTURBATION
        tr = run(q.replace(x0=Fraction(xs), v0=Fraction(v0)), 60, 0)
        z = np.column_stack([np.asarray(tr.x, dtype=float), np.asarray(tr.v, dtype=float)])
        X = np.column_stack([z[:-1], np.ones(len(z) - 1)])
        coef, *_ = np.linalg.lstsq(X, z[1:], rcond=None)
        fits.append(coef[:2].T)
        resid = max(resid, float(np.abs(X @ coef - z[1:]).max()))
    return 0.5 * (fits[0] + fits[1]), resid, settled, (x0, v0)


def model_period_doubling(
    run: Callable[..., Any],
    params: Params,
    eta_mech: float,
    state: tuple,
    max_evaluations: int = 24,
) -> dict:
    """The eta at which the model's 1:1 orbit has a multiplier -1.

    Parameters
    ----------
    run : callable
        ``run(params, periods, per_period)`` -> the model's Trajectory.
    params : Params
        The system.
    eta_mech : float
        The mechanics' period-doubling point (the search starts 0.03 above it, on the
        stable side of the mechanical orbit).
    state : pair
        The mechanical orbit's point at ``t0`` at ``eta_mech`` (the first run starts there).
    max_evaluations : int, default 24
        Evaluations (two model runs each) at most.

    Returns
    -------
    dict
        ``{"eta", "resolution", "evaluations", "values", "fit_residual"}``; the test
        function is ``det(A + I) = (1 + mu_1)(1 + mu_2)`` of the fitted map (real whether the
        multipliers are real or a complex pair, zero at a multiplier -1).
    """
    fits: list[float] = []

    def test(eta: float, st: tuple):
        A, resid, settled, end = _monodromy(run, params, eta, st)
        fits.append(resid)
        return float(np.linalg.det(A + np.eye(2))), settled and resid < 0.05 * PERTURBATION, end

    known = {eta_mech: tuple(state)}

    def mechanics(eta: float) -> tuple:
        """The mechanical 1:1 orbit at eta (Newton from the nearest one known)."""

        if eta not in known:
            near = min(known, key=lambda e: abs(e - eta))
            o = find_orbit(params.replace(eta=Fraction(eta)), 1, guess=known[near], impacts=1)
            known[eta] = (o.x, o.v)
        return known[eta]

    out = _approach(test, eta_mech + 0.03, -1.0, state, max_evaluations, mechanics)
    out["fit_residual"] = max(fits)
    return out


def point_scores(scene: Any, model: str, mechanics: dict | None = None) -> dict:
    """The grazing and period-doubling shifts of ``model`` on ``scene``'s system (eta varied).

    Parameters
    ----------
    scene : Scene
        A single-oscillator scene (its parameters, components and effects).
    model : str
        One of the scene models.
    mechanics : dict or None, default ``None``
        :func:`mechanical_points` of the scene's parameters (computed when ``None``).

    Returns
    -------
    dict
        ``{"grazing": {"mechanics", "model", "shift", "resolution", "evaluations"},
        "period-doubling": {... , "fit_residual"} or None}``.
    """
    base = scene_for_model(scene, model)[0]
    mech = mechanical_points(scene.params) if mechanics is None else mechanics

    def run(params, periods, per_period):
        sc = dataclasses.replace(base, params=params, periods=periods, per_period=per_period)
        return run_scene(sc, max_time=600)

    g = model_grazing(run, scene.params, mech["grazing"])
    out = {
        "grazing": {
            "mechanics": mech["grazing"],
            "model": g["eta"],
            "shift": g["eta"] - mech["grazing"],
            "resolution": g["resolution"],
            "evaluations": g["evaluations"],
            "how": g["how"],
            "lost": g["lost"],
        },
        "period-doubling": None,
    }
    if mech["period-doubling"] is not None:
        d = model_period_doubling(run, scene.params, mech["period-doubling"], mech["pd_state"])
        out["period-doubling"] = {
            "mechanics": mech["period-doubling"],
            "model": d["eta"],
            "shift": d["eta"] - mech["period-doubling"],
            "resolution": d["resolution"],
            "evaluations": 3 * d["evaluations"],
            "fit_residual": d["fit_residual"],
            "how": d["how"],
            "lost": d["lost"],
            "test_at_last_valid": d["values"][-1][1],
        }
    return out
