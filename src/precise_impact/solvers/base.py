"""The Solver protocol and the model registry: one name per model, one way to make it.

Every model is a :class:`Solver` (``solve(params, periods, *, per_period=0) -> Trajectory``);
:func:`make_solver` builds one by name, :data:`MODELS` lists them.
"""

from __future__ import annotations

import dataclasses
import importlib
import threading
import types
from collections.abc import Callable, Iterator, Mapping
from typing import Any, Protocol, runtime_checkable

from precise_impact.core.params import Params
from precise_impact.core.precision import Precision
from precise_impact.core.trajectory import Trajectory
from precise_impact.errors import IntegrationError, ParameterError

__all__ = [
    "Solver",
    "MODELS",
    "MODEL_ALIASES",
    "register_model",
    "canonical_model",
    "make_solver",
    "model_capabilities",
    "Capabilities",
    "PRECISION_KINDS",
    "CoupledSolver",
    "COUPLED_MODELS",
    "register_coupled_model",
    "make_coupled_solver",
    "coupled_model_capabilities",
    "Unresolved",
    "with_fallback",
    "note_fallback",
    "ENGINES",
    "check_engine",
]

#: Engines of the float64 jobs that offer both (sweep, bifurcation, coupled runs and sync):
#: the compiled closed form (:mod:`precise_impact.solvers.fast.single`) or heyoka.
ENGINES = ("fast", "heyoka")


def check_engine(engine: Any, precision: Precision | None = None) -> str:
    """``engine`` if it is one of :data:`ENGINES`, else a :class:`ParameterError` naming it;
    with a ``precision``, ``'fast'`` also needs it to be float64 (the engine's type)."""
    if not isinstance(engine, str) or engine not in ENGINES:
        raise ParameterError("engine", engine, "'fast' or 'heyoka'")
    if engine == "fast" and precision is not None and precision.kind != "float64":
        raise ParameterError(
            "precision",
            precision.name,
            "'float64' for engine='fast' (engine='heyoka' for other precisions)",
        )
    return engine


#: The kinds of working precision (:attr:`Precision.kind`) a model may declare.
PRECISION_KINDS = ("float64", "longdouble", "float128", "mp")
_KIND_NAMES = {"mp": "'mp:BITS'"}


@dataclasses.dataclass(frozen=True)
class Capabilities:
    """What a model takes, declared when it is registered and checked before any work.

    Attributes
    ----------
    precisions : tuple of str
        The kinds of :class:`~precise_impact.core.precision.Precision` it runs in
        (:data:`PRECISION_KINDS`).
    tolerance : bool
        Whether it takes an integrator tolerance ``tol``.
    forms : tuple of str or None
        Coupled models: the slave forms it integrates (``None``: every form).
    note : str
        Said after a refused precision or tolerance (what to use instead, or why).
    dense : bool
        Whether it gives dense output (``per_period > 0``).
    """

    precisions: tuple[str, ...] = PRECISION_KINDS
    tolerance: bool = True
    forms: tuple[str, ...] | None = None
    note: str = ""
    dense: bool = True

    def __post_init__(self) -> None:
        bad = [k for k in self.precisions if k not in PRECISION_KINDS]
        if bad or not self.precisions:
            raise ValueError(f"precision kinds must be among {PRECISION_KINDS}, not {bad}")

    def check(self, model: str, precision: Precision, tol: Any = None, form: Any = None) -> None:
        """Raise :class:`~precise_impact.errors.ParameterError` for what ``model`` does not take."""
        note = f" ({self.note})" if self.note else ""
        if precision.kind not in self.precisions:
            names = " or ".join(_KIND_NAMES.get(k, repr(k)) for k in self.precisions)
            raise ParameterError(
                "precision", precision.name, f"{names} for the {model} model{note}"
            )
        if tol is not None and not self.tolerance:
            raise ParameterError("tol", str(tol), f"the {model} model takes no tolerance{note}")
        if form is not None and self.forms is not None and form not in self.forms:
            raise ParameterError(
                "form", form, f"{' or '.join(map(repr, self.forms))} for the {model} model"
            )


