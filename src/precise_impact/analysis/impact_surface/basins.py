"""Domains of attraction on the impact surface or the stroboscopic section.

Each grid point runs on the fast engine to its attractor and is labelled (periodic orbit,
sticking, non-impacting, chaos, unresolved); boundary cells can be refined (``subgrid``).  The
rules: ``docs/guide/basins.rst``, "Domains of attraction".
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import math
import os
from collections.abc import Callable
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.analysis.orbits.newton import find_orbit
from precise_impact.analysis.periodicity import detect_period
from precise_impact.analysis.scan import NpzTileStore, check_workers, run_scan
from precise_impact.core.budget import check_work
from precise_impact.core.impact import (
    chatter_accumulation_time,
    release_time,
    reset_velocity,
    wall_acceleration,
)
from precise_impact.core.params import Params, check_count, exact, params_or_values
from precise_impact.core.result import ResultMixin
from precise_impact.core.stats import lle_stderr
from precise_impact.errors import ConvergenceError, IntegrationError, ParameterError, check_type
from precise_impact.io.figures import finish, new_figure
from precise_impact.io.progress import ProgressArg

__all__ = [
    "BASIN_KINDS",
    "SAME_ORBIT",
    "SECTIONS",
    "BasinsResult",
    "basins",
    "clear_caches",
    "point_attractor",
    "same_impact",
]

#: The sections a map can be drawn on.
SECTIONS = ("impact", "stroboscopic")

#: Kind codes of a point's attractor.
BASIN_KINDS = {
    0: "outside",  # a stroboscopic start beyond the wall (x > x_w)
    1: "periodic",
    2: "non-impacting",
    3: "chatter + sticking",
    4: "chaotic",
    5: "unresolved",
    6: "grazing contact",
}
_OUTSIDE, _PERIODIC, _NONIMP, _CHATTER, _CHAOS, _UNRESOLVED, _GRAZING = range(7)
_STABILITY = ("stable", "unstable", "elliptic", "parabolic")

#: Per-point fields of a tile (one value per point).
FIELDS = ("kind", "impacts", "period", "stability", "lle", "rep_phase", "rep_v", "stuck", "capture")

#: Seconds per forcing period of one start, classification included: measured on this
#: project's 2-core machine (eta = 0.74, grid 30 x 30 on phase 0..1, v 0..3, transient 200,
#: one worker, warm): 1.52 s for 900 points, 6.8 us per period of ``transient + 3 max_period``;
#: a 1000 x 1000 grid under load 270000 points in 588 s, 8.8 us; priced at 10 us (the
#: refinement of the boundary comes on top; the old figure, 1 us, was 9x under).
SECONDS_PER_PERIOD = 1e-5
#: Bytes held per grid point: the :data:`FIELDS` and the label (8 bytes each), the tile's
#: copy of them and the coordinates: priced at 3 x (9 + 1) x 8 = 240.
BYTES_PER_POINT = 240.0

#: Relative agreement of two refined orbits' representative impacts taken as the same orbit
#: (Newton leaves them at rounding level, ~1e-14; distinct orbits are far apart).
SAME_ORBIT = 1e-7

#: No log of refined flights (the compiled strobe's ``rlog`` with no room: counted only).
_NO_LOG = np.empty((0, 4))


# ------------------------------------------------------------------ one point
def _floats(params: Params) -> tuple[float, float, float, float, float]:
    return tuple(float(getattr(params, k)) for k in ("eta", "zeta", "a", "x_w", "R"))  # type: ignore[return-value]


def _strobe(pars, t, x, v, n, max_impacts):
    """``n`` stroboscopic periods from ``(x, v)`` at ``t`` (retrying with a larger impact store)."""
    from precise_impact.solvers.fast.single import strobe  # noqa: PLC0415 -- heavy: numba, loaded on first use

    eta, zeta, a, xw, R = pars
    cap = 256 + 4 * n
    while True:
        it, iv = np.empty(cap), np.empty(cap)
        xs, vs, ts = np.empty(n + 1), np.empty(n + 1), np.empty(n + 1)
        st, ni, k, _ = strobe(
            eta, zeta, a, xw, R, t, x, v, n, 1, max_impacts, it, iv, xs, vs, ts, _NO_LOG
        )
        if ni <= cap:
            return int(st), int(ni), int(k), it[:ni], iv[:ni], xs[: k + 1], vs[: k + 1], ts[: k + 1]
        cap = 2 * ni


def _phase(t: float, eta: float) -> float:
    return (eta * t / (2 * math.pi)) % 1.0


def _sticks(pars, it, iv) -> bool:
    """The contact rule: the last impacts' speeds fall by ``R`` each (a chatter sequence) and the
    wall force pushes into the wall at the last one."""
    eta, zeta, a, xw, R = pars
    if len(iv) < 3 or not R < 1:
        return False
    g = wall_acceleration(it[-1], eta, zeta, a, xw, math.cos)
    r = iv[-3:]
    return bool(g > 0 and r[-1] < 1e-4 * max(1.0, abs(a), abs(xw)) and r[-1] < r[-2] < r[-3])


def _release(pars, t_last: float, v_last: float) -> float | None:
    """Time the mass leaves the wall after the chatter ending at ``(t_last, v_last)``."""
    eta, zeta, a, xw, R = pars
    g = wall_acceleration(t_last, eta, zeta, a, xw, math.cos)
    t_acc = chatter_accumulation_time(t_last, v_last, R, g)
    s = release_time(
        Fraction(t_acc), Fraction(eta), Fraction(a), Fraction(xw)
    )  # exact inputs, mp closed form
    return None if s is None else float(s)


@dataclasses.dataclass
class _Cache:
    """Per process: the refined orbits seen (to skip Newton for a cycle seen before) and the
    release state's attractor."""

    orbits: list = dataclasses.field(default_factory=list)
    release: dict = dataclasses.field(default_factory=dict)


