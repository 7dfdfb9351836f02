"""Old keyword spellings, kept for one release with a :class:`DeprecationWarning`.

The public vocabulary is one set of words (``precision=``, ``model=`` for an engine, ``method=``
for an algorithm, ``segments``, axis tuples, ``lle_stderr``, ``n_impacts``); a renamed keyword
goes through :func:`renamed` so that the warning, the "not both" check and the CHANGELOG entry
say the same thing everywhere.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Any

from precise_impact.errors import ParameterError

__all__ = ["UNSET", "RenamedAttribute", "renamed", "warn_renamed"]


class _Unset:
    """Marker of a keyword that was not given (``None`` can be a meaningful value)."""

    __slots__ = ()

    def __repr__(self) -> str:
        return "UNSET"


#: The default of a deprecated keyword: not given.
UNSET: Any = _Unset()


def warn_renamed(old: str, new: str, where: str, stacklevel: int = 3) -> None:
    """Emit the one :class:`DeprecationWarning` text for ``where``'s ``old`` renamed ``new``."""
    warnings.warn(
        f"{where}: {old} is deprecated, use {new} (the old spelling is removed in the next "
        "release)",
        DeprecationWarning,
        stacklevel=stacklevel,
    )


def renamed(
    new_value: Any,
    old_value: Any,
    *,
    old: str,
    new: str,
    where: str,
    convert: Callable[[Any], Any] | None = None,
    default: Any = UNSET,
) -> Any:
    """The value of a renamed keyword: ``new_value``, or ``old_value`` with a warning.

    Parameters
    ----------
    new_value, old_value : Any
        What the caller passed under the new and the old name (:data:`UNSET` when not given).
    old, new, where : str
        The two names and the function, for the messages.
    convert : callable or None, default ``None``
        Maps an old-style value to the new meaning (e.g. ``bits=448`` -> ``'mp:448'``).
    default : Any, default :data:`UNSET`
        Returned when neither was given.

    Raises
    ------
    ParameterError
        When both spellings are given.

    Examples
    --------
    >>> import warnings
    >>> from precise_impact.core.compat import UNSET, renamed
    >>> with warnings.catch_warnings(record=True) as w:
    ...     warnings.simplefilter("always")
    ...     renamed(UNSET, 448, old="bits", new="precision", where="certify",
    ...             convert=lambda b: f"mp:{b}")
    'mp:448'
    """
    if old_value is UNSET:
        return default if new_value is UNSET else new_value
    if new_value is not UNSET:
        raise ParameterError(old, old_value, f"not both {new}= and the deprecated {old}= ({where})")
    warn_renamed(f"{old}=", f"{new}=", where, stacklevel=4)
    return old_value if convert is None else convert(old_value)


class RenamedAttribute:
    """A result attribute's old name: reads and writes go to the new one, with one warning.

    Examples
    --------
    >>> import dataclasses, warnings
    >>> from precise_impact.core.compat import RenamedAttribute
    >>> @dataclasses.dataclass
    ... class R:
    ...     n_impacts: int
    ...     impacts = RenamedAttribute("n_impacts")
    >>> with warnings.catch_warnings(record=True):
    ...     warnings.simplefilter("always")
    ...     R(3).impacts
    3
    """

    def __init__(self, new: str) -> None:
        self.new = new
        self.old = ""
        self.where = ""

    def __set_name__(self, owner: type, name: str) -> None:
        self.old, self.where = name, owner.__name__

    def __get__(self, obj: Any, objtype: Any = None) -> Any:
        if obj is None:
            return self
        warn_renamed(self.old, self.new, self.where)
        return getattr(obj, self.new)

    def __set__(self, obj: Any, value: Any) -> None:
        warn_renamed(self.old, self.new, self.where)
        setattr(obj, self.new, value)
