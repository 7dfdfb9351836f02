"""Closed-form (analytical) solver of the impact oscillator, eq. (2) of the paper.

Exact segments between impacts in float64 or mpmath; impact finders ``"paper"`` (the paper's
scan + bisection, a baseline that misses grazing impacts) and ``"robust"`` (cannot miss the
first crossing; ``docs/numerics.rst``).
"""

from __future__ import annotations

import math
import time
from fractions import Fraction
from typing import Any

from precise_impact.core import flight
from precise_impact.core.compat import UNSET, warn_renamed
from precise_impact.core.crossing import safeguarded_newton
from precise_impact.core.flow import acceleration, steady_state
from precise_impact.core.impact import impact_at_start, reset_velocity
from precise_impact.core.params import Params, check_count, decimal_str, exact
from precise_impact.core.precision import Precision
from precise_impact.core.trajectory import Trajectory
from precise_impact.errors import BudgetExceededError, ParameterError

__all__ = ["AnalyticalSolver", "ClosedForm"]

#: Safety factor on every rounding-error bound (the bounds below are derived
#: with a handful of roundings per term; 16 covers them with room to spare).
_C = 16

_FINDERS = ("robust", "paper")
_BACKENDS = ("float64", "mpmath")


# --------------------------------------------------------------------------- backends
class _Float64Ops(flight.FloatOps):
    """Scalar float64 arithmetic through :mod:`math`
    (:class:`precise_impact.core.flight.FloatOps`)."""

    @staticmethod
    def from_precision(precision: Precision, x: Any) -> float:
        return float(x)

    @staticmethod
    def to_precision(precision: Precision, x: float) -> float:
        return float(x)


class _MpmathOps(flight.MpmathOps):
    """mpmath at ``dps`` digits or ``bits``, in the solver's own context (thread-safe)."""

    def from_precision(self, precision: Precision, x: Any) -> Any:
        return self.mpf(precision.to_mpf(x))  # exact: a number of this context

    @staticmethod
    def to_precision(precision: Precision, x: Any) -> Any:
        return precision.from_mpf(x)


# --------------------------------------------------------------------------- model
class _Segment:
    """One flight between impacts: its anchor, its homogeneous part in amplitude form ``k``
    (:func:`precise_impact.core.flight.trig_coefficients`) and the amplitude ``E`` bounding the
    homogeneous part and every derivative (:mod:`precise_impact.core.flight`)."""

    __slots__ = ("t_s", "x_s", "v_s", "k", "E", "after_impact")

    def __init__(self, t_s, x_s, v_s, k, E):
        self.after_impact = False
        self.t_s, self.x_s, self.v_s = t_s, x_s, v_s
        self.k, self.E = k, E


