"""How many significant digits a trajectory's samples can claim, and on what basis.

Strongest first: ``"proven"`` (the certified balls), ``"demonstrated"`` (agreement with a run
at higher precision, :func:`demonstrate`) and ``"estimated"`` (one run's rounding amplified by
its tangent flow, :func:`estimate`).  The bound and its constants: ``docs/numerics.rst``,
"Digits a trajectory can claim".
"""

from __future__ import annotations

import dataclasses
import math
from fractions import Fraction
from typing import Any

import mpmath
import numpy as np
from mpmath import libmp

from precise_impact.core.coupling import slave_position_rate, slave_reset, slave_rhs
from precise_impact.core.flight import FLOAT as FLOAT_OPS
from precise_impact.core.flight import (
    NUMPY,
    Flight,
    damped_frequency,
    flow_matrix,
    steady_coefficients,
)
from precise_impact.core.flow import acceleration
from precise_impact.core.impact import oscillator_saltation, saltation_matrix
from precise_impact.core.precision import log10_fraction

__all__ = [
    "Digits",
    "BASES",
    "estimate",
    "estimate_coupled",
    "demonstrate",
    "proven",
    "agreement_digits",
    "max_digits",
    "digits_of",
    "local_error",
    "basis_text",
    "format_claimed",
]

#: The bases, strongest first.
BASES = ("proven", "demonstrated", "estimated")

#: Local error per event, in units of ``max(eps, tol)`` (module docstring).
C_STATE = 8.0
C_TIME = 4.0
#: ngspice's default RELTOL (the netlists keep it): the unit of a ``'spice'`` run's local error.
SPICE_RELTOL = 1e-3
#: Weight rates tried by the Cauchy-Schwarz bound (module docstring); per unit time.
GAMMAS = (0.0, 0.002, 0.01, 0.03)
#: Points per flight of the grid that looks for near-grazing passes.
_GRID = 24
_LN10 = math.log(10.0)


def max_digits(precision: Any) -> int:
    """The most significant digits a number of ``precision`` can claim: ``floor(-log10 eps)``
    (15 for float64, 76 for mp:256)."""
    return int(math.floor((precision.bits - 1) * math.log10(2.0)))


def digits_of(log10_value: float, log10_error: float, cap: int) -> int:
    """``floor(log10 |value| - log10 error)`` clipped to ``[0, cap]`` (logs: any magnitude)."""
    if log10_error == -math.inf:
        return cap
    if log10_value == -math.inf or not math.isfinite(log10_error):
        return 0
    d = math.floor(log10_value - log10_error)
    return int(min(cap, max(0, d)))


def _log10_abs(m: Any) -> float:
    """``log10 |m|`` of an mpmath number of any magnitude (``-inf`` for 0)."""
    if not m:
        return -math.inf
    man, exp = m.man_exp if hasattr(m, "man_exp") else mpmath.mpf(m).man_exp
    man = abs(int(man))
    nb = man.bit_length()
    shift = max(0, nb - 60)
    return (math.log2(man >> shift) + shift + exp) * math.log10(2.0)


def _log10_radius(rad: Any) -> float:
    """``log10 |rad|`` of a radius given as an mpmath number, a Fraction, an int, a float or a
    decimal string, without rounding it at mpmath's (process-global) working precision first
    (mpmath 1.3 cannot make an mpf from a Fraction at all)."""
    if hasattr(rad, "_mpf_"):
        return _log10_abs(rad)
    return log10_fraction(Fraction(rad))


@dataclasses.dataclass
class Digits:
    """The significant digits each sample of a trajectory can claim.

    Attributes
    ----------
    basis : str
        ``'proven'``, ``'demonstrated'`` or ``'estimated'`` (:data:`BASES`).
    x, v : numpy int arrays
        Claimed significant digits of ``x`` and ``v`` at each sample (``0``: none).
    y, w : numpy int arrays or None
        The slave's, for a master-slave pair.
    impacts : dict or None
        ``{"t", "v_before", "v_after"}``: each impact's claimed digits (the estimate of one
        oscillator; ``None`` where not given).
    cap : int
        The most the precision allows (:func:`max_digits`).
    note : str
        How the claim was made (one line).
    reference : str or None
        The second run's precision (``'demonstrated'``).
    """

    basis: str
    x: np.ndarray
    v: np.ndarray
    cap: int
    note: str = ""
    reference: str | None = None
    y: np.ndarray | None = None
    w: np.ndarray | None = None
    impacts: dict | None = None

    def components(self) -> dict[str, np.ndarray]:
        """``{"x": ..., "v": ...}`` and, for a pair, ``"y"``, ``"w"``."""
        out = {"x": self.x, "v": self.v}
        if self.y is not None and self.w is not None:
            out.update(y=self.y, w=self.w)
        return out

    def _least(self) -> np.ndarray:
        return np.minimum.reduce(list(self.components().values()))

    def at(self, k: int) -> int:
        """The digits sample ``k`` claims for every component (the smallest)."""
        return int(self._least()[k])

    @property
    def min(self) -> int:
        return int(self._least().min()) if len(self.x) else self.cap

    @property
    def final(self) -> int:
        return self.at(len(self.x) - 1) if len(self.x) else self.cap

    def first_unclaimed(self) -> int | None:
        """The first sample with a component that claims no digit (``None``: none such)."""
        bad = np.flatnonzero(self._least() <= 0)
        return int(bad[0]) if len(bad) else None

    def summary(self) -> dict:
        """The JSON object beside the samples: basis, note, reference, cap, min, final."""
        return {
            "basis": self.basis,
            "note": self.note,
            "reference": self.reference,
            "max_possible": self.cap,
            "min": self.min,
            "final": self.final,
            "first_unclaimed_period": self.first_unclaimed(),
        }

    def __repr__(self) -> str:
        return (
            f"Digits(basis={self.basis!r}, samples={len(self.x)}, min={self.min}, "
            f"final={self.final}, cap={self.cap})"
        )


