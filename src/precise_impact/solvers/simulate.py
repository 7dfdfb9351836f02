"""One entry point for every model: ``simulate(params, periods, model=..., precision=...)`` for
the single oscillator and ``simulate_coupled(params, k, ..., model=...)`` for the pair.

The solvers' own models are registered here, each with its :class:`Capabilities`
(the circuit models register in :mod:`precise_impact.models`).
"""

from __future__ import annotations

import dataclasses
import threading
from typing import Any

from precise_impact.core import digits as _digits
from precise_impact.core.budget import enforce_max_time
from precise_impact.core.compat import warn_renamed
from precise_impact.core.params import Params, as_params, check_count, params_or_values
from precise_impact.core.precision import Precision
from precise_impact.core.trajectory import Trajectory
from precise_impact.errors import ParameterError
from precise_impact.solvers.base import (
    COUPLED_MODELS,
    MODELS,
    PRECISION_KINDS,
    Capabilities,
    Solver,
    canonical_model,
    check_engine,
    coupled_model_capabilities,
    make_coupled_solver,
    make_solver,
    model_capabilities,
    register_coupled_model,
    register_model,
)
from precise_impact.solvers.closed_form import AnalyticalSolver
from precise_impact.solvers.heyoka.coupled import (
    CoupledTrajectory,
    HeyokaCoupledSolver,
    check_inputs,
    check_max_impacts,
)
from precise_impact.solvers.heyoka.single import HeyokaSolver

__all__ = [
    "MODELS",
    "make_solver",
    "simulate",
    "COUPLED_MODELS",
    "simulate_coupled",
    "reference_precision",
    "demonstration_model",
]


def _heyoka(prec: Precision, tol: Any, **options: Any) -> Solver:
    return HeyokaSolver(prec, tol=tol, **options)


def _analytical(finder: str):
    def factory(prec: Precision, tol: Any, **options: Any) -> Solver:
        return AnalyticalSolver(finder=finder, precision=prec, **options)

    return factory


def _fast(prec: Precision, tol: Any, **options: Any) -> Solver:
    from precise_impact.solvers.fast.single import FastSolver  # noqa: PLC0415 -- optional: numba loaded on first use

    return FastSolver(**options)


def _certified(prec: Precision, tol: Any, **options: Any) -> Solver:
    from precise_impact.solvers.certified.single import CertifiedSolver  # noqa: PLC0415 -- optional: python-flint loaded on first use

    return CertifiedSolver(prec.bits, **options)


#: What each arithmetic takes (shared by the single and the coupled models of an engine).
HEYOKA = Capabilities(PRECISION_KINDS, tolerance=True)
CLOSED_FORM = Capabilities(
    ("float64", "mp"), tolerance=False, note="it works to the precision's epsilon"
)
FAST = Capabilities(
    ("float64",),
    tolerance=False,
    note="closed forms to float64 rounding; heyoka for other precisions",
)
CERTIFIED = Capabilities(("mp",), tolerance=False, note="proven enclosures at BITS", dense=False)

register_model(
    "heyoka",
    "heyoka Taylor integrator with impact events (the mechanical reference)",
    _heyoka,
    HEYOKA,
)
register_model(
    "analytical",
    "closed-form segments, robust impact finder (cannot miss a crossing)",
    _analytical("robust"),
    CLOSED_FORM,
)
register_model(
    "analytical-paper",
    "closed-form segments, the paper's 1e-3 T scan + bisection",
    _analytical("paper"),
    CLOSED_FORM,
)
register_model(
    "fast",
    "compiled closed form (numba, float64): cannot miss a crossing; heyoka for contacts",
    _fast,
    FAST,
)
register_model(
    "certified",
    "ball arithmetic on the closed form (python-flint, mp:BITS): proven enclosures",
    _certified,
    CERTIFIED,
)


def _coupled_heyoka(prec: Precision, tol: Any, **options: Any):
    return HeyokaCoupledSolver(prec, **options)


def _coupled_fast(prec: Precision, tol: Any, **options: Any):
    from precise_impact.solvers.fast.coupled import FastCoupledSolver  # noqa: PLC0415 -- optional: numba loaded on first use

    return FastCoupledSolver(**options)


def _coupled_certified(prec: Precision, tol: Any, **options: Any):
    from precise_impact.solvers.certified.coupled import CertifiedCoupledSolver  # noqa: PLC0415 -- optional: python-flint loaded on first use

    return CertifiedCoupledSolver(prec.bits, **options)


