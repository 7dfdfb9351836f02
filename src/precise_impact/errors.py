"""Error types raised by precise_impact, all under one base class :class:`PreciseImpactError`.

One home for every error a caller may catch, so ``except PreciseImpactError`` catches what the
package raises and the CLI maps errors to exit statuses by type.  Each concrete error also
derives from the builtin it refines (``ValueError`` for bad input, ``RuntimeError`` for a run
that could not finish), so code written against those keeps working.  :class:`Interrupted` is
the one exception here that is not an error: it is a ``KeyboardInterrupt`` (not an
``Exception``), so that ``except Exception`` never swallows Ctrl-C.
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "PreciseImpactError",
    "ParameterError",
    "BudgetExceededError",
    "OverBudgetError",
    "EndlessBouncesError",
    "OptionalDependencyError",
    "MissedImpactError",
    "SpiceError",
    "NgspiceNotFoundError",
    "ReferenceDataError",
    "IntegrationError",
    "CertificationError",
    "ConvergenceError",
    "Interrupted",
]


class PreciseImpactError(Exception):
    """Base class of every error precise_impact raises (``except PreciseImpactError``).

    See Also
    --------
    precise_impact.errors.ParameterError : an invalid argument.
    precise_impact.errors.IntegrationError : an engine failed.
    """


class ParameterError(PreciseImpactError, ValueError):
    """Bad input: names the parameter and the allowed range.

    Raised before any work starts.  The CLI turns it into a one-line message on
    stderr and exit status 2, without a traceback.

    Parameters
    ----------
    name : str
        The parameter (``Params`` field names, CLI flags without ``--``).
    value : object
        The value given.
    allowed : str
        The allowed range or set, in words.

    See Also
    --------
    precise_impact.errors.PreciseImpactError : the base of every error raised here.
    precise_impact.core.params.Params : the validated parameters.
    """

    def __init__(self, name: str, value: object, allowed: str):
        self.name = name
        self.value = value
        self.allowed = allowed
        super().__init__(f"{name} = {one_line(value)} is not allowed: {allowed}")

    def __reduce__(self):
        """Pickled with its three arguments (a pool worker's refusal reaches the caller as
        itself, not as a broken pool: ``BaseException`` pickles ``args``, the message only)."""
        return (type(self), (self.name, self.value, self.allowed))


def check_type(value: Any, types: type | tuple[type, ...], name: str, wanted: str) -> Any:
    """``value`` when it is one of ``types``, else the one-line :class:`ParameterError` naming
    the argument ``name``, the type given and what was ``wanted``: the one type check of the
    public entry points' leading arguments, so that a wrong kind of argument is refused before
    any work (``prove_landmark(Params.make())``: ``bp = 'Params' is not allowed: a BranchPoint
    from locate_landmark, ...``), not as an ``AttributeError`` deep inside.  A ``bool`` is
    never a number here."""
    kinds = types if isinstance(types, tuple) else (types,)
    if isinstance(value, kinds) and not (isinstance(value, bool) and bool not in kinds):
        return value
    raise ParameterError(name, type(value).__name__, wanted)


def one_line(value: object, limit: int = 80) -> str:
    """``repr(value)`` on one line (a 2-D array's repr has several) of at most ``limit``
    characters: the refusal stays one line however large the value."""
    try:
        text = " ".join(repr(value).split())
    except Exception:  # a hostile __repr__: the type still says what was given
        text = f"<{type(value).__name__}>"
    return text if len(text) <= limit else text[: limit - 3] + "..."


class BudgetExceededError(PreciseImpactError, RuntimeError):
    """An integration hit its impact or step budget (e.g. a Zeno impact sequence).

    See Also
    --------
    precise_impact.errors.IntegrationError : another engine failure.
    precise_impact.errors.OverBudgetError : a wall-time budget exceeded.
    """


class EndlessBouncesError(BudgetExceededError):
    """``R = 1`` bounces on the wall under a force into it, predicted to come to rest or to
    outrun the impact budget (:func:`~precise_impact.core.impact.elastic_bounce_count`):
    refused at the first short flight, exit status 3.  Scans record it per point.

    See Also
    --------
    precise_impact.errors.BudgetExceededError : its base.
    """


class OverBudgetError(ParameterError, BudgetExceededError):
    """A request whose estimated cost exceeds its budget, refused before any work.

    Raised by :func:`~precise_impact.core.budget.check_cost` (time over ``max_time``, or
    samples over half the machine's memory).  Both a :class:`ParameterError` (ask for less,
    or raise ``max_time``) and a :class:`BudgetExceededError` (a budget stopped it): the CLI
    reports it as a budget, one line and exit status 3.

    See Also
    --------
    precise_impact.errors.PreciseImpactError : the base of every error raised here.
    precise_impact.errors.BudgetExceededError : an impact or step budget exhausted.
    precise_impact.errors.Interrupted : a run stopped by the user.
    """


class OptionalDependencyError(PreciseImpactError, RuntimeError):
    """An optional component a request needs is not installed.

    The CLI prints the message as one line and exits with status 2 (bad input:
    the request cannot be served on this installation), without a traceback.

    Parameters
    ----------
    component : str
        What is missing (``'ngspice'``, ``'scipy'``, ``'dask'`` ...).
    install : str
        The one command that installs it.
    purpose : str
        What needs it.

    See Also
    --------
    precise_impact.errors.PreciseImpactError : the base of every error raised here.
    precise_impact.errors.NgspiceNotFoundError : ngspice in particular.
    """

    def __init__(self, component: str, install: str, purpose: str):
        self.component = component
        self.install = install
        self.purpose = purpose
        super().__init__(
            f"{purpose} needs {component}, which is not installed; install it with: {install}"
        )

    def __reduce__(self):
        """Pickled with its three arguments (see :meth:`ParameterError.__reduce__`)."""
        if type(self).__init__ is not OptionalDependencyError.__init__:
            return (type(self), self.args)
        return (type(self), (self.component, self.install, self.purpose))


class SpiceError(PreciseImpactError, RuntimeError):
    """ngspice failed, timed out, or wrote no usable output (message has its log tail).

    See Also
    --------
    precise_impact.errors.PreciseImpactError : the base of every error raised here.
    precise_impact.models.circuit.spice.SpiceSolver : the model that runs ngspice.
    """


class NgspiceNotFoundError(SpiceError, OptionalDependencyError):
    """ngspice is not installed / not on PATH (``apt-get install ngspice``).

    Parameters
    ----------
    message : str
        The one-line message (what needed ngspice and the install command).

    See Also
    --------
    precise_impact.errors.OptionalDependencyError : any missing optional dependency.
    precise_impact.models.circuit.spice.SpiceSolver : the model that needs ngspice.
    """

    def __init__(self, message: str):
        RuntimeError.__init__(self, message)
        self.component, self.install, self.purpose = (
            "ngspice",
            "apt-get install ngspice",
            "the spice model",
        )


class ReferenceDataError(PreciseImpactError, RuntimeError):
    """A reference dataset is missing, damaged or changed since it was generated.

    Raised by every loader before any scoring: a damaged reference is never turned into a
    verdict on the solver being scored.  The message names the case and the file.

    See Also
    --------
    precise_impact.errors.PreciseImpactError : the base of every error raised here.
    precise_impact.verification.reference.verify : check the reference datasets.
    precise_impact.verification.reference.generate : write them.
    """


class IntegrationError(PreciseImpactError, RuntimeError):
    """The integrator could not continue (heyoka stopped: a non-finite state or an error outcome).

    Inside the documented parameter box this does not happen; the CLI reports it as one
    line with exit status 3, like an exhausted budget, and keeps what was finished.

    See Also
    --------
    precise_impact.errors.PreciseImpactError : the base of every error raised here.
    precise_impact.errors.MissedImpactError : an impact the engine stepped over.
    precise_impact.errors.BudgetExceededError : an impact or step budget exhausted.
    """


class MissedImpactError(IntegrationError):
    """The guard found a maximum of ``x`` beyond the wall that no impact event caught.

    An :class:`IntegrationError` (the CLI: one line, exit status 3; before 0.3 it escaped
    the CLI as a traceback).

    See Also
    --------
    precise_impact.errors.IntegrationError : another engine failure.
    precise_impact.solvers.certified.single.certify : a run whose impacts are proven.
    """


class CertificationError(IntegrationError):
    """No proof at this precision: the message names the time and the ball.

    Raised by the certified engines (:mod:`precise_impact.solvers.certified`).  ``partial``
    holds the samples proven before the failure (their radius growth projects the bits a run
    needs: :func:`~precise_impact.solvers.certified.single.out_of_reach`), or ``None``.

    See Also
    --------
    precise_impact.errors.PreciseImpactError : the base of every error raised here.
    precise_impact.solvers.certified.single.certify : raises it when certification fails.
    precise_impact.solvers.certified.single.CertifiedSolver : the certified model.
    """

    partial: list | None = None


class ConvergenceError(IntegrationError):
    """Newton's iteration did not reach a periodic orbit (the message says how far it got).

    Raised by :func:`~precise_impact.analysis.orbits.find_orbit` and the continuation.

    See Also
    --------
    precise_impact.errors.PreciseImpactError : the base of every error raised here.
    precise_impact.analysis.orbits.newton.find_orbit : raises it when Newton's method fails.
    precise_impact.analysis.orbits.proof.prove_orbit : a proven orbit.
    """


class Interrupted(KeyboardInterrupt):
    """A long run was interrupted (Ctrl-C, or SIGTERM through the CLI); ``partial`` keeps
    what was finished (e.g. a :class:`~precise_impact.core.trajectory.Trajectory` up to the
    last finished chunk, with ``stats['partial'] = True``).

    A ``KeyboardInterrupt``, so code that does not know it behaves as before.

    See Also
    --------
    precise_impact.errors.OverBudgetError : a wall-time budget exceeded.
    precise_impact.errors.BudgetExceededError : an impact or step budget exhausted.
    """

    def __init__(self, message: str, partial=None) -> None:
        super().__init__(message)
        self.partial = partial