_CACHES: dict = {}


def _cache(pars) -> _Cache:
    return _CACHES.setdefault(pars, _Cache())


def _impacts_of_cycle(pars, t, x, v, p):
    """Impacts of ``p`` periods from ``(x, v)`` at ``t``: ``(m, phase, v)`` of the fastest."""
    st, ni, k, it, iv, *_ = _strobe(pars, t, x, v, p, 10**6)
    if st != 0 or ni == 0:
        return ni, math.nan, math.nan
    j = int(np.argmax(iv))
    return ni, _phase(float(it[j]), pars[0]), float(iv[j])


def _least_period(pars, t, x, v, p) -> int:
    """The least period ``d | p`` of the refined orbit through ``(x, v)`` at ``t``: Newton on
    ``P^p`` also converges to an orbit of a period dividing ``p`` (a slowly spiralling
    transient can look like period ``p`` to the cycle detection); to ``1e-9`` relative (Newton
    leaves the orbit at rounding level, ~1e-15)."""
    for d in range(1, p):
        if p % d:
            continue
        st, _, _, _, _, xs, vs, _ = _strobe(pars, t, x, v, d, 10**6)
        if st == 0 and abs(xs[-1] - x) + abs(vs[-1] - v) <= 1e-9 * (1 + abs(x) + abs(v)):
            return d
    return p


def _periodic(pars, t, x, v, p) -> tuple:
    """Refine the cycle through ``(x, v)`` at ``t`` by Newton; its row."""
    eta, zeta, a, xw, R = pars
    m0, ph0, v0 = _impacts_of_cycle(pars, t, x, v, p)
    if m0 == 0:
        return (_NONIMP, 0, p, 0, -zeta, math.nan, math.nan)
    cache = _cache(pars)
    for row in cache.orbits:  # the same cycle refined before (in this process)
        if row[1] == m0 and row[2] == p and same_impact(row[5], row[6], ph0, v0, 1e-5):
            return row
    try:
        params = Params.make(
            eta=Fraction(eta), zeta=Fraction(zeta), a=Fraction(a), x_w=Fraction(xw),
            R=Fraction(R), t0=Fraction(t), x0=Fraction(x), v0=Fraction(v),
        )  # fmt: skip
        orb = find_orbit(params, p, guess=(x, v))
    except (ConvergenceError, IntegrationError, ParameterError):
        return (_UNRESOLVED, m0, p, 0, math.nan, ph0, v0)
    p = _least_period(pars, t, orb.x, orb.v, p)
    m, ph, vr = _impacts_of_cycle(pars, t, orb.x, orb.v, p)
    if m == 0:
        return (_NONIMP, 0, p, 0, -zeta, math.nan, math.nan)
    row = (_PERIODIC, m, p, _STABILITY.index(orb.stability), float(orb.lle), ph, vr)
    cache.orbits.append(row)
    return row


def same_impact(ph1: float, v1: float, ph2: float, v2: float, tol: float = SAME_ORBIT) -> bool:
    """Whether two impacts ``(phase, v)`` are the same point of the impact surface to ``tol``.

    Parameters
    ----------
    ph1, v1, ph2, v2 : float
        The phases (in [0, 1), compared on the circle) and incoming speeds.
    tol : float, default :data:`SAME_ORBIT`
        Phase distance and relative speed difference allowed.

    Returns
    -------
    bool

    See Also
    --------
    basins : labels periodic orbits by their fastest impact with this test.

    Examples
    --------
    >>> from precise_impact.analysis.impact_surface.basins import same_impact
    >>> same_impact(0.999999999, 1.0, 1e-9, 1.0), same_impact(0.2, 1.0, 0.3, 1.0)
    (True, False)
    """
    d = abs(ph1 - ph2)
    return min(d, 1 - d) <= tol and abs(v1 - v2) <= tol * (1 + abs(v1))


def clear_caches() -> None:
    """Forget the periodic orbits refined and the release states' attractors of this process.

    :func:`basins` refines a cycle by Newton once per process and reuses it for every start
    whose cycle has the same impacts; clearing makes the next identifications from scratch
    (an independent check).

    See Also
    --------
    point_attractor : one start, identified after a clear from scratch.

    Examples
    --------
    >>> from precise_impact.analysis.impact_surface.basins import clear_caches
    >>> clear_caches()
    """
    _CACHES.clear()


