"""Two identical impact oscillators with master-slave coupling, the paper's eqs. (10)-(15).

Three slave forms: ``'first-order'`` (eqs. 12 as written), ``'paper'`` (eq. 14a as printed) and
``'reduced'`` (what eqs. 12 reduce to; derivation in ``docs/numerics.rst``).  References: Pecora &
Carroll, Phys. Rev. Lett. 64 (1990) 821; Pikovsky, Rosenblum & Kurths (2001), ch. 13.
"""

from __future__ import annotations

import dataclasses
import time as _time
from fractions import Fraction
from typing import Any

import numpy as np

from precise_impact.core.coupling import (
    COUPLED_FORMS,
    check_form,
    check_k,
    check_y0,
    slave_position_rate,
    slave_reset,
    slave_rhs,
)
from precise_impact.core.digits import Digits, estimate_coupled
from precise_impact.core.flow import acceleration
from precise_impact.core.impact import impact_at_start, reset_velocity
from precise_impact.core.params import RUNTIME_PARAMS, Params, check_count, decimal_str
from precise_impact.core.precision import Precision
from precise_impact.core.result import ResultMixin, columns
from precise_impact.errors import BudgetExceededError, IntegrationError, ParameterError
from precise_impact.io.figures import CoupledPlotMixin
from precise_impact.solvers.heyoka.cache import IntegratorCache
from precise_impact.solvers.heyoka.events import ImpactRecorder

__all__ = [
    "COUPLED_FORMS",
    "CoupledTrajectory",
    "simulate_coupled",  # noqa: F822 - the registry entry point, by __getattr__ below
    "HeyokaCoupledSolver",
    "slave_rhs",
    "slave_position_rate",
    "slave_reset",
    "check_k",
    "check_form",
    "check_y0",
]

#: Runtime parameters of the coupled integrator: the single oscillator's, then k.
COUPLED_PARAMS = RUNTIME_PARAMS + ("k",)
_IDX = {name: i for i, name in enumerate(COUPLED_PARAMS)}


# ------------------------------------------------------------------ the callback
def _touch_tol(P: Precision, x_w: Fraction) -> float:
    """How far below the wall (in position) the *other* oscillator may be and still
    be treated as impacting at the same instant: a few ulps of the wall position."""
    return 64 * P.eps_float * (1 + abs(float(x_w)))


class _CoupledImpact:
    """Terminal-event callback for one of the two impact events.

    ``role`` is ``'master'`` (event ``x - x_w``) or ``'slave'`` (event ``y - x_w``).
    When it fires it also looks at the other oscillator: if that one is within
    :func:`_touch_tol` of the wall and moving into it, both impacts are applied
    now, the master's first (so the slave's reduced-form rule sees ``x = x_w``).
    Without this a simultaneous impact (always the case on the diagonal ``y = x``)
    would leave the other oscillator a round-off *beyond* the wall after this
    event, where heyoka (which detects sign changes) could miss its impact.

    The impacts it applies go to two :class:`~precise_impact.solvers.heyoka.events.ImpactRecorder`
    logs, ``master`` (``t, v_before, v_after``) and ``slave`` (``t, w_before, w_after``
    and the master's position in ``aux``); the budget covers both.  heyoka deep-copies
    the callback: read results from ``ta.t_events[i].callback``.
    """

    def __init__(self, role: str, form: str) -> None:
        self.role = role
        self.form = form
        self.touch = 0.0
        self.reset(10**6)

    def reset(self, max_impacts: int, touch: float = 0.0) -> None:
        self.master = ImpactRecorder()  # (t, v_before, v_after)
        self.slave = ImpactRecorder()  # (t, w_before, w_after, aux = x)
        self.max_impacts = max_impacts
        self.touch = touch
        self.exceeded = False

    def __call__(self, ta, d_sgn) -> bool:
        st, pr = ta.state, ta.pars
        R, x_w, k = pr[_IDX["R"]], pr[_IDX["x_w"]], pr[_IDX["k"]]
        x, v, y, w = st[0], st[1], st[2], st[3]
        if self.role == "master":
            hit_m = True
            hit_s = float(y - x_w) >= -self.touch and slave_position_rate(self.form, x, y, w, k) > 0
        else:
            hit_s = True
            hit_m = float(x - x_w) >= -self.touch and v > 0
        t = ta.time
        if hit_m:
            va = reset_velocity(v, R)
            st[0] = x_w  # the event fixes the instant; the position is the wall (2b)
            st[1] = va
            self.master.log(t, v, va)
        if hit_s:
            xm = st[0]
            wa = slave_reset(self.form, xm, w, R, k, x_w)
            st[2] = x_w
            st[3] = wa
            self.slave.log(t, w, wa, xm)
        if self.master.count + self.slave.count >= self.max_impacts:
            self.exceeded = True
            return False
        return True