register_coupled_model(
    "heyoka",
    "heyoka Taylor integrator of the pair, both walls as events (every precision)",
    _coupled_heyoka,
    dataclasses.replace(HEYOKA, tolerance=False, note="the pair runs at the precision's epsilon"),
)
register_coupled_model(
    "fast",
    "compiled closed forms of the pair (numba, float64); heyoka for contacts",
    _coupled_fast,
    FAST,
)
register_coupled_model(
    "certified",
    "the pair in ball arithmetic (python-flint, mp:BITS): proven enclosures",
    _coupled_certified,
    CERTIFIED,
)


_PER_THREAD = threading.local()
#: heyoka solvers kept per thread by :func:`simulate` (distinct precisions/tolerances).
_KEEP = 8


def _solver(model: Any, precision: Any, tol: Any) -> Solver:
    """``make_solver(model, precision, tol)``, reusing this thread's heyoka solver.

    A :class:`HeyokaSolver` owns a private copy of the compiled integrator, and making
    that copy costs ~0.6 ms in float64 (a third of a 200-period run).  Each thread
    keeps its own solvers, per setting, so nothing is shared across threads (a
    compiled integrator is mutable state); one that is busy (re-entered from inside
    a run, e.g. by a signal handler) is not reused.  Every solve resets
    the integrator's time, state, parameters and callback, so a reused solver gives
    the same bits as a new one (``tests/test_threads.py``).
    """
    new = make_solver(model, precision, tol)  # validates; cheap (no integrator yet)
    if type(new) is not HeyokaSolver:
        return new
    key = (
        new.precision.name,
        new.tol_exact,
        new.high_accuracy,
        new.compact_mode,
        new.max_impacts,
        new.max_steps,
    )
    kept = _PER_THREAD.__dict__.setdefault("solvers", {})
    old = kept.get(key)
    if old is not None and not old.busy():
        return old
    if len(kept) >= _KEEP:
        kept.pop(next(iter(kept)))
    kept[key] = new
    return new


def simulate(
    params: Params | None = None,
    periods: int = 200,
    *,
    model: str = "heyoka",
    precision: str | Precision = "float64",
    tol: Any = None,
    per_period: int = 0,
    max_time: Any = None,
    demonstrate: bool | str | Precision = False,
    **param_values: Any,
) -> Trajectory:
    """Simulate the impact oscillator with any model.

    Parameters
    ----------
    params : Params, mapping or None, default ``None``
        Exact parameters; ``None`` builds them from ``param_values`` (names as in
        :class:`Params`, defaults the paper's: zeta=0.05, a=1, eta=0.712, x_w=2, R=1).
    periods : int, default 200
        Forcing periods; samples at ``t0 + k 2 pi / eta``, ``k = 0..periods``.
    model : str, default ``'heyoka'``
        One of :data:`~precise_impact.solvers.base.MODELS` (``'mechanical'`` is accepted
        for ``'heyoka'``): the heyoka reference, the closed forms, the circuit models.
    precision : str, default ``'float64'``
        ``'float64'``, ``'longdouble'``, ``'float128'``, ``'mp:BITS'``.
    tol : decimal or None, default ``None`` (the precision's epsilon)
        heyoka's tolerance.
    per_period : int, default 0
        Dense output points per period.
    max_time : decimal or None, default ``None``
        Time budget in seconds (``1 <= max_time <= 604800``): the run's estimated cost
        (:func:`~precise_impact.core.budget.estimate_cost`) is checked against it before
        any work (:class:`~precise_impact.errors.OverBudgetError`); ``None``: no budget.
    demonstrate : bool or str, default ``False``
        Run a second time at a higher precision (``True``: :func:`reference_precision`, or a
        precision such as ``'mp:512'``) and claim, at each sample, the digits the two runs
        agree on (``traj.claimed_digits().basis == 'demonstrated'``).  A float64-only model
        is checked by its mp counterpart (:func:`demonstration_model`).  Without it every
        trajectory still claims digits: ``'proven'`` (certified) or ``'estimated'``
        (:meth:`~precise_impact.core.trajectory.Trajectory.claimed_digits`).
    **param_values
        Parameter values (exact decimals) replacing those of ``params``.

    Returns
    -------
    Trajectory
        Stroboscopic samples, impacts, and dense output if asked for.

    Raises
    ------
    ParameterError
        Bad input, before any work.
    OverBudgetError
        The estimated cost is over ``max_time`` (a ``ParameterError`` and a
        ``BudgetExceededError``), before any work.
    BudgetExceededError
        An impact or step budget was exhausted (e.g. a Zeno impact sequence).

    See Also
    --------
    precise_impact.solvers.certified.single.certify : the same trajectory enclosed in proven balls.
    precise_impact.solvers.base.make_solver : the solver object behind ``model``.
    precise_impact.analysis.lyapunov.lyapunov
        The largest Lyapunov exponent of the trajectory's attractor.
    precise_impact.scenes.run.run_scene : simulate a named scene.

    References
    ----------
    .. [1] V. Denysenko, M. Balcerzak, A. Dabrowski, "Electronic equivalent of a
       mechanical impact oscillator" (the system and its parameters).
    .. [2] F. Biscani, D. Izzo, "Revisiting high-order Taylor methods for astrodynamics
       and celestial mechanics", MNRAS 504 (2021) (heyoka, the reference integrator).

    Examples
    --------
    >>> import precise_impact as pi
    >>> tr = pi.simulate(pi.Params.make(eta="0.74"), 3, model="fast")
    >>> tr.x.shape, tr.n_impacts
    ((4,), 2)
    >>> round(float(tr.x[-1]), 6)
    1.344885
    """
    params = params_or_values(params, param_values)  # a Params (validated), a mapping, or None
    periods = check_count(periods, "periods")
    solver = _solver(model, precision, tol)
    prec = getattr(solver, "precision", None) or Precision.parse(precision)
    second = None
    if demonstrate is not False and demonstrate is not None:
        ref = reference_precision(prec, demonstrate)
        second = _solver(demonstration_model(model, ref), ref, None)
    if max_time is not None:
        per_period = check_count(per_period, "per_period", 100_000)
        enforce_max_time(
            max_time, "simulate", periods=periods, per_period=per_period, precision=prec
        )
        if second is not None:
            enforce_max_time(max_time, "simulate", periods=periods, precision=ref)
    traj = solver.solve(params, periods, per_period=per_period)
    if second is not None:
        traj.claim = _digits.demonstrate(traj, second.solve(params, periods))
    return traj