class _Model:
    """Backend-converted parameters and the closed-form evaluation (one place)."""

    def __init__(self, params: Params, ops) -> None:
        self.ops = ops
        num = ops.num
        ss = steady_state(params)
        self.eta, self.zeta, self.a = num(params.eta), num(params.zeta), num(params.a)
        self.x_w, self.R = num(params.x_w), num(params.R)
        self.P, self.Q = num(ss.P), num(ss.Q)
        self.wd = ops.sqrt(num(1 - params.zeta**2))
        u = ops.u
        self.u = u
        self.infl = 1 + _C * u  # inflation factor that turns a computed bound into a safe one
        self.Ap = ops.sqrt(num(ss.amplitude_squared)) * self.infl
        self.eta2 = self.eta * self.eta
        self.eta3 = self.eta2 * self.eta
        self.abs_xw = abs(self.x_w)
        self.abs_a = abs(self.a)
        self.one = num(Fraction(1))

    # -- closed form --------------------------------------------------------------
    def segment(self, t_s, x_s, v_s) -> _Segment:
        y, u = flight.homogeneous_start(t_s, x_s, v_s, self.P, self.Q, self.eta, self.ops)
        E = flight.homogeneous_amplitudes(y, u, self.zeta, self.wd, self.ops)[0] * self.infl
        return _Segment(t_s, x_s, v_s, flight.trig_coefficients(y, u, self.zeta, self.wd), E)

    def state(self, seg: _Segment, t):
        """``(x, v, exp(-zeta (t - t_s)))`` from the segment's closed form."""
        if t == seg.t_s:
            return seg.x_s, seg.v_s, self.one
        return flight.state_from_coefficients(
            t, seg.t_s, seg.k, self.P, self.Q, self.eta, self.zeta, self.wd, self.ops
        )

    def accel(self, t, x, v):
        """``x''`` from eq. (2a), via :func:`~precise_impact.core.flow.acceleration`."""
        return acceleration(t, x, v, self.eta, self.zeta, self.a, self.ops.cos)

    # -- rounding margins and derivative bounds ------------------------------------
    def margins(self, seg: _Segment, t, dec):
        """Bounds ``(d0, d1, hom)`` on the evaluation error of ``f = x - x_w`` and ``f' = v``.

        Terms: the rounding of ``eta t`` (absolute ``u eta |t|``) and of ``wd s``,
        ``zeta s`` (``u s``) propagated through cos/sin/exp, a few roundings per
        term, plus the time resolution ``|f'| u |t|`` (neighbouring representable
        times are ``u |t|`` apart).  ``hom = E exp(-zeta s)`` bounds the homogeneous
        part and each of its derivatives.
        """
        u = self.u
        at = abs(t)
        ds = t - seg.t_s
        if ds < 0:
            ds = -ds
        hom = seg.E * dec * self.infl
        pt = self.Ap * (1 + self.eta * at)
        hs = hom * (2 + ds)
        d0 = _C * u * (self.abs_xw + pt + hs + at * (self.Ap * self.eta + hom))
        d1 = _C * u * (self.eta * pt + hs + at * (self.Ap * self.eta2 + hom))
        return d0, d1, hom

    def margin2(self, t, d0, d1, hom):
        """Evaluation-error bound of ``f'' `` computed by :meth:`accel`."""
        u = self.u
        at = abs(t)
        return (
            _C
            * u
            * (
                self.abs_a * (1 + self.eta * at)
                + self.eta2 * self.Ap * (1 + self.eta * at)
                + hom * (2 + at)
            )
            + 2 * self.zeta * d1
            + d0
        )


class ClosedForm:
    """The closed-form solution of (2a) on one segment, ``t -> (x(t), v(t))``.

    Obtained from :meth:`AnalyticalSolver.closed_form`; evaluation uses the solver's
    backend (for mpmath: the solver's own context at its precision).
    """

    def __init__(self, model: _Model, seg: _Segment) -> None:
        self._model = model
        self._seg = seg

    def __call__(self, t) -> tuple:
        with self._model.ops.context():
            t = _as_backend(self._model.ops, t)
            x, v, _ = self._model.state(self._seg, t)
            return x, v

    def x(self, t):
        return self(t)[0]

    def v(self, t):
        return self(t)[1]


def _as_backend(ops, value):
    if isinstance(value, Fraction):
        return ops.num(value)
    if ops.name == "mpmath":
        return ops.mpf(value)
    return float(value)


def _arithmetic(precision: Any, backend: Any, dps: Any, bits: Any) -> tuple[str, Any, Any]:
    """``(backend, dps, bits)`` from ``precision`` (``'float64'`` or ``'mp:BITS'``), or from the
    deprecated ``backend``/``dps``/``bits`` with one :class:`DeprecationWarning`."""
    old = {k: v for k, v in (("backend", backend), ("dps", dps), ("bits", bits)) if v is not UNSET}
    if precision is not None:
        if old:
            name = next(iter(old))
            raise ParameterError(name, old[name], "not with precision= (it is deprecated)")
        P = Precision.parse(precision)
        if P.kind == "float64":
            return "float64", None, None
        if P.kind == "mp":
            return "mpmath", None, P.bits
        raise ParameterError("precision", P.name, "'float64' or 'mp:BITS' for the closed form")
    if old:
        warn_renamed("/".join(f"{k}=" for k in old), "precision=", "AnalyticalSolver", 4)
    return (
        old.get("backend", "float64"),
        old.get("dps", None),
        old.get("bits", None),
    )