def _chaos(pars, t, x, v, periods: int) -> tuple:
    from precise_impact.solvers.fast.lle import lle_batch_serial  # noqa: PLC0415 -- heavy: numba, loaded on first use

    blocks = 10
    status, log1, _, imps, bsums, *_ = lle_batch_serial(
        np.array([pars]), np.array([[t, x, v]]), periods, 0, blocks, 10**9, 1
    )
    T = 2 * math.pi / pars[0]
    if int(status[0]) != 0:
        return (_UNRESOLVED, 0, 0, 0, math.nan, math.nan, math.nan)
    lle = float(log1[0]) / (periods * T)
    per_block = np.asarray(bsums[0], dtype=float) / ((periods // blocks) * T)
    # floored at the sum's rounding
    err = lle_stderr(per_block, lle, periods + float(imps[0]), time=periods * T)
    kind = _CHAOS if lle > 0 and lle > 3 * err else _UNRESOLVED
    return (kind, 0, 0, 0, lle, math.nan, math.nan)


def _run(pars, t, x, v, transient, max_period, chaos_periods, may_stick=True):
    """``(row, stuck, capture)`` of the attractor from ``(x, v)`` at ``t`` (after any impact
    reset); ``may_stick=False`` is the release state's own run (sticking again: chatter)."""
    T = 2 * math.pi / pars[0]
    n = transient + 3 * max_period
    st, ni, k, it, iv, xs, vs, ts = _strobe(pars, t, x, v, n, 10**3 * n)
    if st in (1, 2) and _sticks(pars, it, iv):
        if not may_stick:
            return (_CHATTER, 0, 0, 0, math.nan, _phase(float(it[-1]), pars[0]), 0.0), 1, ni
        row = _release_attractor(pars, transient, max_period, chaos_periods)
        return row, 1, ni
    if st != 0:
        return (_GRAZING, 0, 0, 0, math.nan, math.nan, math.nan), 0, -1
    p = detect_period(xs[-3 * max_period :], vs[-3 * max_period :], max_period)
    t_end = float(ts[-1])
    if p > 0:
        return _periodic(pars, t_end, float(xs[-1]), float(vs[-1]), p), 0, -1
    del T
    return _chaos(pars, t_end, float(xs[-1]), float(vs[-1]), chaos_periods), 0, -1


def _release_attractor(pars, transient, max_period, chaos_periods) -> tuple:
    """The attractor of every start that sticks: from the release state ``(x_w, 0)``."""
    key = (transient, max_period, chaos_periods)
    cache = _cache(pars).release
    if key not in cache:
        eta, zeta, a, xw, R = pars
        s = release_time(Fraction(0), Fraction(eta), Fraction(a), Fraction(xw))
        if s is None:  # the wall force never turns away: stuck for good
            cache[key] = (_CHATTER, 0, 0, 0, math.nan, math.nan, 0.0)
        else:
            t, x, v = _leave_wall(pars, float(s))
            row, _, _ = _run(pars, t, x, v, transient, max_period, chaos_periods, False)
            cache[key] = row
    return cache[key]


def _leave_wall(pars, s: float) -> tuple[float, float, float]:
    """The state a short time ``h`` after release at ``s`` from rest on the wall, by Taylor's
    series: there ``x' = x'' = 0``, ``x''' = G'(s)``, ``x'''' = G''(s) - 2 zeta G'(s)`` with
    ``G = a cos(eta t) - x_w`` (the fast engine cannot start on a tangential contact).  With
    ``h = T / 1000`` the neglected fifth-order term is ``~(eta h)^5 / 120 ~ 1e-14``."""
    eta, zeta, a, xw, R = pars
    h = 2 * math.pi / eta / 1000
    g1 = -a * eta * math.sin(eta * s)
    g2 = -a * eta * eta * math.cos(eta * s) - 2 * zeta * g1
    x = xw + g1 * h**3 / 6 + g2 * h**4 / 24
    v = g1 * h**2 / 2 + g2 * h**3 / 6
    return s + h, min(x, xw), v


def point_attractor(
    params: Any,
    section: str,
    u: float,
    v: float,
    *,
    transient: int = 200,
    max_period: int = 16,
    chaos_periods: int = 1000,
) -> dict:
    """The attractor one start of a domain map goes to.

    Parameters
    ----------
    params : Params or mapping
        The system (``t0``: the stroboscopic section's time).
    section : ``'impact'`` or ``'stroboscopic'``
        ``'impact'``: ``(u, v) = (phase, v)``, an impact at time ``phase 2 pi / eta`` with
        incoming speed ``v > 0`` (the state after it is ``(x_w, -R v)``); ``'stroboscopic'``:
        ``(u, v) = (x, v)`` at ``t0`` (``x > x_w`` is outside).
    u, v : float
        The start.
    transient : int, default 200
        Forcing periods run before the attractor is identified.
    max_period : int, default 16
        Longest period looked for.
    chaos_periods : int, default 1000
        Periods of the LLE of a start without a period.

    Returns
    -------
    dict
        ``kind`` (a value of :data:`BASIN_KINDS`), ``impacts``, ``period``, ``stability``,
        ``lle``, ``rep_phase``, ``rep_v`` (the orbit's fastest impact), ``stuck`` (the start
        sticks to the wall on the way), ``capture`` (impacts before it sticks, -1: never).

    See Also
    --------
    basins : the map of many starts.
    precise_impact.analysis.orbits.newton.find_orbit : the Newton refinement of a cycle.

    Examples
    --------
    >>> import precise_impact as pi
    >>> from precise_impact.analysis.impact_surface.basins import point_attractor
    >>> p = pi.Params.make(eta="4.85", zeta=0, R="0.5", x_w="-0.3", x0="-0.5")
    >>> point_attractor(p, "impact", 0.3, 0.2)["kind"]
    'chatter + sticking'
    """
    params = params_or_values(params, {})
    if not isinstance(section, str) or section not in SECTIONS:
        raise ParameterError("section", str(section)[:40], "'impact' or 'stroboscopic'")
    u, v = exact("u", u), exact("v", v)
    if section == "impact" and not (0 <= u <= 1 and 0 < v <= 10**6):
        raise ParameterError("u, v", f"{float(u):g}, {float(v):g}", "0 <= u <= 1, 0 < v <= 1e6")
    if not (abs(u) <= 10**6 and abs(v) <= 10**6):
        raise ParameterError("u, v", f"{float(u):g}, {float(v):g}", "|u|, |v| <= 1e6")
    pars = _floats(params)
    row, stuck, capture = _point(
        pars, float(params.t0), section, float(u), float(v), transient, max_period, chaos_periods
    )
    return _row_dict(row, stuck, capture)


def _row_dict(row, stuck, capture) -> dict:
    kind, m, p, stab, lle, ph, vr = row
    return {
        "kind": BASIN_KINDS[int(kind)],
        "impacts": int(m),
        "period": int(p),
        "stability": _STABILITY[int(stab)] if kind == _PERIODIC else None,
        "lle": float(lle),
        "rep_phase": float(ph),
        "rep_v": float(vr),
        "stuck": bool(stuck),
        "capture": int(capture),
    }


def _point(pars, t0, section, u, v, transient, max_period, chaos_periods):
    eta, zeta, a, xw, R = pars
    if section == "impact":
        t = u * 2 * math.pi / eta
        x, vel = xw, reset_velocity(v, R)
    else:
        if u > xw:
            return (_OUTSIDE, 0, 0, 0, math.nan, math.nan, math.nan), 0, -1
        t, x, vel = t0, u, v
        if u == xw and v > 0:
            vel = reset_velocity(v, R)
    return _run(pars, t, x, vel, transient, max_period, chaos_periods)


# ------------------------------------------------------------------ the tiles
@dataclasses.dataclass(frozen=True)
class _Spec:
    pars: tuple
    t0: float
    section: str
    axes: tuple  # ((name, start, stop, n), (name, start, stop, n))
    transient: int
    max_period: int
    chaos_periods: int

    @property
    def shape(self) -> tuple[int, int]:
        return (self.axes[1][3], self.axes[0][3])  # rows: v, columns: phase / x

    def coords(self) -> tuple[np.ndarray, np.ndarray]:
        c = []
        for _, lo, hi, n in self.axes:
            c.append(lo + (np.arange(n) + 0.5) * (hi - lo) / n)  # cell centres
        return c[0], c[1]

    def digest(self) -> str:
        text = json.dumps(dataclasses.asdict(self), sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:32]


def _points_job(
    spec: _Spec,
    index: np.ndarray | None,
    transient: int,
    lo: int,
    hi: int,
    points: np.ndarray | None = None,
) -> dict:
    """The rows of flat grid points ``lo .. hi - 1`` (or of ``index[lo:hi]``) as a tile's arrays;
    the coordinates are computed here, so a task carries the spec, not the points.  With
    ``points`` (shape ``(n, 2)``: explicit ``(u, v)`` starts, the sub-grid) the rows of
    ``points[lo:hi]`` instead."""
    cu, cv = spec.coords()
    if points is not None:
        uv = [(float(u), float(v)) for u, v in points[lo:hi]]
    else:
        ks = np.arange(lo, hi) if index is None else index[lo:hi]
        uv = [(float(cu[int(k) % len(cu)]), float(cv[int(k) // len(cu)])) for k in ks]
    out: dict = {f: [] for f in FIELDS}
    for u, v in uv:
        row, stuck, capture = _point(
            spec.pars, spec.t0, spec.section, u, v, transient, spec.max_period,
            spec.chaos_periods,
        )  # fmt: skip
        for f, val in zip(FIELDS[:7], row, strict=True):
            out[f].append(val)
        out["stuck"].append(stuck)
        out["capture"].append(capture)
    arrays = {f: np.asarray(out[f], dtype=float) for f in FIELDS}
    arrays["index"] = np.arange(lo, hi)
    return arrays


def _scan(
    job, n_points, tile_size, store_dir, digest, workers, dask, progress, label, max_tiles,
    on_tile=None,
):  # fmt: skip
    store = None
    if store_dir is not None:
        store = NpzTileStore(Path(store_dir), digest, FIELDS, n_points, tile_size)
    run = run_scan(
        job, n_points, tile_size, workers=workers, dask=dask, store=store, progress=progress,
        label=label, max_tiles=max_tiles, on_tile=on_tile,
    )  # fmt: skip
    tiles = []
    for t in range(run.tiles_total):
        if store is not None:
            arrays, _ = store.read(t)
        else:
            arrays = run.values[t]
        tiles.append(arrays)
    if any(a is None for a in tiles):  # a partial run (max_tiles)
        return None, run
    return {f: np.concatenate([a[f] for a in tiles]) for f in FIELDS}, run


# ------------------------------------------------------------------ labels
def _label(data: dict, sub: dict | None = None) -> tuple:
    """One label per attractor over the whole map: periodic orbits by ``(impacts, period)`` and
    their refined fastest impact (to :data:`SAME_ORBIT`); every other kind one label.  With
    ``sub`` (the sub-grid's rows) also their labels, against the same table (an attractor seen
    only there is appended with ``points`` 0): ``(labels, table, sub_labels)``."""
    table: list[dict] = []
    labels = _assign(data, table, True)
    sub_labels = _assign(sub, table, False) if sub is not None else None
    for att in table:
        att.pop("_code")
    _name(table)
    if sub is not None:
        return labels, table, sub_labels
    return labels, table


def _assign(data: dict, table: list[dict], count: bool) -> np.ndarray:
    """Labels of ``data``'s rows in ``table`` (extended by new attractors); ``count``: add
    them to the attractors' ``points``."""
    kind = data["kind"].astype(int)
    labels = np.full(kind.shape, -1, dtype=int)
    for k in range(kind.size):
        if kind[k] == _OUTSIDE:
            continue
        for j, att in enumerate(table):
            if att["_code"] != kind[k]:
                continue
            if kind[k] != _PERIODIC or (
                att["impacts"] == data["impacts"][k]
                and att["period"] == data["period"][k]
                and same_impact(
                    att["phase"], att["v"], data["rep_phase"][k], data["rep_v"][k], SAME_ORBIT
                )
            ):
                labels[k] = j
                att["points"] += count
                break
        else:
            labels[k] = len(table)
            table.append(_attractor_entry(data, k))
            table[-1]["points"] = int(count)
    return labels


def _attractor_entry(data, k) -> dict:
    code = int(data["kind"][k])
    per = code == _PERIODIC
    return {
        "_code": code,
        "kind": BASIN_KINDS[code],
        "impacts": int(data["impacts"][k]) if per else None,
        "period": int(data["period"][k]) if per or code == _NONIMP else None,
        "stability": _STABILITY[int(data["stability"][k])] if per else None,
        "lle": float(data["lle"][k]),
        "phase": float(data["rep_phase"][k]),
        "v": float(data["rep_v"][k]),
        "points": 1,
    }


def _name(table: list[dict]) -> None:
    seen: dict = {}
    for att in table:
        if att["kind"] == "periodic":
            base = f"({att['impacts']},{att['period']}) {att['stability']}"
        else:
            base = att["kind"]
        seen[base] = seen.get(base, 0) + 1
        att["name"] = base if seen[base] == 1 else f"{base} #{seen[base]}"


def boundary_mask(labels: np.ndarray, unresolved: np.ndarray | None = None) -> np.ndarray:
    """Points with a 4-neighbour of another label (or unresolved themselves)."""
    lab = np.asarray(labels)
    b = np.zeros(lab.shape, dtype=bool)
    d0 = lab[1:, :] != lab[:-1, :]
    d1 = lab[:, 1:] != lab[:, :-1]
    b[1:, :] |= d0
    b[:-1, :] |= d0
    b[:, 1:] |= d1
    b[:, :-1] |= d1
    if unresolved is not None:
        b |= unresolved
    return b


# ------------------------------------------------------------------ result
@dataclasses.dataclass
class BasinsResult(ResultMixin):
    """A domain-of-attraction map.

    Attributes
    ----------
    params : dict
        The system (exact decimals as strings).
    section : str
        ``'impact'`` (axes phase, v) or ``'stroboscopic'`` (axes x, v at ``t0``).
    axes : list
        ``[(name, start, stop, n), ...]``: columns then rows; points at cell centres.
    labels : numpy.ndarray
        Shape ``(n_v, n_u)``: the index of each point's attractor in ``attractors`` (-1
        outside).
    attractors : list of dict
        ``name``, ``kind``, ``impacts``, ``period`` (``(m, n)`` = (impacts, periods)),
        ``stability``, ``lle``, ``phase``, ``v`` (its fastest impact), ``points``.
    stuck : numpy.ndarray
        Points whose orbit sticks to the wall on the way (bool).
    capture : numpy.ndarray
        Impacts before it sticks (-1: never).
    boundary : numpy.ndarray
        Points with a 4-neighbour of another label after refinement (bool).
    stats : dict
        ``points``, ``refined`` (boundary points re-run), ``changed`` (of them relabelled),
        ``boundary_fraction``, ``elapsed_s``, ``time_per_point_s``, ``workers``, ``backend``;
        ``subgrid`` (``k``, 0: off), ``subgrid_points`` (``k * k`` per boundary cell),
        ``mixed_cells`` (boundary cells whose sub-points carry more than one label) and
        ``subgrid_agreement`` (the fraction of sub-points with their cell's label).
    sub_u, sub_v, sub_label : numpy.ndarray
        The sub-grid (``subgrid >= 2``; empty when off): the starts inside the boundary cells
        (cell by cell, row-major as ``labels``) and their attractor's index (-1 outside).
    sub_agree : numpy.ndarray
        Per boundary cell (row-major), the fraction of its sub-points with the cell's label.

    See Also
    --------
    basins : makes it.
    precise_impact.analysis.impact_surface.singularity.singularity_set : where boundaries run.
    precise_impact.analysis.orbits.newton.find_orbit : refines the periodic attractors.
    """

    params: dict
    section: str
    axes: list
    labels: np.ndarray
    attractors: list
    stuck: np.ndarray
    capture: np.ndarray
    boundary: np.ndarray
    stats: dict
    sub_u: np.ndarray = dataclasses.field(default_factory=lambda: np.empty(0))
    sub_v: np.ndarray = dataclasses.field(default_factory=lambda: np.empty(0))
    sub_label: np.ndarray = dataclasses.field(default_factory=lambda: np.empty(0, dtype=int))
    sub_agree: np.ndarray = dataclasses.field(default_factory=lambda: np.empty(0))

    def to_dict(self) -> dict:
        return {
            "params": self.params,
            "section": self.section,
            "axes": self.axes,
            "attractors": self.attractors,
            "labels": self.labels.tolist(),
            "stats": self.stats,
            "sub_u": self.sub_u.tolist(),
            "sub_v": self.sub_v.tolist(),
            "sub_label": self.sub_label.tolist(),
            "sub_agree": self.sub_agree.tolist(),
        }

    def _tables(self) -> dict:
        names = [a["name"] for a in self.attractors]
        tables = {
            "attractors": lambda: {k: [a[k] for a in self.attractors] for k in self.attractors[0]}
        }
        if self.sub_u.size:  # the sub-grid, when there is one
            tables["subgrid"] = lambda: {
                f"{self.axes[0][0]} [1]": self.sub_u.tolist(),
                f"{self.axes[1][0]} [1]": self.sub_v.tolist(),
                "label": self.sub_label.tolist(),
                "name": [names[k] if k >= 0 else "outside" for k in self.sub_label.tolist()],
            }
        return tables

    def coordinates(self) -> tuple[np.ndarray, np.ndarray]:
        """The columns' and rows' coordinates (cell centres)."""
        c = []
        for _, lo, hi, n in self.axes:
            c.append(lo + (np.arange(n) + 0.5) * (hi - lo) / n)
        return c[0], c[1]

    def plot(self, path: str | os.PathLike | None = None, capture: bool | None = None):
        """The map, one colour per attractor with a legend naming each; with ``capture`` (default:
        when some points stick) a second panel of the impacts before sticking."""
        from matplotlib.colors import BoundaryNorm, ListedColormap  # noqa: PLC0415 -- heavy: loaded on first plot
        from matplotlib.patches import Patch  # noqa: PLC0415 -- heavy: loaded on first plot

        if capture is None:
            capture = bool(self.stuck.any())
        fig, axes = new_figure(1, 2 if capture else 1, figsize=(12.5 if capture else 8, 4.8))
        (un, u0, u1, _), (vn, v0, v1, _) = self.axes
        ext = [u0, u1, v0, v1]
        palette = [
            "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
            "#17becf", "#bcbd22", "#7f7f7f", "#aec7e8", "#ffbb78",
        ]  # fmt: skip
        special = {"chatter + sticking": "#f2d04b", "chaotic": "#000000", "unresolved": "#bbbbbb",
                   "grazing contact": "#666666", "non-impacting": "#98df8a"}  # fmt: skip
        colors = []
        for i, att in enumerate(self.attractors):
            colors.append(special.get(att["kind"], palette[i % len(palette)]))
        n = max(1, len(colors))
        cmap = ListedColormap(colors or ["white"])
        cmap.set_bad("white")
        norm = BoundaryNorm(np.arange(-0.5, n + 0.5), n)
        ax = axes[0, 0]
        ax.imshow(
            np.ma.masked_less(self.labels, 0), origin="lower", aspect="auto", extent=ext,
            cmap=cmap, norm=norm, interpolation="nearest",
        )  # fmt: skip
        k = int(self.stats.get("subgrid") or 1)
        if self.sub_u.size:  # the sub-grid: one small square per sub-point, its cell's size / k
            from matplotlib.collections import PolyCollection  # noqa: PLC0415 -- heavy: loaded on first plot

            hu, hv = (u1 - u0) / self.axes[0][3] / k / 2, (v1 - v0) / self.axes[1][3] / k / 2
            inside = self.sub_label >= 0
            su, sv = self.sub_u[inside], self.sub_v[inside]
            corners = np.stack(  # each sub-point's own sub-cell, in data coordinates
                [np.stack([su + a * hu, sv + b * hv], axis=1)
                 for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))], axis=1,
            )  # fmt: skip
            ax.add_collection(
                PolyCollection(
                    corners,
                    facecolors=[colors[i] for i in self.sub_label[inside]],
                    edgecolors="none",
                    antialiaseds=False,
                    zorder=2,  # over the image, under the spines (2.5)
                ),
                autolim=False,
            )  # fmt: skip (the map's extent stays the view)
        share = np.bincount(self.labels[self.labels >= 0].ravel(), minlength=n) / max(
            1, int((self.labels >= 0).sum())
        )
        handles = [
            Patch(color=c, label=f"{a['name']} ({100 * s:.1f} %)")
            for a, c, s in zip(self.attractors, colors, share, strict=True)
        ]
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
        ax.set_xlabel(un)
        ax.set_ylabel(vn)
        p = self.params
        ax.set_title(
            f"domains of attraction, {self.section} section"
            + (f", boundary cells on a {k} x {k} sub-grid" if self.sub_u.size else "")
            + "\n"
            f"eta={p['eta']} zeta={p['zeta']} R={p['R']} x_w={p['x_w']} a={p['a']}",
            fontsize=9,
        )
        if capture:
            ax2 = axes[0, 1]
            cap = np.ma.masked_less(self.capture.astype(float), 0)
            im = ax2.imshow(cap, origin="lower", aspect="auto", extent=ext, cmap="viridis",
                            interpolation="nearest")  # fmt: skip
            fig.colorbar(im, ax=ax2, label="impacts before sticking")
            ax2.set_xlabel(un)
            ax2.set_ylabel(vn)
            ax2.set_title("capture by chatter (white: never sticks)", fontsize=9)
        return finish(fig, path)


# ------------------------------------------------------------------ the map
def _check_axis(axis: Any, name: str) -> tuple:
    try:
        lo, hi, n = axis
        lo, hi = float(lo), float(hi)
    except (TypeError, ValueError):
        raise ParameterError(name, axis, "a triple (start, stop, n)") from None
    n = check_count(n, name + " n", 10**5, minimum=1)
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ParameterError(name, axis, "finite start < stop")
    return (name, lo, hi, n)


def basins(
    params: Any,
    grid: Any,
    *,
    section: str = "impact",
    transient: int = 200,
    max_period: int = 16,
    chaos_periods: int = 1000,
    refine: bool = True,
    refine_factor: int = 10,
    subgrid: int = 0,
    tile_size: int = 200,
    workers: int | None = 1,
    dask: str | None = None,
    out: str | os.PathLike | None = None,
    max_tiles: int | None = None,
    max_time: Any = None,
    progress: ProgressArg = None,
    on_tile: Callable[[int, dict], None] | None = None,
) -> BasinsResult:
    """Domains of attraction on the impact surface or the stroboscopic section.

    Parameters
    ----------
    params : Params or mapping
        The system (``t0`` is the stroboscopic section's time).
    grid : pair of (start, stop, n)
        The columns' axis (``phase`` in [0, 1) on the impact section, ``x <= x_w`` on the
        stroboscopic one) and the rows' (``v``: the incoming speed ``> 0``, or the velocity).
        Points at cell centres.
    section : ``'impact'`` or ``'stroboscopic'``, default ``'impact'``
        Where the starts are (module docstring).
    transient : int, default 200
        Forcing periods before the attractor is identified.
    max_period : int, default 16
        Longest period looked for.
    chaos_periods : int, default 1000
        Periods of the LLE of a start without a period.
    refine : bool, default ``True``
        Re-run the boundary points (a 4-neighbour of another label, or unresolved) with
        ``refine_factor`` times the transient and relabel them.
    refine_factor : int, default 10
        The longer transient of the boundary re-run.
    subgrid : int, default 0
        ``k >= 2`` (at most 32): sample every boundary cell (after the re-run) again at the
        centres of a ``k x k`` sub-grid inside it, with the boundary re-run's transient, and
        label the sub-points against the same attractors (``sub_u``, ``sub_v``, ``sub_label``
        of the result); 0: off.
    tile_size : int, default 200
        Points per tile (unit of work, checkpoint and resume).
    workers, dask : as :func:`~precise_impact.analysis.scan.run_scan`
        Local worker processes, or a Dask cluster (``'local'`` or ``'tcp://HOST:PORT'``).
    out : path or None, default ``None``
        Directory of the finished tiles: a rerun resumes from them.
    max_tiles : int or None
        Compute at most this many tiles (a partial run: :class:`ParameterError` asks to
        rerun for the rest).
    max_time : decimal or None, default ``None``
        Time budget in seconds: a map whose estimate (:data:`SECONDS_PER_PERIOD` per period
        of every point's ``transient + 3 max_period``, over the workers) is over it is refused
        before any work (:class:`~precise_impact.errors.OverBudgetError`); ``None``: no time
        budget.  A grid whose arrays (:data:`BYTES_PER_POINT` a point) would not fit in half
        this machine's memory is refused either way.
    progress : bool, None or callable
        :data:`~precise_impact.io.progress.ProgressArg`.
    on_tile : callable or None, default ``None``
        ``on_tile(tile, arrays)`` in this process as each tile of the map's first pass
        finishes (completion order): ``arrays`` holds the tile's points (``'index'``: their
        flat grid indices, row-major; ``'kind'``, ``'period'``, ``'capture'``, ...), before the
        boundary is refined and the attractors are labelled (the explorer draws them as they
        arrive).  An exception it raises stops the map (finished tiles are kept in ``out``).

    Returns
    -------
    BasinsResult
        Labels, the table of attractors, the boundary and the figures of the run.

    Raises
    ------
    ParameterError
        Bad input, before any work.
    OverBudgetError
        The estimate is over ``max_time``, before any work.
    KeyboardInterrupt
        Ctrl-C: the finished tiles stay in ``out``.

    See Also
    --------
    point_attractor : one start.
    precise_impact.analysis.scan.run_scan : the scan runner.
    precise_impact.analysis.orbits.newton.find_orbit : the refinement of each cycle.

    Examples
    --------
    >>> import precise_impact as pi
    >>> from precise_impact.analysis.impact_surface.basins import basins
    >>> p = pi.Params.make(eta="4.85", zeta=0, R="0.5", x_w="-0.3", x0="-0.5")
    >>> r = basins(p, ((0, 1, 4), (0, 0.5, 3)), transient=50, progress=False)
    >>> r.labels.shape, [a["name"] for a in r.attractors]
    ((3, 4), ['chatter + sticking'])
    """
    params = params_or_values(params, {})
    axes = _check_grid(section, grid)
    transient = check_count(transient, "transient", 10**7, minimum=1)
    max_period = check_count(max_period, "max_period", 1000, minimum=1)
    chaos_periods = check_count(chaos_periods, "chaos_periods", 10**8, minimum=10)
    refine_factor = check_count(refine_factor, "refine_factor", 1000, minimum=1)
    subgrid = _check_subgrid(subgrid)
    spec = _Spec(_floats(params), float(params.t0), section, axes, transient, max_period,
                 chaos_periods)  # fmt: skip
    n = spec.shape[0] * spec.shape[1]
    # priced before any array of the grid's size exists (time over the workers; memory always)
    check_work(
        f"basins: {n} points x {transient + 3 * max_period} periods",
        n,
        (transient + 3 * max_period) * SECONDS_PER_PERIOD,
        BYTES_PER_POINT,
        max_time,
        "grid points",
        scale=check_workers(workers) if dask is None else 1,
    )
    outp = Path(out) if out is not None else None
    job = functools.partial(_points_job, spec, None, transient)
    data, run = _scan(
        job, n, tile_size, outp / "tiles_main" if outp else None, spec.digest(), workers, dask,
        progress, "basins", max_tiles, on_tile,
    )  # fmt: skip
    if data is None:
        raise ParameterError("max_tiles", max_tiles, "enough tiles for the map (rerun with out=)")
    elapsed, n_run = run.elapsed_s, run.tiles_computed
    labels, _ = _label(data)
    refined = changed = 0
    if refine:
        unresolved = np.isin(data["kind"], (_UNRESOLVED, _GRAZING)).reshape(spec.shape)
        mask = boundary_mask(labels.reshape(spec.shape), unresolved).ravel()
        mask &= data["kind"] != _OUTSIDE
        idx = np.flatnonzero(mask)
        refined = len(idx)
        if refined:
            job2 = functools.partial(_points_job, spec, idx, transient * refine_factor)
            sub, run2 = _scan(
                job2, refined, max(1, tile_size // refine_factor), outp / "tiles_refine"
                if outp else None, spec.digest() + f"r{refine_factor}:" + hashlib.sha256(
                    idx.tobytes()).hexdigest()[:16], workers, dask, progress, "basins refine",
                None,
            )  # fmt: skip
            assert sub is not None
            elapsed += run2.elapsed_s
            old = labels.copy()
            for f in FIELDS:
                data[f][idx] = sub[f]
            labels, _ = _label(data)
            changed = _changed(old, labels, idx, data)
    labels, table = _label(data)
    lab2 = labels.reshape(spec.shape)
    unresolved = np.isin(data["kind"], (_UNRESOLVED, _GRAZING)).reshape(spec.shape)
    bnd = boundary_mask(lab2, unresolved) & (lab2 >= 0)
    inside = int((lab2 >= 0).sum())
    sub = _subgrid(spec, bnd, lab2, subgrid, transient * (refine_factor if refine else 1),
                   tile_size, outp, workers, dask, progress, data)  # fmt: skip
    if sub is not None:
        labels, table, sub_label = _label(data, sub["data"])
        elapsed += sub["elapsed"]
    stats = _stats(n, refined, changed, float(bnd.sum() / max(1, inside)), elapsed, n_run, run,
                   transient, refine_factor if refine else None, subgrid)  # fmt: skip
    extra: dict = {}
    if sub is not None:
        extra = _subgrid_fields(sub, sub_label, lab2, subgrid, stats)
    return BasinsResult(
        params={k: str(getattr(params, k)) for k in ("eta", "zeta", "a", "x_w", "R", "t0")},
        section=section,
        axes=[list(a) for a in axes],
        labels=lab2,
        attractors=table,
        stuck=data["stuck"].reshape(spec.shape).astype(bool),
        capture=data["capture"].reshape(spec.shape).astype(int),
        boundary=bnd,
        stats=stats,
        **extra,
    )


def _stats(
    n, refined, changed, boundary_fraction, elapsed, n_run, run, transient, refine_factor, subgrid
) -> dict:
    """The map's ``stats`` (the sub-grid's counts zero until :func:`_subgrid_fields`)."""
    return {
        "points": n,
        "refined": refined,
        "changed": changed,
        "boundary_fraction": boundary_fraction,
        "elapsed_s": elapsed,
        "time_per_point_s": elapsed / max(1, n),
        "tiles_computed": n_run,
        "workers": run.workers,
        "backend": run.backend,
        "transient": transient,
        "refine_factor": refine_factor,
        "subgrid": subgrid,
        "subgrid_points": 0,
        "mixed_cells": 0,
        "subgrid_agreement": None,
    }


def _check_grid(section: str, grid: Any) -> tuple:
    """The section and the grid's two axes, checked: the axes ``(name, start, stop, n)``."""
    if section not in SECTIONS:
        raise ParameterError("section", section, "'impact' or 'stroboscopic'")
    check_type(grid, (tuple, list), "grid", "a pair of axes (start, stop, n)")
    if len(grid) != 2:
        raise ParameterError("grid", grid, "a pair of axes (start, stop, n)")
    names = ("phase", "v") if section == "impact" else ("x", "v")
    axes = tuple(_check_axis(g, nm) for g, nm in zip(grid, names, strict=True))
    if section == "impact" and (axes[0][1] < 0 or axes[0][2] > 1 or axes[1][1] < 0):
        raise ParameterError("grid", grid, "phase within [0, 1] and v >= 0 on the impact section")
    return axes


def _check_subgrid(subgrid: Any) -> int:
    """``subgrid`` checked: 0 (off) or an integer from 2 to 32."""
    subgrid_in = subgrid
    try:  # an int, numpy integer or integer string, like the other counts
        subgrid = check_count(subgrid, "subgrid", 32)
    except ParameterError:
        subgrid = 1
    if subgrid == 1:
        raise ParameterError("subgrid", subgrid_in, "0 (off) or an integer 2 <= subgrid <= 32")
    return subgrid


def _subgrid_fields(sub: dict, sub_label: Any, lab2: Any, subgrid: int, stats: dict) -> dict:
    """The sub-grid's result fields; its counts and agreement written into ``stats``."""
    cells = lab2.ravel()[sub["cells"]]  # each boundary cell's label (unchanged by _label)
    per = sub_label.reshape(len(cells), subgrid * subgrid)
    agree = (per == cells[:, None]).mean(axis=1)
    mixed = int(sum(len(np.unique(r)) > 1 for r in per))
    stats["subgrid_points"] = int(sub_label.size)
    stats["mixed_cells"] = mixed
    stats["subgrid_agreement"] = float((per == cells[:, None]).mean()) if per.size else None
    return {"sub_u": sub["u"], "sub_v": sub["v"], "sub_label": sub_label, "sub_agree": agree}


def _subgrid(spec, bnd, lab2, k, transient, tile_size, outp, workers, dask, progress, data):
    """Run the ``k x k`` sub-grids of the boundary cells; ``None`` when off or no boundary."""
    if k == 0 or not bnd.any():
        return None
    cells = np.flatnonzero(bnd.ravel())
    (_, u0, u1, nu), (_, v0, v1, nv) = spec.axes
    du, dv = (u1 - u0) / nu, (v1 - v0) / nv
    off = (np.arange(k) + 0.5) / k  # sub-cell centres, in cell widths
    i, j = np.divmod(cells, nu)
    # per cell, row-major over the sub-grid (rows: v, columns: u), like the map
    su = u0 + (j[:, None, None] + off[None, None, :]) * du + 0 * off[None, :, None]
    sv = v0 + (i[:, None, None] + off[None, :, None]) * dv + 0 * off[None, None, :]
    pts = np.stack([su.ravel(), sv.ravel()], axis=1)
    tile = max(1, tile_size // max(1, transient // spec.transient))
    digest = (spec.digest() + f"s{k}t{transient}:"
              + hashlib.sha256(pts.tobytes()).hexdigest()[:16])  # fmt: skip
    job = functools.partial(_points_job, spec, None, transient, points=pts)
    sub, run = _scan(
        job, len(pts), tile, outp / "tiles_subgrid" if outp else None, digest, workers, dask,
        progress, "basins subgrid", None,
    )  # fmt: skip
    assert sub is not None
    del lab2, data
    return {"data": sub, "u": pts[:, 0], "v": pts[:, 1], "cells": cells,
            "elapsed": run.elapsed_s}  # fmt: skip


def _changed(old: np.ndarray, new: np.ndarray, idx: np.ndarray, data: dict) -> int:
    """Refined points whose attractor changed (labels are renumbered: compare by name)."""
    del data
    return int(np.sum(old[idx] != new[idx]))
