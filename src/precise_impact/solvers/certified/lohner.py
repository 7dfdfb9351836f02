"""Lohner-type enclosures through impacts: the certified state as ``m + B r``.

The interval scheme wraps its box every period (0.26 digits per period at eta = 0.712 against the
true 0.116); here the state is mapped by the mean-value form with a QR frame (Lohner's QR
variant, as in CAPD's C^0/C^1 Lohner algorithm).  The steps: ``docs/numerics.rst``,
"Certified trajectories".
"""

from __future__ import annotations

import math

import numpy as np

from precise_impact.core import flight
from precise_impact.core.flow import acceleration
from precise_impact.core.linalg import gram_schmidt2
from precise_impact.core.params import Params
from precise_impact.errors import CertificationError
from precise_impact.solvers.certified.single import (
    Constants,
    Flight,
    Isolator,
    _Engine,
    log10_abs,
    period_jacobian,
)
from precise_impact.solvers.certified.single import _flint as _single_flint

__all__ = [
    "LOW_BITS",
    "LohnerEngine",
    "qr_frame",
    "reframe",
    "box_frame",
    "hull",
    "interval_is_tighter",
]

#: Bits of the low pass (impact isolation and Jacobian over the box), doubled on a failure up
#: to the working bits: its balls multiply ``r``, so their width only enters relative to it.
LOW_BITS = 128
#: The low pass's scan step, a fraction of the forcing period (measured: 8 is ~25% cheaper
#: than the interval scheme's 16 at eta = 0.712).
LOW_STEPS = 8


_FLINT: list = []


def _flint():
    """python-flint (imported once; a missing one is refused by the certified engine first)."""
    if not _FLINT:
        _FLINT.append(_single_flint())
    return _FLINT[0]


def _cos(x):
    return x.cos()


def _eye(n: int):
    flint = _flint()
    E = flint.arb_mat(n, n)
    for i in range(n):
        E[i, i] = flint.arb(1)
    return E


def _mv(A, r: list) -> list:
    """``A r`` for an ``arb_mat`` ``A`` and a list of balls ``r`` (a list of balls)."""
    zero = _flint().arb(0)
    n = len(r)
    return [sum((A[i, j] * r[j] for j in range(n)), zero) for i in range(A.nrows())]


def box_frame(balls: list) -> tuple[list, object, list]:
    """``(m, B, r)`` of a box of balls: exact midpoints, ``B = I``, ``r`` the centred balls
    ``[-rad, rad]`` (a run's start, and a restart from a tighter interval image)."""
    flint = _flint()
    m = [flint.arb(b.mid()) for b in balls]
    return m, _eye(len(balls)), [b - mb for b, mb in zip(balls, m, strict=True)]


def hull(m: list, B, r: list, bits: int) -> list:
    """The balls holding ``m + B r``, at ``bits`` (the low pass's precision): the low pass then
    runs on 128-bit numbers, not on the working bits' long midpoints (measured: summing at
    1344 bits made 3000 periods at eta = 0.712 18 % slower); the wider hull (``2^-bits``
    relative) only widens the Jacobian's and the low balls' enclosures, which multiply ``r``
    or are intersected with the Lohner balls."""
    with _Prec(bits):
        Br = _mv(B, r)
        return [a + b for a, b in zip(m, Br, strict=True)]


def interval_is_tighter(interval: list, lohner: list) -> bool:
    """Whether the interval scheme's image of the box (the low pass's balls) is tighter than
    the Lohner image ``P(m) + ([DP] B) r`` in every component: the frame then restarts from
    the sample's balls (:func:`box_frame`)."""
    return max(b.rad() for b in interval) < max(b.rad() for b in lohner)


def reframe(MB, r: list, y: list, bits: int) -> tuple[list, object, list]:
    """Lohner's QR step: from ``P(X) in y + (MB) r`` (``y`` the point image's balls at the
    working bits, ``MB = [DP] B`` an ``arb_mat``) the new ``(m', B', r')`` with ``m' =
    mid(y)``, ``B' = Q`` (:func:`qr_frame`) and ``r' = (Q^-1 MB) r + Q^-1 (y - m')``, the
    products at ``bits``."""
    flint = _flint()
    m = [flint.arb(b.mid()) for b in y]
    e = [b - mb for b, mb in zip(y, m, strict=True)]
    with _Prec(bits):
        Q, Qi = qr_frame(MB, r)
        N = Qi * MB
        r = [a + b for a, b in zip(_mv(N, r), _mv(Qi, e), strict=True)]
    return m, Q, r


class _Prec:
    """``with _Prec(bits):`` python-flint at ``bits`` (the caller holds the engine's lock)."""

    def __init__(self, bits: int) -> None:
        self.bits = bits

    def __enter__(self):
        flint = _flint()
        self.old = flint.ctx.prec
        flint.ctx.prec = self.bits

    def __exit__(self, *exc) -> None:
        _flint().ctx.prec = self.old


def _low_isolator_base():
    return Isolator


