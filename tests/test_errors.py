"""Every error precise_impact raises is under one base class; moved classes are the same objects."""

from __future__ import annotations

import inspect

import pytest

import precise_impact
import precise_impact.errors as errors
from precise_impact.analysis.orbits import ConvergenceError as OrbitsConvergenceError
from precise_impact.analysis.orbits.newton import ConvergenceError as NewtonConvergenceError
from precise_impact.solvers.certified import CertificationError as CertifiedCertificationError
from precise_impact.solvers.certified.single import CertificationError as SingleCertificationError

CLASSES = [
    obj
    for _, obj in inspect.getmembers(errors, inspect.isclass)
    if issubclass(obj, BaseException) and obj.__module__ == errors.__name__
]


def test_errors_module_defines_them():
    names = {c.__name__ for c in CLASSES}
    assert {"CertificationError", "ConvergenceError", "ParameterError", "OverBudgetError"} <= names
    assert set(errors.__all__) == names


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
def test_every_exception_class_derives_from_the_base(cls):
    if cls is errors.Interrupted:
        # the one exception that is not an error: a KeyboardInterrupt, so that
        # ``except Exception`` never swallows Ctrl-C
        assert issubclass(cls, KeyboardInterrupt) and not issubclass(cls, Exception)
        return
    assert issubclass(cls, errors.PreciseImpactError)
    assert issubclass(cls, Exception)


def test_moved_classes_are_the_same_objects():
    assert precise_impact.CertificationError is errors.CertificationError
    assert SingleCertificationError is CertifiedCertificationError is errors.CertificationError
    assert precise_impact.ConvergenceError is errors.ConvergenceError
    assert OrbitsConvergenceError is NewtonConvergenceError is errors.ConvergenceError
    assert precise_impact.PreciseImpactError is errors.PreciseImpactError
    # their place in the hierarchy is unchanged: a stopped integration (CLI exit 3)
    assert issubclass(errors.CertificationError, errors.IntegrationError)
    assert issubclass(errors.ConvergenceError, errors.IntegrationError)


def test_builtin_bases_are_kept():
    # code written against ValueError / RuntimeError keeps catching them
    assert issubclass(errors.ParameterError, ValueError)
    for name in ("BudgetExceededError", "IntegrationError", "SpiceError", "ReferenceDataError"):
        assert issubclass(getattr(errors, name), RuntimeError)
    over = errors.OverBudgetError("max_time", "1 s", "more")
    assert isinstance(over, errors.ParameterError) and isinstance(over, errors.BudgetExceededError)
    assert over.name == "max_time"


def test_a_real_failure_is_caught_by_the_base():
    with pytest.raises(errors.PreciseImpactError):
        precise_impact.Params.make(eta="-1")
    with pytest.raises(errors.PreciseImpactError):
        precise_impact.find_orbit(precise_impact.Params.make(eta="0.712"), 1, guess=("1e9", "0"))


@pytest.mark.parametrize(
    "err",
    [
        errors.ParameterError("eta", "x", "> 0"),
        errors.OverBudgetError("max-time", 5, "more seconds"),
        errors.OptionalDependencyError("scipy", "pip install scipy", "the bench"),
        errors.NgspiceNotFoundError("the spice model needs ngspice"),
        errors.SpiceError("ngspice failed"),
    ],
)
def test_errors_pickle_as_themselves(err):
    """A pool worker's refusal reaches the caller as itself (an unpicklable ParameterError
    broke a ProcessPoolExecutor: "BrokenProcessPool" instead of the one-line refusal)."""
    import pickle  # noqa: PLC0415 -- this test alone

    back = pickle.loads(pickle.dumps(err))
    assert type(back) is type(err) and str(back) == str(err)
    assert vars(back) == vars(err)
