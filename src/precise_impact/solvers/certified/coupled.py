"""The master-slave pair certified: every sample and impact of both oscillators in a proven ball.

The master's flight and the difference ``e = y - x`` (a damped linear oscillator) in ball
arithmetic; an impact order that cannot be proven stops the run (``docs/numerics.rst``).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from fractions import Fraction
from typing import Any

import numpy as np

from precise_impact.core import flight
from precise_impact.core.budget import Deadline, enforce_max_time, parse_max_time
from precise_impact.core.compat import UNSET, warn_renamed
from precise_impact.core.coupling import (
    check_form,
    check_k,
    check_y0,
    error_coefficients,
    slave_derivative,
    slave_reset,
    slave_velocity,
)
from precise_impact.core.digits import Digits, proven
from precise_impact.core.flow import acceleration
from precise_impact.core.impact import reset_velocity, saltation_matrix
from precise_impact.core.params import Params, check_count, decimal_str, params_or_values
from precise_impact.core.precision import Precision
from precise_impact.core.result import ResultMixin, ball_columns
from precise_impact.errors import ParameterError
from precise_impact.io.figures import CoupledPlotMixin
from precise_impact.io.progress import Progress
from precise_impact.solvers.certified.lohner import (
    LOW_BITS,
    LOW_STEPS,
    _eye,
    _flint,
    _Prec,
    box_frame,
    hull,
    interval_is_tighter,
    reframe,
)
from precise_impact.solvers.certified.single import (
    MAX_BITS,
    METHODS,
    MIN_BITS,
    CertificationError,
    Constants,
    Flight,
    Isolator,
    _finite_or_none,
    ball_str,
    certified_bits,
    check_certifiable,
    check_target,
    choose_bits,
    describe,
    doubling,
    exact_value,
    float_up,
    growth_slope,
    log10_abs,
    max_radius_str,
    point,
    to_ball,
    upper,
    working_bits,
)
from precise_impact.solvers.certified.single import _run as run_single  # the diagonal

__all__ = ["certify_coupled", "CertifiedCoupledTrajectory", "CertifiedCoupledSolver"]


class _ErrorFlow:
    """``e'' + c1 e' + c0 e = 0`` from ``(e0, e0')`` at the anchor ``s`` (balls): the damped flow
    of :mod:`precise_impact.core.flight` with ``alpha = c1 / 2``."""

    def __init__(self, al, om, c0, s, e0, ep0) -> None:
        self.al, self.om, self.c0, self.s, self.e0, self.ep0 = al, om, c0, s, e0, ep0
        self._bound = None

    def at(self, t):
        p00, p01, p10, p11 = flight.flow_matrix(t - self.s, self.al, self.om, flight.ARB, self.c0)
        return p00 * self.e0 + p01 * self.ep0, p10 * self.e0 + p11 * self.ep0

    def second_bound(self):
        """A proven bound of ``|e''| = |c1 e' + c0 e|`` for ``tau >= 0`` (the upper end of
        :func:`precise_impact.core.flight.second_derivative_bound` on the amplitudes)."""
        if self._bound is None:
            ae, aep = flight.homogeneous_amplitudes(
                self.e0, self.ep0, self.al, self.om, flight.ARB, self.c0
            )
            self._bound = flight.second_derivative_bound(ae, aep, self.al, self.c0).upper()
        return self._bound


class _Pair:
    """Master flight and error flow from one anchor; the two wall gaps."""

    def __init__(
        self, c: Constants, consts: tuple, s, x, v, e, ep, master: Flight | None = None
    ) -> None:
        self.c = c
        # the master's flight goes on unchanged through a slave impact (no re-anchoring, no
        # wrapping)
        self.m = Flight(c, s, x, v) if master is None else master
        al, om, c0 = consts
        self.e = _ErrorFlow(al, om, c0, s, e, ep)

    def state(self, t):
        x, v = self.m.at(t)
        e, ep = self.e.at(t)
        return x, v, e, ep

    def master_gap(self, t):
        return self.m.gap(t)

    def slave_gap(self, t):
        x, v = self.m.at(t)
        e, ep = self.e.at(t)
        return x + e - self.c.xw, v + ep

    def master_bound(self):
        return self.m.acceleration_bound()

    def slave_bound(self):
        return self.m.acceleration_bound() + self.e.second_bound()


@dataclasses.dataclass
class CertifiedCoupledTrajectory(CoupledPlotMixin, ResultMixin):
    """The master-slave pair with proven enclosures (:func:`certify_coupled`).

    Attributes
    ----------
    params : Params
        The system and the master's start (exact).
    form : str
        One of :data:`~precise_impact.solvers.heyoka.coupled.COUPLED_FORMS`.
    k : Fraction
        The coupling, exact.
    y0 : tuple of Fraction or None
        The slave's start in ``form``'s variables; ``None``: on the diagonal.
    periods, bits : int
        Forcing periods and working precision.
    samples : list of tuple
        ``(period, t, x, v, y, w)`` balls at ``t0 + period T`` (``w``: the slave's velocity
        variable, ``y2`` for 'first-order', ``y'`` otherwise).
    master_impacts : list of tuple
        ``(t, v_before, v_after)`` balls.
    slave_impacts : list of tuple
        ``(t, w_before, w_after)`` balls.
    elapsed_s : float
        Wall time (diagnostic).
    method : str
        The enclosure, ``'lohner'`` or ``'interval'`` (:func:`certify_coupled`).
    bits_choice : str
        How :attr:`bits` was chosen: ``'given'``, or ``'automatic: ...'`` (the pilot's growth
        and the projection), each retry at twice the bits appended with its reason.

    See Also
    --------
    precise_impact.solvers.certified.coupled.certify_coupled : returns it.
    precise_impact.solvers.heyoka.coupled.CoupledTrajectory : the floating-point counterpart.
    """

    params: Any
    form: str
    k: Fraction
    y0: Any
    periods: int
    bits: int
    samples: list
    master_impacts: list
    slave_impacts: list
    elapsed_s: float
    method: str = "interval"
    bits_choice: str = "given"
    claim: Digits | None = dataclasses.field(default=None, repr=False, compare=False)

    def claimed_digits(self) -> Digits:
        """The significant digits each sample's ``x, v, y, w`` can claim: ``'proven'`` by the
        balls' radii (plus the midpoints' rounding to :attr:`precision`)."""
        if self.claim is None:
            rad = {n: [s[i].rad() for s in self.samples] for i, n in enumerate("xvyw", 2)}
            self.claim = proven(
                self,
                [exact_value(r) for r in rad["x"]],
                [exact_value(r) for r in rad["v"]],
                y=(self.y, [exact_value(r) for r in rad["y"]]),
                w=(self.w, [exact_value(r) for r in rad["w"]]),
            )
        return self.claim

    def _tables(self) -> dict:
        """``to_dataframe()`` tables: ``samples`` (default), ``master_impacts``,
        ``slave_impacts``, each ball as its midpoint and its radius (``rad_*``)."""
        return {
            "samples": lambda: ball_columns(("period", "t", "x", "v", "y", "w"), self.samples),
            "master_impacts": lambda: ball_columns(
                ("t", "v_before", "v_after"), self.master_impacts
            ),
            "slave_impacts": lambda: ball_columns(("t", "w_before", "w_after"), self.slave_impacts),
        }

    @property
    def precision(self) -> Precision:
        """The working precision ``mp:bits`` (of the midpoints below)."""
        return Precision.parse(f"mp:{self.bits}")

    def _mids(self, rows: list, i: int) -> np.ndarray:
        P = self.precision
        return P.array([P.from_fraction(exact_value(r[i].mid())) for r in rows])

    @property
    def t(self) -> np.ndarray:
        """Sample times, the balls' midpoints in :attr:`precision` (as every pair model's ``t``)."""
        return self._mids(self.samples, 1)

    @property
    def x(self) -> np.ndarray:
        """The master's position at the samples (midpoints)."""
        return self._mids(self.samples, 2)

    @property
    def v(self) -> np.ndarray:
        """The master's velocity at the samples (midpoints)."""
        return self._mids(self.samples, 3)

    @property
    def y(self) -> np.ndarray:
        """The slave's position at the samples (midpoints)."""
        return self._mids(self.samples, 4)

    @property
    def w(self) -> np.ndarray:
        """The slave's velocity variable at the samples (midpoints)."""
        return self._mids(self.samples, 5)

    @property
    def master_impacts_t(self) -> np.ndarray:
        """The master's impact times (midpoints)."""
        return self._mids(self.master_impacts, 0)

    @property
    def slave_impacts_t(self) -> np.ndarray:
        """The slave's impact times (midpoints)."""
        return self._mids(self.slave_impacts, 0)

    def max_radius(self) -> float:
        """The largest radius of any sample coordinate (a float rounded up: ``5e-324`` below
        1e-308, never 0.0; its size is :meth:`max_log10_radius`)."""
        return float_up(max(exact_value(b.rad()) for s in self.samples for b in s[2:]))

    def max_log10_radius(self) -> float:
        """``log10`` of the largest radius of any sample coordinate, at any magnitude."""
        return max(self.log10_radii())

    def log10_radii(self) -> list[float]:
        """``log10`` of each sample's largest radius of ``x, v, y, w`` (``-inf`` for exact
        points), at any magnitude."""
        return [max(log10_abs(b.rad()) for b in s[2:]) for s in self.samples]

    def growth_digits_per_period(self) -> float:
        """Decimal digits of radius lost per forcing period (least squares over the samples
        after the first, :func:`~precise_impact.solvers.certified.single.growth_slope`)."""
        return growth_slope(self.log10_radii())

    def to_dict(self) -> dict:
        """JSON: ``params``, ``form``, ``k``, ``y0``, ``periods``, ``bits``, ``bits_choice``,
        ``method``,
        ``samples`` (``{"period", "t", "x", "v", "y", "w", "x_rad", "v_rad", "y_rad", "w_rad"}``),
        ``master_impacts`` and ``slave_impacts`` (``{"t", "t_rad", "before", "after", "rad"}``),
        ``max_radius``, ``max_log10_radius`` (``None`` for exact points),
        ``growth_digits_per_period``, ``elapsed_s``; midpoints
        and rigorous radii as decimal strings (``max_radius`` in scientific notation, rounded up,
        never 0 for a ball of any radius): strict JSON."""
        rows = []
        comps = self.claimed_digits().components()
        for j, (k, t, *balls) in enumerate(self.samples):
            row: dict = {"period": k, "t": ball_str(t)[0]}
            for name, b in zip("xvyw", balls, strict=True):
                row[name], row[name + "_rad"] = ball_str(b)
            row.update({f"{n}_digits": int(d[j]) for n, d in comps.items()})
            rows.append(row)

        def imps(lst):
            out = []
            for t, b, a in lst:
                (tm, tr), (bm, br), (am, ar) = ball_str(t), ball_str(b), ball_str(a)
                out.append(
                    {
                        "t": tm,
                        "t_rad": tr,
                        "before": bm,
                        "after": am,
                        "rad": max(br, ar, key=Fraction),
                    }
                )
            return out

        return {
            "params": self.params.decimal(),
            "form": self.form,
            "k": decimal_str(self.k),
            "y0": None if self.y0 is None else [decimal_str(q) for q in self.y0],
            "periods": self.periods,
            "bits": self.bits,
            "bits_choice": self.bits_choice,
            "method": self.method,
            "digits": self.claimed_digits().summary(),
            "samples": rows,
            "master_impacts": imps(self.master_impacts),
            "slave_impacts": imps(self.slave_impacts),
            "max_radius": max_radius_str(b for s in self.samples for b in s[2:]),
            "max_log10_radius": _finite_or_none(self.max_log10_radius()),
            "growth_digits_per_period": self.growth_digits_per_period(),
            "elapsed_s": self.elapsed_s,
        }