# ------------------------------------------------------------------------------ estimate
def local_error(u: float, t: float, x: float, v: float, steps: float, a: float, zeta: float):
    """The local error bound of one event (module docstring), absolute."""
    acc = abs(a) + abs(x) + 2 * zeta * abs(v)  # a < 0 is the forcing's phase: |a| bounds it
    return u * (C_STATE * (steps + 1) * max(1.0, abs(x), abs(v)) + C_TIME * abs(t) * (abs(v) + acc))


def _floats(P: Any, arr: Any) -> np.ndarray:
    if arr is None or len(arr) == 0:
        return np.zeros(0)
    if P.kind == "float64":
        return np.asarray(arr, dtype=float)
    return np.array([P.to_float(z) if z is not None else math.nan for z in arr], dtype=float)


def near_misses(p, starts: np.ndarray, ends: np.ndarray, xs: np.ndarray, vs: np.ndarray):
    """Depth ``x_w - max x`` of each flight ``[starts, ends]`` from ``(xs, vs)`` that turns
    back inside it (``inf`` where none turns back near the wall)."""
    n = len(starts)
    depth = np.full(n, np.inf)
    if n == 0:
        return depth
    eta, zeta, a, x_w = float(p.eta), float(p.zeta), float(p.a), float(p.x_w)
    P_, Q_ = steady_coefficients(eta, zeta, a)
    wd = damped_frequency(zeta, NUMPY)
    frac = (np.arange(1, _GRID) / _GRID)[None, :]
    tg = starts[:, None] + (ends - starts)[:, None] * frac
    with np.errstate(all="ignore"):
        xg, _ = Flight(P_, Q_, eta, zeta, wd, NUMPY, starts[:, None], xs[:, None], vs[:, None]).at(
            tg
        )
    j = np.argmax(xg, axis=1)
    cand = np.flatnonzero(xg[np.arange(n), j] > x_w - 0.1)
    if len(cand) == 0:
        return depth
    t = tg[cand, j[cand]]
    sub = Flight(P_, Q_, eta, zeta, wd, NUMPY, starts[cand], xs[cand], vs[cand])
    for _ in range(30):  # Newton on v = 0 (x's maximum)
        xv, vv = sub.at(t)
        acc = acceleration(t, xv, vv, eta, zeta, a, np.cos)
        with np.errstate(all="ignore"):
            step = np.where(acc < 0, vv / acc, 0.0)
        t = np.clip(t - step, starts[cand], ends[cand])
    xv, vv = sub.at(t)
    acc = acceleration(t, xv, vv, eta, zeta, a, np.cos)
    span = ends[cand] - starts[cand]
    inside = (t > starts[cand] + 1e-9 * span) & (t < ends[cand] - 1e-9 * span) & (acc < 0)
    d = np.where(inside, np.maximum(x_w - xv, 0.0), np.inf)
    depth[cand] = d
    return depth


#: The smallest normal float64: the floor of the unit roundoff the float estimate carries.
_TINY = 2.2250738585072014e-308
#: The most digits an estimate claims: its bounds are float64 numbers, which cannot hold an
#: error below ~1e-300 (mp:4096 claimed its whole 1232-digit cap from bounds that underflowed
#: to 0); a demonstrated or proven claim goes further.
_FLOAT_DIGITS = 300


def _none_claimed(n_s: int, cap: int, reason: str) -> Digits:
    """An estimate that can claim no digit at any of ``n_s`` samples, and why."""
    dx = np.zeros(n_s, int)
    return Digits("estimated", dx, dx.copy(), cap, reason)


#: Why zeta >= 1 claims nothing: the flights' closed form (core.flight) that carries the errors
#: is the underdamped one; a second precision (``demonstrate``) gives digits there.
_OVERDAMPED = (
    "zeta >= 1 (overdamped): no closed-form flight to carry the errors with; "
    "use --demonstrate (a second precision) for digits"
)


