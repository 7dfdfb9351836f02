"""The master-slave pair certified: every sample and impact of both oscillators in a proven ball.

The master's flight and the difference ``e = y - x`` (a damped linear oscillator) in ball
arithmetic; an impact order that cannot be proven stops the run (``docs/numerics.rst``).
"""

from __future__ import annotations

import dataclasses
import os
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
from precise_impact.core.params import Params, check_count, decimal_str, params_or_values
from precise_impact.core.precision import Precision
from precise_impact.core.result import ResultMixin, ball_columns
from precise_impact.errors import BudgetExceededError, ParameterError
from precise_impact.io.progress import Progress
from precise_impact.solvers.certified.single import (
    MAX_BITS,
    MIN_BITS,
    CertificationError,
    Constants,
    Flight,
    Isolator,
    _finite_or_none,
    ball_str,
    certified_bits,
    check_certifiable,
    describe,
    exact_value,
    log10_abs,
    max_radius_str,
    out_of_reach,
    point,
    run_balls,
    to_ball,
    upper,
    working_bits,
)

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
class CertifiedCoupledTrajectory(ResultMixin):
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
        """The largest radius of any sample coordinate (a float rounded up; 0.0 below 1e-308)."""
        return max(float(exact_value(b.rad())) for s in self.samples for b in s[2:]) * (1 + 2**-50)

    def max_log10_radius(self) -> float:
        """``log10`` of the largest radius of any sample coordinate, at any magnitude."""
        return max(log10_abs(b.rad()) for s in self.samples for b in s[2:])

    def plot(
        self,
        path: str | os.PathLike | None = None,
        units: str = "dimensionless",
        components: Any = None,
        threshold: float | None = None,
    ):
        """``|x - y|`` against time on a log axis (:func:`precise_impact.io.figures.plot_coupled`).

        Parameters
        ----------
        path : str, os.PathLike or None, default ``None``
            Also write the figure there (``.png``, ``.pdf``, ``.svg``, atomically).
        units : {'dimensionless', 'circuit'}, default ``'dimensionless'``
            ``'circuit'``: seconds and ``|V_s1 - V_s2|`` in volts of ``components`` (default:
            the nominal design of :attr:`params`).
        components : Components or None
            The design for ``units='circuit'``.
        threshold : float or None
            Drawn as a dashed line.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from precise_impact.io.figures import plot_coupled

        return plot_coupled(self, path, units=units, components=components, threshold=threshold)

    def to_dict(self) -> dict:
        """JSON: ``params``, ``form``, ``k``, ``y0``, ``periods``, ``bits``, ``samples``
        (``{"period", "t", "x", "v", "y", "w", "x_rad", "v_rad", "y_rad", "w_rad"}``),
        ``master_impacts`` and ``slave_impacts`` (``{"t", "t_rad", "before", "after", "rad"}``),
        ``max_radius``, ``max_log10_radius`` (``None`` for exact points), ``elapsed_s``; midpoints
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
            "digits": self.claimed_digits().summary(),
            "samples": rows,
            "master_impacts": imps(self.master_impacts),
            "slave_impacts": imps(self.slave_impacts),
            "max_radius": max_radius_str(b for s in self.samples for b in s[2:]),
            "max_log10_radius": _finite_or_none(self.max_log10_radius()),
            "elapsed_s": self.elapsed_s,
        }


class _Walk:
    """The pair's certified walk between samples: the current :class:`_Pair` (restarted at each
    impact) and the impacts found, ``(t, before, after)`` balls of the master and the slave."""

    def __init__(self, c, iso, consts, form: str, k, bits: int, pair: _Pair) -> None:
        self.c, self.iso, self.consts, self.form, self.k, self.bits = c, iso, consts, form, k, bits
        self.pair = pair
        self.mimp: list = []
        self.simp: list = []

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
        x, v, e, ep = self.pair.state(hit)
        va = -c.R * v
        self.mimp.append((hit, v, va))
        yd = v + ep  # y' is continuous through the master's impact
        pair = self.pair = _Pair(c, self.consts, hit, c.xw, va, e, yd - va)
        return pair.master_gap, pair.master_bound(), pair.slave_gap, pair.slave_bound()

    def slave_impact(self, hit) -> tuple:
        """Reset the slave at ``hit``; (its gap, bound, the master's gap, bound)."""
        c, form, k = self.c, self.form, self.k
        x, v, e, ep = self.pair.state(hit)
        wb = slave_velocity(form, k, e, v + ep)
        wa = slave_reset(form, x, wb, c.R, k, c.xw)
        self.simp.append((hit, wb, wa))
        e_at = c.xw - x  # the slave is on the wall
        yd = slave_derivative(form, k, e_at, wa)
        pair = self.pair = _Pair(c, self.consts, hit, x, v, e_at, yd - v, master=self.pair.m)
        return pair.slave_gap, pair.slave_bound(), pair.master_gap, pair.master_bound()


