"""The one JSON writer: strict JSON (RFC 8259) for every file and every ``--json`` line.

No ``NaN`` / ``Infinity`` tokens ever (``allow_nan=False``): a non-finite number is written as
``null`` (NaN: no value) or the strings ``"inf"`` / ``"-inf"`` (an infinity keeps its sign, e.g.
the Lyapunov exponent of an orbit that reaches a fixed point in finite time is ``"-inf"``).
"""

from __future__ import annotations

import json
import math
import os
import sys
from collections.abc import Callable
from typing import Any, TextIO

from precise_impact.io.atomic import atomic_write

__all__ = ["finite_or_marker", "dumps", "write_json", "print_json"]


def finite_or_marker(x: float) -> float | str | None:
    """A float as strict JSON: itself if finite, ``None`` for NaN, ``'inf'`` / ``'-inf'``."""
    if math.isfinite(x):
        return x
    if math.isnan(x):
        return None
    return "inf" if x > 0 else "-inf"


def _strict(obj: Any) -> Any:
    """``obj`` with every non-finite float replaced in dicts, lists and tuples (other objects
    are left to ``default``, whose results pass through here again)."""
    if isinstance(obj, float):
        return finite_or_marker(obj)
    if isinstance(obj, dict):
        return {k: _strict(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_strict(v) for v in obj]
    return obj


def dumps(
    obj: Any,
    indent: int | None = None,
    default: Callable[[Any], Any] | None = None,
    sort_keys: bool = False,
) -> str:
    """``obj`` as strict JSON text (no ``NaN`` / ``Infinity``; see the module docstring).

    ``default`` converts objects JSON does not know (as in :func:`json.dumps`); its results
    are made strict too.
    """
    strict_default = None if default is None else (lambda o: _strict(default(o)))
    return json.dumps(
        _strict(obj), indent=indent, default=strict_default, sort_keys=sort_keys, allow_nan=False
    )


def write_json(
    path: str | os.PathLike,
    obj: Any,
    indent: int | None = 1,
    default: Callable[[Any], Any] | None = None,
) -> None:
    """Write ``obj`` as strict JSON (UTF-8, trailing newline) atomically."""
    text = dumps(obj, indent=indent, default=default) + "\n"
    atomic_write(path, lambda fh: fh.write(text), binary=False)


def print_json(obj: Any, file: TextIO | None = None) -> None:
    """``obj`` as one line of strict JSON on ``file`` (default standard output)."""
    out = sys.stdout if file is None else file
    out.write(dumps(obj) + "\n")