def estimate(traj: Any) -> Digits:
    """The digits a single run can claim at each sample (``'estimated'``; module docstring).

    Parameters
    ----------
    traj : Trajectory
        Any single-oscillator trajectory (its params, precision, tol, samples, impacts and
        ``stats['steps']`` when the integrator took steps).

    Returns
    -------
    Digits
    """
    P, p = traj.precision, traj.params
    cap = min(max_digits(P), _FLOAT_DIGITS)  # the estimate is carried in float64
    st = traj.stats if isinstance(traj.stats, dict) else {}
    u = _unit(traj, P, st)
    eta, zeta, a, x_w, R = (float(q) for q in (p.eta, p.zeta, p.a, p.x_w, p.R))
    ts, xs, vs = _floats(P, traj.t), _floats(P, traj.x), _floats(P, traj.v)
    it, ivb, iva = (
        _floats(P, traj.impacts_t),
        _floats(P, traj.impacts_v_before),
        _floats(P, traj.impacts_v_after),
    )
    n_s = len(ts)
    refusal = _refusal(n_s, ivb, zeta, st, cap)
    if refusal is not None:
        return refusal
    wd = damped_frequency(zeta, FLOAT_OPS)
    # events in time order: kind 0 = sample, 1 = impact (an impact at a sample time first)
    times, kinds, index = _event_order(ts, it)
    x_after, v_after, v_before, (f00, f01, f10, f11), depth = _flights(
        p, times, kinds, index, xs, vs, ivb, iva, x_w, zeta, wd
    )
    rate = _step_rate(traj, times[-1] - times[0])
    # Cauchy-Schwarz bounds, one per gamma: G = exp(L) (gxx, gxv, gvv) and S (plain floats:
    # a few microseconds an event)
    bounds = [[0.0, 0.0, 0.0, 0.0, 0.0, gm] for gm in GAMMAS]  # gxx, gxv, gvv, L, S, gamma
    log_ex, log_ev = np.full(n_s, -math.inf), np.full(n_s, -math.inf)
    acc_max = abs(a) + abs(x_w) + 1.0  # a may be negative (the forcing's phase)
    tl = times.tolist()
    kl, il = kinds.tolist(), index.tolist()
    xal, val, vbl = x_after.tolist(), v_after.tolist(), v_before.tolist()
    fl = [z.tolist() for z in (f00, f01, f10, f11)]
    dl = depth.tolist()
    inf = math.inf
    log_it, log_ivb, log_iva = (np.full(len(it), math.inf) for _ in range(3))
    for e in range(len(tl)):
        t = tl[e]
        vb = vbl[e]
        if e > 0:
            dt = tl[e] - tl[e - 1]
            _advance(bounds, fl[0][e - 1], fl[1][e - 1], fl[2][e - 1], fl[3][e - 1], dt)
            delta = local_error(u, t, xal[e], max(abs(vb), abs(val[e])), rate * dt, a, zeta)
            if kl[e] == 1 or dl[e - 1] < inf:
                # the position error bound just before this event (and its own error)
                lex = min(_half_log(b[0], b[3], b[4]) for b in bounds)
                ex = math.exp(min(lex, 700.0))
                acc = acc_max + 2 * zeta * abs(vb)
                jump = (1 + R) * math.sqrt(2 * acc * 2 * ex)
                if kl[e] == 1:
                    j = il[e]
                    log_it[j], log_ivb[j], log_iva[j] = _impact_logs(bounds, lex, t, vb, u, acc, R)
                    if vb * vb <= 2 * acc * 2 * ex:
                        delta += jump  # the impact could vanish
                if dl[e - 1] <= 2 * ex:
                    delta += jump  # a pass near the wall could become an impact
            if kl[e] == 1:  # the impact's saltation matrix after the flight to it
                _saltate(bounds, t, vb, eta, zeta, a, x_w, R)
        else:  # the start: the parameters' exact x0, v0 rounded once to the precision
            delta = _start_error(traj)
        for b in bounds:
            _add_identity(b, delta * delta)
        if kl[e] == 0:
            log_ex[il[e]], log_ev[il[e]] = _sample_logs(bounds)
    impacts = {
        name: _claimed(values, logs, cap)
        for name, values, logs in (("t", it, log_it), ("v_before", ivb, log_ivb),
                                   ("v_after", iva, log_iva))
    }  # fmt: skip
    dx, dv = _claimed(xs, log_ex, cap), _claimed(vs, log_ev, cap)
    note = (
        f"tangent flow along the run (flight flows and saltation matrices), local error "
        f"{C_STATE:g} u (steps + 1) |state| + {C_TIME:g} u |t| |f| per event, u = {u:.3g}"
    )
    return Digits("estimated", dx, dv, cap, note, impacts=impacts)


def _flights(p, times, kinds, index, xs, vs, ivb, iva, x_w, zeta, wd) -> tuple:
    """The state after and ``v`` before each event, the flow matrix and the near-wall depth
    of each flight (event ``e - 1`` to ``e``)."""
    # state just after each event (the start of the next flight) and just before it
    x_after = np.where(kinds == 0, _pick(xs, kinds == 0, index), x_w)
    v_after = np.where(kinds == 0, _pick(vs, kinds == 0, index), _pick(iva, kinds == 1, index))
    v_before = np.where(kinds == 1, _pick(ivb, kinds == 1, index), v_after)
    # flights: event e-1 -> e
    tau = np.diff(times)
    flows = flow_matrix(tau, zeta, wd, NUMPY)
    depth = near_misses(p, times[:-1], times[1:], x_after[:-1], v_after[:-1])
    return x_after, v_after, v_before, flows, depth


