"""The Solver protocol and the model registry: one name per model, one way to make it.

Every model is a :class:`Solver` (``solve(params, periods, *, per_period=0) -> Trajectory``);
:func:`make_solver` builds one by name, :data:`MODELS` lists them.
"""

from __future__ import annotations

import dataclasses
import threading
import types
from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

from precise_impact.core.params import Params
from precise_impact.core.precision import Precision
from precise_impact.core.trajectory import Trajectory
from precise_impact.errors import ParameterError

__all__ = [
    "Solver",
    "MODELS",
    "MODEL_ALIASES",
    "register_model",
    "canonical_model",
    "make_solver",
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
    """

    model_name: str
    precision: Precision

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
    factory: Callable[..., Solver]


_REGISTRY: dict[str, _Model] = {}
_DESCRIPTIONS: dict[str, str] = {}
_REGISTRY_LOCK = threading.Lock()

#: Model name -> one-line description (read-only view; filled by :func:`register_model`).
MODELS = types.MappingProxyType(_DESCRIPTIONS)

#: Old or alternative names accepted for a model, mapped to its one canonical name.
MODEL_ALIASES = types.MappingProxyType({"mechanical": "heyoka"})


def register_model(name: str, description: str, factory: Callable[..., Solver]) -> None:
    """Add a model to :data:`MODELS`.

    Parameters
    ----------
    name : str
        The model's one canonical name.
    description : str
        One line for ``--help`` and the docs.
    factory : callable
        ``factory(precision: Precision, tol, **options) -> Solver``; raises
        :class:`~precise_impact.errors.ParameterError` for a precision or option the
        model does not take.
    """
    with _REGISTRY_LOCK:
        _REGISTRY[name] = _Model(name, description, factory)
        _DESCRIPTIONS[name] = description


def canonical_model(name: str) -> str:
    """The canonical name of ``name`` (an alias such as ``'mechanical'`` maps to ``'heyoka'``).

    Raises
    ------
    ParameterError
        ``name`` is neither a model nor an alias.
    """
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
    """
    spec = _REGISTRY[canonical_model(model)]
    return spec.factory(Precision.parse(precision), tol, **options)