def master_reset(c: Constants, x, v, e, ep) -> tuple:
    """``(x, v, e, e')`` just after the master's impact from the state just before it: ``x``
    on the wall, ``v`` reset (:func:`~precise_impact.core.impact.reset_velocity`), ``y'``
    continuous (``e' + v`` kept)."""
    va = reset_velocity(v, c.R)
    yd = v + ep  # y' is continuous through the master's impact
    return c.xw, va, e, yd - va


def slave_impact_state(c: Constants, form: str, k, x, v, e, ep) -> tuple:
    """``(w_before, w_after, (x, v, e, e'))`` of the slave's impact from the state just before
    it (:func:`~precise_impact.core.coupling.slave_reset` in ``form``'s variables; the master
    goes on, ``e = x_w - x`` on the wall)."""
    wb = slave_velocity(form, k, e, v + ep)
    wa = slave_reset(form, x, wb, c.R, k, c.xw)
    e_at = c.xw - x  # the slave is on the wall
    yd = slave_derivative(form, k, e_at, wa)
    return wb, wa, (x, v, e_at, yd - v)


class _Walk:
    """The pair's certified walk between samples: the current :class:`_Pair` (restarted at each
    impact) and the impacts found, ``(t, before, after)`` balls of the master and the slave."""

    def __init__(self, c, iso, consts, form: str, k, bits: int, pair: _Pair) -> None:
        self.c, self.iso, self.consts, self.form, self.k, self.bits = c, iso, consts, form, k, bits
        self.pair = pair
        self.mimp: list = []
        self.simp: list = []
        #: ``(master, hit, (x, v, e, e'))`` before each impact, if ``record`` (the Lohner pair)
        self.record = False
        self.events: list = []
        #: the sample time ``t_(n+1)`` and the state there, once a period is walked (Lohner)
        self.tk1: Any = None
        self.end: Any = None

    def unordered(self, t) -> CertificationError:
        return CertificationError(
            describe(t, "simultaneous master and slave impacts whose order cannot be proven")
            + f" at {self.bits} bits"
        )

    def advance(self, a, tk, end, hstep, check: bool) -> None:
        """Prove both gaps < 0 from ``a`` up to ``end`` (the sample ``tk``'s upper end) in steps
        of ``hstep``, applying every impact on the way; ``check``: prove them < 0 at ``a``."""
        iso = self.iso
        while True:
            b = a + hstep
            b = point(b) if b < end else end
            pair = self.pair
            hm = iso.first_crossing(pair.master_gap, pair.master_bound(), a, b, check_start=check)
            hs = iso.first_crossing(pair.slave_gap, pair.slave_bound(), a, b, check_start=check)
            check = False
            if hm is None and hs is None:
                if not (b < end):
                    return
                a = b
                continue
            if hm is not None and hs is not None and hm.overlaps(hs):
                raise self.unordered(hm.union(hs))
            master = hs is None or (hm is not None and hm < hs)
            d = self.impacts(master, hm if master else hs, tk, end)
            a = d if d < end else end
            if not (a < end):
                return  # both gaps < 0 proven up to the sample

    def impacts(self, master: bool, hit, tk, end):
        """Apply the impact at ``hit`` (the master's if ``master``, else the slave's) and those of
        the other oscillator before this one departs; the proven departure time."""
        iso = self.iso
        while True:  # apply the impact; the other oscillator may impact before this one departs
            if hit.overlaps(tk):
                raise CertificationError(
                    describe(hit, "an impact on a sample time") + f" at {self.bits} bits"
                )
            if master:
                gap, bound, other, obound = self.master_impact(hit)
            else:
                gap, bound, other, obound = self.slave_impact(hit)
            d = iso.depart(gap, bound, hit)  # this one's gap < 0 proven on (impact, d]
            stop = d if d < end else end
            nxt = iso.first_crossing(other, obound, point(hit.lower()), stop, check_start=True)
            if nxt is None:
                return d
            if nxt.overlaps(hit) or not nxt > hit:
                raise self.unordered(hit.union(nxt))
            master, hit = not master, nxt

    def master_impact(self, hit) -> tuple:
        """Reset the master at ``hit``; (its gap, bound, the slave's gap, bound)."""
        c = self.c
        z = self.pair.state(hit)
        if self.record:
            self.events.append((True, hit, z))
        xa, va, ea, epa = master_reset(c, *z)
        self.mimp.append((hit, z[1], va))
        pair = self.pair = _Pair(c, self.consts, hit, xa, va, ea, epa)
        return pair.master_gap, pair.master_bound(), pair.slave_gap, pair.slave_bound()

    def slave_impact(self, hit) -> tuple:
        """Reset the slave at ``hit``; (its gap, bound, the master's gap, bound)."""
        c = self.c
        z = self.pair.state(hit)
        if self.record:
            self.events.append((False, hit, z))
        wb, wa, (x, v, e_at, ep_at) = slave_impact_state(c, self.form, self.k, *z)
        self.simp.append((hit, wb, wa))
        pair = self.pair = _Pair(c, self.consts, hit, x, v, e_at, ep_at, master=self.pair.m)
        return pair.slave_gap, pair.slave_bound(), pair.master_gap, pair.master_bound()