def _sample_logs(bounds: list) -> tuple[float, float]:
    """log10 of the smallest ``x`` and ``v`` error bounds over the gammas."""
    return (
        min(_half_log(b[0], b[3], b[4]) for b in bounds) / _LN10,
        min(_half_log(b[2], b[3], b[4]) for b in bounds) / _LN10,
    )


def _step_rate(traj: Any, span: float) -> float:
    """The integrator's steps per unit time (0 without ``stats['steps']``)."""
    steps = float(traj.stats.get("steps", 0) or 0) if isinstance(traj.stats, dict) else 0.0
    return steps / span if span > 0 else 0.0


def _saltate(bounds: list, t: float, vb: float, eta, zeta, a, x_w, R) -> None:
    """Every bound through the oscillator's saltation matrix at the impact ``(t, vb)``."""
    sm: Any
    if vb == 0:
        sm = ((-R, 0.0), (math.inf, -R))
    else:
        sm = oscillator_saltation(t, vb, eta, zeta, a, x_w, R, math.cos)
    _advance(bounds, sm[0][0], sm[0][1], sm[1][0], sm[1][1], 0.0)


def _unit(traj: Any, P: Any, st: dict) -> float:
    """The run's ``u = max(eps, tol)`` (ngspice's RELTOL for ``'spice'``)."""
    # the unit roundoff, floored at the smallest normal float: above ~1020 bits the estimate
    # (carried in float64) claims at most ~300 digits, fewer than the precision holds, never more
    eps = max(float(P.eps_fraction), _TINY)
    tol = traj.tol
    u = eps
    if tol is not None:
        try:
            u = max(eps, float(P.to_float(tol)))
        except (TypeError, ValueError):
            u = eps
    if traj.model == "spice":  # ngspice's steps are accurate to its RELTOL, not to eps
        u = max(u, float(st.get("reltol", SPICE_RELTOL)))
    return u


def _refusal(n_s: int, ivb: np.ndarray, zeta: float, st: dict, cap: int) -> Digits | None:
    """No digit claimed, and why, where the estimate has nothing to go on; else ``None``."""
    if n_s == 0:
        return _none_claimed(0, cap, "no samples")
    if len(ivb) and not np.all(np.isfinite(ivb)):  # impacts without velocities: nothing to go on
        return _none_claimed(
            n_s, cap, "the model records no impact velocities: no digit can be estimated"
        )
    if zeta >= 1:
        return _none_claimed(n_s, cap, _OVERDAMPED)
    if st.get("effects"):  # a circuit's non-idealities: the run realises another system
        return _none_claimed(
            n_s,
            cap,
            f"the circuit's effects ({', '.join(st['effects'])}) change the system the run "
            "realises (params are the nominal design's): use --demonstrate for digits",
        )
    return None


def _event_order(*groups: np.ndarray) -> tuple:
    """The events of all ``groups`` in time order: ``(times, kinds, index)``, kind ``i`` for
    group ``i``, index within it; at equal times the higher kind first."""
    times = np.concatenate(groups)
    kinds = np.concatenate([np.full(len(g), i, int) for i, g in enumerate(groups)])
    index = np.concatenate([np.arange(len(g)) for g in groups])
    order = np.lexsort((-kinds, times))
    return times[order], kinds[order], index[order]


def _impact_logs(bounds: list, lex: float, t: float, vb: float, u: float, acc: float, R: float):
    """Natural logs / ln 10 of an impact's time, ``v-`` and ``v+`` error bounds."""
    # the impact's time and velocities: the position error is a time error
    # ex / |v-|, which moves v- by |acc| ex / |v-|
    lev = min(_half_log(b[2], b[3], b[4]) for b in bounds)
    lt = lex - math.log(abs(vb)) if vb else math.inf
    lt = _log_add(lt, math.log(u * max(abs(t), 1.0)))
    lvb = _log_add(_log_add(lev, math.log(acc) + lt), math.log(u * abs(vb) + 1e-300))
    return lt / _LN10, lvb / _LN10, (lvb + math.log(R)) / _LN10 if R else -math.inf


def _claimed(values: np.ndarray, logs: np.ndarray, cap: int) -> np.ndarray:
    """The digits each value claims against its log10 error bound."""
    return np.array([digits_of(_lg(z), lg, cap) for z, lg in zip(values, logs, strict=True)], int)