class _LowIsolator(_low_isolator_base()):  # type: ignore[misc]
    """The low pass's isolation: as :class:`~precise_impact.solvers.certified.single.Isolator`,
    its interval Newton started from a bracket of ~1e-11 found by float64 Newton on the
    flight's midpoint (:mod:`precise_impact.core.flight` in float64) and proven
    by one interval Newton step landing inside it; ~4 fewer ball iterations an impact."""

    def newton(self, gap, a, b):
        flint = _flint()
        F = gap.__self__
        c = F.c
        P, Q, eta, zeta, wd, xw = (float(q.mid()) for q in (c.P, c.Q, c.eta, c.zeta, c.w, c.xw))
        y, u, s0 = float(F.y.mid()), float(F.u.mid()), float(F.s.mid())
        lo, hi = float(a.mid()), float(b.mid())
        t = 0.5 * (lo + hi)
        for _ in range(8):
            (p00, p01, p10, p11), _ = flight.flow_and_decay(t - s0, zeta, wd, flight.FLOAT)
            xp, vp = flight.forced_response(t, P, Q, eta, flight.FLOAT)
            g, v = xp + p00 * y + p01 * u - xw, vp + p10 * y + p11 * u
            if not v > 0:
                return super().newton(gap, a, b)
            step = g / v
            t -= step
            if abs(step) < 1e-15 * (1 + abs(t)):
                break
        h = 1e-11 * (1 + abs(t))
        if not lo < t - h < t + h < hi:
            return super().newton(gap, a, b)
        m = flint.arb(t)
        Jd = m + flint.arb(0, h)
        gm, _ = gap(m)
        _, d = gap(Jd)
        N = m - gm / d
        if d > 0 and N.lower() > Jd.lower() and N.upper() < Jd.upper():
            # a root in N (existence); the caller proved g' > 0 on [a, b] (uniqueness)
            return super().newton(gap, flint.arb(N.lower()), flint.arb(N.upper()))
        return super().newton(gap, a, b)


