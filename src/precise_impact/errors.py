"""Error types raised by precise_impact."""

from __future__ import annotations


class ParameterError(ValueError):
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
    """

    def __init__(self, name: str, value: object, allowed: str):
        self.name = name
        self.value = value
        self.allowed = allowed
        super().__init__(f"{name} = {value!r} is not allowed: {allowed}")


class BudgetExceededError(RuntimeError):
    """An integration hit its impact or step budget (e.g. a Zeno impact sequence)."""


class OptionalDependencyError(RuntimeError):
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
    """

    def __init__(self, component: str, install: str, purpose: str):
        self.component = component
        self.install = install
        self.purpose = purpose
        super().__init__(
            f"{purpose} needs {component}, which is not installed; install it with: {install}"
        )


class MissedImpactError(RuntimeError):
    """The guard found a maximum of ``x`` beyond the wall that no impact event caught."""


class SpiceError(RuntimeError):
    """ngspice failed, timed out, or wrote no usable output (message has its log tail)."""


class NgspiceNotFoundError(SpiceError, OptionalDependencyError):
    """ngspice is not installed / not on PATH (``apt-get install ngspice``).

    Parameters
    ----------
    message : str
        The one-line message (what needed ngspice and the install command).
    """

    def __init__(self, message: str):
        RuntimeError.__init__(self, message)
        self.component, self.install, self.purpose = (
            "ngspice",
            "apt-get install ngspice",
            "the spice model",
        )


class ReferenceDataError(RuntimeError):
    """A reference dataset is missing, damaged or changed since it was generated.

    Raised by every loader before any scoring: a damaged reference is never turned into a
    verdict on the solver being scored.  The message names the case and the file.
    """


class IntegrationError(RuntimeError):
    """The integrator could not continue (heyoka stopped with a non-finite state or an error outcome).

    Inside the documented parameter box this does not happen; the CLI reports it as one
    line with exit status 3, like an exhausted budget, and keeps what was finished.
    """


class Interrupted(KeyboardInterrupt):
    """A long run was interrupted (Ctrl-C, or SIGTERM through the CLI); ``partial`` keeps
    what was finished (e.g. a :class:`~precise_impact.core.trajectory.Trajectory` up to the
    last finished chunk, with ``stats['partial'] = True``).

    A ``KeyboardInterrupt``, so code that does not know it behaves as before.
    """

    def __init__(self, message: str, partial=None) -> None:
        super().__init__(message)
        self.partial = partial