# --------------------------------------------------------------------------- solver
def _check_arithmetic(backend: str, dps: Any, bits: Any) -> Any:
    """Validate ``dps``/``bits`` against ``backend``; the digits to use (60 by default for
    mpmath without ``bits``, else as given)."""
    if backend == "float64":
        if dps is not None:
            raise ParameterError(
                "dps", dps, "dps is only for backend='mpmath'; use None with float64"
            )
        if bits is not None:
            raise ParameterError(
                "bits", bits, "bits is only for backend='mpmath'; use None with float64"
            )
    else:
        if bits is not None:
            if dps is not None:
                raise ParameterError("dps", dps, "give dps or bits, not both")
            if isinstance(bits, bool) or not isinstance(bits, int) or not (64 <= bits <= 100_000):
                raise ParameterError("bits", bits, "an integer with 64 <= bits <= 100000")
        else:
            if dps is None:
                dps = 60
            if isinstance(dps, bool) or not isinstance(dps, int) or not (20 <= dps <= 30000):
                raise ParameterError("dps", dps, "an integer with 20 <= dps <= 30000")
    return dps


def _check_limits(scan_fraction: Any, max_impacts: int, max_evals: int | None) -> Fraction:
    """Validate the scan fraction and the budgets; the scan fraction, exact."""
    sf = exact("scan_fraction", scan_fraction)
    if not (0 < sf <= 1):
        raise ParameterError("scan_fraction", decimal_str(sf), "0 < scan_fraction <= 1")
    if isinstance(max_impacts, bool) or not isinstance(max_impacts, int) or max_impacts < 0:
        raise ParameterError("max_impacts", max_impacts, "an integer >= 0")
    if max_evals is not None and (
        isinstance(max_evals, bool) or not isinstance(max_evals, int) or max_evals < 1
    ):
        raise ParameterError("max_evals", max_evals, "None or an integer >= 1")
    return sf


def _no_progress(t1: Any) -> BudgetExceededError:
    """The error of a robust-finder step that does not advance past ``t1``."""
    return BudgetExceededError(f"analytical solver: no progress at t = {float(t1):.17g}")