@runtime_checkable
class Solver(Protocol):
    """What every model implements.

    ``isinstance(obj, Solver)`` checks that ``obj`` has the two attributes and a
    ``solve`` method (Python checks no signatures); every model of the registry has
    the signature below, and :func:`simulate`, the scenes and compare rely on it.

    Attributes
    ----------
    model_name : str
        The model's name in :data:`MODELS` (also :attr:`Trajectory.model` of its results).
    precision : Precision
        The working precision of the solver's numbers.

    Methods
    -------
    solve(params, periods, *, per_period=0) -> Trajectory
        Simulate ``periods`` forcing periods from ``params``' initial condition;
        stroboscopic samples at ``t0 + k 2 pi / eta`` (``k = 0..periods``), every
        impact, and ``per_period`` dense points per period when ``> 0``.  Models
        may take further keyword-only options (the circuit models: ``x0, v0, t0``).

    See Also
    --------
    precise_impact.solvers.base.make_solver : a solver by model name.
    precise_impact.solvers.heyoka.single.HeyokaSolver : the reference solver.
    precise_impact.solvers.simulate.simulate : build and run a solver in one call.
    """

    @property
    def model_name(self) -> str: ...

    @property
    def precision(self) -> Precision: ...

    def solve(
        self, params: Params, periods: int, *, per_period: int = 0
    ) -> Trajectory:  # pragma: no cover - protocol
        """Simulate ``periods`` forcing periods; see the class docstring.

        Parameters
        ----------
        params : Params
            System and initial condition.
        periods : int
            Forcing periods; stroboscopic samples at ``t0 + k 2 pi / eta``,
            ``k = 0..periods``.
        per_period : int, default 0
            Dense output points per period (0: none).

        Returns
        -------
        Trajectory
            Samples, impacts and ``stats``.
        """
        ...


@dataclasses.dataclass(frozen=True)
class _Model:
    name: str
    description: str
    factory: Callable[..., Any]
    capabilities: Capabilities


_REGISTRY: dict[str, _Model] = {}
_DESCRIPTIONS: dict[str, str] = {}
_REGISTRY_LOCK = threading.Lock()

#: The modules whose import registers models: the solvers' own and the circuit models (the
#: registry's plugin list, named, not imported: models/ sits above solvers/).  Loaded at the
#: registry's first use: since the package's names load lazily, nothing else imports them, and
#: ``simulate(..., model="switched-capacitor")`` in a fresh process was "not allowed".
_PROVIDERS = ("precise_impact.solvers.simulate", "precise_impact.models")
_providers_loaded = threading.Event()


def _load_providers() -> None:
    """Import :data:`_PROVIDERS` once (each registers its models as it is imported)."""
    if _providers_loaded.is_set():
        return
    _providers_loaded.set()  # first: a provider's import may look models up itself
    for name in _PROVIDERS:
        importlib.import_module(name)


class _Registered(Mapping):
    """A read-only view of a registry that loads the providers before it is read."""

    def __init__(self, table: dict[str, str]) -> None:
        self._table = table

    def __getitem__(self, key: str) -> str:
        _load_providers()
        return self._table[key]

    def __iter__(self) -> Iterator[str]:
        _load_providers()
        return iter(dict(self._table))

    def __len__(self) -> int:
        _load_providers()
        return len(self._table)

    def __repr__(self) -> str:
        return repr(dict(self))


#: Model name -> one-line description (read-only view; filled by :func:`register_model`).
MODELS: Mapping[str, str] = _Registered(_DESCRIPTIONS)

#: Old or alternative names accepted for a model, mapped to its one canonical name.
MODEL_ALIASES = types.MappingProxyType({"mechanical": "heyoka"})


def register_model(
    name: str,
    description: str,
    factory: Callable[..., Solver],
    capabilities: Capabilities | None = None,
) -> None:
    """Add a model to :data:`MODELS`.

    Parameters
    ----------
    name : str
        The model's one canonical name.
    description : str
        One line for ``--help`` and the docs.
    factory : callable
        ``factory(precision: Precision, tol, **options) -> Solver``, called with a
        precision and tolerance the capabilities allow; raises
        :class:`~precise_impact.errors.ParameterError` for an option it does not take.
    capabilities : Capabilities or None, default ``None``
        The precisions and tolerance it takes, checked by :func:`make_solver` before the
        factory is called (``None``: every precision, with a tolerance).
    """
    with _REGISTRY_LOCK:
        _REGISTRY[name] = _Model(name, description, factory, capabilities or Capabilities())
        _DESCRIPTIONS[name] = description