_INTEGRATORS = IntegratorCache("coupled")  # compiled once; every caller gets its own copy


def build_coupled_integrator(form: str, precision: Precision):
    """The coupled integrator for ``form``.

    State ``(x, v, y, w)``; runtime parameters ``COUPLED_PARAMS`` =
    ``(eta, zeta, a, R, x_w, k)``; events ``[master, slave]``.  Returns a private
    copy (:class:`~precise_impact.solvers.heyoka.cache.IntegratorCache`).
    """
    import heyoka as hy  # noqa: PLC0415 -- optional: heyoka loaded on first use (the module imports without it)

    check_form(form)
    key = (form, precision.name)

    def compile_():
        x, v, y, w = hy.make_vars("x", "v", "y", "w")
        p = {name: hy.par[i] for i, name in enumerate(COUPLED_PARAMS)}
        acc_x = acceleration(hy.time, x, v, p["eta"], p["zeta"], p["a"], hy.cos)
        dy, dw = slave_rhs(form, hy.time, x, v, y, w, p["eta"], p["zeta"], p["a"], p["k"], hy.cos)
        kw = precision.heyoka_kwargs
        events = [
            hy.t_event(
                z - p["x_w"],
                callback=_CoupledImpact(role, form),
                direction=hy.event_direction.positive,
                fp_type=kw["fp_type"],
            )
            for z, role in ((x, "master"), (y, "slave"))
        ]
        zero = precision.from_fraction(Fraction(0))
        ta = hy.taylor_adaptive(
            [(x, v), (v, acc_x), (y, dy), (w, dw)],
            [zero] * 4,
            pars=[zero] * len(COUPLED_PARAMS),
            t_events=events,
            compact_mode=precision.kind == "mp",
            **kw,
        )
        return ta

    return _INTEGRATORS.get(key, compile_)