def _advance(bounds: list, j00: float, j01: float, j10: float, j11: float, dt: float) -> None:
    """``G <- e^{2 gamma dt} J G J^T``, ``S <- e^{-2 gamma dt} S`` on every bound (rescaled)."""
    inf = math.inf
    for b in bounds:
        gxx, gxv, gvv = b[0], b[1], b[2]
        a0 = j00 * gxx + j01 * gxv
        a1 = j00 * gxv + j01 * gvv
        b0 = j10 * gxx + j11 * gxv
        b1 = j10 * gxv + j11 * gvv
        gxx, gxv, gvv = a0 * j00 + a1 * j01, a0 * j10 + a1 * j11, b0 * j10 + b1 * j11
        tr = gxx + gvv
        if not 1e-100 < tr < 1e100:  # rescale (or give up: infinite / NaN)
            if tr == 0:
                pass
            elif tr < inf:
                gxx, gxv, gvv = gxx / tr, gxv / tr, gvv / tr
                b[3] += math.log(tr)
            else:
                gxx = gxv = gvv = inf
        b[0], b[1], b[2] = gxx, gxv, gvv
        if dt:
            b[3] += 2 * b[5] * dt
            b[4] *= math.exp(-2 * b[5] * dt)


def _log_add(p: float, q: float) -> float:
    """``log(e^p + e^q)`` (either may be ``-inf`` / ``inf``)."""
    if p < q:
        p, q = q, p
    if p == math.inf or q == -math.inf:
        return p
    return p + math.log1p(math.exp(q - p))


def _add_identity(b: list, d2: float) -> None:
    """``G += d2 I`` and ``S += 1`` on a bound ``b = [gxx, gxv, gvv, L, S, gamma]`` kept as
    ``G = e^L g`` (the scale moves to ``d2`` when ``g`` is negligible beside it)."""
    b[4] += 1.0
    if d2 <= 0:
        return
    ld = math.log(d2)
    if ld - b[3] > 600 or b[0] + b[2] == 0:
        f = math.exp(b[3] - ld) if ld - b[3] < 700 else 0.0
        b[0], b[1], b[2], b[3] = b[0] * f, b[1] * f, b[2] * f, ld
    add = math.exp(ld - b[3]) if ld - b[3] > -700 else 0.0
    b[0] += add
    b[2] += add


def _pick(values: np.ndarray, mask: np.ndarray, index: np.ndarray) -> np.ndarray:
    """``values[index]`` where ``mask`` (events of that kind), 0 elsewhere; ``values`` may be
    empty (a run without impacts)."""
    out = np.zeros(len(index))
    out[mask] = values[index[mask]]
    return out


def _half_log(g: float, L: float, S: float) -> float:
    """``log sqrt(g e^L S)`` (``-inf`` for ``g = 0``, ``inf`` for an infinite ``g``)."""
    if g <= 0:
        return -math.inf
    if g == math.inf or g != g:
        return math.inf
    return 0.5 * (math.log(g) + L + math.log(S))


def _start_error(traj: Any) -> float:
    """``|(x0, v0)|``'s rounding to the precision (0 when both are exact)."""
    P, p = traj.precision, traj.params
    err = 0.0
    for q in (p.x0, p.v0):
        err = max(err, abs(float(P.to_fraction(P.from_fraction(q)) - q)))
    return err


def _lg(z: float) -> float:
    return math.log10(abs(z)) if z else -math.inf


# ------------------------------------------------------------------------------ two runs
def agreement_digits(a: Any, pa: Any, b: Any, pb: Any, cap: int) -> int:
    """Significant digits on which ``a`` (of precision ``pa``) and ``b`` (of ``pb``) agree:
    ``floor(log10 |a| - log10 |a - b|)`` in ``[0, cap]`` (exact values, any magnitude)."""
    if a is None or b is None:
        return 0
    ma, mb = pa.to_mpf(a), pb.to_mpf(b)
    if not (mpmath.isfinite(ma) and mpmath.isfinite(mb)):
        return 0
    # the exact difference rounded once, relatively, to 64 bits: its log is right to ~1e-18
    diff = mpmath.mpf(libmp.mpf_sub(ma._mpf_, mb._mpf_, 64, "n"))
    return digits_of(_log10_abs(ma), _log10_abs(diff), cap)


def demonstrate(traj: Any, reference: Any) -> Digits:
    """Digits claimed by agreement with ``reference`` (the same run at a higher precision),
    sample by sample (``'demonstrated'``); a pair's slave ``y, w`` too."""
    P, Q = traj.precision, reference.precision
    cap = max_digits(P)
    n = min(len(traj.x), len(reference.x))
    names = ("x", "v", "y", "w") if hasattr(traj, "y") and hasattr(reference, "y") else ("x", "v")
    out = {}
    for name in names:
        mine, ref = getattr(traj, name), getattr(reference, name)
        d = np.zeros(len(traj.x), int)
        for k in range(n):
            d[k] = agreement_digits(mine[k], P, ref[k], Q, cap)
        out[name] = d
    impacts = None
    if hasattr(traj, "impacts_t") and hasattr(reference, "impacts_t"):
        impacts = _impact_agreement(traj, reference, cap)
    by = getattr(reference, "model", None) or getattr(reference, "stats", {}).get("engine", "")
    note = f"agreement with a second run at {Q.name} ({by}), sample by sample"
    return Digits(
        "demonstrated",
        out["x"],
        out["v"],
        cap,
        note,
        reference=Q.name,
        y=out.get("y"),
        w=out.get("w"),
        impacts=impacts,
    )