def reference_precision(precision: str | Precision, spec: Any = True) -> Precision:
    """The second run's precision for ``demonstrate=spec``: ``spec`` itself when it names a
    precision (it must have more bits), else 64 bits more than ``precision`` (~19 digits: the
    second run's own error stays far below the first's), at least ``mp:128``.

    Raises
    ------
    ParameterError
        ``spec`` is not a precision, or not more precise than ``precision``.
    """
    P = Precision.parse(precision)
    if spec is True:
        return Precision.parse(f"mp:{max(128, P.bits + 64)}")
    try:
        ref = Precision.parse(spec)
    except ParameterError as e:  # keep the precision's own range (e.g. 64 <= BITS <= 8192)
        raise ParameterError(
            "demonstrate", str(spec), f"True or a precision (float128, mp:BITS): {e.allowed}"
        ) from None
    if ref.bits <= P.bits:
        raise ParameterError(
            "demonstrate",
            ref.name,
            f"a precision with more bits than {P.name} ({P.bits}), e.g. mp:{max(128, P.bits + 64)}",
        )
    return ref


def demonstration_model(model: str, precision: Precision) -> str:
    """The model that runs the second, more precise run of ``model``: itself when it takes
    ``precision``; the closed forms (``'analytical'``) for ``'fast'`` (the same formulas in
    float64 only).

    Raises
    ------
    ParameterError
        No registered model computes ``model``'s trajectory at ``precision`` (e.g. ``'spice'``).
    """
    name = canonical_model(model)
    if precision.kind in model_capabilities(name).precisions:
        return name
    if name == "fast":
        return "analytical"
    kinds = ", ".join(model_capabilities(name).precisions)
    raise ParameterError(
        "demonstrate",
        precision.name,
        f"not given for model {name!r}: it runs in {kinds} only and has no more precise "
        "counterpart",
    )