class LohnerEngine:
    """One certified run as ``m + B r`` (module docstring), at ``bits`` (the caller holds
    :class:`~precise_impact.solvers.certified.single.working_bits` at ``bits``).

    Parameters
    ----------
    params : Params
        The system and initial condition.
    bits : int
        Working precision of the point pass and the samples.
    """

    def __init__(self, params: Params, bits: int) -> None:
        self.p, self.bits = params, bits
        self.c = Constants(params, bits)
        self.iso = Isolator(bits)
        self._Engine = _Engine
        self._low: dict = {}  # bits -> _Engine at those bits

    def _low_engine(self, bits: int):
        if bits not in self._low:
            with _Prec(bits):
                eng = self._low[bits] = self._Engine(self.p, bits)
                eng.steps_per_period = LOW_STEPS
                eng.iso = _LowIsolator(bits)
        return self._low[bits]

    def _point_impact(self, fl, J):
        """The impact time of the point flight ``fl`` (at the working bits) inside ``J``, the
        low pass's ball (which proves one transversal crossing in it for every state of the
        box): Newton on midpoints at doubling precision from ``mid J`` to half the bits, then
        one interval Newton step at the working bits over ``s +- delta`` that must land inside
        it (existence; uniqueness is the low pass's ``g' > 0`` on ``J``) and doubles the
        digits; failing that, interval Newton over all of ``J``."""
        flint = _flint()
        bits = self.bits
        s = flint.arb(J.mid())
        half = bits // 2 + 64
        lr = log10_abs(J.rad())  # -inf for an exact point
        prec = max(32, int(-lr * 3.32) - 8) if math.isfinite(lr) else bits  # bits of mid J right
        while prec < half:
            prec = min(2 * prec - 8, half)
            with _Prec(prec + 16):
                g, v = fl.gap(s)
                s = flint.arb((s - g / v).mid())
        delta = flint.arb(2) ** (48 - half) * (1 + abs(s))
        Jd = s + flint.arb(0, delta.upper())  # [s - delta, s + delta]
        g, _ = fl.gap(s)
        with _Prec(half + 64):
            _, d = fl.gap(Jd)
        N = s - g / d
        if d > 0 and N.lower() > Jd.lower() and N.upper() < Jd.upper() and J.contains(N):
            return N
        return self.iso.newton(fl.gap, flint.arb(J.lower()), flint.arb(J.upper()))

    def run(self, periods: int, progress=None, deadline=None):
        """``(samples, impacts)`` as :meth:`precise_impact.solvers.certified.single._Engine.run`
        (a :class:`CertificationError` carries the samples proven before it as ``partial``)."""
        samples: list = []
        impacts: list = []
        try:
            self._run(periods, progress, deadline, samples, impacts)
        except CertificationError as e:
            e.partial = samples
            raise
        return samples, impacts

    def _low_pass(self, k: int, m, B, r):
        """The interval scheme over period ``k + 1`` from the hull of ``m + B r``: its engine's
        constants, impacts and end balls, at the fewest bits (from :data:`LOW_BITS`) that prove
        it."""
        lo = min(self.bits, LOW_BITS)
        while True:
            eng = self._low_engine(lo)
            try:
                box = hull(m, B, r, lo)
                with _Prec(lo):
                    samples, impacts = eng.run(1, start=(box[0], box[1]), k0=k)
                return eng.c, impacts, samples[-1]
            except CertificationError:
                if lo >= self.bits:
                    raise
                lo = min(2 * lo, self.bits)

    def _run(self, periods: int, progress, deadline, samples: list, impacts: list) -> None:
        flint = _flint()
        c = self.c
        # the first period by the interval scheme from the exact start (it handles a start on
        # the wall); from its sample on, m + B r
        first = self._Engine(self.p, self.bits)
        s0, imp0 = first.run(1)
        samples.extend(s0)
        impacts.extend(imp0)
        if progress is not None:
            progress.update(1)
        if deadline is not None:
            deadline.check(f"1 of {periods} periods at {self.bits} bits")
        m, B, r = box_frame(list(s0[-1][2:]))
        for k in range(1, periods):
            cl, limps, (_, _, xl, vl) = self._low_pass(k, m, B, r)
            lo = flint.ctx.prec
            with _Prec(cl.bits):
                # Jacobian of the period's map over the box, and of each impact's (t, v-)
                pre: list = []
                tk, tk1 = cl.t0 + k * cl.T, cl.t0 + (k + 1) * cl.T
                MB = flint.arb_mat(period_jacobian(cl, tk, limps, tk1, pre)) * B
                grads = []
                for (J, vb, _), P in zip(limps, pre, strict=True):
                    PB = flint.arb_mat(P) * B
                    acc = acceleration(J, cl.xw, vb, cl.eta, cl.zeta, cl.a, _cos)  # on the wall
                    ds = [-PB[0, 0] / vb, -PB[0, 1] / vb]  # grad of the impact time
                    dv = [PB[1, 0] + acc * ds[0], PB[1, 1] + acc * ds[1]]  # of v- on the wall
                    grads.append((sum_dot(ds, r), sum_dot(dv, r)))
                Mr = _mv(MB, r)
            assert flint.ctx.prec == lo
            # the point pass from m at the working bits, impacts narrowed inside the low balls
            fl = _flight(c, c.t0 + k * c.T, m[0], m[1])
            for (J, vbl, _), (dsr, dvr) in zip(limps, grads, strict=True):
                s = self._point_impact(fl, J)
                _, vb = fl.at(s)
                va = -c.R * vb
                # the box's impact: s(m) + grad s . B r, intersected with the low ball
                st = (s + dsr).intersection(J)
                vbt = (vb + dvr).intersection(vbl)
                impacts.append((st, vbt, -c.R * vbt))
                fl = _flight(c, s, c.xw, va)
            tk1 = c.t0 + (k + 1) * c.T
            y = fl.at(tk1)
            lohner = [y[0] + Mr[0], y[1] + Mr[1]]
            xs, vs = lohner[0].intersection(xl), lohner[1].intersection(vl)
            samples.append((k + 1, tk1, xs, vs))
            if interval_is_tighter([xl, vl], lohner):
                m, B, r = box_frame([xs, vs])
            else:
                m, B, r = reframe(MB, r, list(y), cl.bits)
            if progress is not None:
                progress.update(k + 1)
            if deadline is not None:
                deadline.check(f"{k + 1} of {periods} periods at {self.bits} bits")


def sum_dot(g, r):
    return g[0] * r[0] + g[1] * r[1]


def _flight(c, s, x, v):
    return Flight(c, s, x, v)


def qr_frame(MB, r):
    """Lohner's frame: ``(Q, Q^-1)`` as python-flint ``arb_mat``, ``Q`` exact points from the
    QR factorisation of ``mid(MB)`` (an ``arb_mat``) with its columns ordered by their share
    of the box ``r`` (``|column j| rad r_j``, the largest first), ``Q^-1`` enclosed (at the
    current precision).  n = 2 (the single oscillator) by the package's one tangent-space QR
    (:func:`precise_impact.core.linalg.gram_schmidt2`, 20x cheaper than numpy's call here),
    n = 4 (the pair) by numpy's Householder QR."""
    flint = _flint()
    n = MB.nrows()
    A = [[float(MB[i, j].mid()) for j in range(n)] for i in range(n)]
    w = [
        0.5 * math.log10(sum(A[i][j] ** 2 for i in range(n)) or 1e-300) + log10_abs(r[j].rad())
        for j in range(n)
    ]
    order = sorted(range(n), key=lambda j: -w[j])
    if n == 2:
        i, j = order
        q0, q1, u0, u1, _, _ = gram_schmidt2(A[0][i], A[1][i], A[0][j], A[1][j])
        Qf = [[q0, u0], [q1, u1]]
    else:
        Qf = np.linalg.qr(np.array(A)[:, order])[0].tolist()
    if not all(math.isfinite(q) for row in Qf for q in row):  # pragma: no cover - overflow
        Qf = [[float(i == j) for j in range(n)] for i in range(n)]
    Q = flint.arb_mat([[float(Qf[i][j]) for j in range(n)] for i in range(n)])
    return Q, Q.inv()