# ------------------------------------------------------------------ the result
@dataclasses.dataclass
class CoupledTrajectory(CoupledPlotMixin, ResultMixin):
    """What :func:`simulate_coupled` returns.

    Attributes
    ----------
    params : Params
        Exact parameters; the master starts at ``(params.x0, params.v0)``.
    form : str
        One of :data:`COUPLED_FORMS`.
    k : Fraction
        The coupling, exact.
    y0 : tuple[Fraction, Fraction]
        Slave initial ``(position, velocity variable)`` in ``form``'s variables.
    precision : Precision
    t, x, v, y, w : numpy arrays
        Stroboscopic samples at ``t0 + j T`` (``T = 2 pi / eta``, ``j = 0..periods``):
        master position and velocity, slave position and velocity variable (``y2``
        for 'first-order', ``y'`` for 'paper' and 'reduced').
    master_impacts_t, master_impacts_v_before, master_impacts_v_after : numpy arrays
    slave_impacts_t, slave_impacts_w_before, slave_impacts_w_after : numpy arrays
    slave_impacts_x : numpy array
        The master position at each slave impact (enters the reduced-form rule).
    dense_t, dense_x, dense_v, dense_y, dense_w : numpy arrays or None
        ``per_period`` samples per period (including the stroboscopic ones).
    elapsed_s : float
        Wall time of the integration (compilation excluded).
    stats : dict
        ``steps``; ``simultaneous`` = impacts applied to both oscillators at once.

    See Also
    --------
    precise_impact.solvers.simulate.simulate_coupled : returns it.
    precise_impact.solvers.certified.coupled.CertifiedCoupledTrajectory : the certified counterpart.
    """

    params: Params
    form: str
    k: Fraction
    y0: tuple
    precision: Precision
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    y: np.ndarray
    w: np.ndarray
    master_impacts_t: np.ndarray
    master_impacts_v_before: np.ndarray
    master_impacts_v_after: np.ndarray
    slave_impacts_t: np.ndarray
    slave_impacts_w_before: np.ndarray
    slave_impacts_w_after: np.ndarray
    slave_impacts_x: np.ndarray
    dense_t: np.ndarray | None = None
    dense_x: np.ndarray | None = None
    dense_v: np.ndarray | None = None
    dense_y: np.ndarray | None = None
    dense_w: np.ndarray | None = None
    elapsed_s: float = 0.0
    stats: dict = dataclasses.field(default_factory=dict)
    claim: Digits | None = dataclasses.field(default=None, repr=False, compare=False)

    def _tables(self) -> dict:
        """``to_dataframe()`` tables: ``samples`` (default), ``master_impacts``,
        ``slave_impacts`` (``w``: the slave's velocity variable of ``form``)."""
        P = self.precision
        return {
            "samples": lambda: columns(
                ("period", None, np.arange(len(self.t))),
                *((n, "1", getattr(self, n)) for n in ("t", "x", "v", "y", "w")),
                precision=P,
            ),
            "master_impacts": lambda: columns(
                ("t", "1", self.master_impacts_t),
                ("v_before", "1", self.master_impacts_v_before),
                ("v_after", "1", self.master_impacts_v_after),
                precision=P,
            ),
            "slave_impacts": lambda: columns(
                ("t", "1", self.slave_impacts_t),
                ("w_before", "1", self.slave_impacts_w_before),
                ("w_after", "1", self.slave_impacts_w_after),
                ("x", "1", self.slave_impacts_x),
                precision=P,
            ),
        }

    @property
    def periods(self) -> int:
        return len(self.t) - 1

    def claimed_digits(self) -> Digits:
        """The significant digits each sample's ``x, v, y, w`` can claim, and on what basis:
        ``'demonstrated'`` when ``simulate_coupled(..., demonstrate=...)`` ran a second
        precision, else ``'estimated'`` from the pair's tangent flow along this run
        (:func:`precise_impact.core.digits.estimate_coupled`).  Computed once and kept."""
        if self.claim is None:
            self.claim = estimate_coupled(self)
        return self.claim

    def _f(self, a) -> np.ndarray:
        return self.precision.floats(a)

    def difference(self, dense: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """``(t, |x - y|)`` as float64 (stroboscopic, or dense if ``dense``).

        The difference is formed in the working precision, then rounded.

        Parameters
        ----------
        dense : bool, default ``False``
            Use the dense samples (``per_period > 0`` in the run) instead of the
            stroboscopic ones.

        Returns
        -------
        t, d : numpy.ndarray
            Times and ``|x - y|``, float64.
        """
        if dense:
            if self.dense_t is None:
                raise ParameterError(
                    "dense", True, "this trajectory has no dense output (per_period = 0)"
                )
            t, x, y = self.dense_t, self.dense_x, self.dense_y
            assert x is not None and y is not None  # set together with dense_t
        else:
            t, x, y = self.t, self.x, self.y
        return self._f(t), np.abs(self._f(x - y))

    def to_dict(self) -> dict:
        """Every number a full-precision decimal string (stroboscopic samples, impacts)."""
        s = self.precision.to_str
        c = self.claimed_digits()
        return {
            "params": self.params.decimal(),
            "form": self.form,
            "k": decimal_str(self.k),
            "y0": [decimal_str(q) for q in self.y0],
            "precision": self.precision.name,
            "digits": c.summary(),
            "samples": [
                {
                    "period": j,
                    "t": s(t),
                    "x": s(x),
                    "v": s(v),
                    "y": s(y),
                    "w": s(w),
                    **{f"{n}_digits": int(d[j]) for n, d in c.components().items()},
                }
                for j, (t, x, v, y, w) in enumerate(
                    zip(self.t, self.x, self.v, self.y, self.w, strict=True)
                )
            ],
            "master_impacts": [
                {"t": s(t), "v_before": s(b), "v_after": s(a)}
                for t, b, a in zip(
                    self.master_impacts_t,
                    self.master_impacts_v_before,
                    self.master_impacts_v_after,
                    strict=True,
                )
            ],
            "slave_impacts": [
                {"t": s(t), "w_before": s(b), "w_after": s(a), "x": s(x)}
                for t, b, a, x in zip(
                    self.slave_impacts_t,
                    self.slave_impacts_w_before,
                    self.slave_impacts_w_after,
                    self.slave_impacts_x,
                    strict=True,
                )
            ],
            "elapsed_s": self.elapsed_s,
            "stats": self.stats,
        }


# ------------------------------------------------------------------ the driver
def check_inputs(
    params: Params, k: Any, form: Any, periods: Any, per_period: Any, y0: Any
) -> tuple[Fraction, str, int, int, tuple[Fraction, Fraction]]:
    """The pair's inputs validated (before any work): ``(k, form, periods, per_period, y0)``,
    exact; ``y0 = None`` becomes the master's start (the diagonal)."""
    kq = check_k(k)
    form = check_form(form)
    periods = check_count(periods, "periods")
    per_period = check_count(per_period, "per_period", 100_000)
    y0q = check_y0(y0, params)
    return kq, form, periods, per_period, (params.x0, params.v0) if y0q is None else y0q


def coupled_start(params: Params, kq: Fraction, form: str, y0q: tuple) -> tuple:
    """The exact state at ``t0`` after the impacts a start on the wall moving into it makes:
    ``((x0, v0, y, w), master impact rows, slave impact rows)``."""
    x0, v0 = params.x0, params.v0
    yp, yv = y0q
    m0: list = []
    s0: list = []
    if impact_at_start(x0, v0, params.x_w, params.R):
        va = reset_velocity(v0, params.R)
        m0.append((params.t0, v0, va))
        v0 = va
    if yp == params.x_w and slave_position_rate(form, x0, yp, yv, kq) > 0:
        wa = slave_reset(form, x0, yv, params.R, kq, params.x_w)
        s0.append((params.t0, yv, wa, x0))
        yv = wa
    return (x0, v0, yp, yv), m0, s0


def check_max_impacts(max_impacts: Any) -> int:
    """The impact budget over both oscillators: an integer ``>= 1``."""
    if isinstance(max_impacts, bool) or not isinstance(max_impacts, int) or max_impacts < 1:
        raise ParameterError("max_impacts", max_impacts, "impact budget must be an integer >= 1")
    return max_impacts


class HeyokaCoupledSolver:
    """The pair on heyoka's Taylor integrator (coupled model ``'heyoka'``, every precision).

    Parameters
    ----------
    precision : Precision
        Working precision.
    max_impacts : int, default ``10**7``
        Budget over both oscillators; exceeding it raises :class:`BudgetExceededError`.
    """

    model_name = "heyoka"

    def __init__(self, precision: Precision, max_impacts: int = 10**7) -> None:
        self.precision = precision
        self.max_impacts = check_max_impacts(max_impacts)

    def solve(
        self,
        params: Params,
        k: Any,
        periods: int,
        *,
        form: str = "first-order",
        y0: Any = None,
        per_period: int = 0,
    ) -> CoupledTrajectory:
        """The pair for ``periods`` forcing periods (:func:`~precise_impact.simulate_coupled`)."""
        kq, form, periods, per_period, y0q = check_inputs(params, k, form, periods, per_period, y0)
        (x0, v0, yp, yv), m0, s0 = coupled_start(params, kq, form, y0q)
        step = max(per_period, 1)
        P = self.precision
        ta = build_coupled_integrator(form, P)
        conv = P.from_fraction
        ta.pars[:] = P.array([conv(getattr(params, n)) for n in RUNTIME_PARAMS] + [conv(kq)])
        ta.time = conv(params.t0)
        ta.state[:] = P.array([conv(x0), conv(v0), conv(yp), conv(yv)])
        touch = _touch_tol(P, params.x_w)
        recs = [ta.t_events[0].callback, ta.t_events[1].callback]
        for r in recs:
            r.reset(self.max_impacts, touch)
        ta.reset_cooldowns()

        grid = P.array(P.sample_times(params.t0, params.eta, periods, step))
        import heyoka as hy  # noqa: PLC0415 -- optional: heyoka loaded on first use (the module imports without it)

        start = _time.perf_counter()
        res = ta.propagate_grid(grid)
        elapsed = _time.perf_counter() - start
        outcome, n_steps, states = res[0], res[3], np.asarray(res[-1])
        if any(r.exceeded for r in recs):
            raise BudgetExceededError(
                f"impact budget max_impacts={self.max_impacts} exhausted at t={P.to_str(ta.time)} "
                "(chattering/Zeno sequence?); raise max_impacts or check the parameters"
            )
        if outcome != hy.taylor_outcome.time_limit:
            raise IntegrationError(
                f"heyoka stopped early with outcome {outcome} at t={P.to_str(ta.time)}"
            )

        def conv_exact(rows):
            return [tuple(conv(c) if isinstance(c, Fraction) else c for c in r) for r in rows]

        def merged(attr):
            rows = [row for r in recs for row in getattr(r, attr).rows()]
            rows.sort(key=lambda row: row[0])
            return rows

        master = conv_exact(m0) + merged("master")
        slave = conv_exact(s0) + merged("slave")
        simultaneous = sum((r.slave if r.role == "master" else r.master).count for r in recs)

        def col(rows, i):
            return P.array([row[i] for row in rows])

        traj = CoupledTrajectory(
            params=params,
            form=form,
            k=kq,
            y0=y0q,
            precision=P,
            t=grid[::step].copy(),
            x=states[::step, 0].copy(),
            v=states[::step, 1].copy(),
            y=states[::step, 2].copy(),
            w=states[::step, 3].copy(),
            master_impacts_t=col(master, 0),
            master_impacts_v_before=col(master, 1),
            master_impacts_v_after=col(master, 2),
            slave_impacts_t=col(slave, 0),
            slave_impacts_w_before=col(slave, 1),
            slave_impacts_w_after=col(slave, 2),
            slave_impacts_x=col(slave, 3),
            elapsed_s=elapsed,
            stats={
                "steps": int(n_steps),
                "simultaneous": int(simultaneous),
                "engine": "heyoka",
            },
        )
        if per_period > 0:
            traj.dense_t = grid
            traj.dense_x, traj.dense_v = states[:, 0].copy(), states[:, 1].copy()
            traj.dense_y, traj.dense_w = states[:, 2].copy(), states[:, 3].copy()
        return traj


def __getattr__(name: str):
    # simulate_coupled is the registry's entry point (solvers/simulate.py), over every model
    if name == "simulate_coupled":
        from precise_impact.solvers.simulate import simulate_coupled  # noqa: PLC0415 -- import cycle: simulate imports this module

        return simulate_coupled
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# 0.1.0 name, kept for one release.
CoupledTrajectory.to_json_dict = CoupledTrajectory.to_dict  # type: ignore[attr-defined]