def _run(
    params,
    kq: Fraction,
    form: str,
    y0q,
    periods: int,
    bits: int,
    progress,
    deadline=None,
    method: str = "interval",
) -> tuple:
    samples: list = []
    try:
        if method == "lohner":
            return LohnerPair(params, kq, form, y0q, bits).run(periods, progress, deadline, samples)
        return _walk(params, kq, form, y0q, periods, bits, progress, deadline, samples)
    except CertificationError as e:
        e.partial = samples  # the proven samples, for out_of_reach
        raise


def _setup(params, kq, form: str, bits: int) -> tuple:
    """``(c, iso, k, consts)`` at the current precision: the constants, the isolator, the
    coupling ball and the error flow's ``(alpha, omega, c0)``."""
    c = Constants(params, bits)
    iso = Isolator(bits)
    k = to_ball(kq)
    c1, c0 = error_coefficients(form, c.zeta, k)
    al = c1 / 2
    om2 = c0 - al * al
    if not om2 > 0:  # pragma: no cover - refused by certify_coupled before any work
        raise CertificationError(
            f"e'' + c1 e' + c0 e = 0 is not proven underdamped (c0 - c1^2/4 in {om2})"
        )
    return c, iso, k, (al, om2.sqrt(), c0)


def _start(params, form: str, k, y0q) -> tuple:
    """The start as balls: ``(x0, v0, e0, e0')`` and the slave's ``(y0, w0)``."""
    x0, v0 = to_ball(params.x0), to_ball(params.v0)
    yp, yv = to_ball(y0q[0]), to_ball(y0q[1])
    e0 = yp - x0
    ep0 = slave_derivative(form, k, e0, yv) - v0
    return (x0, v0, e0, ep0), (yp, yv)