def _impact_agreement(traj: Any, reference: Any, cap: int) -> dict:
    """Per-impact agreement of two runs, impact by impact in time order, until the first whose
    time agrees on no digit (from there the two sequences may pair different impacts: 0)."""
    P, Q = traj.precision, reference.precision
    n = len(traj.impacts_t)
    out = {name: np.zeros(n, int) for name in ("t", "v_before", "v_after")}
    for j in range(min(n, len(reference.impacts_t))):
        for name in out:
            attr = "impacts_" + name
            out[name][j] = agreement_digits(
                getattr(traj, attr)[j], P, getattr(reference, attr)[j], Q, cap
            )
        if out["t"][j] == 0:
            for name in out:
                out[name][j:] = 0
            break
    return out


def proven(traj: Any, x_rad: list, v_rad: list, **slave: tuple) -> Digits:
    """Digits every point of the certified balls shares (``'proven'``): radii (decimal strings
    or numbers, rounded up) plus the midpoint's rounding to the precision; a pair passes
    ``y=(mids, radii), w=(mids, radii)``."""
    P = traj.precision
    cap = max_digits(P)
    # log10 of eps exactly: float(eps) underflows to 0 above ~1074 bits (mp:8192 raised
    # "math domain error" in a certified pair's to_dict)
    log_eps = log10_fraction(P.eps_fraction)

    def d(z: Any, rad: Any) -> int:
        m = P.to_mpf(z)
        lv = _log10_abs(m)
        lr = _log10_radius(rad)
        # the midpoint was rounded once to the precision: half an ulp more
        lr = max(lr, lv + log_eps) if lv != -math.inf else lr
        lr = lr + math.log10(2.0) if lr != -math.inf else lr  # radius + rounding <= 2 max
        return digits_of(lv, lr, cap)

    def col(mids: Any, radii: list) -> np.ndarray:
        return np.array([d(z, r) for z, r in zip(mids, radii, strict=True)], dtype=int)

    extra = {n: col(*mr) for n, mr in slave.items()}
    return Digits(
        "proven",
        col(traj.x, x_rad),
        col(traj.v, v_rad),
        cap,
        "radii of the certified balls (python-flint)",
        y=extra.get("y"),
        w=extra.get("w"),
    )


# ------------------------------------------------------------------------------ the pair
def _linear_part(form: str, zeta: float, k: float) -> np.ndarray:
    """``A`` of the pair's flow ``z' = A z + forcing``, ``z = (x, v, y, w)``, read off the one
    home of its equations (:func:`~precise_impact.core.flow.acceleration`,
    :func:`~precise_impact.core.coupling.slave_rhs`) with the forcing switched off."""
    off = lambda _: 0.0  # noqa: E731 - cos of the forcing: 0 leaves the linear part
    A = np.zeros((4, 4))
    for j in range(4):
        z = [0.0] * 4
        z[j] = 1.0
        x, v, y, w = z
        A[:, j] = (v, acceleration(0.0, x, v, 1.0, zeta, 0.0, off)) + slave_rhs(
            form, 0.0, x, v, y, w, 1.0, zeta, 0.0, k, off
        )
    return A


class _Bound:
    """The Cauchy-Schwarz bound of the module docstring in any dimension, one per gamma
    (numpy: the pair's 4 x 4 tangent)."""

    def __init__(self, dim: int) -> None:
        self.gam = np.asarray(GAMMAS)
        ng = len(self.gam)
        self.g = np.zeros((ng, dim, dim))
        self.L = np.zeros(ng)
        self.S = np.zeros(ng)
        self.eye = np.eye(dim)

    def advance(self, J: np.ndarray, dt: float) -> None:
        g = J @ self.g @ J.T
        with np.errstate(all="ignore"):
            tr = np.trace(g, axis1=1, axis2=2)
            bad = ~np.isfinite(tr)
            resc = ~bad & ((tr > 1e100) | ((tr > 0) & (tr < 1e-100)))
            g[resc] /= tr[resc, None, None]
            self.L[resc] += np.log(tr[resc])
            g[bad] = math.inf
        self.g = g
        self.L += 2 * self.gam * dt
        self.S *= np.exp(-2 * self.gam * dt)

    def add(self, d2: float) -> None:
        self.S += 1.0
        if d2 <= 0:
            return
        ld = math.log(d2)
        for i in range(len(self.L)):
            if ld - self.L[i] > 600 or np.trace(self.g[i]) == 0:
                f = math.exp(self.L[i] - ld) if ld - self.L[i] < 700 else 0.0
                self.g[i] *= f
                self.L[i] = ld
            if ld - self.L[i] > -700:
                self.g[i] += math.exp(ld - self.L[i]) * self.eye

    def log10(self, i: int) -> float:
        """``log10`` of the bound on component ``i``."""
        return (
            min(_half_log(float(self.g[j, i, i]), self.L[j], self.S[j]) for j in range(len(self.L)))
            / _LN10
        )


