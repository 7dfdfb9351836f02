"""Error types raised by precise_impact."""

from __future__ import annotations


class ParameterError(ValueError):
    """Bad input: names the parameter and the allowed range.

    Raised before any work starts.  The CLI turns it into a one-line message on
    stderr and exit status 2, without a traceback.
    """

    def __init__(self, name: str, value: object, allowed: str):
        self.name = name
        self.value = value
        self.allowed = allowed
        super().__init__(f"{name} = {value!r} is not allowed: {allowed}")


class BudgetExceededError(RuntimeError):
    """An integration hit its impact or step budget (e.g. a Zeno impact sequence)."""