def simulate_coupled(
    params: Params,
    k: Any,
    form: str = "first-order",
    periods: int = 500,
    y0: Any = None,
    per_period: int = 0,
    precision: str | Precision = "float64",
    max_impacts: int | None = None,
    engine: str | None = None,
    *,
    model: str = "heyoka",
    demonstrate: bool | str | Precision = False,
) -> CoupledTrajectory:
    """Integrate the master-slave pair (11) + slave ``form`` for ``periods`` forcing periods.

    Parameters
    ----------
    params : Params
        System parameters (the paper's: zeta = 0.05, a = 1, x_w = 2, R = 1,
        eta = 0.712 chaotic) and the master's initial state ``(x0, v0)`` at ``t0``.
    k : decimal string / Fraction / int / float
        Coupling ``k >= 0``, converted exactly (:func:`~precise_impact.core.params.exact`; a
        float is read as its shortest round-trip decimal).
    form : str, default ``'first-order'``
        One of :data:`COUPLED_FORMS`: eqs. (12) as written, (14a) as printed, or the
        correct second-order reduction of (12) (module docstring).
    periods : int, default 500
        Forcing periods ``T = 2 pi / eta`` (the paper's Fig. 7 uses 500).
    y0 : pair or None, default ``None``
        Slave ``(position, velocity variable)`` in ``form``'s own variables
        (``(y1, y2)`` or ``(y, y')``), each exact; position ``<= x_w``.  ``None``
        starts the slave on the master, ``(x0, v0)`` -- the diagonal.
    per_period : int, default 0
        Dense samples per period (``0 <= per_period <= 100000``) for plotting.
    precision : str, default ``'float64'``
        ``'float64'``, ``'longdouble'``, ``'float128'`` or ``'mp:BITS'``.
    max_impacts : int or None, default ``None``
        Budget over both oscillators (``None``: the model's, ``10**7`` for heyoka and fast;
        the certified and circuit models take none); exceeding it raises
        :class:`BudgetExceededError`.
    engine : str or None, default ``None``
        Deprecated spelling of ``model`` (``'fast'`` or ``'heyoka'``).
    model : str, default ``'heyoka'``
        One of :data:`~precise_impact.solvers.base.COUPLED_MODELS`: ``'heyoka'`` (Taylor
        integration, any precision), ``'fast'`` (float64 closed forms,
        :mod:`~precise_impact.solvers.fast.coupled`, ~50x faster; a run it does not resolve,
        a tangential contact or chattering, is integrated by heyoka and ``stats['engine']``
        says so), ``'certified'`` (``'mp:BITS'``, balls:
        :class:`~precise_impact.solvers.certified.coupled.CertifiedCoupledTrajectory`) or
        ``'circuit'`` (the Fig. 3 op-amp pair of the nominal design, ``form='paper'``).
        Its precisions and forms are checked before any work.
    demonstrate : bool or str, default ``False``
        Run the pair again at a higher precision (``True``: :func:`reference_precision`, or
        a precision) and claim, per sample, the digits both runs agree on
        (``claimed_digits().basis == 'demonstrated'``); ``'fast'`` is checked by ``'heyoka'``.
        Without it a pair claims ``'estimated'`` digits (``'proven'`` for ``'certified'``).

    Returns
    -------
    CoupledTrajectory
        Stroboscopic (and dense, if asked for) samples of master ``(x, v)`` and slave
        ``(y, w)``, both oscillators' impacts; ``difference()`` gives ``|x - y|``.  (The
        certified and circuit models return their own result types, with the same ``t, x,
        v, y, w``, ``master_impacts_t`` and ``slave_impacts_t``.)

    Raises
    ------
    ParameterError
        Every input is validated before any work; a bad value is named with its
        allowed range.
    BudgetExceededError
        More than ``max_impacts`` impacts.

    See Also
    --------
    precise_impact.solvers.certified.coupled.certify_coupled : the same pair certified.
    precise_impact.analysis.sync.sync_scan : the synchronised fraction against k.
    precise_impact.models.circuit.coupled.simulate_coupled_circuit
        The op-amp circuit of the same pair.

    Notes
    -----
    A start on the wall moving into it is an impact at ``t0`` (applied before the
    first sample).

    References
    ----------
    .. [1] V. Denysenko, M. Balcerzak, A. Dabrowski, "Electronic equivalent of a
           mechanical impact oscillator", eqs. (11)-(14) and Fig. 7.
    .. [2] F. Biscani, D. Izzo, MNRAS 504 (2021) 2614 (heyoka's Taylor method and
           event detection).

    Examples
    --------
    >>> import precise_impact as pi
    >>> ct = pi.simulate_coupled(pi.Params.make(eta="0.74"), "0.1", periods=3)
    >>> ct.form, ct.x.shape
    ('first-order', (4,))
    """

    params = as_params(params)
    check_inputs(params, k, form, periods, per_period, y0)
    P = Precision.parse(precision)
    options = {}
    if max_impacts is not None:
        options["max_impacts"] = check_max_impacts(max_impacts)
    if engine is not None:
        warn_renamed("engine=", "model=", "simulate_coupled")
        model = check_engine(engine)
    solver = make_coupled_solver(model, P, None, form, **options)
    second = None
    if demonstrate is not False and demonstrate is not None:
        ref = reference_precision(P, demonstrate)
        name = model if ref.kind in coupled_model_capabilities(model).precisions else "heyoka"
        if name != model and model != "fast":
            raise ParameterError(
                "demonstrate", ref.name, f"not given for model {model!r}: no {ref.name} run"
            )
        second = make_coupled_solver(name, ref, None, form, **options)
    traj = solver.solve(params, k, periods, form=form, y0=y0, per_period=per_period)
    if second is not None:
        traj.claim = _digits.demonstrate(traj, second.solve(params, k, periods, form=form, y0=y0))
    return traj
