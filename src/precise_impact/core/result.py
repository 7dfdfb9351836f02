"""One base for result types: ``to_dict()`` (JSON-ready) and ``save(path)`` (atomic)."""

from __future__ import annotations

import dataclasses
import functools
import os
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.core.params import Params, decimal_str
from precise_impact.core.precision import Precision
from precise_impact.errors import ParameterError
from precise_impact.io.atomic import atomic_write
from precise_impact.io.jsonout import finite_or_marker, write_json

__all__ = ["ResultMixin", "to_jsonable"]


def to_jsonable(obj: Any) -> Any:
    """``obj`` in plain JSON types, strict JSON: a NaN becomes ``None`` and an infinity the
    string ``'inf'`` or ``'-inf'`` (:func:`precise_impact.io.jsonout.finite_or_marker`)."""
    out = _leaf_jsonable(obj)
    if out is not _NOT_A_LEAF:
        return out
    return _container_jsonable(obj)


_NOT_A_LEAF = object()


def _leaf_jsonable(obj: Any) -> Any:
    """``obj`` as one JSON value if it is a scalar-like leaf, else the ``_NOT_A_LEAF`` marker."""
    if obj is None or isinstance(obj, (bool, str, int)):
        return obj
    if isinstance(obj, float):
        return finite_or_marker(obj)
    if isinstance(obj, Fraction):
        return decimal_str(obj)
    if isinstance(obj, Params):
        return obj.decimal()
    if isinstance(obj, Precision):
        return obj.name
    if isinstance(obj, ResultMixin):
        return obj.to_dict()
    if isinstance(obj, Path):
        return str(obj)
    return _NOT_A_LEAF


def _container_jsonable(obj: Any) -> Any:
    """Numpy values, containers and dataclasses converted element by element; else ``str(obj)``."""
    if isinstance(obj, np.generic):
        return to_jsonable(obj.item())
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind in "fiub":
            return [to_jsonable(v) for v in obj.tolist()]
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if dataclasses.is_dataclass(obj):
        return {f.name: to_jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    return str(obj)  # heyoka real / real128: their str() round-trips


class ResultMixin:
    """``to_dict()``, ``save(path)`` and (for one release) ``result["field"]`` for dataclass
    results.

    See Also
    --------
    precise_impact.core.trajectory.Trajectory : a result using it.
    precise_impact.analysis.lyapunov.result.LyapunovResult : another.
    """

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """A result type's own ``to_dict`` is made strict JSON once, here: its output passes
        through :func:`to_jsonable` (finite numbers, strings and containers unchanged; NaN
        ``None``, infinities ``'inf'`` / ``'-inf'``, numpy values plain)."""
        super().__init_subclass__(**kwargs)
        own = cls.__dict__.get("to_dict")
        if own is None or getattr(own, "_strict_json", False):
            return

        @functools.wraps(own)
        def to_dict(self: Any, *args: Any, **kw: Any) -> Any:
            return to_jsonable(own(self, *args, **kw))

        to_dict._strict_json = True  # type: ignore[attr-defined]
        cls.to_dict = to_dict  # type: ignore[method-assign]

    def to_dict(self) -> dict[str, Any]:
        """The result as plain JSON types; ``json.dumps(result.to_dict(), allow_nan=False)``
        always works (NaN is ``null``, an infinity ``"inf"`` / ``"-inf"``)."""
        return {f.name: to_jsonable(getattr(self, f.name)) for f in dataclasses.fields(self)}  # type: ignore[arg-type]

    def save(self, path: str | os.PathLike) -> Path:
        """Write the result atomically: ``.json`` (:meth:`to_dict`) or ``.npz`` (its arrays and
        scalars).

        Returns
        -------
        pathlib.Path
            The file written.

        Raises
        ------
        ParameterError
            ``path`` ends in neither ``.json`` nor ``.npz``.
        """
        path = Path(path)
        if path.suffix == ".json":
            write_json(path, self.to_dict())
        elif path.suffix == ".npz":
            arrays: dict[str, Any] = {}
            for f in dataclasses.fields(self):  # type: ignore[arg-type]
                v = getattr(self, f.name)
                if isinstance(v, np.ndarray) and v.dtype != object:
                    arrays[f.name] = v
                elif isinstance(v, (int, float, bool, np.generic)):
                    arrays[f.name] = np.asarray(v)
            atomic_write(path, lambda fh: np.savez_compressed(fh, **arrays), binary=True)
        else:
            raise ParameterError("path", str(path), "a file ending in .json or .npz")
        return path

    def __contains__(self, key: object) -> bool:
        return key in {f.name for f in dataclasses.fields(self)}  # type: ignore[arg-type]

    def __getitem__(self, key: str) -> Any:
        names = {f.name for f in dataclasses.fields(self)}  # type: ignore[arg-type]
        if key not in names:
            raise KeyError(key)
        return getattr(self, key)