def _walk(params, kq, form, y0q, periods, bits, progress, deadline, samples: list) -> tuple:
    c, iso, k, consts = _setup(params, kq, form, bits)
    (x0, v0, e0, ep0), (yp, yv) = _start(params, form, k, y0q)
    s = c.t0
    walk = _Walk(c, iso, consts, form, k, bits, _Pair(c, consts, s, x0, v0, e0, ep0))

    samples.append((0, s, x0, v0, yp, yv))
    a = s
    hstep = point(c.T / 16)
    for n in range(1, periods + 1):
        tk = c.t0 + n * c.T
        end = upper(tk)
        walk.advance(a, tk, end, hstep, check=n == 1)  # first: prove both gaps < 0 at the start
        x, v, e, ep = walk.pair.state(tk)
        samples.append((n, tk, x, v, x + e, slave_velocity(form, k, e, v + ep)))
        a = end
        if progress is not None:
            progress.update(n)
        if deadline is not None:
            deadline.check(f"{n} of {periods} periods at {bits} bits")
    return samples, walk.mimp, walk.simp


class LohnerPair:
    """The pair's Lohner enclosure (:mod:`~precise_impact.solvers.certified.lohner`, here with
    ``n = 4`` on ``(x, v, e, e')``): the state at each sample as ``m + B r`` and one period
    mapped by the mean-value form.

    * the **low pass**: :meth:`_Walk.advance` over one period from the hull of ``m + B r`` at
      :data:`~precise_impact.solvers.certified.lohner.LOW_BITS` (doubled on a failure up to the
      working bits) proves the same transversal master/slave impact sequence for every state
      of the box and records each impact's time and state balls;
    * the period's **Jacobian** over the box: between impacts the exact 4x4 variational flow
      ``blockdiag(Phi_master, Phi_error)`` (the error equation is homogeneous and does not see
      the master between impacts; :func:`~precise_impact.core.flight.flow_matrix` for both), at
      each impact the saltation matrix
      (:func:`~precise_impact.core.impact.saltation_matrix`) with the normal ``(1, 0, 0, 0)``
      (master) or ``(1, 0, 1, 0)`` (slave, ``y = x + e``), the fields before and after, and the
      reset's Jacobian (:func:`master_reset`, :func:`slave_impact_state`: affine maps, whose
      Jacobian columns ``g(e_j) - g(0)`` are exact up to the balls' rounding);
    * the **point pass**: the same walk from ``m`` at the working bits;
    * the update as in :class:`~precise_impact.solvers.certified.lohner.LohnerEngine`, the
      frame from :func:`~precise_impact.solvers.certified.lohner.qr_frame`; each sample and
      impact intersected with the low pass's own (interval) balls.
    """

    def __init__(self, params, kq, form: str, y0q, bits: int) -> None:
        self.params, self.kq, self.form, self.y0q, self.bits = params, kq, form, y0q, bits
        self._ctx: dict = {}

    def ctx(self, bits: int) -> tuple:
        if bits not in self._ctx:
            with _Prec(bits):
                self._ctx[bits] = _setup(self.params, self.kq, self.form, bits)
        return self._ctx[bits]

    def period(self, bits: int, n: int, state, check: bool, steps: int = 16) -> _Walk:
        """The interval walk over period ``n + 1`` from ``state`` (balls at ``t0 + n T``), at
        ``bits`` (the caller holds that precision), in scan steps of ``T / steps``, recording
        the impacts' states."""
        c, iso, k, consts = self.ctx(bits)
        tk = c.t0 + n * c.T
        tk1 = c.t0 + (n + 1) * c.T
        walk = _Walk(c, iso, consts, self.form, k, bits, _Pair(c, consts, tk, *state))
        walk.record = True
        walk.advance(point(tk.lower()), tk1, upper(tk1), point(c.T / steps), check)
        for _, hit, _ in walk.events[:1]:
            # the scan starts at the lower end of t_k: an impact must follow all of it (then
            # every state of the box has no crossing on [t_k-, t_k] and the walk is its flow)
            if not hit > tk:
                raise CertificationError(
                    describe(hit, "an impact on a sample time") + f" at {bits} bits"
                )
        walk.end = walk.pair.state(tk1)
        walk.tk1 = tk1
        return walk

    def low_pass(self, n: int, m: list, B, r: list) -> tuple:
        """The interval walk over period ``n + 1`` from the hull of ``m + B r`` at the fewest
        bits from :data:`LOW_BITS` (doubled on a failure, the hull formed again at those bits,
        up to the working bits) that prove it."""
        lo = min(self.bits, LOW_BITS)
        while True:
            try:
                box = hull(m, B, r, lo)
                with _Prec(lo):
                    return lo, self.period(lo, n, box, True, LOW_STEPS)
            except CertificationError:
                if lo >= self.bits:
                    raise
                lo = min(2 * lo, self.bits)

    def jacobian(self, bits: int, n: int, walk: _Walk) -> tuple:
        """The period map's Jacobian over the low pass's box (``arb_mat``) and each impact's
        pre-impact Jacobian ``M_i``, field ``f-`` and normal, at ``bits``."""
        flint = _flint()
        c, _, k, (al, om, c0) = self.ctx(bits)
        form = self.form

        def phi(tau):
            p = flight.flow_matrix(tau, c.zeta, c.w, flight.ARB)
            q = flight.flow_matrix(tau, al, om, flight.ARB, c0)
            z = flint.arb(0)
            return flint.arb_mat(
                [[p[0], p[1], z, z], [p[2], p[3], z, z], [z, z, q[0], q[1]], [z, z, q[2], q[3]]]
            )

        def field(t, x, v, e, ep):
            cos = lambda u: u.cos()  # noqa: E731
            return [v, acceleration(t, x, v, c.eta, c.zeta, c.a, cos), ep, -2 * al * ep - c0 * e]

        def reset_jacobian(g):
            zero, one = flint.arb(0), flint.arb(1)
            g0 = g(zero, zero, zero, zero)
            cols = []
            for j in range(4):
                gj = g(*[one if i == j else zero for i in range(4)])
                cols.append([gj[i] - g0[i] for i in range(4)])
            return [[cols[j][i] for j in range(4)] for i in range(4)]

        def m_reset(x, v, e, ep):
            return master_reset(c, x, v, e, ep)

        def s_reset(x, v, e, ep):
            return slave_impact_state(c, form, k, x, v, e, ep)[2]

        one, zero = flint.arb(1), flint.arb(0)
        M = _eye(4)
        prev = c.t0 + n * c.T
        pre = []
        for master, hit, (x, v, e, ep) in walk.events:
            M = phi(hit - prev) * M
            if master:
                x = c.xw  # on the wall
                normal, g = [one, zero, zero, zero], m_reset
            else:
                normal, g = [one, zero, one, zero], s_reset
            fm = field(hit, x, v, e, ep)
            fp = field(hit, *g(x, v, e, ep))
            den = sum((a * b for a, b in zip(normal, fm, strict=True)), zero)
            if not den > 0:  # pragma: no cover - the walk proved a transversal crossing
                raise CertificationError(
                    describe(hit, "an impact not proven transversal") + f" at {bits} bits"
                )
            pre.append((master, M, fm, normal, den))
            S = saltation_matrix(reset_jacobian(g), fm, fp, normal)
            M = flint.arb_mat(S) * M
            prev = hit
        return phi(walk.tk1 - prev) * M, pre

    def impact_rows(self, bits: int, pre, B) -> list:
        """Per impact: the gradient rows (times ``B``) of its time and its before/after
        velocity variable over the box, at ``bits``."""
        c, _, k, _ = self.ctx(bits)
        zero = _flint().arb(0)
        out = []
        for master, M, fm, normal, den in pre:
            gs = [-sum((normal[i] * M[i, j] for i in range(4)), zero) / den for j in range(4)]
            D = [[M[i, j] + fm[i] * gs[j] for j in range(4)] for i in range(4)]  # of z-
            if master:
                wb = [D[1][j] for j in range(4)]
                wa = [reset_velocity(w, c.R) for w in wb]
            else:
                wb = [slave_velocity(self.form, k, D[2][j], D[1][j] + D[3][j]) for j in range(4)]
                # the reset's linear part (affine in x and w-)
                wa = [slave_reset(self.form, D[0][j], wb[j], c.R, k, zero) for j in range(4)]
            rows = []
            for g in (gs, wb, wa):
                rows.append([sum((g[i] * B[i, j] for i in range(4)), zero) for j in range(4)])
            out.append(rows)
        return out

    def mean_value(self, lo: int, n: int, wl: _Walk, B, r: list, k) -> tuple:
        """The mean-value form of period ``n`` at ``lo`` bits: ``MB = A B``, ``M r`` and the
        changes of ``y``, ``w`` and of every impact's ``(t, x, v)`` over the box ``r``."""
        zero = _flint().arb(0)
        form = self.form
        with _Prec(lo):
            A, pre = self.jacobian(lo, n, wl)
            MB = A * B
            rows = self.impact_rows(lo, pre, B)
            Mr = [sum((MB[i, j] * r[j] for j in range(4)), zero) for i in range(4)]
            yrow = [MB[0, j] + MB[2, j] for j in range(4)]
            wrow = [slave_velocity(form, k, MB[2, j], MB[1, j] + MB[3, j]) for j in range(4)]
            dy = sum((yrow[j] * r[j] for j in range(4)), zero)
            dw = sum((wrow[j] * r[j] for j in range(4)), zero)
            dimp = [[sum((g[j] * r[j] for j in range(4)), zero) for g in rw] for rw in rows]
        return MB, Mr, dy, dw, dimp

    def merge_impacts(self, n: int, wp: _Walk, wl: _Walk, dimp: list, mimp: list, simp) -> None:
        """Period ``n``'s impacts: the point pass's plus their mean-value change, intersected
        with the box pass's, appended to ``mimp`` (master) and ``simp`` (slave)."""
        kinds = [e[0] for e in wp.events]
        if kinds != [e[0] for e in wl.events]:
            raise CertificationError(  # pragma: no cover - m lies in the proven box
                f"the point pass's impacts differ from the box's in period {n + 1} "
                f"at {self.bits} bits"
            )
        im, isl = iter(wp.mimp), iter(wp.simp)
        lm, ls = iter(wl.mimp), iter(wl.simp)
        for master, d in zip(kinds, dimp, strict=True):
            (t, b, a), (tl, bl, al) = (next(im), next(lm)) if master else (next(isl), next(ls))
            box = ((t + d[0]).intersection(tl), (b + d[1]).intersection(bl))
            (mimp if master else simp).append((*box, (a + d[2]).intersection(al)))

    def run(self, periods: int, progress, deadline, samples: list) -> tuple:
        _flint()  # python-flint, refused before any work when missing
        bits, form = self.bits, self.form
        c, _, k, _ = self.ctx(bits)
        state, (yp, yv) = _start(self.params, form, k, self.y0q)
        samples.append((0, c.t0, state[0], state[1], yp, yv))
        mimp: list = []
        simp: list = []

        def sample(n, t, z, y=None, w=None):
            y = z[0] + z[2] if y is None else y
            w = slave_velocity(form, k, z[2], z[1] + z[3]) if w is None else w
            samples.append((n, t, z[0], z[1], y, w))
            if progress is not None:
                progress.update(n)
            if deadline is not None:
                deadline.check(f"{n} of {periods} periods at {bits} bits")

        # the first period by the interval walk from the exact start; from its sample on m + B r
        w0 = self.period(bits, 0, state, True)
        mimp.extend(w0.mimp)
        simp.extend(w0.simp)
        z = w0.end
        sample(1, w0.tk1, z)
        m, B, r = box_frame(list(z))
        for n in range(1, periods):
            lo, wl = self.low_pass(n, m, B, r)
            MB, Mr, dy, dw, dimp = self.mean_value(lo, n, wl, B, r, k)
            wp = self.period(bits, n, m, True)
            self.merge_impacts(n, wp, wl, dimp, mimp, simp)
            y = wp.end
            zl = wl.end
            zs = [(a + b).intersection(q) for a, b, q in zip(y, Mr, zl, strict=True)]
            ys = (y[0] + y[2] + dy).intersection(zl[0] + zl[2])
            ws = (slave_velocity(form, k, y[2], y[1] + y[3]) + dw).intersection(
                slave_velocity(form, k, zl[2], zl[1] + zl[3])
            )
            sample(n + 1, wp.tk1, zs, ys, ws)
            if interval_is_tighter(zl, [a + b for a, b in zip(y, Mr, strict=True)]):
                m, B, r = box_frame(zs)
            else:
                m, B, r = reframe(MB, r, list(y), lo)
        return samples, mimp, simp