class AnalyticalSolver:
    """Closed-form solver of the impact oscillator (eq. 2 of Denysenko, Balcerzak & Dabrowski).

    ``AnalyticalSolver(finder="robust", scan_fraction=Fraction(1, 1000), max_impacts=10**6,
    max_evals=None, *, precision="float64")``: ``precision`` is ``'float64'`` or ``'mp:BITS'``
    (mpmath); ``backend=``, ``dps=`` and ``bits=`` are the 0.2 spellings, kept one release
    with a :class:`DeprecationWarning`.

    Between impacts the motion is the exact solution of the linear flow (2a)
    (underdamped, ``0 <= zeta < 1``); impacts are found as the first upward
    crossing of ``x = x_w`` and the velocity is reset with
    :func:`~precise_impact.core.impact.reset_velocity`.

    Keyword arguments:

    * ``finder = "robust"``: how impact times are located.

      - ``"robust"``: certified stepping, cannot miss the first crossing (below).
      - ``"paper"``: the paper's scheme ("Numerical verification" section): scan
        ``x`` every ``scan_fraction * T`` from the segment start; when
        ``x(t + Delta) > x_w``, bisect ``[t, t + Delta]`` to working precision.
        Misses grazing excursions shorter than one scan step (intended: it is the
        published baseline).

    * ``backend = "float64"``: ``"float64"`` (Python floats and :mod:`math`) or
      ``"mpmath"`` (:mod:`mpmath` at ``dps`` digits).

    * ``dps = None``: decimal digits of the mpmath backend; ``None`` means 60.
      Must be an int with ``20 <= dps <= 30000``; must be ``None`` for float64.
      The result's precision is ``mp:BITS`` with the bits mpmath uses at ``dps`` digits.
    * ``bits = None``: the mpmath backend's working bits instead of ``dps``
      (``simulate(..., model="analytical", precision="mp:320")`` passes 320: the
      result reports exactly the precision that was asked for and used).

    * ``scan_fraction = Fraction(1, 1000)``: scan step of the ``"paper"`` finder
      as a fraction of the forcing period ``T = 2 pi / eta`` (paper:
      ``Delta t = 10^-3 T``); ``0 < scan_fraction <= 1``.  Ignored by ``"robust"``.

    * ``max_impacts = 10**6``: more impacts than this raise
      :class:`~precise_impact.errors.BudgetExceededError` (e.g. chattering).

    * ``max_evals = None``: budget of closed-form evaluations of the impact finder;
      ``None`` means ``(periods + 1) * (10**5 + 2 ceil(1 / scan_fraction))``.
      Exceeding it raises :class:`~precise_impact.errors.BudgetExceededError`.

    ## How the robust finder cannot miss the first crossing

    With ``f = x - x_w`` and ``M`` a bound on ``|x''|`` over the rest of the
    segment (each derivative of the homogeneous part has amplitude
    ``E exp(-zeta s)``, ``E = sqrt(A^2 + B^2)``, because ``|-zeta + i wd| = 1``;
    so ``M = Ap eta^2 + E exp(-zeta s1)`` with ``Ap = sqrt(P^2 + Q^2)``), Taylor's
    theorem gives ``f(t1 + h) <= f1 + f1' h + M h^2 / 2``.  Computed values carry
    errors bounded by margins ``d0``, ``d1`` (proportional to the unit roundoff
    times the scale of the terms and of ``|t|``).  From a point ``t1`` with
    ``f1 < -3 d0`` the finder steps to the positive root ``h*`` of
    ``(f1 + 2 d0) + (f1' + d1) h + M h^2 / 2``: ``f < 0`` on all of
    ``[t1, t1 + h*]``.  The points therefore approach the first crossing from
    below and never pass it (convergence is quadratic at a transversal crossing,
    geometric near a tangency).  Once ``f1 >= -3 d0`` (within rounding of the
    wall):

    1. **transversal crossing**: if ``a = f1' - d1 > 0`` and ``a^2 >= 2 M (3 d0 - f1)``,
       then ``f' >= a - M h > 0`` on ``[t1, t1 + a / M]`` (``f`` increasing, at most
       one crossing) and the lower bound ``f1 - d0 + a h - M h^2 / 2`` reaches
       ``2 d0`` inside it, so that bracket holds exactly one crossing, the first
       one after the segment start.  It is refined by safeguarded Newton /
       bisection to working precision (float64: ``4 u max(1, |t|)``; mpmath:
       ``10^(5 - dps) max(1, |t|)`` for the last Newton correction, which
       leaves an error far below that).

    2. **leaving the wall** (after an impact, ``f1' + d1 < 0``): step to where the
       Taylor bound reaches ``-5 d0``; on the way ``f <= f1 + d0``.

    3. **grazing**: ``f1`` within the margin and ``f1'`` at rounding level with
       ``f'' < 0`` (a maximum touching the wall).  With ``M3`` a bound on
       ``|x'''|``, ``f'' <= f1'' + d2 + M3 h <= (f1'' + d2) / 2 = -kappa`` for
       ``h <= kappa / M3``; thus ``f <= f1 + d0 + (f1' + d1) h - kappa h^2 / 2``,
       which exceeds the rounding band by at most ``(f1' + d1)^2 / (2 kappa)`` and
       falls to ``-5 d0`` within that interval.  The contact is **not** an impact
       (the orbit goes beyond the wall by at most a few rounding margins; an
       impact there would change the velocity by a rounding-level amount) and is
       counted in ``stats["grazing"]``.

    4. otherwise (``f'' >= 0`` at zero velocity on the wall: sticking or
       chattering, which eq. (2) does not model) raise
       :class:`~precise_impact.errors.BudgetExceededError`.

    If ``Ap + E exp(-zeta s) < x_w`` (minus the margin) no impact can happen any
    more, and the segment is continued to the end without stepping
    (``stats["envelope_exit_t"]``).  Every loop is bounded by ``max_evals``.

    ## References

    * V. Denysenko, M. Balcerzak, A. Dabrowski, *Electronic equivalent of a
      mechanical impact oscillator* (eq. 2; "Numerical verification" for the
      ``"paper"`` finder).

    * S. W. Shaw, P. J. Holmes, *A periodically forced piecewise linear
      oscillator*, J. Sound Vib. 90 (1983) 129-155 (closed-form segments).

    * A. B. Nordmark, *Non-periodic motion caused by grazing incidence in an
      impact oscillator*, J. Sound Vib. 145 (1991) 279-297 (grazing).

    * C. J. Budd, F. Dux, *Chattering and related behaviour in impact
      oscillators*, Phil. Trans. R. Soc. A 347 (1994) 365-389 (chattering).

    See Also
    --------
    precise_impact.solvers.base.Solver : the protocol it follows.
    precise_impact.solvers.heyoka.single.HeyokaSolver : the Taylor-integrator model.
    precise_impact.solvers.certified.single.CertifiedSolver : the certified engine as a model.
    """

    def __init__(
        self,
        finder: str = "robust",
        backend: Any = UNSET,
        dps: Any = UNSET,
        scan_fraction: Any = Fraction(1, 1000),
        max_impacts: int = 10**6,
        max_evals: int | None = None,
        bits: Any = UNSET,
        *,
        precision: str | Precision | None = None,
    ) -> None:
        backend, dps, bits = _arithmetic(precision, backend, dps, bits)
        if finder not in _FINDERS:
            raise ParameterError("finder", finder, "one of 'robust', 'paper'")
        if backend not in _BACKENDS:
            raise ParameterError("backend", backend, "one of 'float64', 'mpmath'")
        dps = _check_arithmetic(backend, dps, bits)
        sf = _check_limits(scan_fraction, max_impacts, max_evals)
        self.finder = finder
        self.backend = backend
        self.dps = dps
        self.scan_fraction = sf
        self.max_impacts = max_impacts
        self.max_evals = max_evals
        self._ops: _Float64Ops | _MpmathOps
        if backend == "float64":
            self._ops, self.dps = _Float64Ops(), None
        else:
            mp_ops = _MpmathOps(dps, bits)
            self._ops, self.dps = mp_ops, mp_ops.dps

    # ------------------------------------------------------------------ public API
    @property
    def model_name(self) -> str:
        return "analytical" if self.finder == "robust" else "analytical-paper"

    @property
    def precision(self) -> Precision:
        """Precision of the returned Trajectory's state values: the bits mpmath really uses."""
        if isinstance(self._ops, _MpmathOps):
            return Precision.parse(f"mp:{self._ops.prec}")
        return Precision.parse("float64")

    @staticmethod
    def check_params(params: Params) -> None:
        """Raise :class:`ParameterError` if the closed form does not apply."""
        if not isinstance(params, Params):
            raise ParameterError(
                "params", type(params).__name__, "a Params instance (Params.make(...))"
            )
        if params.zeta >= 1:
            raise ParameterError(
                "zeta",
                decimal_str(params.zeta),
                "the analytical solver needs an underdamped oscillator: 0 <= zeta < 1",
            )
        if params.zeta == 0 and params.eta == 1:
            raise ParameterError(
                "zeta",
                decimal_str(params.zeta),
                "zeta = 0 with eta = 1 is the undamped resonance (no bounded closed form); "
                "need 0 < zeta < 1 when eta = 1",
            )

    def closed_form(self, params: Params, t_s: Any, x_s: Any, v_s: Any) -> ClosedForm:
        """The smooth solution of (2a) through ``(t_s, x_s, v_s)``, as used between impacts.

        Arguments may be Fractions (converted exactly once) or backend numbers.
        """
        self.check_params(params)
        ops = self._ops
        with ops.context():
            model = _Model(params, ops)
            seg = model.segment(_as_backend(ops, t_s), _as_backend(ops, x_s), _as_backend(ops, v_s))
        return ClosedForm(model, seg)

    def solve(self, params: Params, periods: int, per_period: int = 0) -> Trajectory:
        """Integrate ``periods`` forcing periods from ``(t0, x0, v0)`` by closed-form segments.

        Parameters
        ----------
        params : Params
            System and initial condition (exact rationals).
        periods : int
            Forcing periods; samples at ``t0 + k T``, ``k = 0..periods``.
        per_period : int, default 0
            Dense output points per period (0: none).

        Returns
        -------
        Trajectory
            Samples and impacts (``tol = None``).

        Raises
        ------
        ParameterError
            Parameters outside the closed form's range, before any work.
        BudgetExceededError
            A budget is hit or the motion sticks to the wall.
        """
        self.check_params(params)
        periods = check_count(periods, "periods")
        per_period = check_count(per_period, "per_period", 100_000)
        precision = self.precision
        ops = self._ops
        max_evals = self.max_evals
        if max_evals is None:
            max_evals = (periods + 1) * (10**5 + 2 * math.ceil(1 / self.scan_fraction))

        start = time.perf_counter()
        samples_prec = precision.sample_times(params.t0, params.eta, periods)
        dense_prec = (
            precision.sample_times(params.t0, params.eta, periods, per_period)
            if per_period > 0
            else None
        )
        with ops.context():
            run = _Run(self, params, ops, precision, max_evals)
            result = run.execute(samples_prec, dense_prec)
        elapsed = time.perf_counter() - start

        xs, vs, dxs, dvs, impacts, stats = result
        to_p = lambda seq: precision.array([ops.to_precision(precision, z) for z in seq])  # noqa: E731
        traj = Trajectory(
            params=params,
            model=self.model_name,
            precision=precision,
            tol=None,
            t=precision.array(samples_prec),
            x=to_p(xs),
            v=to_p(vs),
            impacts_t=to_p([i[0] for i in impacts]),
            impacts_v_before=to_p([i[1] for i in impacts]),
            impacts_v_after=to_p([i[2] for i in impacts]),
            dense_t=precision.array(dense_prec) if dense_prec is not None else None,
            dense_x=to_p(dxs) if dense_prec is not None else None,
            dense_v=to_p(dvs) if dense_prec is not None else None,
            elapsed_s=elapsed,
            stats=stats,
        )
        return traj