def canonical_model(name: str) -> str:
    """The canonical name of ``name`` (an alias such as ``'mechanical'`` maps to ``'heyoka'``).

    Raises
    ------
    ParameterError
        ``name`` is neither a model nor an alias.
    """
    _load_providers()
    name = MODEL_ALIASES.get(name, name) if isinstance(name, str) else name
    if not isinstance(name, str) or name not in _REGISTRY:
        allowed = ", ".join(list(_REGISTRY) + [f"{a} (= {c})" for a, c in MODEL_ALIASES.items()])
        raise ParameterError("model", name, "one of " + allowed)
    return name


def make_solver(
    model: str = "heyoka", precision: str | Precision = "float64", tol: Any = None, **options: Any
) -> Solver:
    """The solver object for ``model`` at ``precision``.

    Parameters
    ----------
    model : str, default ``'heyoka'``
        A name of :data:`MODELS` or an alias of :data:`MODEL_ALIASES`.
    precision : str or Precision, default ``'float64'``
        ``'float64'``, ``'longdouble'``, ``'float128'`` or ``'mp:BITS'`` (each model
        states which it takes).
    tol : decimal or None, default ``None``
        Integrator tolerance for the models that take one (``None``: the precision's epsilon).
    **options
        Model options (circuit models: ``effects``; spice: ``effects``, ``tmax``, ``timeout``).

    Returns
    -------
    Solver

    Raises
    ------
    ParameterError
        Unknown model, or a precision / tolerance / option the model does not take.

    See Also
    --------
    precise_impact.solvers.simulate.simulate : build the solver and run it in one call.
    precise_impact.solvers.base.Solver : the protocol every solver follows.
    precise_impact.core.precision.Precision : the precision names accepted.

    Examples
    --------
    >>> import precise_impact as pi
    >>> s = pi.make_solver("fast")
    >>> isinstance(s, pi.Solver)
    True
    """
    spec = _REGISTRY[canonical_model(model)]
    P = Precision.parse(precision)
    spec.capabilities.check(spec.name, P, tol)
    return spec.factory(P, tol, **options)


def model_capabilities(model: str) -> Capabilities:
    """The :class:`Capabilities` ``model`` (a name of :data:`MODELS` or an alias) declares."""
    return _REGISTRY[canonical_model(model)].capabilities


# --------------------------------------------------------------------- the coupled pair
@runtime_checkable
class CoupledSolver(Protocol):
    """What every model of the master-slave pair implements.

    Attributes
    ----------
    model_name : str
        The model's name in :data:`COUPLED_MODELS`.
    precision : Precision
        The working precision.

    Methods
    -------
    solve(params, k, periods, *, form='first-order', y0=None, per_period=0)
        The pair from ``params``' start (master) and ``y0`` (slave; ``None``: on the
        diagonal), coupling ``k`` (exact), ``periods`` forcing periods; the result has
        ``t, x, v, y, w`` at ``t0 + j T`` (``j = 0..periods``) and ``master_impacts_t``,
        ``slave_impacts_t``.  Inputs are validated by :func:`~precise_impact.simulate_coupled`.
    """

    @property
    def model_name(self) -> str: ...

    @property
    def precision(self) -> Precision: ...

    def solve(
        self,
        params: Params,
        k: Any,
        periods: int,
        *,
        form: str = "first-order",
        y0: Any = None,
        per_period: int = 0,
    ) -> Any:  # pragma: no cover - protocol
        """Simulate the pair; see the class docstring."""
        ...


_COUPLED: dict[str, _Model] = {}
_COUPLED_DESCRIPTIONS: dict[str, str] = {}

#: Coupled-pair model name -> one-line description (filled by :func:`register_coupled_model`).
COUPLED_MODELS: Mapping[str, str] = _Registered(_COUPLED_DESCRIPTIONS)


def register_coupled_model(
    name: str,
    description: str,
    factory: Callable[..., CoupledSolver],
    capabilities: Capabilities,
) -> None:
    """Add a model of the master-slave pair to :data:`COUPLED_MODELS`.

    Parameters
    ----------
    name, description : str
        As :func:`register_model`.
    factory : callable
        ``factory(precision: Precision, tol, **options) -> CoupledSolver``.
    capabilities : Capabilities
        Precisions, tolerance and slave forms, checked before any work.
    """
    with _REGISTRY_LOCK:
        _COUPLED[name] = _Model(name, description, factory, capabilities)
        _COUPLED_DESCRIPTIONS[name] = description