def _check_pair(params, kq, form: str, y0q) -> None:
    """Refuse a pair the certified engine cannot carry: ``k > 100``, an overdamped error
    equation, or a start on or beyond the wall off the diagonal."""
    if kq > 100:  # |e''| is bounded by c0 |e|, ~k^2: beyond this the crossing scan would crawl
        raise ParameterError("k", decimal_str(kq), "0 <= k <= 100 for the certified pair")
    c1, c0 = error_coefficients(form, params.zeta, kq)
    if not c0 > c1 * c1 / 4:
        raise ParameterError(
            "k",
            decimal_str(kq),
            f"a coupling with c0 > c1^2/4 (underdamped error equation) for the '{form}' form",
        )
    if y0q is not None:
        if not params.x0 < params.x_w:
            raise ParameterError(
                "x0",
                decimal_str(params.x0),
                f"x0 < x_w = {decimal_str(params.x_w)} for the certified pair off the diagonal",
            )
        if not y0q[0] < params.x_w:
            raise ParameterError(
                "y0[0]",
                decimal_str(y0q[0]),
                f"y0[0] < x_w = {decimal_str(params.x_w)} for the certified pair",
            )


def certify_coupled(
    params: Any = None,
    k: Any = "0.1",
    form: str = "first-order",
    periods: int = 100,
    *,
    y0: Sequence[Any] | None = None,
    precision: str = "mp:256",
    target_radius: Any = "1e-30",
    max_bits: int = 4096,
    progress: bool | None = None,
    max_time: Any = None,
    method: str = "lohner",
    bits: Any = UNSET,
    **param_values: Any,
) -> CertifiedCoupledTrajectory:
    """The master-slave pair certified: each sample and impact of both oscillators in a proven ball.

    Parameters
    ----------
    params : Params, mapping or None, default ``None``
        The system and the master's start (exact); ``None``: the paper's defaults with
        ``param_values``.  The master must start below the wall (``x0 < x_w``).
    k : decimal, default ``'0.1'``
        Coupling ``0 <= k <= 100`` (exact); ``e'' + c1 e' + c0 e = 0`` must be underdamped
        (always for 'first-order' and 'reduced'; ``k`` up to about 3.4 for 'paper' at
        zeta = 0.05).
    form : str, default ``'first-order'``
        ``'first-order'``, ``'paper'`` or ``'reduced'``
        (:mod:`~precise_impact.solvers.heyoka.coupled`).
    periods : int, default 100
        Forcing periods (``1 <= periods <= 100000``).
    y0 : pair or None, default ``None``
        The slave's start ``(position, velocity variable)`` in ``form``'s variables, exact,
        position ``< x_w``; ``None``: on the diagonal (the slave is the master, exactly).
    precision : str, default ``'mp:256'``
        Working precision of the balls, ``'mp:BITS'`` (``64 <= BITS <= max_bits``), or
        ``'auto'``: chosen as :func:`~precise_impact.solvers.certified.single.certify` does
        (:func:`~precise_impact.solvers.certified.single.choose_bits`): a pilot run of the pair
        at 128 bits (doubled until it is proven) over a tenth of the run, 40 to 200 periods
        (``'lohner'``; ``'interval'``: 40), measures the radius growth per period, and the bits
        are set so that the last sample's radius is below ``target_radius`` with two decimal
        digits to spare; a run that misses the target is retried at twice the bits.
    target_radius : decimal, default ``'1e-30'``
        The radius wanted at every sample when ``precision`` is ``'auto'``
        (``1e-3000 <= target_radius <= 1e-3``).
    max_bits : int, default 4096
        After a failed proof (or a missed target) the bits are doubled up to this
        (``<= 16384``).
    progress : bool or None, default ``None``
        A progress line on stderr (``None``: only when stderr is a terminal).
    max_time : decimal or None, default ``None``
        Time budget in seconds (``1 <= max_time <= 604800``): the estimated cost
        (:func:`~precise_impact.core.budget.estimate_cost`, job ``'certify'``) is checked
        against it before any work, and the run stops once it is spent; ``None``: no budget.
    method : {'lohner', 'interval'}, default ``'lohner'``
        The enclosure: ``'lohner'`` carries the four-dimensional state ``(x, v, e, e')`` as a
        point plus a matrix times a box in a QR frame, mapped through each period by the
        mean-value form (the flights' exact 4x4 flow and the saltation matrices of both
        oscillators' impacts, enclosed over the box); each ball is intersected with the
        interval scheme's own.  ``'interval'``: the four balls walked on, wrapped every period
        (their radii grow about twice as fast on a chaotic master).  On the diagonal the single
        oscillator's (:func:`~precise_impact.solvers.certified.single.certify`) of the same name.
    bits : int
        Deprecated: ``precision='mp:BITS'``.
    **param_values
        Parameter values replacing those of ``params``.

    Returns
    -------
    CertifiedCoupledTrajectory
        Balls of every sample of ``(x, v, y, w)`` and of every impact of each oscillator.

    Raises
    ------
    ParameterError
        Bad input, before any work.
    OverBudgetError
        The estimated cost is over ``max_time``, before any work.
    BudgetExceededError
        ``max_time`` ran out during the run.
    CertificationError
        No proof up to ``max_bits`` (an impact order that cannot be proven, a tangential
        contact, an impact on a sample time); the message names the time.  Also, without
        doubling on, when the radius growth measured over a failed attempt projects more bits
        than ``max_bits`` can give (:func:`~precise_impact.solvers.certified.single.out_of_reach`).
    OptionalDependencyError
        python-flint is not installed.

    See Also
    --------
    precise_impact.solvers.certified.single.certify : a single oscillator certified.
    precise_impact.solvers.simulate.simulate_coupled : the same pair in floating point.
    precise_impact.analysis.sync.sync_scan : synchronisation against the coupling k.

    References
    ----------
    .. [1] V. Denysenko, M. Balcerzak, A. Dabrowski, "Electronic equivalent of a mechanical
           impact oscillator", eqs. (11)-(14).
    .. [2] F. Johansson, "Arb: efficient arbitrary-precision midpoint-radius interval
           arithmetic", IEEE Trans. Comput. 66 (2017) 1281-1292.

    Examples
    --------
    >>> import precise_impact as pi
    >>> cc = pi.certify_coupled(pi.Params.make(eta="0.74"), k="0.1", periods=2)
    >>> type(cc).__name__, cc.periods
    ('CertifiedCoupledTrajectory', 2)
    """

    params = params_or_values(params, param_values)
    kq = check_k(k)
    form = check_form(form)
    periods = check_count(periods, "periods", 100_000, minimum=1)
    max_bits = check_count(max_bits, "max_bits", MAX_BITS, minimum=MIN_BITS)
    if method not in METHODS:
        raise ParameterError("method", str(method), "'lohner' or 'interval'")
    if bits is not UNSET:  # the 0.2 spelling
        warn_renamed("bits=", "precision=", "certify_coupled")
        bits = check_count(bits, "bits", max_bits, minimum=MIN_BITS)
    else:
        bits = certified_bits(precision, max_bits)
    log_target = check_target(target_radius)
    y0q = check_y0(y0, params)
    check_certifiable(params)
    _check_pair(params, kq, form, y0q)
    coupled = y0q is not None
    enforce_max_time(
        max_time, "certify", periods=periods, precision=f"mp:{bits or 128}", coupled=coupled
    )
    deadline = Deadline(None if max_time is None else parse_max_time(max_time), "certify")

    def attempt(n: int, b: int, bar: Progress | None) -> CertifiedCoupledTrajectory:
        t0 = time.perf_counter()
        if not coupled:  # the diagonal: the slave is the master, exactly (module docstring)
            ss, imps = run_single(params, n, b, None, deadline, method)
            samples = [(j, t, x, v, x, v) for j, t, x, v in ss]
            mimp = simp = list(imps)
            if bar is not None:
                bar.update(n)
        else:
            with working_bits(b):
                samples, mimp, simp = _run(params, kq, form, y0q, n, b, bar, deadline, method)
        return CertifiedCoupledTrajectory(
            params, form, kq, y0q, n, b, samples, mimp, simp, time.perf_counter() - t0, method
        )

    choice = "given"
    if bits is None:
        bits, choice = choose_bits(
            lambda n, b: attempt(n, b, None), periods, method, log_target, max_bits, target_radius
        )
        enforce_max_time(
            max_time, "certify", periods=periods, precision=f"mp:{bits}", coupled=coupled
        )
    bar = Progress(periods, "certified periods (pair)", enabled=progress)
    return doubling(
        lambda b, _: attempt(periods, b, bar), bits, choice, periods, max_bits, log_target, bar
    )