class _Run:
    """One integration (state of the loops; everything inside the backend's context)."""

    def __init__(
        self, solver: AnalyticalSolver, params: Params, ops, precision: Precision, max_evals: int
    ):
        self.solver = solver
        self.params = params
        self.ops = ops
        self.precision = precision
        self.max_evals = max_evals
        self.m = _Model(params, ops)
        self.n_evals = 0
        self.n_steps = 0
        self.n_grazing = 0
        self.envelope_exit_t = None
        eta_b = self.m.eta
        self.delta = ops.num(solver.scan_fraction) * (2 * ops.pi / eta_b)
        if ops.name == "float64":
            self.root_tol_rel = 4 * ops.u
            self.max_iter = 4 * 64 + 200
        else:
            self.root_tol_rel = ops.ctx.mpf(10) ** (5 - ops.dps)
            self.max_iter = 4 * ops.prec + 200

    # -- evaluation with budget --------------------------------------------------------
    def feval(self, seg: _Segment, t):
        self.n_evals += 1
        if self.n_evals > self.max_evals:
            raise BudgetExceededError(
                f"analytical solver: more than {self.max_evals} closed-form evaluations "
                f"(t = {float(t):.17g}); raise max_evals"
            )
        if t == seg.t_s:
            return seg.x_s, seg.v_s, self.m.one
        m = self.m  # m.state, without its call: the hot loop (~20 evaluations a flight)
        return flight.state_from_coefficients(
            t, seg.t_s, seg.k, m.P, m.Q, m.eta, m.zeta, m.wd, m.ops
        )

    # -- main loop -------------------------------------------------------------------------
    def execute(self, samples_prec, dense_prec):
        ops, m, P = self.ops, self.m, self.precision
        p = self.params
        sample_t = [ops.from_precision(P, t) for t in samples_prec]
        dense_t = [ops.from_precision(P, t) for t in dense_prec] if dense_prec is not None else []
        t_end = sample_t[-1]
        xs: list = []
        vs: list = []
        dxs: list = []
        dvs: list = []
        impacts: list = []
        outs = [(sample_t, xs, vs, [0]), (dense_t, dxs, dvs, [0])]

        def emit(seg, t_stop, inclusive):
            for times, ox, ov, ptr in outs:
                i = ptr[0]
                n = len(times)
                while i < n and (times[i] < t_stop or (inclusive and times[i] == t_stop)):
                    x, v, _ = m.state(seg, times[i])
                    ox.append(x)
                    ov.append(v)
                    i += 1
                ptr[0] = i

        t = ops.num(p.t0)
        x = ops.num(p.x0)
        v = ops.num(p.v0)
        if impact_at_start(x, v, m.x_w, m.R):
            v_after = reset_velocity(v, m.R)
            impacts.append((t, v, v_after))
            v = v_after
        seg = m.segment(t, x, v)
        seg.after_impact = bool(impacts)
        find = self.find_robust if self.solver.finder == "robust" else self.find_paper
        n_segments = 1
        while True:
            hit = find(seg, t_end)
            if hit is None:
                emit(seg, t_end, True)
                break
            t_c, v_minus = hit
            emit(seg, t_c, False)
            v_plus = reset_velocity(v_minus, m.R)
            impacts.append((t_c, v_minus, v_plus))
            if len(impacts) > self.solver.max_impacts:
                raise BudgetExceededError(
                    f"analytical solver: more than {self.solver.max_impacts} impacts "
                    f"(t = {float(t_c):.17g}); raise max_impacts"
                )
            seg = m.segment(t_c, m.x_w, v_plus)
            seg.after_impact = True
            n_segments += 1

        stats = {
            "finder": self.solver.finder,
            "backend": ops.name,
            "dps": getattr(ops, "dps", None),
            "impacts": len(impacts),
            "evaluations": self.n_evals,
            "steps": self.n_steps,
            "grazing": self.n_grazing,
            "segments": n_segments,
            "envelope_exit_t": None
            if self.envelope_exit_t is None
            else float(self.envelope_exit_t),
        }
        return xs, vs, dxs, dvs, impacts, stats

    # -- paper finder ------------------------------------------------------------------------
    def find_paper(self, seg: _Segment, t_end):
        """Scan every Delta from the segment start; bisect the first bracket with x > x_w."""
        x_w = self.m.x_w
        t_prev = seg.t_s
        k = 1
        while True:
            tk = seg.t_s + k * self.delta
            last = tk >= t_end
            if last:
                tk = t_end
            if tk <= t_prev:
                return None
            x, v, _ = self.feval(seg, tk)
            if x > x_w:
                return self.bisect(seg, t_prev, tk)
            if last:
                return None
            t_prev = tk
            k += 1

    def bisect(self, seg, lo, hi):
        x_w = self.m.x_w
        tol = self.root_tol_rel * max(abs(hi), 1)
        for _ in range(self.max_iter):
            mid = (lo + hi) / 2
            if hi - lo <= tol or mid <= lo or mid >= hi:
                break
            x, _, _ = self.feval(seg, mid)
            if x > x_w:
                hi = mid
            else:
                lo = mid
        t_c = (lo + hi) / 2
        _, v, _ = self.feval(seg, t_c)
        return t_c, v

    # -- robust finder -----------------------------------------------------------------------
    def find_robust(self, seg: _Segment, t_end):
        """First upward crossing of x = x_w in (t_s, t_end], or None (see class docstring)."""
        m = self.m
        x_w = m.x_w
        t1 = seg.t_s
        while True:
            x, v, dec = self.feval(seg, t1)
            f = x - x_w
            d0, d1, hom = m.margins(seg, t1, dec)
            # Envelope: |x| <= Ap + E e^{-zeta s} for all later times of the segment.
            if (m.Ap + hom) * m.infl < x_w - d0:
                if self.envelope_exit_t is None:
                    self.envelope_exit_t = t1
                return None
            M = (m.Ap * m.eta2 + hom) * m.infl
            if f < -3 * d0:
                # certified step: q(h) = (f + 2 d0) + (v + d1) h + M h^2 / 2 < 0 on [0, h*)
                # (inline: the hot loop, ~15 steps a flight; a call per step cost 8 %)
                F0 = f + 2 * d0
                F1 = v + d1
                den = F1 + self.ops.sqrt(F1 * F1 - 2 * M * F0)
                if not den > 0:
                    return None  # M == 0 and non-increasing: never reaches the wall
                t2 = t1 + (-2 * F0) / den
                self.n_steps += 1
                if t2 >= t_end:
                    return None
                if not t2 > t1:
                    raise _no_progress(t1)
                t1 = t2
                continue
            done, out = self._near_wall(seg, t1, t_end, x, v, f, (d0, d1, hom), M)
            if done:
                return out
            t1 = out

    # The cases of find_robust near the wall: each returns ``(True, result)`` (the crossing
    # ``(t, v)`` or None, no crossing before ``t_end``) or ``(False, t2)`` (no crossing in
    # ``[t1, t2)``: go on from ``t2``), or None where it does not apply.
    def _near_wall(self, seg: _Segment, t1, t_end, x, v, f, margins, M):
        """Within rounding of the wall: a crossing ahead, leaving, grazing, or sticking (raised)."""
        d0, d1, hom = margins
        # 1. transversal upward crossing just ahead
        step = self._crossing_ahead(seg, t1, t_end, v, f, d0, d1, M)
        if step is not None:
            return step
        # 2. leaving the wall: bound f + d0 + s h + M h^2/2 reaches -5 d0
        s = v + d1
        c_out = f + 6 * d0
        step = self._leaving_wall(t1, t_end, s, c_out, M)
        if step is not None:
            return step
        # 3. grazing: a maximum touching the wall (f'' < 0)
        m = self.m
        acc = m.accel(t1, x, v)
        d2 = m.margin2(t1, d0, d1, hom)
        step = self._grazing(seg, t1, t_end, acc + d2, s, c_out, hom)
        if step is not None:
            return step
        # 4. sticking / chattering: zero velocity on the wall, pushed into it
        raise BudgetExceededError(
            "analytical solver: the mass rests on the wall with (rounding-level) zero velocity "
            f"and is pushed into it at t = {float(t1):.17g} (x'' = {float(acc):.3g}): sticking "
            "or the end of a chattering sequence, which eq. (2) does not model"
        )

    def _crossing_ahead(self, seg: _Segment, t1, t_end, v, f, d0, d1, M):
        """Case 1 of :meth:`_near_wall`: a transversal upward crossing just ahead."""
        a_up = v - d1
        c_in = 3 * d0 - f
        if not (a_up > 0 and a_up * a_up >= 2 * M * c_in):
            return None
        tau_in = 2 * c_in / (a_up + self.ops.sqrt(a_up * a_up - 2 * M * c_in))
        tb = t1 + tau_in
        if tb > t_end:
            tb = t_end
        if not tb > t1:
            return True, (t1, v)  # the crossing is at t1 to within the time resolution
        xb, vb, _ = self.feval(seg, tb)
        if xb - self.m.x_w > 0:
            return True, self.refine(seg, t1, f, v, tb)
        if tb == t_end:
            return True, None  # f increasing on [t1, t_end] and still <= 0
        return False, tb  # (only if the margins were pessimistic) no crossing in [t1, tb]

    def _leaving_wall(self, t1, t_end, s, c_out, M):
        """Case 2 of :meth:`_near_wall`: moving away, the bound reaches -5 d0 at ``t2``."""
        if s < 0:
            disc = s * s - 2 * M * c_out
            if disc >= 0:
                tau = 2 * c_out / (-s + self.ops.sqrt(disc))
                t2 = t1 + tau
                if t2 >= t_end:
                    return True, None
                if not t2 > t1:
                    raise _no_progress(t1)
                self.n_steps += 1
                return False, t2
        return None

    def _grazing(self, seg: _Segment, t1, t_end, c2, s, c_out, hom):
        """Case 3 of :meth:`_near_wall`: a maximum touching the wall (``c2`` bounds f'' < 0)."""
        if c2 < 0:
            m = self.m
            kappa = -c2 / 2
            M3 = (m.Ap * m.eta3 + hom) * m.infl
            tau_c = kappa / M3 if M3 > 0 else None
            tau = 2 * c_out / (self.ops.sqrt(s * s + 2 * kappa * c_out) - s)
            if tau_c is None or tau <= tau_c:
                t2 = t1 + tau
                if not (t1 == seg.t_s and seg.after_impact):
                    self.n_grazing += 1  # tangential contact, not an impact
                if t2 >= t_end:
                    return True, None
                if not t2 > t1:
                    raise _no_progress(t1)
                self.n_steps += 1
                return False, t2
        return None

    def refine(self, seg: _Segment, lo, f_lo, v_lo, hi):
        """Root of the increasing ``f`` in ``[lo, hi]`` (``f(lo) <= 0 < f(hi)`` up to rounding):
        :func:`~precise_impact.core.crossing.safeguarded_newton` on ``f = x - x_w``, ``f' = v``."""
        x_w = self.m.x_w

        def gap(t):
            x, v, _ = self.feval(seg, t)
            return x - x_w, v

        tol = self.root_tol_rel * max(abs(hi), 1)
        t, (_, v) = safeguarded_newton(gap, lo, hi, f_lo, v_lo, tol, self.max_iter)
        return t, v