def _run(
    params, kq: Fraction, form: str, y0q, periods: int, bits: int, progress, deadline=None
) -> tuple:
    samples: list = []
    try:
        return _walk(params, kq, form, y0q, periods, bits, progress, deadline, samples)
    except CertificationError as e:
        e.partial = samples  # the proven samples, for out_of_reach
        raise


def _walk(params, kq, form, y0q, periods, bits, progress, deadline, samples: list) -> tuple:
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
    consts = (al, om2.sqrt(), c0)
    x0, v0 = to_ball(params.x0), to_ball(params.v0)
    yp, yv = to_ball(y0q[0]), to_ball(y0q[1])
    e0 = yp - x0
    ep0 = slave_derivative(form, k, e0, yv) - v0
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


def certify_coupled(
    params: Any = None,
    k: Any = "0.1",
    form: str = "first-order",
    periods: int = 100,
    *,
    y0: Sequence[Any] | None = None,
    precision: str = "mp:256",
    max_bits: int = 4096,
    progress: bool | None = None,
    max_time: Any = None,
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
        Working precision of the balls, ``'mp:BITS'`` (``64 <= BITS <= max_bits``).
    max_bits : int, default 4096
        After a failed proof the bits are doubled up to this (``<= 16384``).
    progress : bool or None, default ``None``
        A progress line on stderr (``None``: only when stderr is a terminal).
    max_time : decimal or None, default ``None``
        Time budget in seconds (``1 <= max_time <= 604800``): the estimated cost
        (:func:`~precise_impact.core.budget.estimate_cost`, job ``'certify'``) is checked
        against it before any work, and the run stops once it is spent; ``None``: no budget.
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
    if bits is not UNSET:  # the 0.2 spelling
        warn_renamed("bits=", "precision=", "certify_coupled")
        bits = check_count(bits, "bits", max_bits, minimum=MIN_BITS)
    else:
        bits = certified_bits(precision, max_bits, allow_auto=False)
    y0q = check_y0(y0, params)
    check_certifiable(params)
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
    enforce_max_time(
        max_time, "certify", periods=periods, precision=f"mp:{bits}", coupled=y0q is not None
    )
    deadline = Deadline(None if max_time is None else parse_max_time(max_time), "certify")
    bar = Progress(periods, "certified periods (pair)", enabled=progress)
    while True:
        t0 = time.perf_counter()
        try:
            with working_bits(bits):
                if y0q is None:  # the diagonal: the slave is the master, exactly (module docstring)
                    ss, imps, _ = run_balls(params, periods, bits, deadline=deadline)
                    samples = [(n, t, x, v, x, v) for n, t, x, v in ss]
                    mimp = simp = list(imps)
                    bar.update(periods)
                else:
                    samples, mimp, simp = _run(params, kq, form, y0q, periods, bits, bar, deadline)
            bar.close()
            return CertifiedCoupledTrajectory(
                params, form, kq, y0q, periods, bits, samples, mimp, simp, time.perf_counter() - t0
            )
        except BudgetExceededError:
            bar.close()  # end a line redrawn in place before the one-line refusal
            raise
        except CertificationError as e:
            if 2 * bits > max_bits:
                raise CertificationError(f"{e} (and up to max_bits = {max_bits})") from None
            refusal = out_of_reach(e, bits, periods, max_bits)
            if refusal is not None:
                bar.close()
                raise CertificationError(refusal) from None
            bits *= 2


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