class CertifiedCoupledSolver:
    """The certified pair as a coupled model (``model='certified'``, ``precision='mp:BITS'``).

    :meth:`solve` returns the :class:`CertifiedCoupledTrajectory` itself: the balls, and the
    midpoints as ``t, x, v, y, w``, ``master_impacts_t``, ``slave_impacts_t``.  No dense
    output (``per_period`` must be 0).

    Parameters
    ----------
    bits : int
        Working precision (``MIN_BITS <= bits <= MAX_BITS``); no retry at more bits.
    progress : bool or None, default ``None``
        As :func:`certify_coupled`.
    """

    model_name = "certified"

    def __init__(self, bits: int, progress: bool | None = None) -> None:
        self.bits = check_count(bits, "bits", MAX_BITS, minimum=MIN_BITS)
        self.precision = Precision.parse(f"mp:{self.bits}")
        self.progress = progress

    def solve(
        self,
        params: Params,
        k: Any,
        periods: int,
        *,
        form: str = "first-order",
        y0: Any = None,
        per_period: int = 0,
    ) -> CertifiedCoupledTrajectory:
        """Certify the pair for ``periods`` periods at the solver's bits
        (:func:`certify_coupled`)."""
        if per_period:
            raise ParameterError(
                "per_period", str(per_period), "0 for the certified model (no dense output)"
            )
        return certify_coupled(
            params,
            k,
            form,
            periods,
            y0=y0,
            precision=f"mp:{self.bits}",
            max_bits=self.bits,
            progress=self.progress,
        )