def estimate_coupled(traj: Any) -> Digits:
    """The digits a master-slave pair's run can claim at each sample (``'estimated'``): the
    bound of :func:`estimate` on the pair's 4 x 4 tangent flow -- ``exp(A tau)`` between
    impacts (the flow is linear there) and the saltation matrix
    :func:`~precise_impact.core.impact.saltation_matrix` of the pair at each impact of either
    oscillator.  The master's state at a slave impact comes from its closed-form flight
    (:class:`~precise_impact.core.flight.Flight`).  Near-grazing passes are looked for on the
    master's flights; the slave's impacts slower than its position error count as changes."""
    P, p = traj.precision, traj.params
    cap = min(max_digits(P), _FLOAT_DIGITS)  # the estimate is carried in float64
    u = max(float(P.eps_fraction), _TINY)  # as in estimate
    eta, zeta, a, x_w, R = (float(q) for q in (p.eta, p.zeta, p.a, p.x_w, p.R))
    k, form = float(traj.k), traj.form
    F = {n: _floats(P, getattr(traj, n)) for n in ("t", "x", "v", "y", "w")}
    if zeta >= 1:
        return _none_claimed(len(F["t"]), cap, _OVERDAMPED)
    mt, mvb, mva = (
        _floats(P, getattr(traj, "master_impacts_" + n)) for n in ("t", "v_before", "v_after")
    )
    st, swb, swa, sx = (
        _floats(P, getattr(traj, "slave_impacts_" + n)) for n in ("t", "w_before", "w_after", "x")
    )
    n_s = len(F["t"])
    times, kinds, index = _event_order(F["t"], mt, st)
    A = _linear_part(form, zeta, k)
    lam, V = np.linalg.eig(A)
    Vi = np.linalg.inv(V) if np.linalg.cond(V) < 1e8 else None
    P_, Q_ = steady_coefficients(eta, zeta, a)
    wd = damped_frequency(zeta, FLOAT_OPS)
    depth = _master_depth(p, times, kinds, index, F, mva, x_w)
    rate = _pair_rate(traj, times)
    b = _Bound(4)
    logs = {n: np.full(n_s, -math.inf) for n in ("x", "v", "y", "w")}
    off = lambda _: 0.0  # noqa: E731
    last_m = (times[0] if len(times) else 0.0, float(p.x0), float(p.v0))  # master's last event
    fullscale = abs(a) + abs(x_w) + 1.0
    for e in range(len(times)):
        t, kind, i = float(times[e]), int(kinds[e]), int(index[e])
        if e > 0:
            dt = t - float(times[e - 1])
            J = _pair_flow(A, lam, V, Vi, dt)
            # master's state now (closed-form flight from its last event)
            fl = Flight(P_, Q_, eta, zeta, wd, FLOAT_OPS, *last_m)
            xm, vm = fl.at(t)
            if kind == 1:
                vb, va = float(mvb[i]), float(mva[i])
                J = _master_impact(J, form, t, vb, va, x_w, eta, zeta, a, R, k, off)
                xs, vs, wb = x_w, max(abs(vb), abs(va)), vb
            elif kind == 2:
                wb, wa, xi = float(swb[i]), float(swa[i]), float(sx[i])
                J = _slave_impact(J, form, t, xi, vm, wb, wa, x_w, eta, zeta, a, R, k)
                xs, vs = max(abs(xm), x_w), max(abs(vm), abs(wb), abs(wa))
            else:
                xs = max(abs(F["x"][i]), abs(F["y"][i]))
                vs = max(abs(F["v"][i]), abs(F["w"][i]))
                wb = None
            b.advance(J, dt)
            delta = local_error(u, t, xs, vs, rate * dt + (1 + k) * dt, a, zeta)
            acc = fullscale + 2 * zeta * vs + 2 * k * (fullscale + vs)
            delta = _pair_jumps(b, delta, acc, R, kind, wb, depth[e])
            b.add(delta * delta)
        else:
            b.add(_start_error(traj) ** 2)
        if kind == 0:
            last_m = (t, float(F["x"][i]), float(F["v"][i]))
            for c, n in enumerate(("x", "v", "y", "w")):
                logs[n][i] = b.log10(c)
        elif kind == 1:
            last_m = (t, x_w, float(mva[i]))
    out = {n: _claimed(F[n], logs[n], cap) for n in logs}
    note = (
        "tangent flow of the pair along the run (exp(A tau) between impacts, saltation "
        f"matrices at both oscillators' impacts), local error as for one oscillator, u = {u:.3g}"
    )
    return Digits("estimated", out["x"], out["v"], cap, note, y=out["y"], w=out["w"])


def _pair_rate(traj: Any, times: np.ndarray) -> float:
    """The pair's integrator steps per unit time (0 without ``stats['steps']``)."""
    span = times[-1] - times[0] if len(times) else 0.0
    steps = float((traj.stats or {}).get("steps", 0) or 0)
    return steps / span if span > 0 else 0.0