def _coupled_spec(model: Any) -> _Model:
    _load_providers()
    if not isinstance(model, str) or model not in _COUPLED:
        raise ParameterError("model", model, "one of " + ", ".join(_COUPLED))
    return _COUPLED[model]


def coupled_model_capabilities(model: str) -> Capabilities:
    """The :class:`Capabilities` of a model of :data:`COUPLED_MODELS`."""
    return _coupled_spec(model).capabilities


def make_coupled_solver(
    model: str = "heyoka",
    precision: str | Precision = "float64",
    tol: Any = None,
    form: str | None = None,
    **options: Any,
) -> CoupledSolver:
    """The solver of the pair for ``model`` at ``precision`` (checked against its
    :class:`Capabilities`, with ``form`` if given, before any work).

    Raises
    ------
    ParameterError
        Unknown model, or a precision / tolerance / form / option the model does not take.
    """
    spec = _coupled_spec(model)
    P = Precision.parse(precision)
    spec.capabilities.check(spec.name, P, tol, form)
    return spec.factory(P, tol, **options)


# --------------------------------------------------------------------- the fallback
class Unresolved(IntegrationError):
    """A run the primary engine does not resolve (a tangential contact, chattering, a system
    outside its closed form): :func:`with_fallback` hands it to the fallback engine.

    Parameters
    ----------
    engine : str
        The engine that gave up (``'fast'``).
    why : str
        The reason, for ``stats['engine']``.
    partial : list or None
        For a batch: the results, ``None`` where unresolved.
    """

    def __init__(self, engine: str, why: str, partial: list | None = None) -> None:
        super().__init__(f"the {engine} engine does not resolve this orbit: {why}")
        self.engine, self.why, self.partial = engine, why, partial


def with_fallback(
    primary: Callable[..., Any],
    fallback: Callable[..., Any] | None,
    mark: Callable[[Any, str], Any] | None = None,
    *,
    before_fallback: Callable[[Unresolved], Any] | None = None,
) -> Callable[..., Any]:
    """``primary``, and ``fallback`` for what it does not resolve: the one fallback rule.

    ``run(*args, **kwargs)`` returns ``primary(*args, **kwargs)``; when that raises
    :class:`Unresolved`, it returns ``mark(fallback(*args, **kwargs), why)`` (``mark``
    says so in the result, e.g. ``stats['engine']``).  A batch primary raises
    :class:`Unresolved` with ``partial`` (its results, ``None`` where unresolved): the
    fallback is then called once with ``indices=`` the unresolved positions and returns
    their results in that order, each marked and put in place.  ``fallback=None``: the
    :class:`Unresolved` error propagates (an :class:`~precise_impact.errors.IntegrationError`).

    Parameters
    ----------
    primary, fallback : callable
        The two engines, called with the same arguments.
    mark : callable or None
        ``mark(result, why) -> result``; ``None`` leaves the fallback's result as it is.
    before_fallback : callable or None
        ``before_fallback(unresolved)`` is called before the fallback runs: it may refuse
        it by raising (a time budget the fallback would not fit in:
        :meth:`~precise_impact.core.budget.Deadline.admit`) or say that it falls back.

    Returns
    -------
    callable
    """

    def run(*args: Any, **kwargs: Any) -> Any:
        try:
            return primary(*args, **kwargs)
        except Unresolved as u:
            if fallback is None:
                raise
            if before_fallback is not None:
                before_fallback(u)
            if u.partial is None:
                out = fallback(*args, **kwargs)
                return out if mark is None else mark(out, u.why)
            results = list(u.partial)
            rest = [i for i, r in enumerate(results) if r is None]
            for i, r in zip(rest, fallback(*args, indices=rest, **kwargs), strict=True):
                results[i] = r if mark is None else mark(r, u.why)
            return results

    return run


def note_fallback(engine: str) -> Callable[[Any, str], Any]:
    """A ``mark`` for :func:`with_fallback`: sets ``result.stats["engine"]``, naming the reason.

    Parameters
    ----------
    engine : str
        The fallback engine's name as the result states it (``'heyoka'``).

    Returns
    -------
    callable
    """

    def mark(result: Any, why: str) -> Any:
        result.stats["engine"] = f"{engine} (fallback: {why})"
        return result

    return mark