def _pair_jumps(b: Any, delta: float, acc: float, R: float, kind: int, wb, depth: float) -> float:
    """``delta`` plus the changes of the impact sequence the position errors allow: an impact
    of either oscillator that could vanish, a master's pass near the wall that could hit."""
    for comp, is_imp in ((0, kind == 1), (2, kind == 2)):
        ex = math.exp(min(b.log10(comp) * _LN10, 700.0))
        jump = (1 + R) * math.sqrt(2 * acc * 2 * ex)
        if is_imp and wb is not None and wb * wb <= 2 * acc * 2 * ex:
            delta += jump
        if comp == 0 and depth <= 2 * ex:
            delta += jump
    return delta


def _master_depth(p: Any, times, kinds, index, F: dict, mva, x_w: float) -> np.ndarray:
    """Each event's near-wall depth on the master's flight to it (``inf``: none, or a slave
    event): the master-only segments for the near-grazing passes."""
    msk = kinds != 2
    m_idx = np.flatnonzero(msk)
    mx = np.where(kinds == 0, _pick(F["x"], kinds == 0, index), x_w)
    mv = np.where(kinds == 0, _pick(F["v"], kinds == 0, index), 0.0)
    mv = np.where(kinds == 1, _pick(mva, kinds == 1, index), mv)
    depth_m = near_misses(p, times[m_idx][:-1], times[m_idx][1:], mx[m_idx][:-1], mv[m_idx][:-1])
    depth = np.full(len(times), np.inf)
    depth[m_idx[1:]] = depth_m
    return depth


def _pair_flow(A: np.ndarray, lam, V, Vi, dt: float) -> np.ndarray:
    """``exp(A dt)``: by the eigen-decomposition when well conditioned, else scipy's expm."""
    if Vi is not None:
        J = (V * np.exp(lam * dt)) @ Vi
        return J.real
    import scipy.linalg  # noqa: PLC0415 -- optional: loaded on first use

    return scipy.linalg.expm(A * dt)


def _master_impact(J, form, t, vb, va, x_w, eta, zeta, a, R, k, off) -> np.ndarray:
    """``J`` through the pair's saltation matrix at a master impact (``inf`` at ``vb = 0``)."""
    # the slave's state cancels in f+ - f- (the flow is linear): 0 for both
    fm = [vb, acceleration(t, x_w, vb, eta, zeta, a, math.cos)] + list(
        slave_rhs(form, t, x_w, vb, 0.0, 0.0, eta, zeta, a, k, off)
    )
    fp = [va, acceleration(t, x_w, va, eta, zeta, a, math.cos)] + list(
        slave_rhs(form, t, x_w, va, 0.0, 0.0, eta, zeta, a, k, off)
    )
    jm = [[1.0, 0.0, 0.0, 0.0], [0.0, -R, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]]
    jm.append([0.0, 0.0, 0.0, 1.0])
    S_ = saltation_matrix(jm, fm, fp, [1.0, 0.0, 0.0, 0.0]) if vb else None
    return (np.asarray(S_) if S_ is not None else np.full((4, 4), math.inf)) @ J


def _slave_impact(J, form, t, xi, vm, wb, wa, x_w, eta, zeta, a, R, k) -> np.ndarray:
    """``J`` through the pair's saltation matrix at a slave impact (``inf`` where the slave's
    position does not move)."""
    fm = [vm, acceleration(t, xi, vm, eta, zeta, a, math.cos)] + list(
        slave_rhs(form, t, xi, vm, x_w, wb, eta, zeta, a, k, math.cos)
    )
    fp = fm[:2] + list(slave_rhs(form, t, xi, vm, x_w, wa, eta, zeta, a, k, math.cos))
    h = 1e-7 * max(1.0, abs(xi))  # the reset's x-derivative ('reduced': (1 + R) k)
    dgx = (slave_reset(form, xi + h, wb, R, k, x_w) - slave_reset(form, xi - h, wb, R, k, x_w)) / (
        2 * h
    )
    jac = [[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 1.0, 0], [dgx, 0, 0, -R]]
    rate_y = slave_position_rate(form, xi, x_w, wb, k)
    if rate_y:
        fm[2] = rate_y
        S_ = saltation_matrix(jac, fm, fp, [0.0, 0.0, 1.0, 0.0])
        return np.asarray(S_, dtype=float) @ J
    return np.full((4, 4), math.inf)


# ------------------------------------------------------------------------------ printing
def basis_text(digits: Digits) -> str:
    """The basis in words (``'estimated from the precision and this run's error
    amplification'``, ...)."""
    if digits.basis == "demonstrated":
        return f"demonstrated by a second run at {digits.reference}"
    if digits.basis == "proven":
        return "proven by the certified balls"
    return "estimated from the precision and this run's error amplification"


def format_claimed(precision: Any, value: Any, n: int, unclaimed: int = 3) -> str:
    """``value`` to its ``n`` claimed significant digits; with none claimed, ``unclaimed``
    digits followed by ``' (no digit claimed)'``."""
    m = precision.to_mpf(value)
    if n <= 0:
        return f"{mpmath.nstr(m, unclaimed, strip_zeros=False)} (no digit claimed)"
    return mpmath.nstr(m, n, strip_zeros=False)
